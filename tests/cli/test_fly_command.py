"""`kinolab fly` end to end: the JSON summary, the files it writes, and bad input."""

import csv
import json

import pytest

from conftest import last_json


def test_fly_prints_a_json_summary_and_writes_the_flight(kinolab, world, tmp_path):
    out = tmp_path / "out"
    result = kinolab("fly", "--world", world, "--planner", "lazy_mp_astar",
                     "--start", "1,1,1.5", "--goal", "8.5,8,1.5", "--out", out)
    assert result.returncode == 0, result.stderr
    summary = last_json(result)
    assert summary["status"] == "reached" and summary["success"] is True, summary
    for key in ("time_to_goal", "flown_length", "mean_speed", "replans", "failed_replans",
                "replan_time_median_ms", "replan_time_p95_ms", "replan_time_max_ms",
                "min_clearance", "plan_distance_median", "jerk_integral", "frames",
                "frame_time_ms"):
        assert key in summary, key
    assert summary["flown_length"] >= 10.0  # at least the straight line, 10.1 m
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
