"""The result schema end to end: a statistic a planner declares in one line reaches
`kinolab plan`'s JSON, results.sqlite (with its declaration) and the report, with no other
edit; an undeclared one is refused; `kinolab list metrics` prints the schema."""

import json
import sqlite3

from conftest import SMALL_FOREST
from test_run_command import MISBEHAVING, experiment


def world_file(tmp_path):
    path = tmp_path / "world.yaml"
    path.write_text(SMALL_FOREST)
    return path


def test_a_declared_statistic_reaches_plan_json_sqlite_and_the_report(kinolab, tmp_path):
    plan = kinolab("--plugin", MISBEHAVING, "plan", "--world", world_file(tmp_path), "--planner",
                   "test_metric", "--start", "1,1,1.5", "--goal", "8,8,1.5")
    assert plan.returncode == 0, plan.stderr
    summary = json.loads(plan.stdout.strip().splitlines()[-1])
    assert summary["probe_answer"] == 42 and summary["status"] == "no_solution"

    path = experiment(tmp_path, "\n  - id: probe\n    type: test_metric\n")
    run = kinolab("run", path, "--out", tmp_path / "out")
    assert run.returncode == 0, run.stderr
    with sqlite3.connect(tmp_path / "out" / "results.sqlite") as db:
        values = {v for (v,) in db.execute(
            "SELECT value FROM statistics WHERE name = 'probe_answer'")}
        declared = db.execute("SELECT kind, planner_type, type, unit, doc FROM metrics "
                              "WHERE name = 'probe_answer'").fetchall()
        columns = {row[1] for row in db.execute("PRAGMA table_info(runs)")}
        version = db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
    assert values == {42.0}
    assert declared == [("statistic", "test_metric", "integer", "count",
                         "the answer this test planner always reports")]
    assert {"status", "success", "planning_time_ms", "checker_valid", "wall_time_ms"} <= columns
    # The database records the layout this kinolab writes (`kinolab list metrics --json`).
    listed = json.loads(kinolab("list", "metrics", "--json").stdout)
    assert version == (str(listed["schema_version"]),)

    report = kinolab("report", tmp_path / "out")
    assert report.returncode == 0, report.stderr
    table = (tmp_path / "out" / "report" / "tables" / "statistics.md").read_text()
    row = next(line for line in table.splitlines() if "probe_answer" in line)
    assert "probe" in row and "42" in row and "count" in row


def test_an_undeclared_statistic_is_refused_naming_the_planner(kinolab, tmp_path):
    plan = kinolab("--plugin", MISBEHAVING, "plan", "--world", world_file(tmp_path), "--planner",
                   "test_metric", "--set", "undeclared=true", "--start", "1,1,1.5",
                   "--goal", "8,8,1.5")
    assert plan.returncode == 1
    assert "'test_metric'" in plan.stderr and "'probe_undeclared'" in plan.stderr


def test_list_metrics_prints_the_schema(kinolab):
    listing = kinolab("list", "metrics", "--json")
    assert listing.returncode == 0, listing.stderr
    schema = json.loads(listing.stdout)
    result = {m["name"]: m for m in schema["result"]}
    assert result["planning_time_ms"]["clock"] is True and result["planning_time_ms"]["unit"] == "ms"
    assert result["success"]["type"] == "boolean"
    assert {m["name"] for m in schema["runner"]} == {
        "peak_memory_mb", "planning_time_min_ms", "planning_time_cold_ms", "line_blocked",
        "time_limit", "time_limit_own", "wall_time_ms", "started_at", "load_average"}
    # What a comparison across planners may use: the checker's evaluation of the trajectory
    # is comparable, a planner's own objective is not.
    assert result["cost"]["comparable"] is False and result["objective"]["type"] == "text"
    for name in ("duration", "length", "acceleration_integral", "jerk_integral",
                 "acceleration_jumps", "max_curvature", "min_clearance", "peak_speed"):
        assert result[name]["comparable"] is True, name
    assert result["length"]["direction"] == "lower"
    assert result["min_clearance"]["direction"] == "higher"
    # A flight's run columns are a plan's: one runs table for both.
    flight = {m["name"]: m for m in schema["flight"]}
    assert {"status", "success", "length", "jerk_integral", "undefined"} <= set(flight)
    lazy = {m["name"]: m for m in schema["statistics"]["lazy_mp_astar"]}
    assert lazy["expansions"]["type"] == "integer"
    assert "time_check_ms" in {m["name"] for m in schema["statistics"]["common"]}
    text = kinolab("list", "metrics")
    assert text.returncode == 0 and "statistics of planner 'rrtstar_ceres'" in text.stdout


def test_resuming_into_a_database_of_another_schema_is_refused(kinolab, tmp_path):
    path = experiment(tmp_path, "\n  - id: probe\n    type: test_metric\n")
    assert kinolab("run", path, "--out", tmp_path / "out").returncode == 0
    with sqlite3.connect(tmp_path / "out" / "results.sqlite") as db:
        db.execute("DELETE FROM meta WHERE key = 'schema_version'")
    again = kinolab("run", path, "--out", tmp_path / "out", "--resume")
    assert again.returncode == 1
    assert "schema version 1" in again.stderr and "new --out directory" in again.stderr
