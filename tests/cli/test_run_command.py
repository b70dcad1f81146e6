"""`kinolab run` and `kinolab merge` end to end: isolation of misbehaving plugins, resume
after SIGKILL, shards, Ctrl-C, and malformed experiment files."""

import json
import os
import random
import re
import signal
import sqlite3
import subprocess
import textwrap
import time

import pytest

from conftest import BINARY, SMALL_FOREST, SOURCE_DIR
from results import meta, rows

MISBEHAVING = os.environ.get(
    "KINOLAB_MISBEHAVING", str(SOURCE_DIR / "build" / "tests" / "libkinolab_test_misbehaving.so"))

WORLD = "\n  - id: small\n    spec:\n" + textwrap.indent(SMALL_FOREST, " " * 6)

LAZY = """
  - id: lazy
    type: lazy_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
    params: {heuristic_weight: 2}
"""


def experiment(tmp_path, planners, queries="random: {count: 4, min_distance: 3, max_distance: 8}",
               extra="", name="test", plugins=True):
    text = f"kind: planning\nname: {name}\nseed: 3\n"
    if plugins:
        text += f"plugins: [{MISBEHAVING}]\n"
    text += f"worlds:{WORLD}queries:\n  {queries}\nplanners:{planners}{extra}"
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


def test_dry_run_prints_the_expanded_runs(kinolab, tmp_path):
    sweep = """
sweep:
  grid:
    planners.lazy.params.heuristic_weight: [1, 2, 3]
  zip:
    planners.lazy.sampler.params.samples_per_axis: [3, 5]
    budget.time: [5, 10]
repetitions: 2
"""
    path = experiment(tmp_path, LAZY, extra=sweep, plugins=False)
    result = kinolab("run", path, "--dry-run")
    assert result.returncode == 0, result.stderr
    # 3 x 2 variants x 1 world x 4 queries x 1 planner x 2 repetitions
    assert ": 48 runs" in result.stdout
    assert "planners.lazy.params.heuristic_weight=3, planners.lazy.sampler.params." in result.stdout
    assert kinolab("run", path, "--dry-run", "--shard", "2/3").stdout.count("\n") > 3
    assert ": 16 runs" in kinolab("run", path, "--dry-run", "--shard", "2/3").stdout


@pytest.mark.parametrize("queries", [
    "random: {count: 2, min_distance: 1000, max_distance: 2000}",  # farther than the world
    "random: {count: 2, min_distance: 3, max_distance: 8, clearance: 100}",
])
def test_queries_that_cannot_be_placed_are_refused_by_the_dry_run_as_by_the_run(kinolab, tmp_path,
                                                                                queries):
    # The dry run builds the world and places the queries as the run does: the same error,
    # and nothing written by either.
    path = experiment(tmp_path, LAZY, queries=queries, plugins=False)
    errors = []
    for args in (("--dry-run",), ("--out", tmp_path / "out")):
        result = kinolab("run", path, *args)
        assert result.returncode == 1, result.stdout + result.stderr
        assert "queries: could not place " in result.stderr, result.stderr
        errors.append(result.stderr.strip().splitlines()[-1])
    assert errors[0] == errors[1]
    assert not (tmp_path / "out" / "results.sqlite").exists()
    placed = experiment(tmp_path, LAZY, plugins=False, name="placed")
    result = kinolab("run", placed, "--dry-run")
    assert result.returncode == 0 and "every query placed in its world (1 world(s)" in result.stdout


def test_a_lattice_that_cannot_move_is_refused_before_any_run(kinolab, tmp_path):
    # 27 controls at tau 0.6 s: the gentlest (3 m/s^2) reaches 1.8 m/s, above the limit.
    # Refused by the dry run and the run alike, at the limit's line, with the fix; nothing
    # is written.
    slow = LAZY.replace("params: {heuristic_weight: 2}", "params: {max_velocity: 1.41}")
    path = experiment(tmp_path, slow, plugins=False)
    for args in (("--dry-run",), ("--out", tmp_path / "out")):
        result = kinolab("run", path, *args)
        assert result.returncode == 1, result.stdout + result.stderr
        assert re.search(r"test\.yaml:\d+:\d+: planners\[0\]\.params\.max_velocity: planner "
                         r"'lazy_mp_astar': parameter 'tau': no control of the 27", result.stderr)
        assert "Set tau <= 0.47," in result.stderr
    assert not (tmp_path / "out" / "results.sqlite").exists()
    # With that tau it runs.
    fixed = experiment(tmp_path, slow.replace("{max_velocity: 1.41}", "{max_velocity: 1.41, tau: 0.47}"),
                       plugins=False, name="fixed")
    assert kinolab("run", fixed, "--dry-run").returncode == 0


