"""Figures of single cases: one query's trajectories, speeds and clearances and known maps,
a stored search tree, a flight's animation, and the flights' replan times."""

from __future__ import annotations

import matplotlib
import matplotlib.pyplot as plt
from matplotlib.collections import LineCollection
import numpy as np
import pandas as pd

from .colours import GOAL, START, planner_colours
from .data import EDGE_COLOURS, Results, World


def trajectories(results: Results, world: World, query: int) -> plt.Figure | None:
    """One query of one world: the obstacles from above and from the side, with the
    trajectory of every planner that stored one."""
    runs = results.runs
    chosen = runs[(runs["world_hash"] == world.world_hash) & (runs["query"] == query)]
    colours = planner_colours(runs["planner"])
    paths = []
    for _, run in chosen.iterrows():
        trajectory = results.trajectory(run["run_hash"])
        if trajectory is not None and len(trajectory):
            paths.append((run["planner"], run["success"], trajectory, colours[run["planner"]]))
    if not paths:
        return None
    r = world.resolution
    nx, ny, nz = world.dims
    extent_top = [world.origin[0], world.origin[0] + nx * r, world.origin[1], world.origin[1] + ny * r]
    extent_side = [world.origin[0], world.origin[0] + nx * r, world.origin[2], world.origin[2] + nz * r]
    figure, (top, side) = plt.subplots(2, 1, figsize=(7, 9),
                                       gridspec_kw={"height_ratios": [ny, max(nz * 2, ny // 4)]})
    heights = np.ma.masked_equal(world.top.T.astype(float) * r, 0)
    top.imshow(heights, origin="lower", extent=extent_top, cmap="Greys", vmin=0,
               interpolation="nearest")
    side.imshow(world.side.T, origin="lower", extent=extent_side, cmap="Greys", aspect="auto",
                interpolation="nearest")
    for name, success, trajectory, colour in paths:
        style = "-" if success else "--"
        top.plot(trajectory["x"], trajectory["y"], style, color=colour, lw=1.5, label=name)
        side.plot(trajectory["x"], trajectory["z"], style, color=colour, lw=1.5)
    run = chosen.iloc[0]
    for axis, (a, b) in ((top, ("x", "y")), (side, ("x", "z"))):
        axis.plot(run[f"start_{a}"], run[f"start_{b}"], **START, label="start")
        axis.plot(run[f"goal_{a}"], run[f"goal_{b}"], **GOAL, label="goal")
        axis.set_xlabel(f"{a} (m)")
        axis.set_ylabel(f"{b} (m)")
    # Zoomed to the trajectories, 3 m around them, within the map.
    xs = np.concatenate([t["x"].to_numpy(dtype=float) for _, _, t, _ in paths])
    ys = np.concatenate([t["y"].to_numpy(dtype=float) for _, _, t, _ in paths])
    top.set_xlim(max(extent_top[0], xs.min() - 3), min(extent_top[1], xs.max() + 3))
    top.set_ylim(max(extent_top[2], ys.min() - 3), min(extent_top[3], ys.max() + 3))
    side.set_xlim(*top.get_xlim())
    top.set_title(f"{world.label}, query {query}: top view (darker = taller)")
    side.set_title("side view (obstacles projected along y)")
    top.legend(fontsize=8, loc="upper left")
    figure.tight_layout()
    return figure


def search_tree(results: Results, run: pd.Series, world: World | None) -> plt.Figure | None:
    """The lazy search tree from above (the paper's Fig. 6): partially evaluated edges
    (queued on their lower bound, never fully checked) and fully evaluated ones in two
    colours, the trajectory on top."""
    tree = results.tree(run["run_hash"])
    if tree is None or tree.empty:
        return None
    figure, axis = plt.subplots(figsize=(7, 7))
    if world is not None:
        r = world.resolution
        nx, ny, _ = world.dims
        extent = [world.origin[0], world.origin[0] + nx * r, world.origin[1], world.origin[1] + ny * r]
        axis.imshow(np.ma.masked_equal(world.top.T.astype(float), 0), origin="lower",
                    extent=extent, cmap="Greys", vmin=0, interpolation="nearest", alpha=0.6)
    colours = EDGE_COLOURS
    for state, edges in tree.groupby("state"):
        segments = [group[["x", "y"]].to_numpy() for _, group in edges.groupby("edge")]
        partial = state == "partial"
        axis.add_collection(LineCollection(segments, colors=colours.get(state, "grey"),
                                           lw=0.5 if partial else 1.6, zorder=1 if partial else 3,
                                           label=f"{state} ({len(segments)})"))
    trajectory = results.trajectory(run["run_hash"])
    if trajectory is not None:
        axis.plot(trajectory["x"], trajectory["y"], color="black", lw=0.8, ls="--", zorder=4,
                  label="trajectory")
    xs, ys = tree["x"], tree["y"]
    margin = 1.0
    axis.set_xlim(xs.min() - margin, xs.max() + margin)
    axis.set_ylim(ys.min() - margin, ys.max() + margin)
    axis.set_aspect("equal")
    axis.legend(fontsize=8)
    axis.set_title(f"{run['planner']} search tree, {run['world']} query {run['query']}")
    figure.tight_layout()
    return figure


def speeds(results: Results, world: World, query: int) -> plt.Figure | None:
    """Speed and (flights) clearance to the ground truth over time of every stored
    trajectory of one query, one line per planner; None without trajectories."""
    runs = results.runs
    chosen = runs[(runs["world_hash"] == world.world_hash) & (runs["query"] == query)]
    colours = planner_colours(runs["planner"])
    figure, (speed_axis, clearance_axis) = plt.subplots(2, 1, figsize=(7, 5.2), sharex=True)
    drawn = 0
    for _, run in chosen.iterrows():
        trajectory = results.trajectory(run["run_hash"])
        if trajectory is None or not len(trajectory):
            continue
        style = "-" if run["success"] else "--"
        speed = np.linalg.norm(trajectory[["vx", "vy", "vz"]].to_numpy(dtype=float), axis=1)
        speed_axis.plot(trajectory["t"], speed, style, color=colours[run["planner"]],
                        label=run["planner"])
        clearance = results.clearance(run["run_hash"])
        if clearance is not None:
            clearance_axis.plot(clearance["t"], clearance["clearance"], style,
                                color=colours[run["planner"]])
        drawn += 1
    if not drawn:
        plt.close(figure)
        return None
    speed_axis.set_ylabel("speed (m/s)")
    clearance_axis.set_ylabel("clearance (m)")
    clearance_axis.axhline(0.0, color="black", lw=0.8)
    clearance_axis.set_xlabel("time (s)")
    for axis in (speed_axis, clearance_axis):
        axis.grid(alpha=0.3)
    speed_axis.legend(fontsize=8)
    speed_axis.set_title(f"{world.label}, query {query}: speed and clearance over time")
    figure.tight_layout()
    return figure


def known_maps(results: Results, world: World, query: int) -> plt.Figure | None:
    """The final known map of each planner's flight of one query from above (obstacles
    black, known free white, unknown grey) with the flown path; None without stored maps."""
    runs = results.runs
    chosen = runs[(runs["world_hash"] == world.world_hash) & (runs["query"] == query)]
    maps = [(run, results.known_maps(run["run_hash"])) for _, run in chosen.iterrows()]
    maps = [(run, known[-1][1:]) for run, known in maps if known]
    if not maps:
        return None
    figure, axes = plt.subplots(1, len(maps), figsize=(4.2 * len(maps), 4.4), squeeze=False)
    colours = matplotlib.colors.ListedColormap(["#bbbbbb", "#ffffff", "#000000"])
    planners = planner_colours(runs["planner"])
    for axis, (run, (grid, origin, resolution)) in zip(axes[0], maps):
        extent = [origin[0], origin[0] + grid.shape[0] * resolution,
                  origin[1], origin[1] + grid.shape[1] * resolution]
        axis.imshow(grid.T, origin="lower", extent=extent, cmap=colours, vmin=0, vmax=2,
                    interpolation="nearest")
        trajectory = results.trajectory(run["run_hash"])
        if trajectory is not None and len(trajectory):
            axis.plot(trajectory["x"], trajectory["y"], color=planners[run["planner"]], lw=1.5)
        axis.plot(run["start_x"], run["start_y"], **START)
        axis.plot(run["goal_x"], run["goal_y"], **GOAL)
        axis.set_title(f"{run['planner']}: {run['status']}", fontsize=9)
        axis.set_xlabel("x (m)")
        axis.set_ylabel("y (m)")
    figure.tight_layout()
    return figure


def replan_times(replans: pd.DataFrame, colours: dict[str, str]) -> plt.Figure | None:
    """Histogram of every replan's planning time per planner (log scale; `colours`: the
    report's planner_colours); None without replans."""
    times = replans[replans["planning_time_ms"] > 0] if len(replans) else replans
    if not len(times):
        return None
    figure, axis = plt.subplots(figsize=(6.5, 3.6))
    low = max(1e-3, float(times["planning_time_ms"].min()))
    high = float(times["planning_time_ms"].max())
    bins = np.logspace(np.log10(low), np.log10(max(high, low * 10)), 40)
    for name, group in times.groupby("planner", sort=False):
        axis.hist(group["planning_time_ms"], bins=bins, histtype="step", lw=1.5,
                  color=colours[name], label=f"{name} ({len(group)} replans)")
    axis.set_xscale("log")
    axis.set_xlabel("replan planning time (ms)")
    axis.set_ylabel("replans")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    figure.tight_layout()
    return figure


def flight_animation(results: Results, run: pd.Series) -> bytes | None:
    """A GIF of one flight: its known map growing from above, snapshot by snapshot, with the
    path flown so far; None when no snapshots were stored."""
    from matplotlib import animation
    import tempfile

    snapshots = results.known_maps(run["run_hash"])
    trajectory = results.trajectory(run["run_hash"])
    if not snapshots or trajectory is None:
        return None
    _, first, origin, resolution = snapshots[0]
    extent = [origin[0], origin[0] + first.shape[0] * resolution,
              origin[1], origin[1] + first.shape[1] * resolution]
    colours = matplotlib.colors.ListedColormap(["#bbbbbb", "#ffffff", "#000000"])
    figure, axis = plt.subplots(figsize=(4.6, 4.6))
    image = axis.imshow(first.T, origin="lower", extent=extent, cmap=colours, vmin=0, vmax=2,
                        interpolation="nearest")
    (path,) = axis.plot([], [], color=planner_colours(results.runs["planner"])[run["planner"]],
                        lw=1.5)
    axis.plot(run["goal_x"], run["goal_y"], **GOAL)
    axis.set_xlabel("x (m)")
    axis.set_ylabel("y (m)")

    def draw(index):
        time, grid, _, _ = snapshots[index]
        image.set_data(grid.T)
        flown = trajectory[trajectory["t"] <= time + 1e-9]
        path.set_data(flown["x"], flown["y"])
        axis.set_title(f"{run['planner']}, query {run['query']}: t = {time:.0f} s", fontsize=9)
        return image, path

    movie = animation.FuncAnimation(figure, draw, frames=len(snapshots), blit=False)
    with tempfile.TemporaryDirectory() as directory:
        file = f"{directory}/flight.gif"
        movie.save(file, writer=animation.PillowWriter(fps=4), dpi=70)
        plt.close(figure)
        with open(file, "rb") as data:
            return data.read()
