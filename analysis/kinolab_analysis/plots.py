"""Figures, each a matplotlib Figure. Importing this module leaves matplotlib's backend as it
is (a notebook keeps its own); the `kinolab report` command selects Agg, which needs no
display."""

from __future__ import annotations

import math
import re

import matplotlib
import matplotlib.pyplot as plt
from matplotlib.collections import LineCollection
import numpy as np
import pandas as pd

from . import stats
from .data import EDGE_COLOURS, Results, World
from .tables import SPEEDUP_COLUMNS

COLOURS = plt.rcParams["axes.prop_cycle"].by_key()["color"]

# Planners' colours (planner_colours): 20 colours far apart (CIE Lab distance 25 or more, so
# that two planners never look alike), none black, grey or pale (the start and goal markers',
# the page's), none the search tree's edge states (data.EDGE_COLOURS).
# viewer/viewer.js holds the same list for scenes that bring no colours (tests keep them equal).
PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#000080", "#bcbd22", "#637939", "#a6761d", "#01665e", "#f99379",
           "#dd1c77", "#393b79", "#1b9e77", "#800000", "#e6ab02", "#b3446c"]
# The query's start and goal in every figure: colours no planner has, shapes of their own.
START = {"marker": "o", "color": "black", "ms": 7, "linestyle": "none"}
GOAL = {"marker": "*", "color": "#6c757d", "ms": 12, "markeredgecolor": "black",
        "linestyle": "none"}


def _colour(index: int) -> str:
    """A series' colour that is not a planner's (samplers, a single line)."""
    return COLOURS[index % len(COLOURS)]


def _slot(name: str) -> int:
    """The planner's own place in PALETTE: FNV-1a of its UTF-8 bytes (viewer.js computes the
    same), so that its colour depends on its id alone, not on the other planners."""
    digest = 0x811C9DC5
    for byte in str(name).encode("utf-8"):
        digest = ((digest ^ byte) * 0x01000193) & 0xFFFFFFFF
    return digest % len(PALETTE)


def planner_colours(planners) -> dict[str, str]:
    """One colour per planner id, the same in every figure of every report: its PALETTE slot
    (_slot). Two of these planners on one slot: in id order, the later takes the next free
    slot (all taken: its own again), so one report never draws two planners alike."""
    taken: set[int] = set()
    colours = {}
    for name in sorted(set(map(str, planners))):
        slot = _slot(name)
        for step in range(len(PALETTE)):
            if (slot + step) % len(PALETTE) not in taken:
                slot = (slot + step) % len(PALETTE)
                break
        taken.add(slot)
        colours[name] = PALETTE[slot]
    return colours


def ecdf(runs: pd.DataFrame, by: str = "planner") -> plt.Figure:
    """Time-to-solve ECDFs: every run but a success (exact and checker-valid) counts as never
    solved, approximate answers and timeouts included, so a curve ends at its planner's
    success rate."""
    colours = planner_colours(runs[by])
    figure, axis = plt.subplots(figsize=(6, 4))
    for name, group in runs.groupby(by, sort=False):
        x, y = stats.ecdf_unsolved(group["planning_time_ms"], group["success"])
        if x.size:
            axis.step(np.concatenate([[x[0]], x]), np.concatenate([[0], y]), where="post",
                      label=f"{name} ({y[-1]:.0%})", color=colours[str(name)])
    axis.set_xscale("log")
    axis.set_xlabel("planning time (ms)")
    axis.set_ylabel("share of runs solved exactly")
    axis.set_ylim(0, 1.02)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title("Time to solve (failures count as unsolved)")
    figure.tight_layout()
    return figure


