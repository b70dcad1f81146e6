"""kinolab from Python: worlds as NumPy views, plugins, planners with keyword parameters,
results with every metric, errors as exceptions, the GIL released while planning, and the
experiment runner with its progress."""

import json
import math
import os
from pathlib import Path
import subprocess
import threading
import time

import numpy as np
import pytest
import yaml

import kinolab
from conftest import BINARY, SMALL_FOREST

START, GOAL = (1.0, 1.0, 1.5), (9.0, 8.0, 1.5)


def cli(*args, tmp_path):
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(tmp_path / "cache"))
    return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True, env=env,
                          timeout=300)


# ---- worlds ---------------------------------------------------------------------------

def test_the_grid_and_esdf_are_read_only_views_of_kinolabs_arrays(forest, tmp_path):
    occupancy, esdf = forest.occupancy, forest.esdf
    assert occupancy.dtype == np.uint8 and esdf.dtype == np.float32
    assert occupancy.shape == esdf.shape == forest.shape == (100, 100, 30)
    # No copy: two reads share one buffer, owned by the world, and neither can be written.
    assert np.shares_memory(occupancy, forest.occupancy) and np.shares_memory(esdf, forest.esdf)
    assert not occupancy.flags.owndata and not occupancy.flags.writeable
    with pytest.raises(ValueError):
        esdf[0, 0, 0] = 1.0
    # The same arrays `kinolab world --out` writes.
    assert cli("world", SMALL_FOREST, "--out", tmp_path / "w", tmp_path=tmp_path).returncode == 0
    assert np.array_equal(occupancy, np.load(tmp_path / "w" / "occupancy.npy"))
    assert np.array_equal(esdf, np.load(tmp_path / "w" / "esdf.npy"))
    # The arrays outlive the Python world object that handed them out.
    del forest
    assert occupancy.sum() > 0 and np.isfinite(esdf).all()


def test_a_spec_dict_builds_the_same_world_as_its_file_and_the_cache_serves_it_again():
    spec = yaml.safe_load(SMALL_FOREST.read_text())
    from_file = kinolab.World.from_file(SMALL_FOREST)
    from_dict = kinolab.World.from_spec(spec)
    assert from_dict.spec_hash == from_file.spec_hash
    assert np.array_equal(from_dict.occupancy, from_file.occupancy)
    assert from_file.source == "built" and from_dict.source == "cache"
    uncached = kinolab.World.from_spec(dict(spec, seed=5), cache=False)
    assert uncached.source == "built" and uncached.spec_hash != from_file.spec_hash


def test_nan_and_negative_inputs_never_give_a_distance_or_a_verdict(forest):
    for query in (forest.distance, forest.distance_with_gradient):
        with pytest.raises(kinolab.InvalidArgument, match="row 1 is not finite"):
            query(np.array([[1.0, 1.0, 1.0], [1.0, math.nan, 1.0]]))
        with pytest.raises(kinolab.InvalidArgument, match="row 0 is not finite"):
            query(np.array([1.0, 1.0, math.inf]))
    for radius in (math.nan, -1.0, math.inf):
        with pytest.raises(kinolab.InvalidArgument, match="radius"):
            forest.segment_free((1, 1, 1), (8, 8, 1), radius)
    assert forest.segment_free(START, START, 0.0)  # a valid radius still answers


def test_distances_are_vectorised_and_their_gradient_is_the_fields_slope(forest):
    rng = np.random.default_rng(3)
    points = rng.uniform([0.5, 0.5, 0.5], [9.5, 9.5, 2.5], size=(500, 3))
    distance = forest.distance(points)
    assert distance.shape == (500,)
    # Many points at once (two to an SSE2 register) give exactly what one at a time gives.
    assert all(distance[i] == forest.distance(points[i]) for i in range(0, 500, 7))
    # At a voxel centre the trilinear distance is the ESDF's value there.
    index = np.array([37, 52, 14])
    centre = np.array(forest.origin) + (index + 0.5) * forest.resolution
    assert forest.distance(centre) == pytest.approx(forest.esdf[tuple(index)], abs=1e-6)
    d, gradient = forest.distance_with_gradient(points)
    assert np.array_equal(d, distance) and gradient.shape == (500, 3)
    step = 1e-5  # central differences inside the trilinear cells agree with the gradient
    for axis in range(3):
        offset = np.zeros(3)
        offset[axis] = step
        numeric = (forest.distance(points + offset) - forest.distance(points - offset)) / (2 * step)
        agree = np.isclose(numeric, gradient[:, axis], atol=1e-3)
        assert agree.mean() > 0.97  # a cell face between the two probes may kink it
    with pytest.raises(kinolab.InvalidArgument, match=r"shape \(n, 3\)"):
        forest.distance(np.zeros((4, 2)))


