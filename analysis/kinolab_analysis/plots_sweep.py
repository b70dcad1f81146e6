"""Figures over a sweep: a metric's median and the success rate against the swept value,
success over the sweep's dimensions, and where each planner wins."""

from __future__ import annotations

import math
import re

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from . import stats
from .colours import planner_colours


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