def boxes(runs: pd.DataFrame, metrics: list[tuple[str, str, str]],
          by: str = "planner") -> plt.Figure:
    """Box plots of each metric over successful runs, one box per planner."""
    metrics = [m for m in metrics if m[0] in runs.columns]
    figure, axes = plt.subplots(1, len(metrics), figsize=(3.2 * len(metrics), 3.6), squeeze=False)
    names = list(dict.fromkeys(runs[by]))
    colours = planner_colours(names)
    ok = runs[runs["success"]]
    for axis, (column, label, unit) in zip(axes[0], metrics):
        data = [ok.loc[ok[by] == name, column].dropna().to_numpy(dtype=float) for name in names]
        drawn = axis.boxplot(data, labels=names, showfliers=True, patch_artist=True)
        for box, name in zip(drawn["boxes"], names):
            box.set(facecolor=colours[str(name)], alpha=0.6)
        axis.set_title(f"{label} ({unit})" if unit else label, fontsize=10)
        axis.tick_params(axis="x", labelrotation=45, labelsize=8)
        if column == "planning_time_ms":
            axis.set_yscale("log")
        axis.grid(alpha=0.3, axis="y")
    figure.tight_layout()
    return figure


def per_world(runs: pd.DataFrame, by: str = "planner") -> plt.Figure:
    """Success rate (exact and checker-valid, Wilson interval) and median planning time of
    the successful runs per world and planner."""
    worlds = list(dict.fromkeys(runs["world"]))
    names = list(dict.fromkeys(runs[by]))
    colours = planner_colours(names)
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8))
    width = 0.8 / max(1, len(names))
    for index, name in enumerate(names):
        rates, errors, times = [], [[], []], []
        for world in worlds:
            group = runs[(runs["world"] == world) & (runs[by] == name)]
            rate = stats.wilson(int(group["success"].sum()), len(group))
            rates.append(rate.estimate)
            errors[0].append(max(0.0, rate.estimate - rate.low))
            errors[1].append(max(0.0, rate.high - rate.estimate))
            solved = group.loc[group["success"], "planning_time_ms"]
            times.append(float(solved.median()) if len(solved) else math.nan)
        x = np.arange(len(worlds)) + (index - (len(names) - 1) / 2) * width
        left.bar(x, rates, width, yerr=errors, label=name, color=colours[str(name)], capsize=2)
        right.bar(x, times, width, label=name, color=colours[str(name)])
    for axis, title in ((left, "success: exact, checker-valid (95 % Wilson)"),
                        (right, "median planning time (ms)")):
        axis.set_xticks(np.arange(len(worlds)), worlds)
        axis.set_title(title, fontsize=10)
        axis.grid(alpha=0.3, axis="y")
    left.set_ylim(0, 1.05)
    right.legend(fontsize=8)
    figure.tight_layout()
    return figure


def _over_sweep(runs: pd.DataFrame, by: str, interval_of, ylabel: str,
                title: str) -> plt.Figure | None:
    """Per planner (`by`), interval_of(its runs of a sweep value) (an Interval, or None to
    skip) against the sweep values; None without a sweep."""
    labels = list(dict.fromkeys(runs["sweep"].fillna("")))
    if len(labels) < 2:
        return None
    colours = planner_colours(runs[by])
    figure, axis = plt.subplots(figsize=(7, 4))
    for name, group in runs.groupby(by, sort=False):
        estimates, low, high, xs = [], [], [], []
        for position, label in enumerate(labels):
            interval = interval_of(group[group["sweep"].fillna("") == label])
            if interval is None:
                continue
            xs.append(position)
            estimates.append(interval.estimate)
            low.append(max(0.0, interval.estimate - interval.low))
            high.append(max(0.0, interval.high - interval.estimate))
        if xs:
            axis.errorbar(xs, estimates, yerr=[low, high], marker="o", capsize=3, label=name,
                          color=colours[str(name)])
    short = [re.sub(r"[^,=]*\.", "", label) for label in labels]
    axis.set_xticks(range(len(labels)), short, rotation=30, ha="right", fontsize=8)
    axis.set_ylabel(ylabel)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title(title)
    figure.tight_layout()
    return figure