# ---- plugins and parameters -----------------------------------------------------------

def test_plugins_are_listed_with_their_parameters_as_the_command_lists_them(tmp_path):
    listed = json.loads(cli("list", "--json", tmp_path=tmp_path).stdout)
    planners = {p["key"]: p for p in kinolab.planners()}
    assert set(planners) == {p["key"] for p in listed["planners"]}
    lazy = {p["name"]: p for p in planners["lazy_mp_astar"]["parameters"]}
    assert lazy["heuristic_weight"]["default"] == 1.0 and lazy["heuristic_weight"]["range"] == "[1, 100]"
    assert {s["key"] for s in kinolab.samplers()} >= {"uniform", "normal", "random"}


def test_an_out_of_tree_plugin_library_loads():
    kinolab.load_plugin(os.environ["KINOLAB_MISBEHAVING"])
    assert "test_metric" in {p["key"] for p in kinolab.planners()}
    with pytest.raises(kinolab.PluginError, match="libplugin.so.: no such file"):
        kinolab.load_plugin("/nonexistent/libplugin.so")


def hostile_library(name):
    """A test-only library beside the misbehaving one (tests/plugins/hostile_libraries.cpp)."""
    return str(Path(os.environ["KINOLAB_MISBEHAVING"]).with_name(f"libkinolab_test_{name}.so"))


@pytest.mark.parametrize("library, message", [
    ("abi_mismatch", r"built for plugin ABI \d+, this kinolab has ABI \d+"),
    ("entry_throws", r"its entry point \(kinolab_register_plugins\) threw: hostile entry point"),
    ("entry_throws_int", r"threw something that is not a std::exception"),
])
def test_a_hostile_library_is_a_plugin_error_and_registers_nothing(library, message):
    with pytest.raises(kinolab.PluginError, match=message):
        kinolab.load_plugin(hostile_library(library))
    assert "test_half_registered" not in {p["key"] for p in kinolab.planners()}


@pytest.mark.parametrize("key, message", [
    ("test_factory_throws", r"\(planner 'test_factory_throws'\): its factory threw: "),
    ("test_factory_throws_int", r"its factory threw something that is not a std::exception"),
    ("test_throw", r"\(planner 'test_throw'\): plan\(\) threw: test_throw always throws"),
    ("test_throw_int", r"\(planner 'test_throw_int'\): plan\(\) threw something that is not"),
])
def test_plugin_code_that_throws_is_a_plugin_error_naming_it(forest, key, message):
    kinolab.load_plugin(os.environ["KINOLAB_MISBEHAVING"])
    with pytest.raises(kinolab.PluginError, match=message):
        kinolab.Planner(key, forest).plan(START, GOAL)


def test_keyword_parameters_configure_the_planner_and_its_sampler(forest):
    planner = kinolab.Planner("lazy_mp_astar", forest, sampler="normal",
                              **{"sampler.sigma": 0.4, "sampler.samples_per_axis": 5},
                              heuristic_weight=np.float64(1.5), duplicate_rule="seed")
    parameters = planner.parameters
    assert parameters["sampler"] == "normal" and parameters["sampler.sigma"] == 0.4
    assert parameters["sampler.samples_per_axis"] == 5
    assert parameters["heuristic_weight"] == 1.5 and parameters["duplicate_rule"] == "seed"


