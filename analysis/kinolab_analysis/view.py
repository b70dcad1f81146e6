"""3D views of a results database for kinolab's viewer (viewer/viewer.js; the scene format
is in docs/viewer.md): a world's obstacles and, per query, every planner's stored trajectory,
search tree and flight with its known map growing."""

from __future__ import annotations

import html
import json
import os
from pathlib import Path

import numpy as np
import pandas as pd

from .data import EDGE_STATES as STATES, Results, World
from .plots import planner_colours


def template_path() -> Path | None:
    """The viewer page `kinolab` built (share/kinolab/viewer.html), as `kinolab report`
    passes it in $KINOLAB_VIEWER; None without one."""
    path = os.environ.get("KINOLAB_VIEWER")
    return Path(path) if path and Path(path).is_file() else None


def _flat(points: np.ndarray) -> list[float]:
    return np.round(np.asarray(points, dtype=float), 3).ravel().tolist()


def _tree_edges(tree: pd.DataFrame) -> dict[str, list[float]]:
    """Per evaluation state, the tree's polylines as flat point pairs (line segments)."""
    tree = tree.sort_values(["edge", "point"])
    points = tree[["x", "y", "z"]].to_numpy()
    edge = tree["edge"].to_numpy()
    state = tree["state"].to_numpy()
    joined = np.flatnonzero(edge[:-1] == edge[1:])  # segment i -> i + 1 within an edge
    edges = {}
    for name in STATES:
        chosen = joined[state[joined] == name]
        pairs = np.stack([points[chosen], points[chosen + 1]], axis=1)
        edges[name] = _flat(pairs)
    return edges


def _known(results: Results, run_hash: str) -> dict | None:
    """A flight's known voxels (centres and the time each was first known occupied), cubes of
    its map's resolution; None when the flight's map was not stored."""
    voxels = results.known_voxels(run_hash)
    if voxels is None or voxels.empty:
        return None
    size = results.known_maps(run_hash)[-1][3]
    return {"size": float(size), "points": _flat(voxels[["x", "y", "z", "t"]])}


def scene(results: Results, world: World, queries: list[int]) -> dict:
    """The scene of one world (a sweep's variant: its label) with its obstacles and the given
    queries' stored runs, each planner in its colour of every figure of the report."""
    r = world.resolution
    colours = planner_colours(results.runs["planner"])
    document = {
        "format": "kinolab-scene", "version": 1,
        "title": f"{results.meta.get('name', 'results')}: {world.label}",
        "world": {"name": world.label, "spec_hash": world.world_hash, "resolution": r,
                  "origin": _flat(world.origin), "dims": list(map(int, world.dims)),
                  "stride": int(world.box_stride),
                  "boxes": world.boxes.ravel().astype(int).tolist()},
        "queries": []}
    runs = results.runs
    flights = "time_to_goal" in runs.columns  # a flight experiment: its trajectories were flown
    for query in queries:
        chosen = runs[(runs["world_hash"] == world.world_hash) & (runs["query"] == query)]
        if chosen.empty:
            continue
        first = chosen.iloc[0]
        start = np.array([first["start_x"], first["start_y"], first["start_z"]], dtype=float)
        goal = np.array([first["goal_x"], first["goal_y"], first["goal_z"]], dtype=float)
        entry = {"name": f"query {query}", "start": _flat(start), "goal": _flat(goal),
                 "trajectories": [], "trees": [], "flights": []}
        for _, run in chosen.sort_values(["planner", "repetition"]).drop_duplicates("planner").iterrows():
            trajectory = results.trajectory(run["run_hash"])
            if flights:
                if trajectory is not None and len(trajectory):
                    entry["flights"].append({
                        "planner": run["planner"], "t": _flat(trajectory["t"]),
                        "points": _flat(trajectory[["x", "y", "z"]]),
                        "known": _known(results, run["run_hash"])})
                continue
            if trajectory is not None and len(trajectory):
                entry["trajectories"].append({"planner": run["planner"],
                                              "points": _flat(trajectory[["x", "y", "z"]])})
            tree = results.tree(run["run_hash"])
            if tree is not None and len(tree):
                entry["trees"].append({"planner": run["planner"], "edges": _tree_edges(tree)})
        document["queries"].append(entry)
    drawn = {item["planner"] for query in document["queries"]
             for kind in ("trajectories", "trees", "flights") for item in query[kind]}
    document["colours"] = {name: colours[name] for name in sorted(drawn)}
    return document


def page(document: dict, template: Path) -> str:
    """The viewer page with the scene inlined ("</" escaped, as in a script element)."""
    text = template.read_text()
    if "__KINOLAB_SCENE__" not in text:
        raise ValueError(f"{template}: not a kinolab viewer (no scene placeholder)")
    return text.replace("__KINOLAB_SCENE__", json.dumps(document).replace("</", "<\\/"), 1)


def iframe(page_text: str, name: str) -> str:
    """The page inline in the report: an iframe whose document is the page itself."""
    return (f'<iframe class="view3d" data-view="{html.escape(name)}" '
            f'srcdoc="{html.escape(page_text, quote=True)}"></iframe>')
