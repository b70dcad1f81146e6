"""A paper an experiment reproduces (`reproduces:`): its figures, from papers.yaml (the one
definition, which kinolab also reads for the rows an experiment may name), and the tables
that set them beside what kinolab measured. Only experiments that say what they reproduce
use this module."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from . import stats, tables

PAPERS = Path(__file__).with_name("papers.yaml")


def _number(value) -> float:
    return math.nan if value is None else float(value)


@dataclass(frozen=True)
class Paper:
    """A paper's figures: per Table II row (T ms, N, D m), its speedup claim (eager T over
    lazy T) and per sampler of Table I (alpha, L m)."""

    key: str
    title: str
    rows: dict[str, tuple[float, float, float]]
    speedup: float
    samplers: dict[str, tuple[float, float]]
    # Table II's setting: the searches' expansion cap (NaN: not stated).
    max_expansions: float = math.nan


def load(key: str) -> Paper:
    """The paper `key` of papers.yaml; a ValueError naming the known ones otherwise."""
    papers = yaml.safe_load(PAPERS.read_text())
    if key not in papers:
        raise ValueError(f"{PAPERS}: no paper '{key}'; known: {', '.join(sorted(papers))}")
    entry = papers[key]
    rows = {row: (_number(v["T"]), _number(v["N"]), _number(v["D"]))
            for row, v in entry["rows"].items()}
    speedup = entry.get("speedup")
    ratio = rows[speedup["eager"]][0] / rows[speedup["lazy"]][0] if speedup else math.nan
    samplers = {name: (_number(v["alpha"]), _number(v["L"]))
                for name, v in (entry.get("samplers") or {}).items()}
    setting = entry.get("setting") or {}
    return Paper(key, " ".join(str(entry.get("title", key)).split()), rows, ratio, samplers,
                 _number(setting.get("max_expansions")))


def in_setting(runs: pd.DataFrame, paper: Paper, declared: set[str]) -> dict[str, str]:
    """Per sweep variant, whether its runs are in the paper's setting: "the paper's" when the
    experiment declares it (`reproduces: {setting: [...]}`) and its searches (the rows with
    an N) stopped at the paper's expansion cap (median N of the answered runs); otherwise
    why not."""
    verdicts = {}
    for variant, group in runs.groupby(runs["sweep"].fillna(""), sort=False):
        if variant not in declared:
            verdicts[variant] = "not the paper's setting (not declared)"
            continue
        searches = group[group["paper"].isin([r for r, (_, n, _) in paper.rows.items()
                                              if math.isfinite(n)])]
        answered = searches[tables.answered(searches)]
        medians = (answered.groupby("paper")["expansions"].median()
                   if "expansions" in answered else pd.Series(dtype=float))
        cap = paper.max_expansions
        if math.isfinite(cap) and (medians.empty or (medians != cap).any()):
            found = ", ".join(f"{row} {value:,.0f}" for row, value in medians.items()) or "none"
            verdicts[variant] = (f"declared, but not the paper's setting: the searches' median "
                                 f"N is {found}, the paper's cap {cap:,.0f}")
        else:
            verdicts[variant] = "the paper's"
    return verdicts


def table2(runs: pd.DataFrame, paper: Paper, declared: set[str] | None = None) -> pd.DataFrame:
    """The paper's T, N, D beside the medians kinolab measured for the same planner
    families, per sweep variant and world when there are several: T and N over the runs that
    returned a checked trajectory (answered: exact, or approximate at the budget), D over all
    runs, with intervals. Only in a variant run in the paper's setting (in_setting) is each
    difference tested (one-sample Wilcoxon p); elsewhere the p columns are empty and the
    setting column says why: such figures are not a reproduction."""
    rows = []
    variants = list(dict.fromkeys(runs["sweep"].fillna("")))
    worlds = list(dict.fromkeys(runs["world"]))
    setting = in_setting(runs, paper, declared or set())
    for variant, world in itertools.product(variants, worlds):
        for family, (t, n, d) in paper.rows.items():
            group = runs[(runs["paper"] == family) & (runs["sweep"].fillna("") == variant)
                         & (runs["world"] == world)]
            ok = group[tables.answered(group)]
            row = {"variant": variant} if len(variants) > 1 else {}
            if len(worlds) > 1:
                row["world"] = world
            row.update({"planner": family, "setting": setting.get(variant, ""),
                        "runs": len(group),
                        "success": stats.wilson(int(group["success"].sum()), len(group)),
                        "answered": stats.wilson(len(ok), len(group))})
            for label, column, paper_value, subset in (("T (ms)", "planning_time_ms", t, ok),
                                                       ("N", "expansions", n, ok),
                                                       ("D (m)", "distance_to_goal", d, group)):
                values = (subset[column].dropna().to_numpy(dtype=float) if column in subset
                          else np.array([]))
                row[f"paper {label}"] = paper_value
                row[f"kinolab {label}"] = stats.bootstrap(values, np.median)
                testable = (setting.get(variant) == "the paper's" and math.isfinite(paper_value)
                            and len(values))
                row[f"p {label}"] = (stats.one_sample_wilcoxon(values, paper_value)
                                     if testable else math.nan)
            rows.append(row)
    return pd.DataFrame(rows)


def _study_csv(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    """A sampling study's CSV (kinolab sampling-study writes them) with at least `columns`
    of numbers (but the sampler's name); a clear error naming the file otherwise."""
    try:
        frame = pd.read_csv(path)
    except (UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as error:
        raise ValueError(f"{path}: not a sampling study's CSV ({type(error).__name__}: "
                         f"{str(error).splitlines()[0] if str(error) else 'unreadable'})") from error
    missing = [c for c in columns if c not in frame.columns]
    if missing or frame.empty:
        raise ValueError(f"{path}: not a sampling study's CSV: expected the columns "
                         f"{', '.join(columns)} (kinolab sampling-study writes them) and a row "
                         f"per sampler; {'missing ' + ', '.join(missing) if missing else 'no row'}")
    for column in columns[1:]:
        if not pd.api.types.is_numeric_dtype(frame[column]):
            raise ValueError(f"{path}: column {column} holds text where numbers belong")
    return frame


def table1(summary_csv: Path, paper: Paper | None) -> pd.DataFrame:
    """The sampling study's summary (kinolab sampling-study's summary.csv) beside the
    paper's Table I: alpha and L (mean nearest-neighbour distance of endpoints), with the
    one-sample Wilcoxon p of each difference over the study's initial states (from the
    sampling_study.csv beside it, when present). The paper's figures are the summary's own
    (the study's `paper_alpha`, `paper_mean_nearest`) or else `paper`'s."""
    study = _study_csv(summary_csv, ("sampler", "alpha", "mean_nearest"))
    per_state_csv = summary_csv.parent / "sampling_study.csv"
    per_state = (_study_csv(per_state_csv, ("sampler", "alpha", "mean_nearest"))
                 if per_state_csv.is_file() else None)
    rows = []
    for _, row in study.iterrows():
        name = str(row["sampler"])
        figures = paper.samplers.get(name, (math.nan, math.nan)) if paper else (math.nan, math.nan)
        paper_alpha = float(row.get("paper_alpha", figures[0]))
        paper_l = float(row.get("paper_mean_nearest", figures[1]))
        states = per_state[per_state["sampler"] == name] if per_state is not None else None
        p_alpha = p_l = math.nan
        if states is not None and len(states):
            if math.isfinite(paper_alpha):
                p_alpha = stats.one_sample_wilcoxon(states["alpha"], paper_alpha)
            if math.isfinite(paper_l):
                p_l = stats.one_sample_wilcoxon(states["mean_nearest"], paper_l)
        rows.append({"sampler": name, "paper alpha": paper_alpha,
                     "kinolab alpha": float(row["alpha"]), "p alpha": p_alpha,
                     "paper L (m)": paper_l, "kinolab L (m)": float(row["mean_nearest"]),
                     "p L": p_l})
    return pd.DataFrame(rows)


def sampling_readings(readings: pd.DataFrame, paper: Paper,
                      samplers: tuple[str, str, str] = ("random", "uniform", "normal")
                      ) -> tuple[pd.DataFrame, str]:
    """Table I under every reading (the sampling study's readings.csv): per reading
    (M, distance, propagation, pooling, threshold) alpha and L of the three samplers,
    whether the paper's ranking (random < uniform < normal) holds for each, and the largest
    gap to the paper's six figures; then a one-sentence verdict."""
    keys = ["controls", "distance", "propagation", "pooling", "threshold"]
    chosen = readings[readings["sampler"].isin(samplers)]
    wide = chosen.pivot_table(index=keys, columns="sampler", values=["alpha", "mean_nearest"])
    rows = []
    for key, values in wide.iterrows():
        alpha = [values[("alpha", s)] for s in samplers]
        length = [values[("mean_nearest", s)] for s in samplers]
        gap = max(max(abs(alpha[i] - paper.samplers[s][0]), abs(length[i] - paper.samplers[s][1]))
                  for i, s in enumerate(samplers))
        rows.append({**dict(zip(keys, key)),
                     **{f"alpha {s}": alpha[i] for i, s in enumerate(samplers)},
                     **{f"L {s}": length[i] for i, s in enumerate(samplers)},
                     "alpha ranked as the paper": alpha[0] < alpha[1] < alpha[2],
                     "L ranked as the paper": length[0] < length[1] < length[2],
                     "largest gap to the paper": gap})
    table = pd.DataFrame(rows)
    if table.empty:
        return table, "No readings."
    both = table["alpha ranked as the paper"] & table["L ranked as the paper"]
    closest = table.loc[table["largest gap to the paper"].idxmin()]
    verdict = (
        f"Of {len(table)} readings ({table['controls'].nunique()} M x "
        f"{table['distance'].nunique()} distances x {table['propagation'].nunique()} "
        f"propagations x {table['pooling'].nunique()} poolings x "
        f"{table['threshold'].nunique()} thresholds), the paper's ranking random < uniform < "
        f"normal holds for alpha in {int(table['alpha ranked as the paper'].sum())}, for L in "
        f"{int(table['L ranked as the paper'].sum())} and for both in {int(both.sum())}; "
        f"the reading closest to the paper's six figures (M {int(closest['controls'])}, "
        f"{closest['distance']}, {closest['propagation']}, {closest['pooling']}, threshold "
        f"{closest['threshold']:g}) is still {closest['largest gap to the paper']:.2f} away in "
        f"its worst figure.")
    return table, verdict
