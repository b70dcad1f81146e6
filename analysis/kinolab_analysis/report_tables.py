"""The report's tables: status counts, summaries, paired tests, the paper's tables and the
comparison with another result set."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from . import paper, tables
from .data import Results, load
from .report_page import Report


def _summary_columns(summary: pd.DataFrame, statistic: str = "median") -> pd.DataFrame:
    """A tables.summary with its medians (or means) only, named by their metrics."""
    other = "mean " if statistic == "median" else "median "
    keep = [c for c in summary.columns if not c.startswith(other)]
    return summary[keep].rename(columns={c: c.replace(f"{statistic} ", "") for c in keep})


def _undefined_notes(report: Report, name: str, runs: pd.DataFrame) -> None:
    """The notes under a table: each metric of it undefined for some of its runs, and why."""
    if notes := tables.undefined_notes(runs, [str(c) for c in report.tables[name].columns]):
        report.notes[name] = notes


def find_sampling_study(directory: Path) -> Path | None:
    found = sorted(directory.glob("sampling_study/*/summary.csv"))
    return found[0] if found else None


# The front end x back end matrix's figures (docs/back_ends.md), over the successful runs.
BACK_END_METRICS = [("time_front_end_ms", "front T", ""), ("time_back_end_ms", "back T", ""),
                    ("duration", "duration", ""), ("jerk_integral", "jerk", ""),
                    ("min_clearance", "min clearance", "")]


def back_end_of(label: str, planner: str) -> str | None:
    """The back end a sweep label gives a planner: `planners.ID.params.back_end=NAME` (or
    `.back_end.type=NAME`), with its parameters swept beside it ("corridor_minco (order=4)");
    None when the label does not choose one."""
    prefix = f"planners.{planner}.params.back_end"
    name, settings = None, []
    for part in label.split(", "):
        path, _, value = part.partition("=")
        if path in (prefix, prefix + ".type"):
            name = value
        elif path.startswith(prefix + "."):
            settings.append(f"{path[len(prefix) + 1:]}={value}")
    if name is None:
        return None
    return name + (f" ({', '.join(settings)})" if settings else "")


def back_end_matrix(runs: pd.DataFrame) -> pd.DataFrame | None:
    """Front ends (planners) x back ends, when the sweep's variants choose each planner's back
    end (as experiments/back_ends.yaml does; its swept parameters keep variants apart): per
    pair the runs, success and the medians of BACK_END_METRICS; None otherwise."""
    back_ends = pd.Series([back_end_of(str(label or ""), str(planner))
                           for label, planner in zip(runs["sweep"], runs["planner"])],
                          index=runs.index, dtype=object)
    if back_ends.isna().any() or back_ends.nunique() < 2:
        return None
    if "time_front_end_ms" in runs:
        # A back end that keeps the front end's trajectory (`none`) is not run: the plan is
        # the front end's alone.
        unrun = runs["time_front_end_ms"].isna()
        runs = runs.assign(
            time_front_end_ms=runs["time_front_end_ms"].where(~unrun, runs["planning_time_ms"]),
            time_back_end_ms=runs["time_back_end_ms"].where(~unrun, 0.0))
    matrix = tables.summary(runs.assign(**{"back end": back_ends}), by=["planner", "back end"],
                            metrics=BACK_END_METRICS)
    return matrix.rename(columns={"planner": "front end"})


def add_tables(report: Report, results, paths: list[Path], compare: Path | None,
               sampling_csv: Path | None) -> tuple[Path | None, pd.DataFrame | None, str, str]:
    """The report's tables; returns the sampling study's CSV, its readings and their verdict,
    and the compared database's name."""
    runs = results.runs
    reproduced = results.reproduces()
    report.tables["status_counts"] = tables.status_counts(runs).reset_index()
    if not (reasons := tables.failure_reasons(runs)).empty:
        report.tables["failure_reasons"] = reasons
    if runs["line_blocked"].notna().any():
        report.tables["worlds"] = tables.worlds(runs)
    if runs["planning_time_cold_ms"].notna().any():
        report.tables["timing"] = tables.timing(runs)
    # The paper's tables only for an experiment that says what it reproduces.
    reproduced_paper = paper.load(reproduced[0]) if reproduced else None
    if reproduced_paper:
        report.tables["paper_table2"] = paper.table2(runs, reproduced_paper,
                                                     results.paper_setting())
    full_summary = tables.summary(runs)
    if runs["time_limit"].notna().any():
        budgets = tables.budgets(runs)
        full_summary.insert(1, "time budget", full_summary["planner"].map(budgets))
    report.tables["summary"] = _summary_columns(full_summary)
    report.tables["means"] = _summary_columns(full_summary.drop(
        columns=["time budget", "runs", *tables.OUTCOMES], errors="ignore"), "mean")
    for name in ("summary", "means"):
        _undefined_notes(report, name, runs)
    if runs["sampler"].fillna("").nunique() > 1:
        report.tables["per_sampler"] = _summary_columns(
            tables.summary(runs, by=["sampler", "planner"],
                           metrics=tables.metrics(results.metrics,
                                                  ("planning_time_ms", "expansions"))))
    if runs["world"].nunique() > 1:
        report.tables["per_world"] = _summary_columns(
            tables.summary(runs, by=["world", "planner"],
                           metrics=tables.metrics(results.metrics, ("planning_time_ms",))))
    if runs["sweep"].fillna("").nunique() > 1:
        sweep = _summary_columns(
            tables.summary(runs, by=["sweep", "planner"],
                           metrics=tables.metrics(results.metrics,
                                                  ("planning_time_ms", "expansions", "cost"))))
        report.tables["sweep"] = sweep.assign(sweep=sweep["sweep"].map(tables.sweep_name))
        if runs["planner"].nunique() >= 2:
            report.tables["sweep_winners"] = tables.sweep_winners(runs)
    if (matrix := back_end_matrix(runs)) is not None:
        report.tables["back_ends"] = _summary_columns(matrix)
        _undefined_notes(report, "back_ends", runs)
    if not (statistics := tables.statistics(runs, results.metrics)).empty:
        report.tables["statistics"] = statistics
    report.tables["paired"] = tables.paired(runs, tables.comparable(results.metrics,
                                                                    tables.PAIRED))
    # The field: three planners or more, each against the paper's lazy planner.
    if runs["planner"].nunique() >= 3 and "time_to_goal" not in runs.columns:
        report.tables["which_planner"] = tables.which_planner(
            runs, tables.reference_planner(runs),
            tables.comparable(results.metrics, tables.FIELD_METRICS))
        _undefined_notes(report, "which_planner", runs)
    if not results.stale.empty:
        report.tables["stale"] = tables.status_counts(results.stale).reset_index()
    if reproduced:
        sampling_csv = sampling_csv or find_sampling_study(paths[0] if paths[0].is_dir()
                                                           else paths[0].parent)
    readings = None
    readings_verdict = ""
    if sampling_csv is not None:
        report.tables["paper_table1"] = paper.table1(sampling_csv, reproduced_paper)
        if reproduced_paper and (sampling_csv.parent / "readings.csv").is_file():
            readings = pd.read_csv(sampling_csv.parent / "readings.csv")
            report.tables["sampling_readings"], readings_verdict = paper.sampling_readings(
                readings, reproduced_paper)
    compare_name = ""
    if compare is not None:
        other = load(compare)
        compare_name = str(compare)
        report.tables["compare"] = tables.compare(runs, other.runs)
        report.warnings += machine_differences(results, other)

    return sampling_csv, readings, readings_verdict, compare_name


def machine_differences(a: Results, b: Results) -> list[str]:
    """Warnings when two results directories' machines or loads differ (their times then do
    not compare)."""
    warnings = []
    machine_a, machine_b = a.meta.get("machine"), b.meta.get("machine")
    if machine_a != machine_b:
        first, second = machine_a or "not recorded", machine_b or "not recorded"
        warnings.append(f"The compared results come from different machines ({first} against "
                        f"{second}): their clock figures do not compare.")
    loads = [r.runs["load_average"].median() if "load_average" in r.runs else math.nan
             for r in (a, b)]
    if all(math.isfinite(x) for x in loads) and abs(loads[0] - loads[1]) > 1.0:
        warnings.append(f"The median load average differs ({loads[0]:.1f} against "
                        f"{loads[1]:.1f}): a timing difference may be the machine's load, not "
                        "the planners'.")
    return warnings