def sweep(runs: pd.DataFrame, metric: str = "planning_time_ms",
          by: str = "planner") -> plt.Figure | None:
    """A metric's median (bootstrap interval) over successful runs against the sweep
    value, per planner; None without a sweep."""
    def median(variant: pd.DataFrame):
        values = variant.loc[variant["success"].astype(bool), metric]
        return None if values.empty else stats.bootstrap(values.to_numpy(dtype=float))
    return _over_sweep(runs, by, median, f"median {metric}", "Sweep")


def sweep_success(runs: pd.DataFrame, by: str = "planner") -> plt.Figure | None:
    """Success rate (Wilson 95 %) against the sweep value, per planner (for flights: over
    density, speed, sensor, ...); None without a sweep."""
    def rate(variant: pd.DataFrame):
        outcomes = variant["success"]
        return None if outcomes.empty else stats.wilson(int(outcomes.sum()), len(outcomes))
    figure = _over_sweep(runs, by, rate, "success rate (exact, checker-valid)",
                         "Success over the sweep")
    if figure is not None:
        figure.axes[0].set_ylim(-0.02, 1.02)
    return figure


def sweep_axes(labels: list[str]) -> tuple[list[str], pd.DataFrame]:
    """The sweep's dimensions and each label's value on them (a frame indexed by label).
    A sweep label is "key=value, key=value, ...". Keys that vary together (a `zip:` of one
    value per planner) are one dimension, named by the last key's last part
    (`planners.lazy.params.max_velocity` -> `max_velocity`). Dimensions are in first-key
    order; only keys with two values or more count."""
    parsed = []
    for label in labels:
        pairs = [part.split("=", 1) for part in label.split(", ") if "=" in part]
        parsed.append({key.strip(): value.strip() for key, value in pairs})
    frame = pd.DataFrame(parsed, index=labels).fillna("")
    varying = [key for key in frame.columns if frame[key].nunique() > 1]
    dimensions, columns = [], {}
    for key in varying:
        partner = next((d for d in dimensions
                        if frame.groupby(columns[d])[key].nunique().max() == 1
                        and frame.groupby(key)[columns[d]].nunique().max() == 1), None)
        if partner is None:
            name = key.rsplit(".", 1)[-1]
            while name in columns:
                name += "'"
            dimensions.append(name)
            columns[name] = key
    return dimensions, pd.DataFrame({name: frame[key] for name, key in columns.items()},
                                    index=labels)


def _numeric(value: str) -> float | str:
    try:
        return float(value)
    except ValueError:
        return value


