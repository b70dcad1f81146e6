"""Plugin libraries and plugins that misbehave where kinolab calls them: a library built for
another ABI, one whose ABI record or entry point is not what it should be (a one-byte record,
data for a function), an entry point or factory that throws (a std::exception or an int), a
planner that throws an int, a sensor and a vehicle map that throw. Each is one `kinolab: error:` line naming the library and the plugin, a
non-zero exit, never a crash; in `kinolab run` a throwing planner is its runs' error and the
other planners go on. `--plugin` is repeatable and loads a library once."""

import json
import os
import sqlite3
from contextlib import closing
from pathlib import Path

import pytest

MISBEHAVING = os.environ.get("KINOLAB_MISBEHAVING")
pytestmark = pytest.mark.skipif(not MISBEHAVING, reason="needs the test plugin library (CTest)")


def hostile(name):
    """A library beside the misbehaving one (tests/plugins/hostile_libraries.cpp)."""
    return str(Path(MISBEHAVING).with_name(f"libkinolab_test_{name}.so"))


def hostile_experiment(tmp_path, world, plugin, count, planners, kind="planning"):
    """An experiment of `kind` in tmp_path loading `plugin`: `count` random queries in `world`
    (at 1.5 m for flights), the `planners` list and anything after it given as YAML text."""
    experiment = tmp_path / "experiment.yaml"
    height = ", height: [1.5, 1.5]" if kind == "flight" else ""
    experiment.write_text(f"""kind: {kind}
name: hostile
plugins: [{plugin}]
worlds:
  - id: small
    spec: {world}
queries:
  random: {{count: {count}, min_distance: 4, max_distance: 9{height}}}
planners:
""" + planners)
    return experiment


def one_error_line(result, *needles):
    assert result.returncode == 1, (result.returncode, result.stderr)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("kinolab: error: "), result.stderr
    for needle in needles:
        assert needle in lines[0], lines[0]


@pytest.mark.parametrize("library, message", [
    ("abi_mismatch", "this kinolab has ABI"),
    ("entry_throws", "its entry point (kinolab_register_plugins) threw: hostile entry point"),
    ("entry_throws_int", "threw something that is not a std::exception"),
    ("small_record", "its kinolab_plugin_abi_record is 1 bytes, not 16"),
    ("data_entry", "its kinolab_register_plugins is not a function"),
])
def test_a_hostile_library_is_refused_by_every_command(kinolab, world, tmp_path, library,
                                                       message):
    path = hostile(library)
    one_error_line(kinolab("--plugin", path, "list", "planners"), path, message)
    one_error_line(kinolab("plan", "--plugin", path, "--world", world, "--planner",
                           "lazy_mp_astar", "--start", "1,1,1", "--goal", "8,8,1"), message)
    experiment = hostile_experiment(tmp_path, world, path, 1, """  - id: lazy
    type: lazy_mp_astar
""")
    result = kinolab("run", experiment, "--out", tmp_path / "out")
    assert result.returncode == 1 and message in result.stderr, result.stderr
    assert not (tmp_path / "out" / "results.sqlite").exists()


@pytest.mark.parametrize("planner, message", [
    ("test_throw", "(planner 'test_throw'): plan() threw: test_throw always throws"),
    ("test_throw_int", "(planner 'test_throw_int'): plan() threw something that is not"),
    ("test_factory_throws", "(planner 'test_factory_throws'): its factory threw: "),
    ("test_factory_throws_int", "its factory threw something that is not a std::exception"),
])
def test_plan_names_the_plugin_whose_code_threw(kinolab, world, planner, message):
    result = kinolab("--plugin", MISBEHAVING, "plan", "--world", world, "--planner", planner,
                     "--start", "1,1,1", "--goal", "8,8,1")
    one_error_line(result, MISBEHAVING, message)


