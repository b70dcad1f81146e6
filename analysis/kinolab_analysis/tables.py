"""Summary tables: counts by status, per-planner statistics with intervals, paired
comparisons and the lazy speedup. A paper's tables are kinolab_analysis.paper's."""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pandas as pd

from . import stats

CASE = ["sweep", "world", "query", "repetition"]

# A planner's own cost as every heading and test names it: each planner's objective, compared
# only between runs of one objective (same_objective).
OWN_COST = "cost (own objective)"

# Metrics summarised over successful runs, in groups (a table each, so that no table is wider
# than the page): (column, short label). Their units are the database's declaration
# (Results.metrics, written from kinolab's metric specs): metrics().
GROUPS = {
    "time": [("planning_time_ms", "T"), ("expansions", "N"),
             ("partial_evaluations", "partial evals"), ("full_evaluations", "full evals")],
    "path": [("cost", OWN_COST), ("distance_to_goal", "D"), ("duration", "duration"),
             ("length", "length")],
    "smoothness": [("acceleration_integral", "acceleration"),
                   ("acceleration_per_metre", "acceleration per metre"),
                   ("jerk_integral", "jerk"), ("acceleration_jumps", "acceleration jumps"),
                   ("mean_curvature", "mean curvature"), ("max_curvature", "max curvature")],
    "clearance and limits": [("min_clearance", "min clearance"),
                             ("mean_clearance", "mean clearance"),
                             ("speed_limit_ratio", "speed / limit"),
                             ("acceleration_limit_ratio", "acceleration / limit")],
    # Flights (kind: flight): their statistics.
    "flight": [("time_to_goal", "time to goal"), ("mean_speed", "mean speed"),
               ("replans", "replans"), ("failed_replans", "failed replans"),
               ("inside_margin", "inside margin"), ("replan_time_p95_ms", "replan p95"),
               ("replan_time_max_ms", "replan max"), ("frame_time_ms", "frame time")],
}
SUMMARISED = [metric for group in GROUPS.values() for metric in group]

# What a run came to, the columns of every table that counts runs: success (exact and
# accepted by the checker), approximate (a trajectory towards the goal at a budget stop),
# timeout (the planner spent its budget with nothing) and failed (every other status, an
# exact trajectory the checker refused included).
OUTCOMES = ("success", "approximate", "timeout", "failed")

# A cell whose metric is not defined for the runs it summarises (the jerk of
# piecewise-constant acceleration): never a 0, and the reason in a note (undefined_notes).
UNDEFINED = "undefined"


def metrics(declared: pd.DataFrame, columns: tuple[str, ...] | None = None
            ) -> list[tuple[str, str, str]]:
    """(column, label, unit) of the summarised metrics (those in `columns`, or all), the unit
    from the database's declaration `declared` (Results.metrics; "" where it declares none)."""
    units: dict[str, str] = {}
    if not declared.empty and {"name", "unit"} <= set(declared.columns):
        units = dict(zip(declared["name"], declared["unit"].fillna("")))
    return [(column, label, units.get(column, "")) for column, label in SUMMARISED
            if columns is None or column in columns]


def comparable(declared: pd.DataFrame, names: tuple[str, ...]) -> tuple[str, ...]:
    """Of `names`, those a test across planners may use: the metrics every declaration of
    which says comparable (the same for every planner: success, planning time, the checker's
    evaluation of the trajectory; not a planner's counters), and cost, which paired_tests
    pairs only between runs of one objective. Without declarations (synthetic frames), all."""
    if declared.empty or "comparable" not in declared:
        return names
    flags = declared.groupby("name")["comparable"].min()
    return tuple(name for name in names if name == "cost" or flags.get(name, 0) == 1)


def outcome(runs: pd.DataFrame) -> pd.Series:
    """Each run's OUTCOMES entry."""
    return pd.Series(np.select([runs["success"].astype(bool), runs["status"] == "approximate",
                                runs["status"] == "timeout"], list(OUTCOMES[:3]), OUTCOMES[3]),
                     index=runs.index)