def success_grid(runs: pd.DataFrame, by: str = "planner") -> plt.Figure | None:
    """Success (Wilson 95 %) against the sweep's first dimension with more than two values
    (the first otherwise), a line per planner and value of the last other dimension, a panel
    per value of the first other one: for flight_benchmark.yaml, success over density, per
    planner and speed, a panel per camera range. None unless the sweep has two dimensions or
    more."""
    labels = list(dict.fromkeys(runs["sweep"].fillna("")))
    dimensions, values = sweep_axes(labels)
    if len(dimensions) < 2:
        return None
    x_name = next((d for d in dimensions if values[d].nunique() > 2), dimensions[0])
    rest = [d for d in dimensions if d != x_name]
    # A zip (per-planner speeds) comes last in a label: lines; the grid's outer key: panels.
    line_name = rest[-1]
    panel_name = rest[0] if len(rest) > 1 else None
    # In the sweep's own order (flight_benchmark.yaml lists the default camera first).
    panels = list(dict.fromkeys(values[panel_name])) if panel_name else [""]
    lines = list(dict.fromkeys(values[line_name]))
    styles = [("-", "o"), ("--", "s"), (":", "^"), ("-.", "D")]
    figure, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels) + 0.6, 3.8),
                                sharey=True, squeeze=False)
    planners = list(dict.fromkeys(runs[by]))
    colours = planner_colours(planners)
    for column, panel in enumerate(panels):
        axis = axes[0][column]
        for planner in planners:
            for (style, marker), line in zip(styles * len(lines), lines):
                xs, estimates, low, high = [], [], [], []
                for label in labels:
                    if values.at[label, line_name] != line or (
                            panel_name and values.at[label, panel_name] != panel):
                        continue
                    outcomes = runs.loc[(runs["sweep"].fillna("") == label)
                                        & (runs[by] == planner), "success"]
                    if outcomes.empty:
                        continue
                    interval = stats.wilson(int(outcomes.sum()), len(outcomes))
                    xs.append(_numeric(values.at[label, x_name]))
                    estimates.append(interval.estimate)
                    low.append(max(0.0, interval.estimate - interval.low))
                    high.append(max(0.0, interval.high - interval.estimate))
                if not xs:
                    continue
                order = np.argsort(np.array(xs, dtype=object).astype(str)) if any(
                    isinstance(x, str) for x in xs) else np.argsort(xs)
                axis.errorbar([xs[i] for i in order], [estimates[i] for i in order],
                              yerr=[[low[i] for i in order], [high[i] for i in order]],
                              marker=marker, capsize=3, linestyle=style,
                              color=colours[str(planner)], label=f"{planner}, {line_name} {line}")
        axis.set_xlabel(x_name)
        axis.set_ylim(-0.02, 1.02)
        axis.grid(alpha=0.3)
        if panel_name:
            axis.set_title(f"{panel_name} {panel}", fontsize=9)
    axes[0][0].set_ylabel("success: exact, checker-valid\n(Wilson 95 %)")
    axes[0][-1].legend(fontsize=7)
    figure.suptitle(f"Success over {x_name}, per planner and {line_name}", fontsize=10)
    figure.tight_layout()
    return figure


def sweep_winners(table: pd.DataFrame, metric: str = "planning_time_ms",
                  colours: dict[str, str] | None = None) -> plt.Figure | None:
    """Where each planner wins: one cell per sweep value (the first two axes with more than one
    value as columns and rows), coloured by the planner with the least median `metric` on the
    cases all solved, with the runner-up's ratio; hatched where the two are not told apart
    (paired Wilcoxon, Holm, p >= 0.05); `colours`: the report's planner_colours. None
    without a sweep of two or more values."""
    if table.empty or "winner" not in table or len(table) < 2:
        return None
    axes = [column for column in table.columns
            if column not in {"cases", "of", "winner", "winner median", "runner-up",
                              "runner-up median", "ratio", "p", "p (Holm)"}
            and table[column].nunique() > 1]
    if not axes:
        return None
    across = axes[0]
    down = axes[1] if len(axes) > 1 else None
    columns = list(dict.fromkeys(table[across]))
    rows = list(dict.fromkeys(table[down])) if down else [""]
    colours = colours or planner_colours([*table["winner"].dropna(),
                                          *table["runner-up"].dropna()])
    figure, axis = plt.subplots(figsize=(1.9 * len(columns) + 1.6, 1.1 * len(rows) + 1.4))
    for _, row in table.iterrows():
        x = columns.index(row[across])
        y = rows.index(row[down]) if down else 0
        if not isinstance(row.get("winner"), str):
            axis.text(x, y, "no case\nall solved", ha="center", va="center", fontsize=7)
            continue
        tied = not (row.get("p (Holm)", math.nan) < 0.05)
        axis.add_patch(plt.Rectangle((x - 0.48, y - 0.48), 0.96, 0.96,
                                     facecolor=colours[row["winner"]], alpha=0.35,
                                     hatch="//" if tied else None, edgecolor="0.5"))
        axis.text(x, y, f"{row['winner']}\n{row['winner median']:.3g} {_unit(metric)}\n"
                  f"{row['runner-up']} x{row['ratio']:.2g}\n"
                  f"{row['cases']}/{row['of']} cases", ha="center", va="center", fontsize=7)
    axis.set_xlim(-0.5, len(columns) - 0.5)
    axis.set_ylim(len(rows) - 0.5, -0.5)
    axis.set_xticks(range(len(columns)), [str(value) for value in columns])
    axis.set_yticks(range(len(rows)), [str(value) for value in rows])
    axis.set_xlabel(across)
    if down:
        axis.set_ylabel(down)
    axis.set_title(f"Least median {metric}")
    figure.tight_layout()
    return figure