def test_a_throwing_planner_is_its_runs_error_and_the_others_go_on(kinolab, world, tmp_path):
    experiment = hostile_experiment(tmp_path, world, MISBEHAVING, 2, """  - id: lazy
    type: lazy_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
  - id: factory
    type: test_factory_throws_int
  - id: plans
    type: test_throw_int
""")
    result = kinolab("run", experiment, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    with closing(sqlite3.connect(tmp_path / "out" / "results.sqlite")) as db:
        rows = db.execute("SELECT planner, status, message FROM runs").fetchall()
    by_planner = {}
    for planner, status, message in rows:
        by_planner.setdefault(planner, []).append((status, message))
    assert [status for status, _ in by_planner["lazy"]] == ["exact", "exact"]
    for planner, needle in (("factory", "its factory threw"), ("plans", "plan() threw")):
        assert len(by_planner[planner]) == 2
        for status, message in by_planner[planner]:
            assert status == "error" and needle in message and MISBEHAVING in message


def test_a_throwing_sensor_or_vehicle_map_is_named_by_fly_and_is_its_runs_error(kinolab, world,
                                                                               tmp_path):
    fly = ["fly", "--world", world, "--planner", "lazy_mp_astar", "--start", "1,1,1.5",
           "--goal", "8.5,8,1.5"]
    one_error_line(kinolab("--plugin", MISBEHAVING, *fly, "--flight", "sensor=test_sensor_throws"),
                   MISBEHAVING, "(sensor 'test_sensor_throws'): rayCount() threw: "
                   "test_sensor_throws has no rays")
    map_message = ("(vehicle_map 'test_map_throws_int'): insert() threw something that is not "
                   "a std::exception")
    one_error_line(kinolab("--plugin", MISBEHAVING, *fly, "--flight", "map=test_map_throws_int"),
                   MISBEHAVING, map_message)
    experiment = hostile_experiment(tmp_path, world, MISBEHAVING, 2, """  - id: lazy
    type: lazy_mp_astar
flight: {map: test_map_throws_int}
""", kind="flight")
    result = kinolab("run", experiment, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    with closing(sqlite3.connect(tmp_path / "out" / "results.sqlite")) as db:
        rows = db.execute("SELECT status, message FROM runs").fetchall()
    assert len(rows) == 2
    for status, message in rows:
        assert status == "error" and map_message in message and MISBEHAVING in message


def test_plugin_is_repeatable_and_loads_a_library_once(kinolab, tmp_path):
    link = tmp_path / "same.so"
    link.symlink_to(MISBEHAVING)
    for args in (("--plugin", MISBEHAVING, "--plugin", MISBEHAVING, "list", "planners"),
                 ("--plugin", MISBEHAVING, "list", "--plugin", str(link), "planners"),
                 ("list", "planners", "--plugin", MISBEHAVING, "--plugin", MISBEHAVING)):
        result = kinolab(*args)
        assert result.returncode == 0, result.stderr
        assert result.stdout.count("test_trivial ") == 1, result.stdout


@pytest.mark.parametrize("command, needle", [
    (["plan", "--time-limit", "0.5", "--start", "1,1,1", "--goal", "8,8,1"],
     "did not return within its 0.5 s budget"),
    (["fly", "--flight", "planning_margin=0", "--start", "1,1,1.5", "--goal", "8.5,8,1.5"],
     "did not return from a replan within its 0.1 s budget"),
])
def test_a_planner_that_never_returns_is_stopped(kinolab, world, command, needle):
    # test_hang ignores its budget: the watchdog ends the process at budget + grace (the
    # subprocess's own 300 s timeout would fail the test long before "forever").
    result = kinolab("--plugin", MISBEHAVING, command[0], "--world", world, "--planner",
                     "test_hang", "--grace", "0.5", *command[1:])
    assert result.returncode == 1, result.stderr
    assert needle in result.stderr
    last = json.loads(result.stdout.strip().splitlines()[-1])
    assert last["status"] == "killed" and last["message"].startswith("timeout: ")
