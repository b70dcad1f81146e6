"""What makes a comparison across planners trustworthy at the level of the runner: one time
budget for every planner, experiments that grow in place with --resume, and queries no planner
can start from refused before any run."""

import sqlite3

from conftest import SMALL_FOREST


def write_experiment(directory, planners, queries=3, name="grow", extra=""):
    """A planning experiment in the small forest; `planners` is YAML list text."""
    world = directory / "world.yaml"
    world.write_text(SMALL_FOREST)
    path = directory / f"{name}.yaml"
    path.write_text(f"""kind: planning
name: {name}
seed: 11
worlds:
  - id: small
    spec: {world}
queries:
  random: {{count: {queries}, min_distance: 4, max_distance: 9}}
planners:{planners}
timing: {{warmup: 0, repeats: 1}}
{extra}""")
    return path


EAGER = """
  - id: eager
    type: eager_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
"""
LAZY = """
  - id: lazy
    type: lazy_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
"""


def rows(database, sql):
    with sqlite3.connect(database) as db:
        return db.execute(sql).fetchall()


def test_the_experiments_budget_is_every_planners_budget(kinolab, tmp_path):
    """BIT* refines to its time limit; its own default is 1 s. The experiment's 2 s budget is
    its budget (it refines past 1 s), unless its entry sets its own time_limit, which is then
    recorded with the run."""
    planners = """
  - id: bit
    type: ompl_geometric
  - id: bit_own
    type: ompl_geometric
    params: {time_limit: 0.2}
  - id: bit_none
    type: ompl_geometric
    params: {time_limit: 0, max_iterations: 2000}
"""
    path = write_experiment(tmp_path, planners, queries=1, extra="budget: {time: 2}\n")
    result = kinolab("run", path, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    stored = dict((planner, (limit, own, time)) for planner, limit, own, time in rows(
        tmp_path / "out" / "results.sqlite",
        "SELECT planner, time_limit, time_limit_own, planning_time_ms FROM runs"))
    limit, own, time = stored["bit"]
    assert (limit, own) == (2.0, 0)
    assert time >= 1500.0, "BIT* stopped at its own default, not at the experiment's budget"
    limit, own, _ = stored["bit_own"]
    assert (limit, own) == (0.2, 1)
    # An own time_limit of 0 ("none") leaves the experiment's budget as its budget.
    limit, own, _ = stored["bit_none"]
    assert (limit, own) == (2.0, 0)


def test_an_experiment_grows_in_place_with_resume(kinolab, tmp_path):
    """Adding a planner and queries adds only their runs; every earlier row stays as it was.
    Changing a planner's parameters makes new runs, and the file keeps the old ones apart (not
    in the planned table)."""
    out = tmp_path / "out"
    database = out / "results.sqlite"
    first = write_experiment(tmp_path, EAGER, queries=2)
    assert kinolab("run", first, "--out", out).returncode == 0
    before = {row[0]: row for row in rows(database, "SELECT * FROM runs")}
    assert len(before) == 2

    grown = write_experiment(tmp_path, EAGER + LAZY, queries=3)
    refused = kinolab("run", grown, "--out", out)
    assert refused.returncode == 1 and "--resume" in refused.stderr
    result = kinolab("run", grown, "--out", out, "--resume")
    assert result.returncode == 0, result.stderr
    assert "2 were already done" in result.stdout or "2 already done" in result.stderr
    after = {row[0]: row for row in rows(database, "SELECT * FROM runs")}
    assert len(after) == 6  # 2 kept + eager's third query + lazy's three
    for run_hash, row in before.items():
        assert after[run_hash] == row, "an earlier run changed"
    planned = {row[0] for row in rows(database, "SELECT run_hash FROM planned")}
    assert planned == set(after)
    # Labels stay the planner ids.
    assert {row[0] for row in rows(database, "SELECT DISTINCT planner FROM runs")} == {
        "eager", "lazy"}

    changed = write_experiment(
        tmp_path, EAGER + LAZY.replace("samples_per_axis: 3}}", "samples_per_axis: 3}}\n"
                                       "    params: {heuristic_weight: 2}"), queries=3)
    assert kinolab("run", changed, "--out", out, "--resume").returncode == 0
    final = {row[0] for row in rows(database, "SELECT run_hash FROM runs")}
    planned = {row[0] for row in rows(database, "SELECT run_hash FROM planned")}
    stale = final - planned
    assert len(final) == 9 and len(stale) == 3  # the old lazy runs, kept apart
    assert {row[0] for row in rows(database, "SELECT planner FROM runs WHERE run_hash IN ("
                                   + ",".join(f"'{h}'" for h in stale) + ")")} == {"lazy"}

    # --retry reruns only what the experiment still plans: the old lazy runs stay.
    assert kinolab("run", changed, "--out", out, "--resume", "--retry", "exact").returncode == 0
    assert stale <= {row[0] for row in rows(database, "SELECT run_hash FROM runs")}

    other = write_experiment(tmp_path, EAGER, queries=2, name="other")
    result = kinolab("run", other, "--out", out, "--resume")
    assert result.returncode == 1 and "holds another experiment" in result.stderr


def test_a_fixed_query_inside_an_obstacle_is_refused_by_the_dry_run(kinolab, tmp_path):
    """A fixed start outside the map: no planner can start there. The dry run refuses it with
    its place; so does the run, before anything is written."""
    path = write_experiment(tmp_path, EAGER, queries=1)
    text = path.read_text().replace(
        "queries:\n  random: {count: 1, min_distance: 4, max_distance: 9}",
        "queries:\n  fixed:\n    - {start: [1, 1, 1.5], goal: [8, 8, 1.5]}\n"
        "    - {start: [-2, 1, 1.5], goal: [8, 8, 1.5]}")
    path.write_text(text)
    dry = kinolab("run", path, "--dry-run")
    assert dry.returncode == 1
    assert "world 'small', query 1: the start (-2, 1, 1.5) is outside the map" in dry.stderr
    run = kinolab("run", path, "--out", tmp_path / "out")
    assert run.returncode == 1 and "query 1" in run.stderr
    assert not (tmp_path / "out" / "results.sqlite").exists()