def test_misbehaving_plugins_get_their_status_and_the_rest_completes(kinolab, tmp_path):
    planners = LAZY + "".join(f"""
  - id: {kind}
    type: test_{kind}
""" for kind in ("crash", "hang", "oom", "throw"))
    path = experiment(tmp_path, planners, extra="budget: {time: 1, memory_mb: 256}\n")
    result = kinolab("run", path, "--out", tmp_path / "out", "-j", "2", "--grace", "1")
    assert result.returncode == 0, result.stderr
    runs = rows(tmp_path / "out" / "results.sqlite").values()
    assert len(runs) == 20
    status = {}
    for run in runs:
        status.setdefault(run["planner"], set()).add(run["status"])
    assert status == {"lazy": {"exact"}, "crash": {"crash"}, "hang": {"killed"},
                      "oom": {"oom"}, "throw": {"error"}}
    messages = {run["planner"]: run["message"] for run in runs}
    assert "signal 11" in messages["crash"]
    assert "test_throw always throws" in messages["throw"]
    assert "256 MB" in messages["oom"]
    assert "ignored its time budget" in messages["hang"]
    assert all(run["checker_valid"] == 1 for run in runs if run["planner"] == "lazy")
    provenance = meta(tmp_path / "out" / "results.sqlite")
    for key in ("config", "config_hash", "provenance.git_commit", "provenance.compiler",
                "provenance.ompl_version", "provenance.ceres_version", "provenance.cpu",
                "provenance.host", "started_at", "finished_at"):
        assert provenance.get(key), key
    assert provenance["plugins"] == MISBEHAVING


def deterministic(tmp_path, name="resume", sleep_ms=60):
    planners = LAZY + f"""
  - id: slow
    type: test_trivial
    params: {{sleep_ms: {sleep_ms}}}
"""
    return experiment(tmp_path, planners, name=name,
                      queries="random: {count: 12, min_distance: 3, max_distance: 8}")


def stored_runs(database):
    """Runs committed to `database` (0 before its tables exist): one query, one snapshot (the
    runner commits while this reads)."""
    try:
        if not database.exists():
            return 0
        with sqlite3.connect(database) as db:
            return db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.Error:  # created but its tables not yet committed
        return 0


def test_resume_after_sigkill_at_random_moments_equals_an_uninterrupted_run(kinolab, tmp_path):
    """SIGKILL at moments counted in runs stored, not in seconds (a loaded machine only makes
    the test slower): each attempt kills the runner once 0 to 3 more runs are committed (0:
    as soon as it has started), and resumes; the result equals an uninterrupted run."""
    path = deterministic(tmp_path)
    reference = kinolab("run", path, "--out", tmp_path / "reference")
    assert reference.returncode == 0, reference.stderr
    expected = rows(tmp_path / "reference" / "results.sqlite")
    assert len(expected) == 24

    out = tmp_path / "killed"
    database = out / "results.sqlite"
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
    rng = random.Random(5)
    kills = 0
    early = 0  # kills before a new run: at most 5, so that every other attempt progresses
    for attempt in range(40):
        before = stored_runs(database)
        wanted = rng.randint(0 if early < 5 else 1, 3)
        errors = tmp_path / f"attempt{attempt}.stderr"
        with open(errors, "w") as stderr:
            process = subprocess.Popen(
                [BINARY, "run", str(path), "--out", str(out), "--resume"],
                stdout=subprocess.DEVNULL, stderr=stderr, env=env)
        # Wait (polling) for the wanted progress or the end; a hang fails after 10 minutes.
        deadline = time.monotonic() + 600
        while process.poll() is None and stored_runs(database) < before + wanted:
            assert time.monotonic() < deadline, "the runner made no progress"
            time.sleep(0.01)
        if process.poll() is not None:
            assert process.returncode == 0, f"attempt {attempt}: {errors.read_text()[-2000:]}"
            break
        process.send_signal(signal.SIGKILL)
        process.wait()
        kills += 1
        early += wanted == 0
    else:
        pytest.fail("the runner never finished in 40 attempts")
    assert kills >= 5
    assert rows(database) == expected