def _unit(metric: str) -> str:
    return "ms" if metric.endswith("_ms") else ""


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


def anytime(runs: pd.DataFrame, samples: pd.DataFrame, name: str, unit: str,
            by: str = "planner") -> plt.Figure | None:
    """A progress series over planning time (OMPL's planner progress, Planner Arena's
    progress plots): per planner, the median and interquartile range over *all* its runs of
    the series read as a step function (stats.step_values: no value yet counts as infinite,
    a run that stopped keeps its last value), and below, the share of runs with a value."""
    samples = samples[samples["name"] == name]
    if samples.empty:
        return None
    positive = samples["time_ms"][samples["time_ms"] > 0]
    low = float(positive.min()) if not positive.empty else 1e-3
    times = np.geomspace(low, max(float(samples["time_ms"].max()), low) * 1.1, 200)
    figure, (axis, solved_axis) = plt.subplots(
        2, 1, figsize=(6, 5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    with_samples = runs[runs["run_hash"].isin(samples["run_hash"])][by].unique()
    colours = planner_colours(runs[by])
    for label, group in runs.groupby(by, sort=False):
        if label not in with_samples:
            continue
        table = stats.step_values(samples, group["run_hash"].tolist(), times)
        median = np.quantile(table, 0.5, axis=0, method="inverted_cdf")
        low_q, high_q = np.quantile(table, [0.25, 0.75], axis=0, method="inverted_cdf")
        colour = colours[str(label)]
        shown = np.isfinite(median)
        axis.step(times[shown], median[shown], where="post", color=colour,
                  label=f"{label} (n = {len(group)})")
        band = np.isfinite(high_q)
        axis.fill_between(times[band], low_q[band], high_q[band], step="post", color=colour,
                          alpha=0.15, linewidth=0)
        solved_axis.step(times, np.isfinite(table).mean(axis=0), where="post", color=colour)
    axis.set_xscale("log")
    axis.set_ylabel(f"{name} ({unit})" if unit else name)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title(f"Anytime progress: {name}")
    solved_axis.set_ylim(-0.05, 1.05)
    solved_axis.set_ylabel("runs with\na value")
    solved_axis.set_xlabel("planning time (ms)")
    solved_axis.grid(alpha=0.3)
    figure.tight_layout()
    return figure


def pareto(runs: pd.DataFrame, world: str, quality: str = "duration",
           by: str = "planner") -> plt.Figure | None:
    """Time against quality in one world: per planner the median planning time and the median
    trajectory `quality` over its successful runs (interquartile bars), its success rate in
    the label, and the Pareto front (no other planner both faster and better) joined."""
    chosen = runs[(runs["world"] == world) & runs["success"]]
    if chosen.empty:
        return None
    colours = planner_colours(runs[by])
    figure, axis = plt.subplots(figsize=(6.5, 4.5))
    points = []
    for name, group in runs[runs["world"] == world].groupby(by, sort=False):
        solved = group[group["success"]]
        if solved.empty:
            continue
        t = solved["planning_time_ms"].to_numpy(dtype=float)
        q = solved[quality].to_numpy(dtype=float)
        x, y = float(np.median(t)), float(np.median(q))
        axis.errorbar(x, y, xerr=[[x - np.percentile(t, 25)], [np.percentile(t, 75) - x]],
                      yerr=[[y - np.percentile(q, 25)], [np.percentile(q, 75) - y]],
                      fmt="o", color=colours[str(name)], capsize=3,
                      label=f"{name} ({100.0 * len(solved) / len(group):.0f} % success)")
        points.append((x, y))
    front = sorted(p for p in points
                   if not any(o[0] <= p[0] and o[1] <= p[1] and o != p for o in points))
    if len(front) > 1:
        axis.plot(*zip(*front), "--", color="grey", linewidth=0.8, label="Pareto front")
    axis.set_xscale("log")
    axis.set_xlabel("median planning time (ms)")
    axis.set_ylabel("median trajectory duration (s)" if quality == "duration" else f"median {quality}")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=7)
    axis.set_title(f"Time against quality: {world}")
    figure.tight_layout()
    return figure


def sampling_study(table: pd.DataFrame) -> plt.Figure:
    """Table I as bars: alpha and L per sampler, kinolab beside the paper."""
    figure, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    x = np.arange(len(table))
    for axis, (label, paper, ours) in zip(axes, (("alpha", "paper alpha", "kinolab alpha"),
                                                 ("L (m)", "paper L (m)", "kinolab L (m)"))):
        axis.bar(x - 0.2, table[paper], 0.4, label="paper", color="#bbbbbb")
        axis.bar(x + 0.2, table[ours], 0.4, label="kinolab", color=_colour(0))
        axis.set_xticks(x, table["sampler"], rotation=20)
        axis.set_title(label)
        axis.grid(alpha=0.3, axis="y")
    axes[0].legend(fontsize=8)
    figure.tight_layout()
    return figure


def sampling_readings(readings: pd.DataFrame, paper: dict[str, tuple[float, float]],
                      samplers: tuple[str, ...] = ("random", "uniform", "normal")) -> plt.Figure:
    """Table I under every reading: per reading (distance x propagation x pooling) alpha
    against the threshold (top rows; one line per sampler and M) and L against M (bottom
    rows); the paper's figures as stars (alpha at 0.1 m) and dashed lines (L)."""
    readings = readings[readings["sampler"].isin(samplers)]
    panels = list(readings.groupby(["distance", "propagation", "pooling"], sort=True).groups)
    columns = 4
    rows = math.ceil(len(panels) / columns)
    figure, axes = plt.subplots(2 * rows, columns, figsize=(3.2 * columns, 2.6 * 2 * rows),
                                squeeze=False)
    styles = {m: s for m, s in zip(sorted(readings["controls"].unique()), ["-", "--", ":", "-."])}
    for index, key in enumerate(panels):
        alpha_axis = axes[2 * (index // columns)][index % columns]
        l_axis = axes[2 * (index // columns) + 1][index % columns]
        panel = readings[(readings["distance"] == key[0]) & (readings["propagation"] == key[1])
                         & (readings["pooling"] == key[2])]
        for number, sampler in enumerate(samplers):
            mine = panel[panel["sampler"] == sampler]
            for controls, group in mine.groupby("controls"):
                alpha_axis.plot(group["threshold"], group["alpha"], styles.get(controls, "-"),
                                color=_colour(number), marker=".",
                                label=f"{sampler} M={controls}" if index == 0 else None)
            lengths = mine.drop_duplicates("controls").sort_values("controls")
            l_axis.plot(lengths["controls"], lengths["mean_nearest"], "-o", color=_colour(number),
                        label=sampler if index == 0 else None)
            if sampler in paper:
                alpha_axis.plot([0.1], [paper[sampler][0]], "*", markersize=11,
                                color=_colour(number), markeredgecolor="black")
                l_axis.axhline(paper[sampler][1], color=_colour(number), linestyle="--",
                               linewidth=0.8)
        title = f"{key[0].replace('_', '+')}, {key[1]}, {key[2].replace('_', ' ')}"
        alpha_axis.set_title(title, fontsize=8)
        alpha_axis.set_xscale("log")
        alpha_axis.set_ylim(-0.02, 1.02)
        alpha_axis.set_xlabel("threshold", fontsize=8)
        alpha_axis.set_ylabel("alpha", fontsize=8)
        l_axis.set_xscale("log")
        l_axis.set_xlabel("M (controls)", fontsize=8)
        l_axis.set_ylabel("L", fontsize=8)
        for axis in (alpha_axis, l_axis):
            axis.grid(alpha=0.3)
            axis.tick_params(labelsize=7)
    for index in range(len(panels), rows * columns):
        axes[2 * (index // columns)][index % columns].set_visible(False)
        axes[2 * (index // columns) + 1][index % columns].set_visible(False)
    figure.legend(loc="lower center", ncol=6, fontsize=7)
    figure.tight_layout(rect=(0, 0.05, 1, 1))
    return figure


def _axes_of(table: pd.DataFrame) -> list[str]:
    return [c for c in table.columns if c not in SPEEDUP_COLUMNS]


def lazy_speedup(table: pd.DataFrame, title: str,
                 reference: tuple[str, float] | None = None) -> plt.Figure | None:
    """Eager's time over lazy's (tables.lazy_speedup) against the swept value, median with
    its bootstrap interval and the range over cases, parity dashed and a reproduced paper's
    speedup (`reference`: label, value) dotted; with two swept axes a heat map. None without
    a sweep axis."""
    axes = _axes_of(table)
    if not axes or table.empty:
        return None
    if len(axes) >= 2:
        x_name, y_name = axes[0], axes[1]
        xs = sorted(table[x_name].unique(), key=float)
        ys = sorted(table[y_name].unique(), key=float)
        grid = np.full((len(ys), len(xs)), np.nan)
        for _, row in table.iterrows():
            grid[ys.index(row[y_name]), xs.index(row[x_name])] = row["speedup"].estimate
        figure, axis = plt.subplots(figsize=(1.3 * len(xs) + 2.5, 0.8 * len(ys) + 2))
        image = axis.imshow(grid, origin="lower", cmap="RdYlGn", vmin=0.5,
                            vmax=max(2.0 * (reference[1] if reference else 1.0),
                                     float(np.nanmax(grid))), aspect="auto")
        for j in range(len(ys)):
            for i in range(len(xs)):
                if np.isfinite(grid[j, i]):
                    axis.text(i, j, f"{grid[j, i]:.2f}x", ha="center", va="center", fontsize=9)
        axis.set_xticks(range(len(xs)), xs)
        axis.set_yticks(range(len(ys)), ys)
        axis.set_xlabel(x_name)
        axis.set_ylabel(y_name)
        figure.colorbar(image, ax=axis, label="median eager T / lazy T")
        axis.set_title(title)
        figure.tight_layout()
        return figure
    name = axes[0]
    ordered = table.assign(_x=table[name].astype(float)).sort_values("_x")
    x = ordered["_x"].to_numpy()
    medians = np.array([i.estimate for i in ordered["speedup"]])
    low = np.array([i.low for i in ordered["speedup"]])
    high = np.array([i.high for i in ordered["speedup"]])
    figure, axis = plt.subplots(figsize=(6, 4))
    axis.fill_between(x, ordered["min speedup"], ordered["max speedup"], color=_colour(0),
                      alpha=0.12, label="range over queries")
    axis.errorbar(x, medians, yerr=[np.maximum(0, medians - low), np.maximum(0, high - medians)],
                  marker="o", capsize=3,
                  color=_colour(0), label="median (bootstrap 95 %)")
    axis.axhline(1.0, color="black", linestyle="--", linewidth=0.8, label="parity")
    if reference is not None:
        axis.axhline(reference[1], color=_colour(3), linestyle=":", label=reference[0])
    if x.min() > 0 and x.max() / x.min() >= 10:
        axis.set_xscale("log")
    axis.set_xticks(x, [f"{v:g}" for v in x])
    axis.set_xlabel(name)
    axis.set_ylabel("eager T / lazy T (same cost)")
    axis.set_ylim(bottom=0)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title(title)
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
