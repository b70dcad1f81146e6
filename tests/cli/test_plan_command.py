"""`kinolab plan` end to end: the JSON summary, the files it writes, and bad input."""

import csv
import json
import os
import re
import subprocess

import pytest

from conftest import BINARY, last_json

FAST = ["--set", "sampler.samples_per_axis=3", "--set", "heuristic_weight=2"]


@pytest.mark.parametrize("planner", ["lazy_mp_astar", "eager_mp_astar", "greedy_mp"])
def test_plan_prints_a_checked_json_summary_and_writes_files(kinolab, world, tmp_path, planner):
    out = tmp_path / "out"
    result = kinolab("plan", "--world", world, "--planner", planner, *FAST,
                     "--start", "1,1,1.5", "--goal", "8.5,8,1.5", "--out", out)
    assert result.returncode == 0, result.stderr
    summary = last_json(result)
    for key in ("status", "success", "cost", "planning_time_ms", "expansions", "pops",
                "partial_evaluations", "full_evaluations", "distance_to_goal", "checker_valid",
                "time_check_ms"):
        assert key in summary, key
    assert summary["status"] == "exact" and summary["success"] is True
    assert summary["checker_valid"] is True
    assert summary["distance_to_goal"] <= 0.5
    assert summary["expansions"] > 0 and summary["planning_time_ms"] > 0
    assert isinstance(summary["expansions"], int)  # a declared counter
    if planner == "lazy_mp_astar":
        assert summary["partial_evaluations"] > summary["full_evaluations"] > 0
    assert json.loads((out / "result.json").read_text()) == summary

    rows = list(csv.DictReader((out / "trajectory.csv").open()))
    assert list(rows[0]) == ["t", "x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az",
                             "jx", "jy", "jz"]
    assert [float(rows[0][k]) for k in ("x", "y", "z", "vx")] == [1.0, 1.0, 1.5, 0.0]
    assert float(rows[1]["t"]) == pytest.approx(0.01)
    assert float(rows[-1]["t"]) == pytest.approx(summary["duration"])
    end = [float(rows[-1][k]) for k in ("x", "y", "z")]
    assert sum((a - b) ** 2 for a, b in zip(end, (8.5, 8, 1.5))) ** 0.5 <= 0.5 + 1e-6

    tree = list(csv.DictReader((out / "tree.csv").open()))
    states = {row["state"] for row in tree}
    assert "full" in states or "certified" in states
    if planner == "lazy_mp_astar":
        assert "partial" in states
    assert any(row["closed"] == "1" for row in tree)


def test_infeasible_queries_print_their_status_and_fail(kinolab, world):
    """An invalid start or goal is bad input: the result is printed (its status and why), and
    the command exits 1 naming the option."""
    outside = kinolab("plan", "--world", world, "--planner", "lazy_mp_astar", *FAST,
                      "--start", "-3,1,1.5", "--goal", "8,8,1.5")
    assert outside.returncode == 1
    assert "--start '-3,1,1.5': start (-3, 1, 1.5) is outside the map" in outside.stderr
    summary = last_json(outside)
    assert summary["status"] == "invalid_start" and "outside the map" in summary["message"]
    assert summary["checker_valid"] is False and summary["success"] is False
    floor = kinolab("plan", "--world", world, "--planner", "eager_mp_astar", *FAST,
                    "--start", "1,1,1.5", "--goal", "5,5,0.02")
    assert floor.returncode == 1 and "--goal '5,5,0.02'" in floor.stderr
    assert last_json(floor)["status"] == "invalid_goal"
    assert "in collision" in last_json(floor)["message"]