def test_errors_are_exceptions_with_the_command_lines_messages(forest, tmp_path):
    for name, value in [("heuristic_wieght", 2), ("heuristic_weight", -2), ("tau", "fast")]:
        with pytest.raises(kinolab.ConfigError) as raised:
            kinolab.Planner("lazy_mp_astar", **{name: value})
        command = cli("plan", "--world", SMALL_FOREST, "--planner", "lazy_mp_astar", "--set",
                      f"{name}={value}", "--start", "1,1,1", "--goal", "5,5,1", tmp_path=tmp_path)
        assert command.returncode == 1
        said = command.stderr.strip().removeprefix("kinolab: error: --set: ")
        assert str(raised.value) == f"keyword argument '{name}': {said}"
    with pytest.raises(kinolab.PluginError, match="unknown planner 'lazy'; known planners"):
        kinolab.Planner("lazy")
    with pytest.raises(kinolab.ConfigError, match="densty"):
        kinolab.World.from_spec({"name": "x", "resolution": 0.1,
                                 "bounds": {"min": [0, 0, 0], "max": [2, 2, 2]},
                                 "generators": [{"type": "forest", "densty": 0.1}]})
    with pytest.raises(kinolab.Error, match="nothing.yaml"):
        kinolab.World.from_file(tmp_path / "nothing.yaml")
    assert issubclass(kinolab.ParameterConflict, kinolab.ConfigError)
    assert issubclass(kinolab.ConfigError, kinolab.Error)
    with pytest.raises(kinolab.InvalidArgument, match="goal: expected three numbers"):
        kinolab.Planner("lazy_mp_astar", forest).plan(START, (1, 2))
    with pytest.raises(kinolab.InvalidArgument, match="start_velocity: not finite"):
        kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL, start_velocity=(0, math.inf, 0))
    with pytest.raises(kinolab.InvalidArgument, match="goal: not finite"):
        kinolab.Planner("lazy_mp_astar", forest).plan(START, (1, float("nan"), 1))
    with pytest.raises(kinolab.InvalidArgument, match="no world"):
        kinolab.Planner("lazy_mp_astar").plan(START, GOAL)
    with pytest.raises(kinolab.InvalidArgument, match="time_limit"):
        kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL, time_limit=-1)


# ---- planning -------------------------------------------------------------------------

def test_a_plan_carries_every_metric_of_the_schema_as_the_command_prints_it(forest, tmp_path):
    result = kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL, tree=True)
    assert result.status == "exact" and result.success and result.check["valid"]
    command = cli("plan", "--world", SMALL_FOREST, "--planner", "lazy_mp_astar",
                  "--start", "1,1,1.5", "--goal", "9,8,1.5", tmp_path=tmp_path)
    printed = json.loads(command.stdout.strip().splitlines()[-1])
    metrics = result.metrics
    assert set(metrics) == set(printed) - {"planner", "world", "seed"}
    assert metrics["cost"] == printed["cost"] and metrics["expansions"] == printed["expansions"]
    assert isinstance(metrics["success"], bool) and isinstance(metrics["expansions"], int)
    samples = result.trajectory(0.01)
    assert samples["position"].shape == (len(samples["t"]), 3)
    assert samples["t"][-1] == pytest.approx(result.duration)
    assert np.allclose(samples["position"][0], START) and np.linalg.norm(
        samples["position"][-1] - GOAL) <= 0.5
    tree = result.tree
    assert len(tree["points"]) == len(tree["state"]) == len(tree["closed"]) > 0
    assert set(tree["state"]) <= {"partial", "full", "certified", "rejected"}
    assert "partial" in set(tree["state"])  # lazy queues edges on their lower bound
    assert kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL).tree is None


def test_lazy_and_eager_return_the_same_cost_from_python(forest):
    lazy = kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL)
    eager = kinolab.Planner("eager_mp_astar", forest).plan(START, GOAL, start_velocity=(0, 0, 0))
    assert lazy.cost == pytest.approx(eager.cost, rel=1e-9)
    moving = kinolab.Planner("eager_mp_astar", forest).plan(START, GOAL, start_velocity=(0.6, 0, 0))
    assert moving.trajectory()["velocity"][0] == pytest.approx([0.6, 0, 0])


def test_an_invalid_start_is_a_status_not_an_exception(forest):
    result = kinolab.Planner("lazy_mp_astar", forest).plan((-5, 1, 1), GOAL)
    assert result.status == "invalid_start" and not result.success


