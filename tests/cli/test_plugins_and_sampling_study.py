"""`kinolab list` and `kinolab sampling-study` end to end."""

import csv
import json
import os

from conftest import SOURCE_DIR

MISBEHAVING = os.environ.get("KINOLAB_MISBEHAVING")


def test_list_prints_every_sampler_with_its_parameters(kinolab):
    result = kinolab("list")
    assert result.returncode == 0, result.stderr
    for key in ("uniform", "normal", "random"):
        assert f"\n  {key} " in result.stdout
    assert "samples_per_axis" in result.stdout and "quantile|random" in result.stdout


def test_list_json_is_complete_and_typed(kinolab):
    result = kinolab("list", "samplers", "--json")
    assert result.returncode == 0, result.stderr
    document = json.loads(result.stdout)
    samplers = {plugin["key"]: plugin for plugin in document["samplers"]}
    assert set(samplers) >= {"uniform", "normal", "random"}
    sigma = next(p for p in samplers["normal"]["parameters"] if p["name"] == "sigma")
    assert sigma == {"name": "sigma", "type": "real", "default": 0.5, "minimum": 0.05,
                     "maximum": 10.0, "doc": sigma["doc"]} and sigma["doc"]
    variant = next(p for p in samplers["normal"]["parameters"] if p["name"] == "variant")
    assert variant["choices"] == ["quantile", "random"]
    count = samplers["uniform"]["parameters"][0]
    assert (count["type"], count["minimum"], count["maximum"]) == ("int", 1, 64)


def test_list_rejects_unknown_kinds_and_plugin_files(kinolab, tmp_path):
    assert kinolab("list", "samplerz").returncode != 0
    missing = kinolab("--plugin", tmp_path / "nothing.so", "list")
    assert missing.returncode == 1
    assert "nothing.so': no such file" in missing.stderr
    not_elf = tmp_path / "fake.so"
    not_elf.write_text("not a library")
    result = kinolab("list", "--plugin", not_elf)
    assert result.returncode == 1 and "cannot be loaded" in result.stderr


def test_test_plugin_runs_the_conformance_suites_on_the_library_s_plugins_only(kinolab, tmp_path):
    # A planner that does nothing fails the planner contract (it never solves); the runner
    # names each of the library's plugins, runs only theirs, and exits non-zero.
    result = kinolab("test-plugin", MISBEHAVING, "--", "--gtest_filter=*/test_trivial")
    assert result.returncode == 1, result.stdout + result.stderr
    for key in ("test_trivial", "test_throw", "test_metric"):
        assert f"testing planner '{key}'" in result.stdout
    assert "SolvesAndSolvesAgainTheSameAfterReset/test_trivial" in result.stdout
    assert "FAILED" in result.stdout and "/uniform" not in result.stdout
    assert "4 tests: 1 passed, 3 FAILED" in result.stdout, result.stdout
    # Each test runs in a child: a plugin that crashes or hangs fails its tests, the rest run.
    crash = kinolab("test-plugin", MISBEHAVING, "--timeout", "3", "--",
                    "--gtest_filter=*/test_crash:*/test_hang")
    assert crash.returncode == 1, crash.stdout + crash.stderr
    assert "test_crash: crashed: signal 11" in crash.stdout, crash.stdout
    assert "test_hang: hung: killed after 3 s" in crash.stdout, crash.stdout
    assert "8 tests: 2 passed, 6 FAILED" in crash.stdout  # parameter checks pass for both
    # A filter that selects no test is an error, not a pass.
    none = kinolab("test-plugin", MISBEHAVING, "--", "--gtest_filter=*/no_such_plugin")
    assert none.returncode == 1 and "no conformance test selected" in none.stderr, none.stderr
    # Bad input: a file that is not a library, a missing one; no suite runs.
    not_elf = tmp_path / "fake.so"
    not_elf.write_text("not a library")
    for path, message in ((not_elf, "cannot be loaded"), (tmp_path / "none.so", "no such file")):
        refused = kinolab("test-plugin", path)
        assert refused.returncode == 1 and message in refused.stderr, refused.stderr
        assert refused.stderr.startswith("kinolab: error: ") and "Running" not in refused.stdout


def test_paper_table1_study_writes_consistent_csv(kinolab, tmp_path):
    config = SOURCE_DIR / "experiments" / "paper_table1_samplers.yaml"
    result = kinolab("sampling-study", config, "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    assert "paper a" in result.stdout and "uniform" in result.stdout
    with open(tmp_path / "summary.csv") as f:
        summary = {row["sampler"]: row for row in csv.DictReader(f)}
    assert set(summary) == {"random", "uniform", "normal", "normal_random"}
    with open(tmp_path / "sampling_study.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4 * 21  # rest + 20 moving states per sampler
    for name, entry in summary.items():
        mine = [r for r in rows if r["sampler"] == name]
        mean_alpha = sum(float(r["alpha"]) for r in mine) / len(mine)
        assert abs(mean_alpha - float(entry["alpha"])) < 1e-12
        for r in mine:
            assert int(r["useful"]) == round(float(r["alpha"]) * int(r["controls"]))
            assert 0 <= int(r["limit_breaking"]) <= int(r["controls"])
    # 5 per axis over +-3 m/s^2 for 0.4 s: endpoints 0.12 m apart, all useful.
    assert float(summary["uniform"]["alpha"]) == 1.0
    assert abs(float(summary["uniform"]["mean_nearest"]) - 0.12) < 1e-9
    assert float(summary["uniform"]["paper_alpha"]) == 0.84


def test_sampling_study_errors_name_file_and_key(kinolab, tmp_path):
    config = tmp_path / "study.yaml"
    config.write_text(
        "kind: sampling_study\nname: x\n"
        "dynamics: {order: 2, duration: 0.4, limits: {velocity: 2, acceleration: 3}}\n"
        "samplers:\n  - {type: normal, params: {sigma: 20}}\n")
    result = kinolab("sampling-study", config, "--out", tmp_path / "out")
    assert result.returncode == 1
    assert f"{config}:5:" in result.stderr
    assert "samplers[0].params.sigma" in result.stderr and "[0.05, 10]" in result.stderr
    assert not (tmp_path / "out").exists()
    result = kinolab("sampling-study", tmp_path / "missing.yaml")
    assert result.returncode == 1 and "no such file" in result.stderr
