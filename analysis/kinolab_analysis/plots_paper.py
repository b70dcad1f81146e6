"""Figures of a paper's reproduction: its Table I (the sampling study, and under every
reading) and lazy MP-A*'s speedup over eager."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from .tables import SPEEDUP_COLUMNS

COLOURS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def _colour(index: int) -> str:
    """A series' colour that is not a planner's (samplers, a single line)."""
    return COLOURS[index % len(COLOURS)]


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
