"""`kinolab fly` end to end: the JSON summary, the files it writes, and bad input."""

import csv
import json
import os

import pytest

from conftest import last_json


def test_fly_prints_a_json_summary_and_writes_the_flight(kinolab, world, tmp_path):
    out = tmp_path / "out"
    result = kinolab("fly", "--world", world, "--planner", "lazy_mp_astar",
                     "--start", "1,1,1.5", "--goal", "8.5,8,1.5", "--out", out)
    assert result.returncode == 0, result.stderr
    summary = last_json(result)
    assert summary["status"] == "reached" and summary["success"] is True, summary
    for key in ("time_to_goal", "length", "mean_speed", "replans", "failed_replans",
                "replan_time_median_ms", "replan_time_p95_ms", "replan_time_max_ms",
                "min_clearance", "plan_distance_median", "jerk_integral", "frames",
                "frame_time_ms"):
        assert key in summary, key
    assert summary["length"] >= 10.0  # at least the straight line, 10.1 m
    assert summary["min_clearance"] > -0.011  # the body keeps its radius less the tolerance
    assert json.loads((out / "summary.json").read_text())["status"] == "reached"
    flown = list(csv.DictReader((out / "flown.csv").open()))
    assert float(flown[0]["x"]) == pytest.approx(1.0)
    replans = list(csv.DictReader((out / "replans.csv").open()))
    assert len(replans) == summary["replans"] and replans[0]["reason"] == "start"
    plans = list(csv.DictReader((out / "plans.csv").open()))
    assert {row["replan"] for row in plans} <= {row["replan"] for row in replans}
    assert (out / "known_map.bt").read_bytes().startswith(b"# Octomap OcTree binary file")


def test_fly_refuses_bad_input_naming_it(kinolab, world):
    base = ["fly", "--world", world, "--planner", "lazy_mp_astar", "--start", "1,1,1.5",
            "--goal", "8.5,8,1.5"]
    for extra, expected in ((["--flight", "rnage=3"], "rnage"),
                            (["--flight", "range=-1"], "range"),
                            (["--flight", "sensor=sonar"], "sensor"),
                            (["--set", "tua=1"], "tua")):
        result = kinolab(*base, *extra)
        assert result.returncode == 1, (extra, result.stderr)
        assert expected in result.stderr, (extra, result.stderr)
    blocked = kinolab("fly", "--world", world, "--planner", "lazy_mp_astar",
                      "--start", "-5,1,1.5", "--goal", "8.5,8,1.5")
    assert blocked.returncode == 0 and last_json(blocked)["status"] == "invalid_start"


def test_in_range_flight_settings_end_as_a_status_or_a_refusal_naming_the_setting(kinolab, world):
    """A margin that leaves nothing of the map to plan in is refused naming it; wind that
    blows the vehicle off the map ends the flight as left_map (before: an abort on the
    planning window's box)."""
    base = ["fly", "--world", world, "--planner", "lazy_mp_astar", "--start", "1,1,1.5",
            "--goal", "8.5,8,1.5"]
    margin = kinolab(*base, "--flight", "planning_margin=10")
    assert margin.returncode == 1, margin.stdout
    assert "planning_margin 10 m" in margin.stderr and "1.5 m" in margin.stderr, margin.stderr
    windy = kinolab(*base, "--flight", "wind_sigma=100", "--flight", "timing=deterministic")
    assert windy.returncode == 0, windy.stderr
    summary = last_json(windy)
    assert summary["status"] == "left_map" and summary["success"] is False, summary
    assert "left the map" in summary["message"]


@pytest.mark.skipif(not os.environ.get("KINOLAB_MISBEHAVING"),
                    reason="needs the test plugin library (CTest)")
def test_a_replan_is_timed_on_the_cpu_unless_the_wall_clock_is_asked_for(kinolab, world,
                                                                         tmp_path):
    # test_trivial sleeps 200 ms and plans nothing: a wait, not work. On the CPU clock (the
    # default) its replans are on time and fail as no_solution; on the wall clock every one is
    # later than the 125 ms latency. Its planning model has no speed limit: the flight still
    # samples its stops finitely (it looped forever on a zero time step).
    for clock, status in (("cpu", "no_solution"), ("wall", "late")):
        out = tmp_path / clock
        result = kinolab("--plugin", os.environ["KINOLAB_MISBEHAVING"], "fly", "--world", world,
                         "--planner", "test_trivial", "--set", "sleep_ms=200", "--flight",
                         "planning_margin=0", "--flight", "stuck_time=0.5", "--flight",
                         f"clock={clock}", "--start", "1,1,1.5", "--goal", "8.5,8,1.5",
                         "--out", out)
        assert result.returncode == 0, result.stderr
        assert last_json(result)["status"] == "stuck"
        replans = list(csv.DictReader((out / "replans.csv").open()))
        assert replans and {row["status"] for row in replans} == {status}, (clock, replans)
        times = [float(row["planning_time_ms"]) for row in replans]
        assert (max(times) < 125.0) if clock == "cpu" else (min(times) >= 200.0), times
