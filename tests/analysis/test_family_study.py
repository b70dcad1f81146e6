"""The study a new user writes first: four planners of three families (lazy MP-A*, hybrid
A*, BIT* with the B-spline back end, the TGK analogue) on a world of their own swept over its
density, under one budget, then `kinolab report`; then the study grows by a planner. The
report must not test own objectives across families, must honour the experiment's budget,
count only exact answers as successes, keep the world variants apart, and the experiment must
grow in place."""

import os
import re
import sqlite3
import subprocess
import textwrap
from pathlib import Path

import pytest

SOURCE_DIR = Path(__file__).resolve().parents[2]
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))

PLANNERS = """
  - id: lazy
    type: lazy_mp_astar
  - id: hybrid
    type: hybrid_astar
  - id: bit
    type: ompl_geometric
    params: {planner: bitstar, back_end: bspline}
  - id: tgk
    type: rrtstar_ceres
    params: {refine_iterations: 100}
"""
EAGER = """
  - id: eager
    type: eager_mp_astar
"""


def study(planners: str) -> str:
    world = textwrap.indent((SOURCE_DIR / "tests/support/small_forest.yaml").read_text(), " " * 6)
    return f"""kind: planning
name: family_study
seed: 7
worlds:
  - id: forest
    spec:
{world}queries:
  random: {{count: 3, min_distance: 5, max_distance: 9}}
planners:{planners}budget: {{time: 1.5}}
timing: {{warmup: 0, repeats: 1}}
store: {{trajectories: true, trees: 1}}
sweep:
  list:
    - {{worlds.forest.spec.generators.0.density: 0.05}}
    - {{worlds.forest.spec.generators.0.density: 0.12}}
"""


def kinolab(*args, cache):
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(cache))
    return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True, env=env,
                          timeout=900)


def markdown_rows(path: Path) -> list[dict[str, str]]:
    lines = [line for line in path.read_text().splitlines() if line.startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    return [dict(zip(header, (cell.strip() for cell in line.strip("|").split("|"))))
            for line in lines[2:]]


@pytest.fixture(scope="module")
def grown(tmp_path_factory):
    """The study run, reported; then grown by eager MP-A* with --resume and reported again."""
    base = tmp_path_factory.mktemp("study")
    cache = base / "cache"
    out = base / "out"
    path = base / "study.yaml"
    path.write_text(study(PLANNERS))
    first = kinolab("run", path, "--out", out, "-j", "2", cache=cache)
    assert first.returncode == 0, first.stderr
    with sqlite3.connect(out / "results.sqlite") as db:
        before = {row[0]: row for row in db.execute("SELECT * FROM runs")}
    report = kinolab("report", out, "--out", base / "report", cache=cache)
    assert report.returncode == 0, report.stderr
    path.write_text(study(PLANNERS + EAGER))
    again = kinolab("run", path, "--out", out, "-j", "2", "--resume", cache=cache)
    assert again.returncode == 0, again.stderr
    with sqlite3.connect(out / "results.sqlite") as db:
        after = {row[0]: row for row in db.execute("SELECT * FROM runs")}
    grown_report = kinolab("report", out, "--out", base / "grown_report", cache=cache)
    assert grown_report.returncode == 0, grown_report.stderr
    return {"out": out, "report": base / "report", "grown_report": base / "grown_report",
            "before": before, "after": after}


def test_no_test_of_own_objectives_across_families(grown):
    with sqlite3.connect(grown["out"] / "results.sqlite") as db:
        objectives = dict(db.execute("SELECT DISTINCT planner, objective FROM runs "
                                     "WHERE objective != ''"))
    assert objectives["lazy"] != objectives["bit"] != objectives["hybrid"]
    tested = set()
    for row in markdown_rows(grown["report"] / "tables" / "paired.md"):
        if "cost" in row["metric"] or "objective" in row["metric"]:
            assert objectives[row["a"]] == objectives[row["b"]], row
            tested.add(frozenset((row["a"], row["b"])))
    # BIT* and the TGK analogue both minimise the trajectory's length: their costs compare
    # (in either order: the pair's order follows the runs' order in the database).
    assert tested == {frozenset(("bit", "tgk"))}


def test_the_experiments_budget_is_every_planners(grown):
    with sqlite3.connect(grown["out"] / "results.sqlite") as db:
        limits = set(db.execute("SELECT time_limit, time_limit_own FROM runs"))
    assert limits == {(1.5, 0)}


def test_success_is_exact_and_checker_valid(grown):
    with sqlite3.connect(grown["out"] / "results.sqlite") as db:
        stored = db.execute("SELECT status, checker_valid, success FROM runs").fetchall()
    for status, valid, success in stored:
        assert success == (status == "exact" and valid == 1)
    # Approximate, timeout and failed are their own columns, beside success.
    per_planner = markdown_rows(grown["report"] / "tables" / "summary.md")
    assert {"success", "approximate", "timeout", "failed"} <= set(per_planner[0])


def test_world_variants_are_apart(grown):
    html = (grown["report"] / "index.html").read_text()
    headings = re.findall(r"<h[23][^>]*>(.*?)</h[23]>", html, re.S)
    assert len(headings) == len(set(headings)), [h for h in headings if headings.count(h) > 1]
    worlds = markdown_rows(grown["report"] / "tables" / "worlds.md")
    assert len(worlds) == 2
    assert any("0.05" in row["world"] for row in worlds)
    assert any("0.12" in row["world"] for row in worlds)


def test_the_study_grows_by_a_planner(grown):
    before, after = grown["before"], grown["after"]
    assert len(after) == len(before) + 6  # eager on 3 queries in each of 2 worlds
    for run_hash, row in before.items():
        assert after[run_hash] == row
    summary = (grown["grown_report"] / "tables" / "status_counts.md").read_text()
    assert "eager" in summary and "experiment" not in summary