def test_ctrl_c_stops_cleanly_and_resume_finishes(kinolab, tmp_path):
    path = deterministic(tmp_path, name="interrupt", sleep_ms=300)
    out = tmp_path / "out"
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
    process = subprocess.Popen([BINARY, "run", str(path), "--out", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    # Interrupt once at least one run is stored (the database exists by then).
    database = out / "results.sqlite"
    for _ in range(600):
        if stored_runs(database) > 0:
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    stdout, _ = process.communicate(timeout=60)
    assert process.returncode == 130
    assert "resume with" in stdout
    done = len(rows(out / "results.sqlite"))
    assert 0 < done < 24
    again = kinolab("run", path, "--out", out)
    assert again.returncode == 1 and "--resume" in again.stderr
    resumed = kinolab("run", path, "--out", out, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert f"{done} were already done" in resumed.stdout
    assert len(rows(out / "results.sqlite")) == 24


@pytest.mark.parametrize("second", ["other experiment", "other shard", "resume"])
def test_one_writer_per_results_directory(kinolab, tmp_path, second):
    """Two runners into one --out: the second stops before any work, naming the holder;
    the first finishes alone and its database holds only its own runs."""
    path = deterministic(tmp_path, name="owner", sleep_ms=200)
    out = tmp_path / "out"
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
    first = subprocess.Popen([BINARY, "run", str(path), "--out", str(out), "--shard", "1/2"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    lock = out / ".kinolab.lock"
    for _ in range(600):
        if lock.exists() and "pid" in lock.read_text():
            break
        time.sleep(0.02)
    if second == "other experiment":
        (tmp_path / "other").mkdir()
        other = deterministic(tmp_path / "other", name="intruder")
        result = kinolab("run", other, "--out", out)
    elif second == "other shard":
        result = kinolab("run", path, "--out", out, "--shard", "2/2")
    else:
        result = kinolab("run", path, "--out", out, "--shard", "1/2", "--resume")
    _, stderr = first.communicate(timeout=120)
    assert first.returncode == 0, stderr
    assert result.returncode == 1, result.stdout + result.stderr
    assert "is in use by another process (kinolab run" in result.stderr
    assert f"pid {first.pid}" in result.stderr
    assert meta(out / "results.sqlite")["shard"] == "1/2"
    assert meta(out / "results.sqlite")["name"] == "owner"
    assert len(rows(out / "results.sqlite")) == 12  # exactly the first runner's shard
    # Once the first is done, the directory is free again.
    assert kinolab("run", path, "--out", out, "--shard", "1/2", "--resume").returncode == 0


def test_resume_retry_reruns_only_the_chosen_statuses(kinolab, tmp_path):
    """Runs recorded as crash or killed (a worker stopped from outside) run again with
    --resume --retry crash,killed; the others are kept as they are."""
    planners = LAZY + "\n  - id: crash\n    type: test_crash\n"
    path = experiment(tmp_path, planners)
    out = tmp_path / "out"
    assert kinolab("run", path, "--out", out).returncode == 0
    before = rows(out / "results.sqlite")
    with sqlite3.connect(out / "results.sqlite") as db:
        started = dict(db.execute("SELECT run_hash, started_at FROM runs"))
    time.sleep(1.1)  # a rerun run gets a later start time
    result = kinolab("run", path, "--out", out, "--resume", "--retry", "crash,killed")
    assert result.returncode == 0, result.stderr
    assert "4 stored runs with status crash or killed will run again" in result.stderr
    assert "4 runs ran" in result.stdout and "4 were already done" in result.stdout
    assert rows(out / "results.sqlite") == before  # same outcomes, deterministic
    with sqlite3.connect(out / "results.sqlite") as db:
        for run_hash, planner, when in db.execute("SELECT run_hash, planner, started_at FROM runs"):
            assert (when != started[run_hash]) == (planner == "crash"), planner

    for arguments, message in ((["--retry", "crash"], "add --resume"),
                               (["--resume", "--retry", "crashed"], "did you mean 'crash'")):
        refused = kinolab("run", path, "--out", out, *arguments)
        assert refused.returncode == 1 and message in refused.stderr, refused.stderr


def test_three_shards_merged_equal_the_unsharded_run(kinolab, tmp_path):
    path = deterministic(tmp_path, name="shards")
    whole = kinolab("run", path, "--out", tmp_path / "whole", "-j", "2")
    assert whole.returncode == 0, whole.stderr
    databases = []
    for shard in (1, 2, 3):
        out = tmp_path / f"shard{shard}"
        result = kinolab("run", path, "--out", out, "--shard", f"{shard}/3")
        assert result.returncode == 0, result.stderr
        databases.append(out / "results.sqlite")
    sizes = [len(rows(db)) for db in databases]
    assert sum(sizes) == 24 and min(sizes) >= 7

    missing = kinolab("merge", tmp_path / "two.sqlite", *databases[:2])
    assert missing.returncode == 1 and "2 of 3 shards" in missing.stderr
    merged = kinolab("merge", tmp_path / "merged.sqlite", *databases)
    assert merged.returncode == 0, merged.stderr
    assert rows(tmp_path / "merged.sqlite") == rows(tmp_path / "whole" / "results.sqlite")
    assert meta(tmp_path / "merged.sqlite")["config_hash"] == meta(databases[0])["config_hash"]

    (tmp_path / "other").mkdir()
    other = deterministic(tmp_path / "other", name="shards")
    other.write_text(other.read_text().replace("seed: 3", "seed: 4"))
    kinolab("run", other, "--out", tmp_path / "other_shard", "--shard", "3/3")
    mixed = kinolab("merge", tmp_path / "mixed.sqlite", databases[0], databases[1],
                    tmp_path / "other_shard" / "results.sqlite")
    assert mixed.returncode == 1 and "holds another experiment" in mixed.stderr
    assert not (tmp_path / "mixed.sqlite").exists()


def test_an_output_directory_of_another_experiment_is_refused(kinolab, tmp_path):
    first = experiment(tmp_path, LAZY, plugins=False, name="first")
    second = experiment(tmp_path, LAZY.replace("heuristic_weight: 2", "heuristic_weight: 3"),
                        plugins=False, name="second")
    assert kinolab("run", first, "--out", tmp_path / "out").returncode == 0
    result = kinolab("run", second, "--out", tmp_path / "out", "--resume")
    assert result.returncode == 1 and "holds another experiment" in result.stderr


MALFORMED = [
    ("planners: [{id: a, type: lazy_mp_astr}]", "unknown planner 'lazy_mp_astr'"),
    ("planners: [{id: a, type: lazy_mp_astar, params: {heuristic_weigth: 2}}]",
     "did you mean 'heuristic_weight'"),
    ("planners: [{id: a, type: lazy_mp_astar, params: {heuristic_weight: 0.5}}]",
     "heuristic_weight"),
    ("planners: [{id: a, type: lazy_mp_astar, params: {heuristic_weight: fast}}]",
     "heuristic_weight"),
    ("planners: [{id: a, type: lazy_mp_astar, sampler: {type: gauss}}]", "unknown sampler 'gauss'"),
    ("planners: [{id: a, type: lazy_mp_astar, sampler: {type: normal, params: {sigmaa: 1}}}]",
     "did you mean 'sigma'"),
    ("planners: [{id: a, type: rrtstar, sampler: {type: normal}}]", "unknown key 'sampler'"),
    ("planners: [{id: a, type: lazy_mp_astar}, {id: a, type: eager_mp_astar}]",
     "duplicate planner id"),
    ("planners: [{type: lazy_mp_astar}]", "missing required key 'id'"),
    ("planners: []", "no planners"),
    ("planner: [{id: a, type: lazy_mp_astar}]", "unknown key 'planner'"),
    ("repetitions: 0", "repetitions"),
    ("repetitions: many", "repetitions"),
    ("budget: {time: -1}", "budget.time"),
    ("budget: {memroy_mb: 100}", "did you mean 'memory_mb'"),
    ("queries: {random: {count: 0}}", "queries.random.count"),
    ("queries: {random: {count: 2, min_distance: 5, max_distance: 1}}", "max_distance"),
    ("queries: ~", "no queries"),
    ("queries: {across: {count: 1, axis: z}}", "expected x or y"),
    ("queries: {fixed: [{start: [1, 2], goal: [3, 3, 1]}]}", "queries.fixed"),
    ("worlds: [{id: w, spec: missing.yaml}]", "no such world spec file"),
    ("worlds: [{id: w, map: missing.bt, resolution: 0.1}]", "no such map file"),
    ("worlds: [{id: w, map: " + str(SOURCE_DIR / "data/maps/geb079.bt") + "}]",
     "missing required key 'resolution'"),
    ("worlds: [{id: w, spec: {name: w, resolution: 0.1, generators: [{type: forrest}]}}]",
     "forrest"),
    ("kind: sampling_study", "sampling studies run with kinolab sampling-study"),
    ("sweep: {grid: {planners.b.params.heuristic_weight: [1, 2]}}", "no list item 'b'"),
    ("sweep: {grid: {planners.a.parms.heuristic_weight: [1, 2]}}", "did you mean 'params'"),
    ("sweep: {zip: {planners.a.params.heuristic_weight: [1, 2], budget.time: [1]}}",
     "equal lengths"),
    ("sweep: {grid: {planners.a.params.heuristic_weight: [1, 0.5]}}", "heuristic_weight"),
    ("sweep: {gird: {budget.time: [1]}}", "did you mean 'grid'"),
    ("extends: nowhere.yaml", "no such file"),
    ("plugins: [nowhere.so]", "no such plugin library"),
    ("seed: [1]", "seed"),
]


@pytest.mark.parametrize("override, message", MALFORMED,
                         ids=[f"{i:02d}" for i in range(len(MALFORMED))])
def test_malformed_experiment_files_fail_with_the_expected_message(kinolab, tmp_path, override,
                                                                   message):
    base = tmp_path / "base.yaml"
    base.write_text(f"""kind: planning
name: base
seed: 1
worlds:{WORLD}queries:
  random: {{count: 2, min_distance: 3, max_distance: 8}}
planners: [{{id: a, type: lazy_mp_astar}}]
""")
    # Mappings merge with the base, lists replace it: each file changes one thing.
    path = tmp_path / "broken.yaml"
    path.write_text(override + "\n" if override.startswith("extends:")
                    else f"extends: base.yaml\n{override}\n")
    result = kinolab("run", path, "--out", tmp_path / "out")
    assert result.returncode == 1, result.stdout + result.stderr
    assert message in result.stderr, result.stderr
    assert "broken.yaml" in result.stderr, result.stderr
    assert not (tmp_path / "out").exists()


SHIPPED = sorted(p for p in (SOURCE_DIR / "experiments").rglob("*.yaml")
                 if "kind: sampling_study" not in p.read_text())


@pytest.mark.parametrize("path", SHIPPED,
                         ids=[str(p.relative_to(SOURCE_DIR / "experiments")) for p in SHIPPED])
def test_every_shipped_experiment_validates(kinolab, path):
    # A dry run builds the worlds in a cold cache: the 1 km city alone takes about 2 minutes
    # on 2 quiet cores, so a loaded machine gets more than the usual 300 s.
    result = kinolab("run", path, "--dry-run", timeout=1200)
    assert result.returncode == 0, result.stderr
    assert " runs\n" in result.stdout


def test_a_map_file_is_a_world(kinolab, tmp_path):
    path = tmp_path / "map.yaml"
    path.write_text(f"""kind: planning
name: map
worlds: [{{id: corridor, map: {SOURCE_DIR / "data/maps/geb079.bt"}, resolution: 0.08}}]
queries: {{random: {{count: 3, min_distance: 2, clearance: 0.4}}}}
planners: [{{id: lazy, type: lazy_mp_astar, params: {{heuristic_weight: 2}}}}]
""")
    result = kinolab("run", path, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    runs = rows(tmp_path / "out" / "results.sqlite").values()
    assert len(runs) == 3 and all(run["world"] == "corridor" for run in runs)


def test_a_reference_planner_the_sweep_does_not_touch_runs_once(kinolab):
    result = kinolab("run", SOURCE_DIR / "experiments" / "ablations" / "lazy_duplicate_rule.yaml",
                     "--dry-run")
    # 30 queries: eager once, lazy with lwa and with seed.
    assert ": 90 runs" in result.stdout, result.stdout


def select(directory, sql):
    with sqlite3.connect(directory / "results.sqlite") as db:
        return db.execute(sql).fetchall()


def test_the_timing_protocol_keeps_median_minimum_and_cold_time(kinolab, tmp_path):
    """`timing: {warmup, repeats}`: planning_time_ms is the median of the timed plans, never
    below their minimum; the cold time is the first plan's; the straight line's verdict is
    stored per run; a protocol out of range is refused naming the key."""
    path = experiment(tmp_path, LAZY, extra="\ntiming: {warmup: 1, repeats: 3}\n", plugins=False)
    assert kinolab("run", path, "--out", tmp_path / "out").returncode == 0
    runs = select(tmp_path / "out", "SELECT planning_time_ms, planning_time_min_ms, "
                  "planning_time_cold_ms, line_blocked, success FROM runs")
    assert len(runs) == 4
    for median, minimum, cold, blocked, success in runs:
        assert success == 1 and blocked in (0, 1)
        assert 0 < minimum <= median and cold > 0
    single = experiment(tmp_path, LAZY, extra="\ntiming: {warmup: 0, repeats: 1}\n",
                        plugins=False, name="single")
    assert kinolab("run", single, "--out", tmp_path / "single").returncode == 0
    for median, minimum, cold in select(tmp_path / "single", "SELECT planning_time_ms, "
                                        "planning_time_min_ms, planning_time_cold_ms FROM runs"):
        assert median == minimum == cold
    bad = experiment(tmp_path, LAZY, extra="\ntiming: {warmup: 1, repeats: 0}\n", plugins=False,
                     name="bad")
    refused = kinolab("run", bad, "--dry-run")
    assert refused.returncode == 1 and "timing.repeats" in refused.stderr


def test_a_plan_that_spends_its_own_time_limit_is_timed_once(kinolab, tmp_path):
    """RRT* refining without end spends its own `time_limit` (0.05 s), far inside the
    experiment's 5 s budget: the
    timing protocol times against the budget the planner has (Planner::budgetFor), so the
    plan is made once and that one is timed, not warm-up plus three repeats of it."""
    rrt = """
  - id: rrt
    type: rrtstar
    params: {time_limit: 0.05, refine_iterations: 100000000}
"""
    path = experiment(tmp_path, rrt, queries="random: {count: 2, min_distance: 3, max_distance: 8}",
                      extra="\nbudget: {time: 5}\ntiming: {warmup: 1, repeats: 3}\n", plugins=False)
    assert kinolab("run", path, "--out", tmp_path / "out").returncode == 0
    runs = select(tmp_path / "out", "SELECT planning_time_ms, planning_time_min_ms, "
                  "planning_time_cold_ms FROM runs")
    assert len(runs) == 2
    for median, minimum, cold in runs:
        assert median >= 50.0
        assert median == minimum == cold, "planned more than once"


def test_a_labelled_sweep_point_is_named_by_its_label(kinolab, tmp_path):
    sweep = """
sweep:
  list:
    - {label: coarse, planners.lazy.params.heuristic_weight: 3}
    - {planners.lazy.params.heuristic_weight: 1}
"""
    path = experiment(tmp_path, LAZY, extra=sweep, plugins=False)
    result = kinolab("run", path, "--dry-run")
    assert result.returncode == 0, result.stderr
    assert "coarse" in result.stdout and "planners.lazy.params.heuristic_weight=1" in result.stdout
    assert "heuristic_weight=3" not in result.stdout
    bad = experiment(tmp_path, LAZY, extra=sweep.replace("coarse", "bad name"), plugins=False,
                     name="bad")
    refused = kinolab("run", bad, "--dry-run")
    assert refused.returncode == 1 and "sweep.list[0].label" in refused.stderr
    twice = experiment(tmp_path, LAZY, plugins=False, name="twice",
                       extra=sweep.replace("- {planners", "- {label: coarse, planners"))
    refused = kinolab("run", twice, "--dry-run")
    assert refused.returncode == 1
    assert "sweep.list[1].label: another list item has the label 'coarse'" in refused.stderr


FLIGHT = """
  - id: lazy
    type: lazy_mp_astar
"""


def test_a_flight_experiment_flies_every_query_and_stores_the_flight_metrics(kinolab, tmp_path):
    path = experiment(tmp_path, FLIGHT, plugins=False, name="flights",
                      queries="random: {count: 2, min_distance: 6, max_distance: 9}",
                      extra="\nflight: {sensor: {type: depth_camera, range: 4}, max_time: 40}\n"
                            "store: {trajectories: true, trees: 1}\nbudget: {time: 120}\n")
    path.write_text(path.read_text().replace("kind: planning", "kind: flight"))
    result = kinolab("run", path, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    runs = select(tmp_path / "out", "SELECT status, success, length, checker_valid FROM runs")
    assert [r[0] for r in runs] == ["reached", "reached"], runs
    assert all(r[1] == 1 and r[2] > 6 and r[3] == 1 for r in runs)
    stats = dict(select(tmp_path / "out", "SELECT name, COUNT(*) FROM statistics GROUP BY name"))
    for name in ("time_to_goal", "replans", "replan_time_p95_ms", "frames", "frame_time_ms"):
        assert stats.get(name) == 2, (name, stats)
    assert len(select(tmp_path / "out", "SELECT run_hash FROM trajectories")) == 2
    # Every flight's replans; the known map of the first query only (store.trees: 1).
    flights = select(tmp_path / "out", "SELECT f.replans, f.known_map, r.query FROM flights f "
                     "JOIN runs r USING (run_hash) ORDER BY r.query")
    assert len(flights) == 2 and all(f[0].startswith("replan,time,reason") for f in flights)
    assert flights[0][1].count("\n") > 10 and flights[1][1] == ""
    again = kinolab("run", path, "--out", tmp_path / "out", "--resume")
    assert again.returncode == 0 and "2 already done" in again.stderr
    report = kinolab("report", tmp_path / "out")
    assert report.returncode == 0, report.stderr
    figures = {p.stem for p in (tmp_path / "out" / "report" / "figures").glob("*.png")}
    assert {"replan_times", "known_maps_small", "speeds_small", "trajectories_small"} <= figures
    gif = tmp_path / "out" / "report" / "figures" / "flight_lazy.gif"
    assert gif.read_bytes().startswith(b"GIF8")
    assert "Flights: each replan is timed once" in (
        tmp_path / "out" / "report" / "index.html").read_text()
    # The 3D view replays the stored flight with the known map it grew.
    page = (tmp_path / "out" / "report" / "view_small.html").read_text()
    scene = json.loads(re.search(r'id="kinolab-scene">(.*?)</script>', page, re.S).group(1))
    flight = scene["queries"][0]["flights"][0]
    assert flight["planner"] == "lazy" and len(flight["t"]) * 3 == len(flight["points"])
    known = flight["known"]["points"]  # x, y, z, first seen: every voxel of the final map
    stored = select(tmp_path / "out", "SELECT known_voxels FROM flights WHERE known_voxels != ''")
    assert len(known) == 4 * (stored[0][0].count("\n") - 1) > 0
    assert all(0 <= t <= flight["t"][-1] + 1e-6 for t in known[3::4])


@pytest.mark.parametrize("kind, extra, message", [
    ("flight", "\nflight: {rnage: 4}\n", "flight.rnage"),
    ("flight", "\nflight: {unknown: maybe}\n", "unknown"),
    ("flight", "\ntiming: {repeats: 1}\n", "timing: a flight is flown once"),
    ("planning", "\nflight: {range: 4}\n", "flight: flight parameters belong to 'kind: flight'"),
])
def test_malformed_flight_experiments_name_the_key(kinolab, tmp_path, kind, extra, message):
    path = experiment(tmp_path, FLIGHT, plugins=False, name="bad_flight", extra=extra)
    path.write_text(path.read_text().replace("kind: planning", f"kind: {kind}"))
    result = kinolab("run", path, "--dry-run")
    assert result.returncode == 1, result.stdout
    assert message in result.stderr, result.stderr


def test_threads_times_workers_beyond_the_cores_is_refused_before_anything_is_written(
        kinolab, tmp_path):
    cores = os.cpu_count()
    planners = f"""
  - id: eager
    type: eager_mp_astar
    sampler: {{type: uniform, params: {{samples_per_axis: 3}}}}
    params: {{threads: {cores}}}
"""
    path = experiment(tmp_path, planners, plugins=False)
    out = tmp_path / "out"
    result = kinolab("run", path, "--out", out, "-j", "2")
    assert result.returncode == 1
    assert f"planners 'eager', key threads: {cores} threads x -j 2 workers" in result.stderr
    assert f"expected threads x jobs <= {cores}" in result.stderr
    assert not out.exists()
    # Within the cores it runs, with the answers of one thread.
    result = kinolab("run", path, "--out", out, "-j", "1")
    assert result.returncode == 0, result.stderr