def outcome_counts(runs: pd.DataFrame) -> dict[str, object]:
    """Runs, success (Wilson 95 %) and the count of each other outcome: every run counted
    once, approximate answers never as successes."""
    counts = outcome(runs).value_counts()
    return {"runs": len(runs),
            "success": stats.wilson(int(counts.get("success", 0)), len(runs)),
            **{name: int(counts.get(name, 0)) for name in OUTCOMES[1:]}}


def budgets(runs: pd.DataFrame) -> dict[str, str]:
    """Per planner, the time budget of each plan its runs ran under: "10 s" (the experiment's
    budget.time) or "1 s (own time_limit)" (its entry sets its own), several when a sweep
    varies it; empty where the database does not record it (before schema version 8)."""
    words = {}
    for planner, group in runs.groupby("planner", sort=False):
        limits = (group[["time_limit", "time_limit_own"]].dropna(subset=["time_limit"])
                  .drop_duplicates().sort_values("time_limit"))
        words[planner] = ", ".join(
            (f"{stats.number(float(limit))} s" if limit > 0 else "none")
            + (" (own time_limit)" if own == 1 else "")
            for limit, own in limits.itertuples(index=False))
    return words


def undefined(runs: pd.DataFrame) -> pd.DataFrame:
    """Every metric undefined for a run, from the runs' `undefined` lines ("NAME: REASON"):
    the run's index, the metric and the reason."""
    rows = [{"index": index, "metric": name.strip(), "reason": reason.strip()}
            for index, text in (runs["undefined"].dropna().items() if "undefined" in runs
                                else [])
            for name, _, reason in (line.partition(":") for line in str(text).splitlines())
            if name.strip()]
    return pd.DataFrame(rows, columns=["index", "metric", "reason"])


def estimate(runs: pd.DataFrame, column: str, gaps: pd.DataFrame,
             statistic=np.median) -> stats.Interval | str:
    """The statistic of a metric over runs with its bootstrap 95 % interval, or UNDEFINED when
    no run has a value and runs say it is undefined for them (`gaps`: undefined())."""
    values = runs[column].to_numpy(dtype=float)
    if not np.isfinite(values).any() and (
            (gaps["metric"] == column) & gaps["index"].isin(runs.index)).any():
        return UNDEFINED
    return stats.bootstrap(values, statistic)


def undefined_notes(runs: pd.DataFrame, columns: list[str]) -> list[str]:
    """Per metric of `columns` and planner, the successful runs it is undefined for and why
    (the first run's reason), for the note under a table that summarises them."""
    ok = runs[runs["success"]]
    gaps = undefined(ok)
    gaps = gaps[gaps["metric"].isin(columns)]
    notes = []
    for (metric, planner), found in gaps.assign(planner=ok.loc[gaps["index"], "planner"].values
                                                 ).groupby(["metric", "planner"], sort=False):
        notes.append(f"{metric} is undefined for {len(found)} of "
                     f"{int((ok['planner'] == planner).sum())} successful runs of {planner}, "
                     f"not 0 (the first: {found['reason'].iloc[0]}).")
    return notes


def status_counts(runs: pd.DataFrame, by: str = "planner") -> pd.DataFrame:
    """Runs per status (every status, failures included), with the total."""
    table = runs.pivot_table(index=by, columns="status", values="run_hash", aggfunc="count",
                             fill_value=0)
    table["total"] = table.sum(axis=1)
    table.columns.name = None  # no empty heading cell in HTML
    return table


def failure_reasons(runs: pd.DataFrame, by: str = "planner") -> pd.DataFrame:
    """Why runs did not succeed, per planner: each status other than a checked exact one with
    its messages grouped (numbers and points in them read as #), the count and one message
    in full. Empty when every run succeeded."""
    failed = runs[~runs["success"]]
    if failed.empty:
        return pd.DataFrame()
    message = failed["message"].fillna("").astype(str)
    if "checker_valid" in failed:
        # An exact plan that the checker refused says so.
        refused = (failed["status"] == "exact") & (failed["checker_valid"] == 0)
        message = message.where(~refused, "refused by the checker: " +
                                failed.get("checker_detail", pd.Series("", failed.index))
                                .fillna("").astype(str))
    pattern = message.str.replace(r"-?\d+(\.\d+)?(e-?\d+)?", "#", regex=True)
    frame = pd.DataFrame({by: failed[by], "status": failed["status"], "reason": pattern,
                          "example": message})
    table = (frame.groupby([by, "status", "reason"], sort=False)
             .agg(runs=("example", "size"), example=("example", "first")).reset_index())
    table = table.sort_values([by, "runs"], ascending=[True, False], kind="stable")
    return table.drop(columns="reason")[[by, "status", "runs", "example"]]


