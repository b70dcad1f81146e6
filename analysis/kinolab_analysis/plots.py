"""Figures, each a matplotlib Figure: here those over all runs, and from plots_sweep,
plots_cases and plots_paper those over a sweep, of single cases and of a paper's reproduction,
with the planners' colours (colours), so that every figure is plots.NAME. Importing this
module leaves matplotlib's backend as it is (a notebook keeps its own); the `kinolab report`
command selects Agg, which needs no display."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from . import stats
from .colours import GOAL, PALETTE, START, planner_colours
from .plots_cases import (flight_animation, known_maps, replan_times, search_tree, speeds,
                          trajectories)
from .plots_paper import lazy_speedup, sampling_readings, sampling_study
from .plots_sweep import success_grid, sweep, sweep_axes, sweep_success, sweep_winners

__all__ = ["PALETTE", "START", "GOAL", "planner_colours", "ecdf", "boxes", "per_world",
           "anytime", "pareto", "sweep", "sweep_success", "sweep_axes", "success_grid",
           "sweep_winners", "trajectories", "search_tree", "speeds", "known_maps",
           "replan_times", "flight_animation", "sampling_study", "sampling_readings",
           "lazy_speedup"]


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