def test_planning_releases_the_gil(forest):
    """While one thread plans, Python code runs in another."""
    # 343 controls and the paper's heuristic: this query takes about a second, so the plan
    # spends its 0.6 s budget.
    planner = kinolab.Planner("eager_mp_astar", forest, heuristic="time_optimal",
                              **{"sampler.samples_per_axis": 7})
    window = {}

    def plan():
        window["begin"] = time.perf_counter()
        window["result"] = planner.plan(START, (9.0, 9.0, 2.5), time_limit=0.6,
                                        max_iterations=10**9)
        window["end"] = time.perf_counter()

    thread = threading.Thread(target=plan)
    ticks = []
    thread.start()
    while thread.is_alive():
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    thread.join()
    assert window["result"].planning_time_ms > 300  # the plan took long enough to tell
    inside = [t for t in ticks if window["begin"] + 0.05 < t < window["end"] - 0.05]
    assert len(inside) > 50  # with the GIL held there would be none


def test_one_planner_shared_by_threads_serves_one_call_at_a_time(forest):
    """Two threads planning with the same Planner object neither hang nor race: each call
    gets the cost the planner gives alone (before: the interpreter hung)."""
    planner = kinolab.Planner("lazy_mp_astar", forest)
    reference = planner.plan(START, GOAL).cost
    costs = []

    def plan_several():
        for _ in range(5):
            costs.append(planner.plan(START, GOAL).cost)
            planner.reset()

    threads = [threading.Thread(target=plan_several) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert not any(thread.is_alive() for thread in threads)
    assert costs == [reference] * 10


def test_a_trajectory_is_sampled_only_at_a_finite_step(forest):
    result = kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL)
    for step in (math.inf, math.nan, 0.0):
        with pytest.raises(kinolab.InvalidArgument, match="step"):
            result.trajectory(step=step)


