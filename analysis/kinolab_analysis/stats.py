"""Statistics with intervals and paired tests, as plain typed functions."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from scipy import stats as sps

Z95 = 1.959963984540054


def number(value: float, digits: int = 3, noise: float = 1e-9) -> str:
    """A figure as a reader wants it: "-" when not finite, 0 within `noise` of zero (floating
    point noise; 0 for a p-value), whole numbers exactly and values from 1,000 up to `digits` significant
    digits, both without an exponent and with thousands separators, tiny values (p-values) in
    scientific notation, the rest to `digits` significant digits."""
    if not math.isfinite(value):
        return "-"
    if abs(value) < noise or value == 0:
        return "0"
    if value == round(value) and abs(value) < 1e15:  # a count: exact
        return f"{value:,.0f}"
    if abs(value) >= 1000:
        magnitude = math.floor(math.log10(abs(value)))
        rounded = round(value, min(0, digits - 1 - magnitude))
        return f"{rounded:,.0f}" if rounded == round(rounded) else f"{rounded:.{digits}g}"
    if abs(value) < 1e-3:
        return f"{value:.1e}"
    return f"{value:.{digits}g}"


@dataclass(frozen=True)
class Interval:
    """An estimate with its 95 % interval."""

    estimate: float
    low: float
    high: float

    def format(self, digits: int = 3) -> str:
        if not math.isfinite(self.estimate):
            return "-"
        return (f"{number(self.estimate, digits)} "
                f"[{number(self.low, digits)}, {number(self.high, digits)}]")

    def percent(self, digits: int = 3) -> str:
        """A share (0..1) as a percentage with its interval."""
        if not math.isfinite(self.estimate):
            return "-"
        return (f"{number(100 * self.estimate, digits)} % "
                f"[{number(100 * self.low, digits)}, {number(100 * self.high, digits)}]")


def wilson(successes: int, n: int, z: float = Z95) -> Interval:
    """The success rate with its Wilson score interval (NaN when n == 0)."""
    if n == 0:
        return Interval(math.nan, math.nan, math.nan)
    p = successes / n
    denominator = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    # The interval holds p; at p = 0 or 1 rounding could put a bound a hair past it.
    return Interval(p, min(p, max(0.0, centre - half)), max(p, min(1.0, centre + half)))


def bootstrap(values: Sequence[float], statistic: Callable[[np.ndarray], float] = np.median,
              resamples: int = 2000, seed: int = 0) -> Interval:
    """The statistic of the finite values with a percentile bootstrap 95 % interval."""
    data = np.asarray(values, dtype=float)
    data = data[np.isfinite(data)]
    if data.size == 0:
        return Interval(math.nan, math.nan, math.nan)
    estimate = float(statistic(data))
    if data.size == 1:
        return Interval(estimate, estimate, estimate)
    rng = np.random.default_rng(seed)
    samples = data[rng.integers(0, data.size, size=(resamples, data.size))]
    if statistic in (np.median, np.mean):
        replicates = statistic(samples, axis=1)
    else:
        replicates = np.apply_along_axis(statistic, 1, samples)
    low, high = np.percentile(replicates, [2.5, 97.5])
    return Interval(estimate, float(low), float(high))


def holm(pvalues: Sequence[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (NaN stays NaN, not counted)."""
    p = np.asarray(pvalues, dtype=float)
    finite = np.where(np.isfinite(p))[0]
    adjusted = np.full(p.shape, math.nan)
    m = finite.size
    running = 0.0
    for rank, index in enumerate(finite[np.argsort(p[finite], kind="stable")]):
        running = max(running, min(1.0, (m - rank) * p[index]))
        adjusted[index] = running
    return adjusted.tolist()


def mcnemar(a_success: Sequence[bool], b_success: Sequence[bool]) -> tuple[int, int, float]:
    """Exact McNemar test on paired successes: (A only, B only, two-sided p)."""
    a = np.asarray(a_success, dtype=bool)
    b = np.asarray(b_success, dtype=bool)
    a_only = int(np.sum(a & ~b))
    b_only = int(np.sum(~a & b))
    if a_only + b_only == 0:
        return a_only, b_only, 1.0
    p = sps.binomtest(a_only, a_only + b_only, 0.5).pvalue
    return a_only, b_only, float(p)


