"""Every option of the command is range-checked: a value that would switch a safety off
(a NaN or negative grace, a negative seed, a fourth coordinate, a zero step) is a clear
error with exit status 1, before any work."""

import pytest

from conftest import SOURCE_DIR

WORLD = str(SOURCE_DIR / "tests" / "support" / "small_forest.yaml")
EXPERIMENT = str(SOURCE_DIR / "experiments" / "quick.yaml")
PLAN = ["plan", "--world", WORLD, "--planner", "eager_mp_astar"]
START_GOAL = ["--start", "1,1,1.5", "--goal", "8.5,8,1.5"]


@pytest.mark.parametrize("arguments, message", [
    (["run", EXPERIMENT, "--dry-run", "--grace", "nan"], "--grace"),
    (["run", EXPERIMENT, "--dry-run", "--grace", "inf"], "--grace"),
    (["run", EXPERIMENT, "--dry-run", "--grace", "-100"], "--grace"),
    (["run", EXPERIMENT, "--dry-run", "-j", "0"], "--jobs"),
    (["run", EXPERIMENT, "--dry-run", "-j", "1e9"], "--jobs"),
    (["run", EXPERIMENT, "--dry-run", "--shard", "4/3"], "--shard"),
    (["run", EXPERIMENT, "--dry-run", "--shard", "1/2/3"], "--shard"),
    (PLAN + START_GOAL + ["--seed", "-1"], "--seed"),
    # 2^64: the help's bound is 2^64 - 1, and nothing past it is clamped to it.
    (PLAN + START_GOAL + ["--seed", "18446744073709551616"], "not a whole number"),
    (PLAN + START_GOAL + ["--seed", "1.5"], "not a whole number"),
    (PLAN + START_GOAL + ["--seed", "1e3"], "not a whole number"),
    (["fly", "--world", WORLD, "--planner", "lazy_mp_astar", "--start", "1,1,1.5", "--goal",
      "8.5,8,1.5", "--seed", "18446744073709551616"], "not a whole number"),
    (PLAN + START_GOAL + ["--sample-step", "0"], "--sample-step"),
    (PLAN + START_GOAL + ["--sample-step", "1e-9"], "--sample-step"),
    (PLAN + START_GOAL + ["--sample-step", "nan"], "--sample-step"),
    (PLAN + ["--start", "1,1,1.5,4", "--goal", "8.5,8,1.5"], "expected three numbers"),
    (PLAN + ["--start", "1,1", "--goal", "8.5,8,1.5"], "expected three numbers"),
    (PLAN + ["--start", "1,1,", "--goal", "8.5,8,1.5"], "is not a finite number"),
    (PLAN + ["--start", "1,1,1.5", "--goal", "8.5,inf,1.5"], "is not a finite number"),
    (PLAN + ["--start", "1,1,1e999", "--goal", "8.5,8,1.5"], "is not a finite number"),
    (["slurm", EXPERIMENT, "--out", "/tmp/x", "--shards", "0", "--dry-run"], "--shards"),
    (["slurm", EXPERIMENT, "--out", "/tmp/x", "--shards", "2", "--cpus-per-task", "0",
      "--dry-run"], "--cpus-per-task"),
    (["slurm", EXPERIMENT, "--out", "/tmp/x", "--shards", "2", "--mem", "8G\ntouch x",
      "--dry-run"], "--mem"),
    (["world", WORLD, "--slice-height", "nan"], "--slice-height"),
])
def test_out_of_range_options_are_refused(kinolab, arguments, message):
    result = kinolab(*arguments)
    assert result.returncode == 1, result.stdout + result.stderr
    assert message in result.stderr, result.stderr


def test_in_range_options_still_work(kinolab):
    result = kinolab(*PLAN, *START_GOAL, "--seed", "18446744073709551615", "--sample-step",
                     "0.5")
    assert result.returncode == 0, result.stderr
    assert "seed 18446744073709551615" in result.stdout
    assert kinolab("run", EXPERIMENT, "--dry-run", "--grace", "0", "-j", "4").returncode == 0


@pytest.mark.parametrize("arguments, message", [
    (["rn"], "unknown command 'rn'; did you mean 'run'?"),
    (["--plugin", "x.so", "lst"], None),  # the plugin fails to load first: a clear error
    (["repot", "out"], "did you mean 'report'?"),
    (["frobnicate"], "unknown command 'frobnicate' (kinolab --help lists the commands)"),
    (["list", "planer"], "unknown kind 'planer' (did you mean 'planners'?)"),
    (["export", "out", "--format", "csv"], "--format: csv not in {ompl}"),
    ([], "A subcommand is required"),
])
def test_command_line_errors_have_one_prefix_and_suggest_the_command(kinolab, arguments, message):
    result = kinolab(*arguments)
    assert result.returncode == 1
    assert result.stderr.startswith("kinolab: error: "), result.stderr
    if message:
        assert message in result.stderr
