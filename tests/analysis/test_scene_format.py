"""Both writers of the 3D scene, kinolab's C++ `view::Scene` (`kinolab plan/fly --out`) and
the analysis package's `view.scene` (reports), against the one definition of the format,
`viewer/scene.schema.json`; and the tree edge states it names are kinolab's."""

import json
import os
import re
import subprocess
import textwrap
from pathlib import Path

import jsonschema
import pytest

from kinolab_analysis import data, view

SOURCE = Path(__file__).resolve().parents[2]
SCHEMA = json.loads((SOURCE / "viewer" / "scene.schema.json").read_text())
WORLD = SOURCE / "tests" / "support" / "small_forest.yaml"
QUERY = ["--start", "1,1,1.5", "--goal", "8.5,8,1.5"]


def kinolab(*args, cwd: Path):
    binary = os.environ.get("KINOLAB_BIN")
    if not binary:
        pytest.fail("KINOLAB_BIN is not set: run through ctest")
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(cwd / "cache"))
    result = subprocess.run([binary, *map(str, args)], capture_output=True, text=True, env=env,
                            timeout=600)
    assert result.returncode == 0, result.stderr
    return result


def page_scene(path: Path) -> dict:
    """The scene inlined in a viewer page (`<\\/` is `</` in the JSON)."""
    found = re.search(r'<script type="application/json" id="kinolab-scene">(.*?)</script>',
                      path.read_text(), re.S)
    assert found, f"{path}: no scene"
    return json.loads(found.group(1).replace("<\\/", "</"))


def valid(scene: dict) -> dict:
    jsonschema.validate(scene, SCHEMA, cls=jsonschema.Draft202012Validator)
    return scene


def test_the_definition_rejects_what_the_viewer_cannot_draw():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    good = {"format": "kinolab-scene", "version": 1, "title": "t",
            "world": {"name": "w", "spec_hash": "h", "resolution": 0.1, "origin": [0, 0, 0],
                      "dims": [1, 1, 1], "stride": 1, "boxes": [0, 0, 0, 1, 1, 1]},
            "queries": []}
    valid(good)
    for broken in ({**good, "version": 2}, {**good, "queries": [{"name": "q"}]},
                   {**good, "world": {**good["world"], "dims": [1, 1]}},
                   {**good, "extra": 1}):
        with pytest.raises(jsonschema.ValidationError):
            valid(broken)


def test_the_edge_states_are_kinolabs():
    tree = SCHEMA["$defs"]["query"]["properties"]["trees"]["items"]["properties"]["edges"]
    listed = json.loads(kinolab("list", "metrics", "--json", cwd=Path.cwd()).stdout)
    assert tree["required"] == list(data.EDGE_STATES) == listed["edge_states"]


def test_kinolabs_plan_and_flight_pages_follow_the_definition(tmp_path):
    kinolab("plan", "--world", WORLD, "--planner", "lazy_mp_astar", *QUERY, "--out",
            tmp_path / "plan", cwd=tmp_path)
    plan = valid(page_scene(tmp_path / "plan" / "view.html"))
    query = plan["queries"][0]
    assert query["trajectories"] and query["trees"] and not query["flights"]
    assert sum(map(len, query["trees"][0]["edges"].values())) > 0
    kinolab("fly", "--world", WORLD, "--planner", "lazy_mp_astar", *QUERY, "--out",
            tmp_path / "fly", cwd=tmp_path)
    flight = valid(page_scene(tmp_path / "fly" / "view.html"))["queries"][0]["flights"][0]
    assert flight["known"] and len(flight["known"]["points"]) % 4 == 0


EXPERIMENT = """
kind: KIND
name: scene_KIND
seed: 3
worlds:
  - id: small
    spec:
SPEC
queries: {fixed: [{start: [1, 1, 1.5], goal: [8.5, 8, 1.5]}]}
planners:
  - {id: lazy, type: lazy_mp_astar}
  - {id: eager, type: eager_mp_astar}
store: {trajectories: true, trees: 1}
budget: {time: 120}
"""


@pytest.mark.parametrize("kind", ["planning", "flight"])
def test_the_reports_scenes_follow_the_definition(tmp_path, kind):
    text = EXPERIMENT.replace("KIND", kind).replace(
        "SPEC\n", textwrap.indent(WORLD.read_text(), " " * 6))
    (tmp_path / "experiment.yaml").write_text(text)
    kinolab("run", tmp_path / "experiment.yaml", "--out", tmp_path / "out", cwd=tmp_path)
    results = data.load(tmp_path / "out")
    world = next(iter(results.worlds.values()))
    scene = valid(view.scene(results, world, [0]))
    query = scene["queries"][0]
    if kind == "planning":
        assert {t["planner"] for t in query["trajectories"]} == {"lazy", "eager"}
        assert query["trees"]
    else:
        assert {f["planner"] for f in query["flights"]} == {"lazy", "eager"}
        assert all(f["known"] for f in query["flights"])