def test_piecewise_constant_acceleration_has_no_jerk_integral_but_its_jumps(kinolab, world):
    """MP-A* of order 2 flies constant accelerations: its jerk is impulsive at the joints, so
    the jerk integral is undefined (null, with the reason), never 0; the acceleration jumps
    and the integral of |a|^2 are its finite measures."""
    result = kinolab("plan", "--world", world, "--planner", "lazy_mp_astar", *FAST,
                     "--start", "1,1,1.5", "--goal", "8,8,1.5")
    assert result.returncode == 0, result.stderr
    summary = last_json(result)
    assert summary["status"] == "exact"
    assert summary["jerk_integral"] is None and summary["jerk_per_metre"] is None
    assert "jerk_integral: the acceleration jumps at" in summary["undefined"]
    assert summary["acceleration_jumps"] > 0 and summary["acceleration_integral"] > 0
    assert summary["objective"].startswith("motion-primitive cost: order 2")


@pytest.mark.parametrize("arguments, message", [
    (["--start", "1,2", "--goal", "8,8,1.5"], "--start '1,2': expected three numbers x,y,z"),
    (["--start", "1,a,2", "--goal", "8,8,1.5"], "'a' is not a finite number"),
    (["--planner", "lazy_mp_astr"], "unknown planner 'lazy_mp_astr' (did you mean 'lazy_mp_astar'?)"),
    (["--set", "heuristic_weigth=2"], "did you mean 'heuristic_weight'"),
    (["--set", "heuristic_weight=0.5"], "heuristic_weight"),
    (["--set", "lower_bound=lipschits"], "did you mean 'lipschitz'"),
    (["--set", "sampler.sigma=0.3"], "sigma"),
    (["--set", "sampler=gauss"], "unknown sampler 'gauss'"),
    (["--world", "missing.yaml"], "missing.yaml"),
])
def test_bad_input_fails_with_a_clear_message(kinolab, world, arguments, message):
    base = {"--world": str(world), "--planner": "lazy_mp_astar", "--start": "1,1,1.5",
            "--goal": "8,8,1.5"}
    extra = []
    for i in range(0, len(arguments), 2):
        if arguments[i] in base:
            base[arguments[i]] = arguments[i + 1]
        else:
            extra += arguments[i:i + 2]
    args = [item for pair in base.items() for item in pair] + extra
    result = kinolab("plan", *args)
    assert result.returncode == 1, result.stdout
    assert message in result.stderr, result.stderr


def test_list_shows_the_planners(kinolab):
    result = kinolab("list", "planners", "--json")
    assert result.returncode == 0, result.stderr
    planners = {p["key"]: p for p in json.loads(result.stdout)["planners"]}
    assert {"eager_mp_astar", "lazy_mp_astar", "greedy_mp", "rrtstar_ceres", "rrtstar"} <= set(planners)
    lazy = {p["name"]: p for p in planners["lazy_mp_astar"]["parameters"]}
    assert lazy["duplicate_rule"]["choices"] == ["lwa", "seed"]
    # Lower bounds and heuristics are plugin kinds: the parameter names its kind, and that
    # kind's registry lists the built-in ones.
    assert lazy["lower_bound"]["type"] == "lower_bound" and lazy["lower_bound"]["kind"] == "lower_bound"
    assert lazy["heuristic"]["kind"] == "heuristic" and lazy["heuristic"]["default"] == "lattice"
    everything = json.loads(kinolab("list", "--json").stdout)
    assert {"endpoint", "control_only", "lipschitz", "full"} <= {p["key"] for p in everything["lower_bounds"]}
    assert {"euclidean", "min_time", "time_optimal", "obvp", "max"} <= {p["key"] for p in everything["heuristics"]}
    assert {"depth_camera", "lidar"} <= {p["key"] for p in everything["sensors"]}
    assert lazy["heuristic_weight"]["minimum"] == 1.0


