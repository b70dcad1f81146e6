"""`kinolab export DIR --format ompl OUT`: OMPL benchmark logs that OMPL's own
ompl_benchmark_statistics (Debian's ompl-demos) turns into Planner Arena's database, read
back here run by run."""

import os
import shutil
import sqlite3
import subprocess

import pytest


EXPERIMENT = """
name: export_test
seed: 5
plugins: [{misbehaving}]
worlds: [{{id: forest, spec: {world}}}]
queries: {{random: {{count: 4, min_distance: 4, max_distance: 8, clearance: 0.5, height: [1.5, 1.5]}}}}
planners:
  - {{id: eager, type: eager_mp_astar}}
  - {{id: lazy, type: lazy_mp_astar, params: {{heuristic_weight: 1.0}}}}
  - {{id: crashes, type: test_crash}}
  - {{id: rrt, type: rrtstar, params: {{refine_iterations: 200}}}}
budget: {{time: 2.0}}
timing: {{warmup: 0, repeats: 1}}
sweep:
  list:
    - {{label: tight, planners.lazy.params.goal_radius: 0.3}}
    - {{label: loose, planners.lazy.params.goal_radius: 0.6}}
"""


@pytest.fixture
def results(kinolab, tmp_path, world):
    path = tmp_path / "experiment.yaml"
    path.write_text(EXPERIMENT.format(world=world, misbehaving=os.environ["KINOLAB_MISBEHAVING"]))
    run = kinolab("run", path, "--out", tmp_path / "out", "-j", "2")
    assert run.returncode == 0, run.stderr
    return tmp_path / "out"


def test_the_logs_become_planner_arenas_database_with_every_run(kinolab, results, tmp_path):
    script = shutil.which("ompl_benchmark_statistics")
    assert script, "OMPL's ompl_benchmark_statistics: apt-get install ompl-demos (setup_debian.sh)"
    export = kinolab("export", results, "--format", "ompl", tmp_path / "logs")
    assert export.returncode == 0, export.stderr
    logs = sorted((tmp_path / "logs").glob("*.log"))
    assert [log.name for log in logs] == ["forest_loose.log", "forest_tight.log"]
    convert = subprocess.run([script, *map(str, logs), "-d", str(tmp_path / "arena.db")],
                             capture_output=True, text=True, timeout=120)
    assert convert.returncode == 0, convert.stderr

    with sqlite3.connect(tmp_path / "arena.db") as arena, \
            sqlite3.connect(results / "results.sqlite") as ours:
        experiments = dict(arena.execute("SELECT id, name FROM experiments"))
        assert sorted(experiments.values()) == ["export_test.forest.loose", "export_test.forest.tight"]
        assert {row[0] for row in arena.execute("SELECT timelimit FROM experiments")} == {2.0}
        planners = dict(arena.execute("SELECT id, name FROM plannerConfigs"))
        assert set(planners.values()) == {"eager", "lazy", "crashes", "rrt"}
        statuses = [row[0] for row in arena.execute(
            "SELECT description FROM enums WHERE name = 'status' ORDER BY value")]
        mine = {}
        for row in ours.execute("SELECT sweep, planner, query, status, success, planning_time_ms, "
                                "cost, length FROM runs"):
            mine[row[:3]] = row[3:]
        # The sweep changes only lazy: the runner stores eager's and crashes' runs once (in
        # the first variant, tight); each variant's log has them.
        assert {(s, p) for s, p, _ in mine} == {("tight", "eager"), ("tight", "crashes"),
                                                ("tight", "rrt"), ("tight", "lazy"),
                                                ("loose", "lazy")}
        for planner in ("eager", "crashes", "rrt"):
            mine.update({("loose", planner, q): mine[("tight", planner, q)] for q in range(4)})
        theirs = {}
        for row in arena.execute("SELECT experimentid, plannerid, query, status, solved, time, "
                                 "cost, \"solution_length\" FROM runs"):
            variant = experiments[row[0]].rsplit(".", 1)[1]
            theirs[(variant, planners[row[1]], row[2])] = row[3:]
        # RRT*'s anytime progress: Planner Arena's progress table holds every sample of
        # ours, in seconds, for the run it belongs to.
        our_progress = {}
        for query, time_ms, value in ours.execute(
                "SELECT runs.query, time_ms, value FROM progress JOIN runs USING (run_hash) "
                "WHERE runs.planner = 'rrt' AND progress.name = 'anytime_cost'"):
            our_progress.setdefault(query, []).append((time_ms / 1000.0, value))
        arena_progress = {}
        for experiment, query, time_s, value in arena.execute(
                "SELECT runs.experimentid, runs.query, progress.time, anytime_cost FROM progress "
                "JOIN runs ON progress.runid = runs.id ORDER BY progress.time"):
            if experiments[experiment].endswith("tight"):
                arena_progress.setdefault(query, []).append((time_s, value))
    assert our_progress and sum(map(len, our_progress.values())) >= 4
    assert {q: sorted(samples) for q, samples in our_progress.items()} == arena_progress
    assert set(theirs) == set(mine) and len(mine) == 2 * 4 * 4  # every run, once
    for case, (status, success, time_ms, cost, length) in mine.items():
        arena_status, solved, time_s, arena_cost, arena_length = theirs[case]
        assert statuses[arena_status] == status, case
        assert bool(solved) == bool(success), case
        if time_ms is None:
            assert time_s is None, case
        else:
            assert time_s == pytest.approx(time_ms / 1000.0, rel=1e-12), case
        assert arena_cost == (pytest.approx(cost) if cost is not None else None), case
        assert arena_length == (pytest.approx(length) if length is not None else None), case
    assert {status for status, *_ in mine.values()} >= {"exact", "crash"}


def test_exporting_what_is_not_a_planning_database_is_a_clear_error(kinolab, tmp_path):
    missing = kinolab("export", tmp_path / "nothing", "--format", "ompl", tmp_path / "logs")
    assert missing.returncode == 1 and "no results database" in missing.stderr
    unknown = kinolab("export", tmp_path, "--format", "csv", tmp_path / "logs")
    assert unknown.returncode == 1 and "ompl" in unknown.stderr
    alone = kinolab("export", tmp_path, "--format", "ompl")
    assert alone.returncode == 1 and "OUT" in alone.stderr
    assert not (tmp_path / "logs").exists()


def test_an_out_that_is_a_file_is_refused_and_left_alone(kinolab, results, tmp_path):
    (tmp_path / "logs").write_text("mine")
    export = kinolab("export", results, "--format", "ompl", tmp_path / "logs")
    assert export.returncode == 1 and "kinolab: error:" in export.stderr
    assert "Traceback" not in export.stderr and (tmp_path / "logs").read_text() == "mine"
