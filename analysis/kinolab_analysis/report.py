"""`kinolab report`: a results database (or several) into a self-contained HTML report,
figures as PNG and SVG, tables as Markdown and LaTeX, and a summary on the terminal.

The parts: report_page.py (the contents and the page), report_tables.py (the tables),
report_figures.py (the figures and 3D views); their public names are this module's too."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from . import files, tables
from .data import load
from .report_figures import (case_figures, find_lazy_regime, lazy_regime, progress_figures,
                             summary_figures)
from .report_page import SPLIT, TEMPLATE, Figure, Report, View, timing_protocol, write_page
from .report_tables import add_tables, find_sampling_study, machine_differences

__all__ = ["TEMPLATE", "SPLIT", "Figure", "View", "Report", "find_lazy_regime",
           "find_sampling_study", "write", "stale_warnings", "load_warnings",
           "machine_differences", "timing_protocol", "terminal_summary"]


def write(paths: list[Path], out: Path, compare: Path | None = None,
          sampling_csv: Path | None = None, allow_mixed: bool = False) -> Report:
    """Writes the report directory and returns what it holds (databases of different
    experiments only with `allow_mixed`: data.load)."""
    results = load(paths, allow_mixed)
    report = Report(out)
    report.warnings += load_warnings(results.runs, results.meta)
    report.warnings += stale_warnings(results.stale)
    if "experiment" in results.runs and results.runs["experiment"].nunique() > 1:
        counts = results.runs["experiment"].value_counts().sort_index()
        report.warnings.append(
            f"{len(counts)} experiments side by side (--allow-mixed): "
            + ", ".join(f"{name} ({count} runs)" for name, count in counts.items())
            + "; each planner is labelled with its experiment and never pooled across them")
    # The inputs are read (and refused) before anything is written.
    sampling_csv, readings, readings_verdict, compare_name = add_tables(
        report, results, paths, compare, sampling_csv)
    files.directory(out)
    summary_figures(report, results, sampling_csv, readings, readings_verdict)
    case_figures(report, results, out)
    regime_sources = lazy_regime(report, results,
                                 paths[0] if paths[0].is_dir() else paths[0].parent)
    progress_figures(report, results)
    write_page(report, results, out, compare_name, readings_verdict, regime_sources)
    return report


def stale_warnings(stale: pd.DataFrame) -> list[str]:
    """A warning when the directory holds runs of an earlier configuration of the experiment
    (data.load keeps them apart): how many, of which planners."""
    if stale.empty:
        return []
    counts = stale["planner"].value_counts().sort_index()
    return [f"{len(stale):,} stored runs are of an earlier configuration of this experiment "
            "(a planner's parameters changed, then --resume): "
            + ", ".join(f"{planner} {count:,}" for planner, count in counts.items())
            + ". They stay in the file and are left out of every table and figure but the "
            "count under \"Runs by status\"."]


def load_warnings(runs: pd.DataFrame, meta: dict[str, str]) -> list[str]:
    """A warning when runs started with a 1-minute load average above the machine's cores:
    they waited for a core, and their clock figures are inflated."""
    if "load_average" not in runs or runs["load_average"].isna().all():
        return []
    cores = float(meta.get("cores", "nan"))
    if not math.isfinite(cores):
        return []
    loaded = runs["load_average"] > cores
    if not loaded.any():
        return []
    return [f"{int(loaded.sum()):,} of {len(runs):,} runs started with a load average above "
            f"the machine's {int(cores)} cores (up to {runs['load_average'].max():.1f}): their "
            "clock figures (planning_time_ms and the other times) are inflated by waiting for "
            "a core. Compare timings only between runs taken at a load below the core count."]


def terminal_summary(report: Report) -> str:
    """What `kinolab report` prints."""
    lines = [f"report: {report.out / 'index.html'}"]
    lines += [f"warning: {warning}" for warning in report.warnings]
    counts = report.tables["status_counts"]
    lines.append("runs by status:")
    lines += ["  " + line for line in tables.to_markdown(counts).splitlines()]
    if "paper_table2" in report.tables:
        lines.append("the paper's Table II beside kinolab (medians, 95 % intervals):")
        table2 = report.tables["paper_table2"]
        columns = [c for c in table2.columns if c in (
            "variant", "world", "planner", "runs", "answered", "paper T (ms)", "kinolab T (ms)",
            "paper N", "kinolab N", "paper D (m)", "kinolab D (m)")]
        lines += ["  " + line for line in tables.to_markdown(table2[columns]).splitlines()]
    else:
        lines.append("per planner (medians, 95 % intervals):")
        parts = tables.split(report.tables["summary"], ["planner"])
        for part in (parts[""], parts.get("time")):
            if part is not None:
                lines += ["  " + line for line in tables.to_markdown(part).splitlines()]
    lines.append(f"{len(report.figures)} figures (PNG and SVG) in {report.out / 'figures'}; "
                 f"tables (Markdown, LaTeX) in {report.out / 'tables'}")
    return "\n".join(lines)