def summary(runs: pd.DataFrame, by: list[str] | None = None,
            metrics: list[tuple[str, str, str]] | None = None) -> pd.DataFrame:
    """Per group: outcome_counts and, over the successful runs, median and mean of each
    metric with bootstrap intervals (UNDEFINED where the metric is undefined for them)."""
    by = by or ["planner"]
    # Only the metrics these runs have (a flight has no expansions, a plan no time to goal).
    metrics = [m for m in (metrics or [(c, label, "") for c, label in SUMMARISED])
               if m[0] in runs.columns]
    gaps = undefined(runs)
    rows = []
    for key, group in runs.groupby(by if len(by) > 1 else by[0], sort=False, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        row = {**dict(zip(by, key)), **outcome_counts(group)}
        ok = group[group["success"]]
        for column, _, _ in metrics:
            row[f"median {column}"] = estimate(ok, column, gaps, np.median)
            row[f"mean {column}"] = estimate(ok, column, gaps, np.mean)
        rows.append(row)
    return pd.DataFrame(rows)


def split(table: pd.DataFrame, keys: list[str],
          groups: dict[str, list[str]] | None = None) -> dict[str, pd.DataFrame]:
    """A wide table as narrow ones that each fit the page: "" with the keys and every column
    of no group's metric (the run counts), then one per group (default: GROUPS) with the keys
    and the columns that name one of its metrics as a word ("planning_time_ms",
    "p planning_time_ms vs lazy", "kinolab T (ms)"); a part without such columns is left out."""
    groups = groups or {group: [column for column, _ in entries]
                        for group, entries in GROUPS.items()}
    group_of = {metric: group for group, names in groups.items() for metric in names}
    parts: dict[str, list[str]] = {group: [] for group in ["", *groups]}
    for column in table.columns:
        if column not in keys:
            metric = next((word for word in str(column).split(" ") if word in group_of), None)
            parts[group_of[metric] if metric else ""].append(column)
    return {group: table[keys + columns] for group, columns in parts.items() if columns}


def statistics(runs: pd.DataFrame, metrics: pd.DataFrame) -> pd.DataFrame:
    """Per planner, every statistic its planner type declares (the database's `metrics`
    table) with its unit, the runs that report it and the median over them (bootstrap 95 %):
    a statistic describes a run, solved or not, so every run counts."""
    if metrics.empty:
        return pd.DataFrame()
    declared = metrics[metrics["kind"] == "statistic"]
    rows = []
    for planner, group in runs.groupby("planner", sort=False):
        mine = declared[declared["planner_type"].isin(set(group["planner_type"]))]
        for _, spec in mine.drop_duplicates("name").iterrows():
            name = spec["name"]
            if name not in group.columns or spec["type"] in ("text", "boolean"):
                continue
            values = group[name].dropna().to_numpy(dtype=float)
            if len(values) == 0:
                continue
            rows.append({"planner": planner, "statistic": name, "unit": spec["unit"],
                         "clock": bool(spec["clock"]), "runs": len(values),
                         "median": stats.bootstrap(values, np.median)})
    return pd.DataFrame(rows)


def same_objective(left: pd.DataFrame, right: pd.DataFrame) -> np.ndarray:
    """Per pair of runs (row for row), whether their costs measure the same thing: equal
    objectives (schema 8's `objective`; before it, data.load sets the planner type)."""
    def objectives(runs: pd.DataFrame) -> np.ndarray:
        column = "objective" if "objective" in runs else "planner_type"
        return (runs[column].fillna("").astype(str).to_numpy() if column in runs
                else np.full(len(runs), ""))
    a, b = objectives(left), objectives(right)
    return (a == b) & (a != "")


def paired_tests(left: pd.DataFrame, right: pd.DataFrame, names: tuple[str, str],
                 metrics: tuple[str, ...]) -> list[dict]:
    """Two sets of runs on the same cases, row for row: McNemar (exact) on success, and
    Wilcoxon signed-rank on each metric over the cases both solved, with effect sizes
    (success: (a only - b only) / n; metrics: matched-pairs rank-biserial, > 0: a larger).
    Cost, each planner's own objective, only over the cases whose two runs share their
    objective (none between planner families)."""
    a, b = names
    n = len(left)
    a_only, b_only, p = stats.mcnemar(left["success"], right["success"])
    rows = [{"test": "McNemar", "metric": "success", "n": n,
             "effect": f"{a} only {a_only}, {b} only {b_only}",
             "effect size": (a_only - b_only) / n, "p": p}]
    both = left["success"].to_numpy() & right["success"].to_numpy()
    for metric in metrics:
        if metric in left.columns and metric in right.columns:
            cases = both & same_objective(left, right) if metric == "cost" else both
            test = stats.wilcoxon(left[metric].to_numpy(dtype=float)[cases],
                                  right[metric].to_numpy(dtype=float)[cases])
            if test.n == 0:
                continue  # a metric one of them does not report (N of RRT*), or other objectives
            rows.append({"test": "Wilcoxon", "metric": OWN_COST if metric == "cost" else metric,
                         "n": test.n, "effect": f"median {a} - {b} {test.median_difference:.3g}",
                         "effect size": test.rank_biserial, "p": test.p})
    return rows


def _aligned(left: pd.DataFrame, right: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The runs of both on the cases both ran, in the same order."""
    left, right = left.set_index(CASE), right.set_index(CASE)
    shared = left.index.intersection(right.index)
    return left.loc[shared], right.loc[shared]


def _with_holm(rows: list[dict]) -> pd.DataFrame:
    table = pd.DataFrame(rows)
    if not table.empty:
        table["p (Holm)"] = stats.holm(table["p"].tolist())
    return table


# What "which planner when" compares: time to plan, and the trajectory's quality measured the
# same way for every planner and defined for every trajectory (not jerk: undefined for
# piecewise-constant acceleration).
FIELD_METRICS = ("planning_time_ms", "duration", "acceleration_integral", "min_clearance")

# What the paired comparisons test besides success: FIELD_METRICS, cost between runs of one
# objective, and a flight's time to the goal.
PAIRED = (*FIELD_METRICS, "cost", "time_to_goal")


def paired(runs: pd.DataFrame, metrics: tuple[str, ...] = PAIRED,
           by: str = "planner") -> pd.DataFrame:
    """Every pair of planners on the cases both ran (paired_tests), p-values Holm-corrected
    over the whole table. `metrics` must be comparable across planners (comparable())."""
    rows = []
    names = list(dict.fromkeys(runs[by]))
    for a, b in itertools.combinations(names, 2):
        left, right = _aligned(runs[runs[by] == a], runs[runs[by] == b])
        if len(left):
            rows += [{"a": a, "b": b, **row} for row in paired_tests(left, right, (a, b), metrics)]
    return _with_holm(rows)


def reference_planner(runs: pd.DataFrame) -> str:
    """The planner the field is paired against: the paper's lazy MP-A* (the first planner of
    type lazy_mp_astar), else the first planner."""
    lazy = runs[runs["planner_type"] == "lazy_mp_astar"]
    return str((lazy if not lazy.empty else runs)["planner"].iloc[0])


def which_planner(runs: pd.DataFrame, reference: str,
                  metrics: tuple[str, ...] = FIELD_METRICS) -> pd.DataFrame:
    """Per world and planner: outcome_counts, the medians of `metrics` (comparable across
    planners) over its successful runs (bootstrap 95 %, UNDEFINED where undefined), and each
    paired against `reference` on the cases both ran (McNemar on success, Wilcoxon on each
    metric over cases both solved), p-values Holm-corrected over the whole table. Metrics the
    runs lack (a database before schema 8 has no acceleration_integral) are left out."""
    metrics = tuple(metric for metric in metrics if metric in runs)
    rows = []
    tests = []
    gaps = undefined(runs)
    for world, in_world in runs.groupby("world", sort=False):
        base = in_world[in_world["planner"] == reference]
        for planner, group in in_world.groupby("planner", sort=False):
            row = {"world": world, "planner": planner, **outcome_counts(group)}
            solved = group[group["success"]]
            for metric in metrics:
                row[metric] = estimate(solved, metric, gaps)
            if planner != reference and not base.empty:
                left, right = _aligned(group, base)
                for test in paired_tests(left, right, (planner, reference), metrics):
                    tests.append((len(rows), test))
            rows.append(row)
    table = pd.DataFrame(rows)
    adjusted = stats.holm([test["p"] for _, test in tests])
    for (index, test), p in zip(tests, adjusted):
        table.loc[index, f"p {test['metric']} vs {reference}"] = p
    return table


def compare(a: pd.DataFrame, b: pd.DataFrame,
            metrics: tuple[str, ...] = ("planning_time_ms", "cost")) -> pd.DataFrame:
    """Two result sets (A, B), each planner on the cases both ran: success rates and median
    planning times side by side, then paired_tests (cost where A's and B's objectives are
    equal), Holm-corrected over the table."""
    rows = []
    for planner in dict.fromkeys(a["planner"]):
        left, right = _aligned(a[a["planner"] == planner], b[b["planner"] == planner])
        if not len(left):
            continue
        side_by_side = {"planner": planner, "cases": len(left),
                        "success A": stats.wilson(int(left["success"].sum()), len(left)),
                        "success B": stats.wilson(int(right["success"].sum()), len(right)),
                        "T A (ms)": stats.bootstrap(left.loc[left["success"], "planning_time_ms"]),
                        "T B (ms)": stats.bootstrap(right.loc[right["success"], "planning_time_ms"])}
        rows += [{**side_by_side, **row}
                 for row in paired_tests(left, right, ("A", "B"), metrics)]
    return _with_holm(rows)


def answered(runs: pd.DataFrame) -> pd.Series:
    """Runs that returned a trajectory the checker accepts: exact, or approximate at a budget
    stop (a receding-horizon plan towards a goal beyond reach)."""
    return runs["checker_valid"].fillna(0).astype(bool) & runs["status"].isin(
        ["exact", "approximate"])


def worlds(runs: pd.DataFrame) -> pd.DataFrame:
    """Per world: its queries and the share whose straight line from start to goal is
    blocked for the planners' body (a query needs a detour), with a Wilson interval."""
    rows = []
    for world, group in runs.groupby("world", sort=False):
        cases = group.dropna(subset=["line_blocked"]).groupby(["sweep", "query"])["line_blocked"]
        blocked = cases.max()
        row = {"world": world, "queries": int(group["query"].nunique())}
        row["straight line blocked"] = (stats.wilson(int(blocked.sum()), len(blocked))
                                        if len(blocked) else math.nan)
        cases = group.drop_duplicates(["sweep", "query"])
        lengths = np.linalg.norm(cases[["goal_x", "goal_y", "goal_z"]].to_numpy(dtype=float)
                                 - cases[["start_x", "start_y", "start_z"]].to_numpy(dtype=float),
                                 axis=1)
        row["query length (m)"] = stats.bootstrap(lengths, np.median)
        rows.append(row)
    return pd.DataFrame(rows)


def timing(runs: pd.DataFrame) -> pd.DataFrame:
    """Per planner, the warm planning time (the run's median of timed plans), the fastest
    timed plan and the cold first plan in a fresh worker, medians over answered runs with
    bootstrap intervals, and the median cold / warm ratio."""
    rows = []
    for planner, group in runs[answered(runs)].groupby("planner", sort=False):
        row = {"planner": planner, "runs": len(group)}
        for label, column in (("warm T (ms)", "planning_time_ms"),
                              ("fastest T (ms)", "planning_time_min_ms"),
                              ("cold T (ms)", "planning_time_cold_ms")):
            row[label] = stats.bootstrap(group[column].dropna().to_numpy(dtype=float), np.median)
        ratio = (group["planning_time_cold_ms"] / group["planning_time_ms"]).dropna()
        row["cold / warm"] = stats.bootstrap(ratio.to_numpy(dtype=float), np.median)
        rows.append(row)
    return pd.DataFrame(rows)


# Words that mark a column holding a share (0..1), shown in percent ("straight line
# blocked", "line_blocked"); a word, not a part of one ("unsolved" is a count).
SHARE_WORDS = {"success", "answered", "solved", "blocked", "exact"}


def header(column: object) -> str:
    """A column's heading: cost named as each planner's own objective, a p-value's without the
    unit of the metric it tests."""
    name = re.sub(r"\bcost\b(?! \(own)", OWN_COST, str(column))
    return re.sub(r"^(p .*?) \([^)]*\)$", r"\1", name)


def text(value: object, digits: int = 3, column: object = None) -> str:
    """A cell as text: intervals as 'estimate [low, high]', shares (SHARE_COLUMNS) in percent,
    numbers as stats.number (0 for noise, separators, no exponents on counts)."""
    name = str(column)
    words = set(re.split(r"[ _]", name))
    share = not name.startswith("p ") and (bool(words & SHARE_WORDS) or "equal cost" in name)
    if isinstance(value, stats.Interval):
        return value.percent(digits) if share else value.format(digits)
    if isinstance(value, (bool, np.bool_)):
        return str(value)
    if isinstance(value, (int, np.integer)):
        return f"{int(value):,}"
    if isinstance(value, (float, np.floating)):
        if share and math.isfinite(value) and 0.0 <= value <= 1.0:
            return f"{stats.number(100 * float(value), digits)} %"
        p_value = str(column).startswith("p ") or str(column) == "p"
        return stats.number(float(value), digits, noise=0.0 if p_value else 1e-9)
    return str(value)


def to_markdown(table: pd.DataFrame) -> str:
    heading = "| " + " | ".join(header(c) for c in table.columns) + " |"
    rule = "|" + "|".join("---" for _ in table.columns) + "|"
    body = ["| " + " | ".join(text(v, column=c) for v, c in zip(row, table.columns)) + " |"
            for row in table.itertuples(index=False)]
    return "\n".join([heading, rule, *body]) + "\n"


def _latex_escape(value: str) -> str:
    for old, new in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("_", r"\_"),
                     ("#", r"\#"), ("^", r"\^{}"), ("*", r"$^*$")):
        value = value.replace(old, new)
    return value