@pytest.mark.parametrize("planner", ["rrtstar_ceres", "rrtstar"])
def test_the_tgk_analogue_plans_and_reports_both_stages(kinolab, world, tmp_path, planner):
    out = tmp_path / "out"
    args = ("plan", "--world", world, "--planner", planner, "--set", "refine_iterations=200",
            "--start", "1,1,1.5", "--goal", "8.5,8,1.5", "--seed", "9", "--out", out)
    result = kinolab(*args)
    assert result.returncode == 0, result.stderr
    summary = last_json(result)
    assert summary["status"] == "exact" and summary["checker_valid"] is True
    assert summary["iterations"] == summary["first_solution_iteration"] + 200
    for key in ("tree_size", "collision_checks", "time_rrt_ms"):
        assert key in summary, key
    # The anytime series: [name, time_ms, value], the cost falling to RRT*'s best.
    progress = summary["progress"]
    assert progress and {name for name, _, _ in progress} == {"anytime_cost"}
    assert progress[-1][2] == summary["best_cost"]
    assert all(later[2] < earlier[2] for earlier, later in zip(progress, progress[1:]))
    if planner == "rrtstar_ceres":
        assert summary["ceres_iterations"] > 0 and summary["objective"] == "trajectory length"
        assert summary["jerk_integral"] > 0
        assert summary["time_back_end_ms"] > 0
    tree = list(csv.DictReader((out / "tree.csv").open()))
    assert len({row["edge"] for row in tree}) == summary["tree_size"] - 1
    # The same seed repeats the run exactly (time aside).
    again = last_json(kinolab(*args))
    assert again["length"] == summary["length"] and again["duration"] == summary["duration"]


@pytest.mark.parametrize("arguments, message", [
    (["--set", "refine_iterations=-1"], "refine_iterations"),
    (["--set", "back_end.knot_spacin=0.3"], "did you mean 'knot_spacing'"),
    (["--set", "back_end=bsplin"], "did you mean 'bspline'"),
    (["--set", "goal_bias=1.5"], "goal_bias"),
    (["--set", "sampler.sigma=0.3"], "it has no plugin parameter 'sampler'"),
])
def test_the_tgk_analogue_refuses_bad_parameters(kinolab, world, arguments, message):
    result = kinolab("plan", "--world", world, "--planner", "rrtstar_ceres", "--start", "1,1,1.5",
                     "--goal", "8,8,1.5", *arguments)
    assert result.returncode == 1, result.stdout
    assert message in result.stderr, result.stderr


def _loaded_libraries(world, tmp_path, *args):
    """The shared objects `kinolab plan ARGS` loads (the dynamic loader's own account)."""
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"), LD_DEBUG="files")
    result = subprocess.run([BINARY, "plan", "--world", str(world), "--start", "1,1,1.5",
                             "--goal", "8.5,8,1.5", *args],
                            capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    return set(re.findall(r"file=(\S+)\s+\[\d+\];\s+generating link map", result.stderr))


def test_a_plan_loads_ompl_ceres_and_fcl_only_when_it_uses_them(world, tmp_path):
    """Plugins of ON_USE modules (rrtstar_ceres: OMPL; bspline: Ceres, linked statically, with
    its solvers' libraries such as CHOLMOD) are known from their manifests; their modules and
    libraries load only when one of them is made. The checker's FCL module (and FCL) loads only
    for a body: a point robot's check never needs it."""
    marks = {"kinolab_module_rrtstar_ceres": "rrtstar module", "libompl": "OMPL",
             "kinolab_module_bspline_back_end": "bspline module", "libcholmod": "CHOLMOD",
             "kinolab_fcl_body": "FCL module", "libfcl": "FCL"}

    def loaded(*args):
        libraries = _loaded_libraries(world, tmp_path, *args)
        return {name for mark, name in marks.items() if any(mark in path for path in libraries)}

    point = ("--set", "robot_radius=0")
    assert loaded("--planner", "lazy_mp_astar", *point) == set()
    assert loaded("--planner", "lazy_mp_astar") == {"FCL module", "FCL"}
    assert loaded("--planner", "lazy_mp_astar", "--set", "back_end=bspline", *point) == {
        "bspline module", "CHOLMOD"}
    assert loaded("--planner", "rrtstar_ceres", "--set", "time_limit=0.5") >= {
        "rrtstar module", "OMPL", "FCL module", "FCL"}