@dataclass(frozen=True)
class PairedTest:
    n: int
    median_difference: float  # median of a - b
    p: float                  # Wilcoxon signed-rank, two-sided
    rank_biserial: float      # matched-pairs rank-biserial correlation, in [-1, 1]


def wilcoxon(a: Sequence[float], b: Sequence[float]) -> PairedTest:
    """Wilcoxon signed-rank test of paired values (pairs with a NaN dropped) and the
    matched-pairs rank-biserial correlation r = (R+ - R-) / (R+ + R-) (> 0: a larger)."""
    x = np.asarray(a, dtype=float)
    y = np.asarray(b, dtype=float)
    keep = np.isfinite(x) & np.isfinite(y)
    d = x[keep] - y[keep]
    n = int(d.size)
    if n == 0:
        return PairedTest(0, math.nan, math.nan, math.nan)
    nonzero = d[d != 0]
    if nonzero.size == 0:
        return PairedTest(n, 0.0, 1.0, 0.0)
    ranks = sps.rankdata(np.abs(nonzero))
    r_plus = float(ranks[nonzero > 0].sum())
    r_minus = float(ranks[nonzero < 0].sum())
    p = float(sps.wilcoxon(nonzero).pvalue)
    return PairedTest(n, float(np.median(d)), p, (r_plus - r_minus) / (r_plus + r_minus))


def vargha_delaney_a(a: Sequence[float], b: Sequence[float]) -> float:
    """A = P(a > b) + P(a = b) / 2 for independent samples (0.5: no effect)."""
    x = np.asarray(a, dtype=float)
    y = np.asarray(b, dtype=float)
    x = x[np.isfinite(x)]
    y = y[np.isfinite(y)]
    if x.size == 0 or y.size == 0:
        return math.nan
    greater = (x[:, None] > y[None, :]).sum()
    equal = (x[:, None] == y[None, :]).sum()
    return float((greater + 0.5 * equal) / (x.size * y.size))


def one_sample_wilcoxon(values: Sequence[float], reference: float) -> float:
    """Two-sided p of the Wilcoxon signed-rank test that the values' median is `reference`."""
    d = np.asarray(values, dtype=float) - reference
    d = d[np.isfinite(d) & (d != 0)]
    if d.size == 0:
        return math.nan
    return float(sps.wilcoxon(d).pvalue)


def ecdf_unsolved(times: Sequence[float], solved: Sequence[bool]) -> tuple[np.ndarray, np.ndarray]:
    """The time-to-solve ECDF with failures counted as never solved: x = sorted solve times,
    y = share of all runs solved by then (it ends at the success rate, not at 1)."""
    t = np.asarray(times, dtype=float)
    ok = np.asarray(solved, dtype=bool) & np.isfinite(t)
    n = t.size
    x = np.sort(t[ok])
    y = np.arange(1, x.size + 1) / n if n else np.array([])
    return x, y


def step_values(samples: pd.DataFrame, runs: Sequence[str], times: Sequence[float]) -> np.ndarray:
    """A progress series (samples: run_hash, time_ms, value) as a step function per run, read
    at `times`: an array (len(runs), len(times)) with each run's last value at or before the
    time, and infinity before its first sample (no solution yet). A run that stopped keeps
    its last value: every run counts at every time, so a statistic over the runs never rises
    because runs drop out."""
    times = np.asarray(times, dtype=float)
    table = np.full((len(runs), len(times)), np.inf)
    by_run = {run: group for run, group in samples.groupby("run_hash")}
    for row, run in enumerate(runs):
        if run not in by_run:
            continue
        group = by_run[run].sort_values("time_ms", kind="stable")
        at = np.searchsorted(group["time_ms"].to_numpy(dtype=float), times, side="right") - 1
        values = group["value"].to_numpy(dtype=float)
        table[row, at >= 0] = values[at[at >= 0]]
    return table


def is_success(runs: pd.DataFrame) -> pd.Series:
    """Exact and accepted by the independent checker: kinolab's one definition (C++
    `isSuccess`), which the runner stores as the `success` column. Only data that predates
    that column (version 1 databases, synthetic frames) needs it computed here."""
    return (runs["status"] == "exact") & (runs["checker_valid"] == 1)