def to_latex(table: pd.DataFrame, caption: str) -> str:
    """A booktabs table."""
    columns = "l" + "r" * (len(table.columns) - 1)
    lines = [r"\begin{table}[t]", r"\centering", f"\\caption{{{_latex_escape(caption)}}}",
             f"\\begin{{tabular}}{{{columns}}}", r"\toprule",
             " & ".join(_latex_escape(header(c)) for c in table.columns) + r" \\", r"\midrule"]
    for row in table.itertuples(index=False):
        lines.append(" & ".join(_latex_escape(text(v, column=c)) for v, c in zip(row, table.columns))
                     + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


# The columns of lazy_speedup besides the swept axes.
SPEEDUP_COLUMNS = ["sweep", "cases", "exact", "approximate", "eager T (ms)", "lazy T (ms)",
                   "speedup", "min speedup", "max speedup", "equal cost"]


def sweep_axes(label: str) -> dict[str, str]:
    """A sweep label ("planners.eager.params.edge_samples=5, planners.lazy.params.
    edge_samples=5, worlds.forest.spec.generators.0.density=0.1") as its axes by the last
    path component ({"edge_samples": "5", "density": "0.1"}): a value several planners share
    is one axis; a component with different values keeps its whole path."""
    pairs = [part.split("=", 1) for part in label.split(", ") if "=" in part]
    short: dict[str, set[str]] = {}
    for path, value in pairs:
        short.setdefault(path.rsplit(".", 1)[-1], set()).add(value)
    axes: dict[str, str] = {}
    for path, value in pairs:
        name = path.rsplit(".", 1)[-1]
        axes[name if len(short[name]) == 1 else path] = value
    return axes


def sweep_name(label: str) -> str:
    """A sweep variant by its axes' short names ("density=0.1, edge_samples=2"), or its label
    when that names no axis."""
    return ", ".join(f"{axis}={value}" for axis, value in sweep_axes(label).items()) or label


def sweep_winners(runs: pd.DataFrame, metric: str = "planning_time_ms") -> pd.DataFrame:
    """Per sweep value: the planner with the least median `metric` over the cases every planner
    solved, the runner-up, the ratio of their medians and a paired Wilcoxon test of the two
    on those cases (Holm-corrected over the sweep values). A planner that failed a case is not
    compared on it: `cases` says on how many of the sweep value's cases all succeeded."""
    rows = []
    for label, in_sweep in runs.groupby(runs["sweep"].fillna(""), sort=False):
        solved = in_sweep[in_sweep["success"]].set_index(CASE)
        planners = list(dict.fromkeys(in_sweep["planner"]))
        per_planner = {name: solved[solved["planner"] == name][metric] for name in planners}
        shared = None
        for values in per_planner.values():
            shared = values.index if shared is None else shared.intersection(values.index)
        total = in_sweep.set_index(CASE).index.unique()
        row = {**sweep_axes(label), "cases": len(shared) if shared is not None else 0,
               "of": len(total)}
        if len(planners) < 2 or shared is None or len(shared) == 0:
            rows.append(row)
            continue
        medians = {name: float(values.loc[shared].median())
                   for name, values in per_planner.items()}
        ranked = sorted(medians, key=medians.get)
        winner, second = ranked[0], ranked[1]
        test = stats.wilcoxon(per_planner[second].loc[shared].to_numpy(dtype=float),
                              per_planner[winner].loc[shared].to_numpy(dtype=float))
        row.update({"winner": winner, "winner median": medians[winner], "runner-up": second,
                    "runner-up median": medians[second],
                    "ratio": medians[second] / medians[winner] if medians[winner] > 0
                    else math.inf, "p": test.p})
        rows.append(row)
    table = pd.DataFrame(rows)
    if "p" in table:
        tested = table["p"].notna()
        table.loc[tested, "p (Holm)"] = stats.holm(table.loc[tested, "p"].tolist())
    return table


def lazy_speedup(runs: pd.DataFrame) -> pd.DataFrame:
    """Eager MP-A*'s planning time over lazy MP-A*'s, per sweep variant, at equal cost: over
    the cases (world, query, repetition) both answered (exact, or approximate at a budget
    stop, with a trajectory the checker accepts), the share where both
    returned the same cost (relative 1e-6; lazy with the lwa rule should always), and over
    those the median ratio of their times with a bootstrap 95 % interval and its range.
    `exact` is the share of cases both solved exactly, `approximate` the answered cases with
    an approximate answer among the two. Empty without one planner of each type."""
    eager = runs[runs["planner_type"] == "eager_mp_astar"]
    lazy = runs[runs["planner_type"] == "lazy_mp_astar"]
    if eager["planner"].nunique() != 1 or lazy["planner"].nunique() != 1:
        return pd.DataFrame()
    rows = []
    for label in dict.fromkeys(runs["sweep"].fillna("")):
        left, right = _aligned(eager[eager["sweep"].fillna("") == label],
                               lazy[lazy["sweep"].fillna("") == label])
        both = answered(left).to_numpy() & answered(right).to_numpy()
        exact = left["success"].to_numpy() & right["success"].to_numpy()
        c_eager = left["cost"].to_numpy(dtype=float)[both]
        c_lazy = right["cost"].to_numpy(dtype=float)[both]
        equal = np.abs(c_eager - c_lazy) <= 1e-6 * np.maximum(1.0, np.abs(c_eager))
        if not equal.any():
            continue
        t_eager = left["planning_time_ms"].to_numpy(dtype=float)[both][equal]
        t_lazy = right["planning_time_ms"].to_numpy(dtype=float)[both][equal]
        ratio = t_eager / t_lazy
        rows.append({"sweep": label, **sweep_axes(label), "cases": int(equal.sum()),
                     "exact": stats.wilson(int(exact.sum()), len(left)),
                     "approximate": int((both & ~exact).sum()),
                     "eager T (ms)": stats.bootstrap(t_eager, np.median),
                     "lazy T (ms)": stats.bootstrap(t_lazy, np.median),
                     "speedup": stats.bootstrap(ratio, np.median),
                     "min speedup": float(ratio.min()), "max speedup": float(ratio.max()),
                     "equal cost": float(equal.mean())})
    return pd.DataFrame(rows)