def test_two_threads_plan_at_once_and_agree_with_one(forest):
    """While one thread runs a long plan, another completes whole plans of its own, with
    the cost it gets alone."""
    reference = kinolab.Planner("lazy_mp_astar", forest).plan(START, GOAL).cost
    long_plan, short_plans = {}, []

    def long():
        planner = kinolab.Planner("eager_mp_astar", forest, heuristic="time_optimal",
                              **{"sampler.samples_per_axis": 7})
        long_plan["begin"] = time.perf_counter()
        long_plan["result"] = planner.plan(START, (9.0, 9.0, 2.5), time_limit=0.6)
        long_plan["end"] = time.perf_counter()

    def short():
        planner = kinolab.Planner("lazy_mp_astar", forest)
        while "end" not in long_plan:
            begin = time.perf_counter()
            cost = planner.plan(START, GOAL).cost
            short_plans.append((begin, time.perf_counter(), cost))

    threads = [threading.Thread(target=long), threading.Thread(target=short)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert long_plan["result"].planning_time_ms > 300
    during = [cost for begin, end, cost in short_plans
              if long_plan["begin"] < begin and end < long_plan["end"]]
    assert len(during) > 10  # with the GIL held by the long plan there would be none
    assert all(cost == reference for _, _, cost in short_plans)


# ---- experiments and the viewer -------------------------------------------------------

EXPERIMENT = """
name: from_python
seed: 3
worlds: [{{id: forest, spec: {world}}}]
queries: {{random: {{count: 3, min_distance: 4, max_distance: 8, clearance: 0.5, height: [1.5, 1.5]}}}}
planners:
  - {{id: eager, type: eager_mp_astar}}
  - {{id: lazy, type: lazy_mp_astar}}
budget: {{time: 2.0}}
store: {{trajectories: true, trees: 1}}
"""


def test_an_experiment_runs_with_progress_and_loads_with_the_analysis_package(tmp_path):
    path = tmp_path / "experiment.yaml"
    path.write_text(EXPERIMENT.format(world=SMALL_FOREST))
    seen = []
    summary = kinolab.run_experiment(path, tmp_path / "out", jobs=2,
                                     progress=lambda *state: seen.append(state))
    assert summary["finished"] == 6 and summary["succeeded"] == 6
    assert [done for done, *_ in seen] == list(range(1, 7)) and seen[-1][1] == 6
    results = kinolab.load_results(tmp_path / "out")
    assert len(results.runs) == 6 and set(results.runs["planner"]) == {"eager", "lazy"}
    again = kinolab.run_experiment(path, tmp_path / "out", resume=True, progress=False)
    assert again["skipped"] == 6 and again["finished"] == 0
    with pytest.raises(kinolab.Error, match="already holds"):
        kinolab.run_experiment(path, tmp_path / "out", progress=False)
    with pytest.raises(kinolab.InvalidArgument, match=r"jobs: expected a whole number"):
        kinolab.run_experiment(path, tmp_path / "other", jobs=0)
    with pytest.raises(ZeroDivisionError):  # a failing progress callback stops the run
        kinolab.run_experiment(path, tmp_path / "stopped", progress=lambda *state: 1 / 0)
    assert len(kinolab.load_results(tmp_path / "stopped").runs) == 1  # what ran is kept
    with pytest.raises(kinolab.ConfigError, match="budget"):
        bad = tmp_path / "bad.yaml"
        bad.write_text(EXPERIMENT.format(world=SMALL_FOREST).replace("time: 2.0", "tiem: 2.0"))
        kinolab.run_experiment(bad, tmp_path / "bad")


def test_a_scene_of_python_results_becomes_a_view(forest, tmp_path):
    scene = kinolab.Scene("python", forest)
    query = scene.add_query("q", START, GOAL)
    for key in ("lazy_mp_astar", "eager_mp_astar"):
        scene.add_result(query, key, kinolab.Planner(key, forest).plan(START, GOAL, tree=True))
    document = json.loads(scene.json())
    assert document["format"] == "kinolab-scene" and len(document["world"]["boxes"]) % 6 == 0
    assert [t["planner"] for t in document["queries"][0]["trajectories"]] == [
        "lazy_mp_astar", "eager_mp_astar"]
    assert document["queries"][0]["trees"][0]["edges"]["partial"]
    page = scene.write(tmp_path / "view.html").read_text()
    assert page == scene.html() and "THREE.OrbitControls" in page and "__KINOLAB_SCENE__" not in page
    inline = scene._repr_html_()  # what a notebook shows
    assert inline.startswith("<iframe srcdoc=") and "&lt;script" in inline


def test_every_plugin_kind_is_listed_from_its_registry():
    """plugins(kind) lists any registry, as `kinolab list KIND` does; an unknown kind is a clear
    error naming the known ones."""
    kinds = kinolab.plugin_kinds()
    assert {"planners", "samplers", "heuristics", "lower_bounds", "worlds", "sensors",
            "search_spaces"} <= set(kinds)
    assert {"time_optimal", "obvp"} <= {p["key"] for p in kinolab.plugins("heuristics")}
    forest = next(p for p in kinolab.plugins("worlds") if p["key"] == "forest")
    assert {"density", "canopy", "region"} <= {p["name"] for p in forest["parameters"]}
    with pytest.raises(kinolab.InvalidArgument, match="did you mean 'sensors'"):
        kinolab.plugins("sensor_s")


def test_every_public_name_has_a_docstring():
    """Every name in kinolab.__all__, and every public method and property of its classes,
    says what it is (a pybind signature line alone does not count)."""
    import inspect
    import kinolab

    def documented(doc):
        lines = [line for line in (doc or "").strip().splitlines() if line.strip()]
        if lines and "(self" in lines[0] and "->" in lines[0]:  # pybind's signature line
            lines = lines[1:]
        return bool(lines)

    missing = []
    for name in kinolab.__all__:
        item = getattr(kinolab, name)
        if not documented(item.__doc__) or (inspect.isclass(item) and
                                             item.__doc__ in (object.__doc__,
                                                              Exception.__doc__)):
            missing.append(name)
        if inspect.isclass(item):
            for attribute, value in vars(item).items():
                if attribute.startswith("_"):
                    continue
                if not documented(getattr(value, "__doc__", None)):
                    missing.append(f"{name}.{attribute}")
    assert missing == []


def test_run_experiment_shows_one_progress_display_as_lines_off_a_terminal(tmp_path, capfd):
    path = tmp_path / "experiment.yaml"
    path.write_text(EXPERIMENT.format(world=SMALL_FOREST))
    kinolab.run_experiment(path, tmp_path / "out", jobs=2)  # progress=True, stdout captured
    out, err = capfd.readouterr()
    assert "\r" not in out
    lines = [line for line in out.splitlines() if line.startswith("run: ")]
    assert lines and lines[-1].startswith("run: 6/6 done") and len(lines) <= 7
    assert "unsolved" not in err  # the runner's own display is off: one display, not two
