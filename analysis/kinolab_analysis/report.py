"""`kinolab report`: a results database (or several) into a self-contained HTML report,
figures as PNG and SVG, tables as Markdown and LaTeX, and a summary on the terminal."""

from __future__ import annotations

import base64
import html
import io
import math
import re
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path

import jinja2
import yaml
import matplotlib.pyplot as plt
import pandas as pd

from . import paper, plots, stats, tables, view
from .data import Results, load

TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>kinolab report: {{ name }}</title>
<style>
body { font-family: sans-serif; max-width: 1600px; margin: 2em auto; padding: 0 1.5em;
       color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.85em; }
th { vertical-align: bottom; }
iframe.view3d { width: 100%; height: 620px; border: 1px solid #ccc; box-sizing: border-box; }
th, td { border-bottom: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
th { border-bottom: 2px solid #444; }
img { max-width: 100%; }
.note { color: #555; font-size: 0.9em; }
.wide { overflow-x: auto; max-width: 100%; }
.parts { display: flex; flex-wrap: wrap; align-items: flex-start; gap: 0 3em; }
.part { min-width: 0; max-width: 100%; }
.ci { color: #666; font-size: 0.85em; white-space: nowrap; }
.warning { background: #fff3cd; border-left: 4px solid #d39e00; padding: 0.5em 0.8em; }
dl { display: grid; grid-template-columns: max-content auto; gap: 0.2em 1em; font-size: 0.85em; }
dt { font-weight: bold; }
</style></head>
<body data-figures="{{ figures|length }}">
<h1>kinolab report: {{ name }}</h1>
<p class="note">{{ databases }} &middot; config {{ meta.get('config_hash', '?') }} &middot;
written by kinolab {{ meta.get('provenance.kinolab_version', '?') }}</p>

{#- A table (whole, or in parts each with its heading) and its notes: the metrics undefined
    for its runs, and why. -#}
{% macro show(name) -%}
{{ tables[name] }}
{% for note in notes.get(name, []) %}<p class="note">{{ note }}</p>
{% endfor %}
{%- endmacro %}
{% for warning in warnings %}<p class="warning">{{ warning }}</p>
{% endfor %}
<h2>Experiment and provenance</h2>
<dl>{% for key, value in provenance %}<dt>{{ key }}</dt><dd>{{ value }}</dd>{% endfor %}</dl>

{% if 'worlds' in tables %}
<h2>Worlds and queries</h2>
<p class="note">Per world: the queries, the share whose straight line from start to goal is
blocked for the planners' body (Wilson 95 %), and the median straight-line length.</p>
{{ tables['worlds'] }}
{% endif %}

<h2>Timing protocol</h2>
<p class="note">{{ timing_protocol }}</p>
{% if 'timing' in tables %}{{ tables['timing'] }}{% endif %}

<h2>Runs by status</h2>
<p class="note">Every run is counted: failures, crashes and timeouts included. Success =
exact status and accepted by the independent checker, in every table and figure; approximate
answers, timeouts and failures are counted apart.</p>
{{ tables['status_counts'] }}
{% if 'stale' in tables %}
<h3>Runs of an earlier configuration (not reported)</h3>
<p class="note">Stored in this directory by an earlier configuration of the experiment (a
planner's parameters changed, then <code>--resume</code>): kept in the file, counted here, and
pooled into no other table or figure.</p>
{{ tables['stale'] }}
{% endif %}
{% if 'failure_reasons' in tables %}
<h3>Why runs did not succeed</h3>
<p class="note">Per planner and status, the runs' messages grouped (numbers read as #), with
one in full: a planner that never ran on a query says why (an invalid start for its own
clearance margin, a budget, an exhausted search).</p>
{{ tables['failure_reasons'] }}
{% endif %}

{% if 'paper_table1' in tables %}
<h2>The paper's Table I beside kinolab (sampling study)</h2>
<p class="note">alpha: share of useful samples; L: mean nearest-neighbour distance of
primitive endpoints; p: one-sample Wilcoxon test over the study's initial states against
the paper's figure.</p>
{{ tables['paper_table1'] }}
{% endif %}
{% if 'lazy_regime' in tables %}
<h2>Where lazy pays off</h2>
<p class="note">Eager MP-A*'s planning time over lazy MP-A*'s on the same cases, per swept
value (this experiment's sweep and the lazy-regime experiments beside it{{ regime_sources }}):
over the cases both answered (exact, or approximate at the same budget), the share with the
same cost (lazy with the lwa rule is exact), and over those the median ratio with a
bootstrap 95 % interval and its range. The figures "Lazy speedup: ..." below plot
each sweep, the heat map two at once{{ paper_speedup }}.</p>
{{ tables['lazy_regime'] }}
{% endif %}

{% if 'sampling_readings' in tables %}
<h2>Table I under every reading</h2>
<p>{{ readings_verdict }}</p>
<p class="note">The figure "Table I under every reading" below shows each; the table has one
row per reading (M, distance, propagation, pooling, threshold).</p>
<details><summary>every reading</summary>{{ tables['sampling_readings'] }}</details>
{% endif %}

{% if 'paper_table2' in tables %}
<h2>The paper's Table II beside kinolab</h2>
<p class="note">Medians with bootstrap 95 % intervals: T and N over the runs that returned a
trajectory the checker accepts (answered: exact, or approximate at a budget stop), D (the
distance from the trajectory's closest point, the best node of a budget stop, to the goal)
over all runs; T is the warm planning time (see the timing protocol); one block per sweep
variant and world. Only a variant run in <b>the paper's setting</b> (declared in the
experiment's <code>reproduces: {setting: [...]}</code> and checked: its searches stopped at
the paper's expansion cap) is a reproduction, and only there does p test kinolab's values
against the paper's figure (two-sided one-sample Wilcoxon). Elsewhere the figures are shown
for orientation, without tests: the paper's numbers come from another setting. Rows as the experiment's <code>reproduces:</code> maps them: {{ paper_rows }}.</p>
{{ tables['paper_table2'] }}
{% endif %}

<h2>Per planner</h2>
<p class="note">Per planner its time budget per plan (the experiment's
<code>budget.time</code>, or "own" where the planner's entry sets its own
<code>time_limit</code>), its runs by outcome with the success rate's Wilson 95 % interval,
then per group of metrics the medians over its successful runs with bootstrap 95 % intervals.
"cost (own objective)" is each planner's own objective: it compares only between planners of
one objective. A metric undefined for a trajectory (the jerk of piecewise-constant
acceleration) reads "undefined", with the reason under its table.</p>
{{ show('summary') }}

{% if 'which_planner' in tables %}
<h2>Which planner when</h2>
<p class="note">Per world, every planner: its runs by outcome, success with Wilson 95 %
intervals; over its successful runs the median planning time, trajectory duration,
acceleration integral (integral of |a|^2, defined for every trajectory) and clearance with
bootstrap 95 % intervals, all measured the same way for every planner by the independent
checker; each paired against {{ field_reference }} on the cases both ran (McNemar on success,
Wilcoxon signed-rank on each metric over cases both solved), p-values Holm-corrected over the
table. The figures "Time against quality" plot each world.</p>
{{ show('which_planner') }}
{% endif %}

<h2>Paired comparisons</h2>
<p class="note">Planners on the cases both ran (same world, query, repetition and sweep
value): McNemar (exact) on success, Wilcoxon signed-rank over cases both solved on the
metrics that mean the same for every planner ({{ paired_metrics }}) and on cost only between
two planners of one objective (never across planner families), with the matched-pairs
rank-biserial correlation as effect size (> 0: a larger); p-values Holm-corrected over the
whole table.</p>
{{ tables['paired'] }}

{% if 'compare' in tables %}
<h2>Compared with {{ compare_name }}</h2>
<p class="note">Each planner on the cases both result sets ran (A: this one, B: the other):
success rates and median planning times side by side, McNemar on success and Wilcoxon
signed-rank on planning time, and on cost where A's and B's objectives are equal, over cases
both solved (Holm-corrected).</p>
{{ tables['compare'] }}
{% endif %}

{% for view in views %}
<h2>{{ view.title }}</h2>
<p class="note">{{ view.caption }} <a href="{{ view.file }}">Open it on its own page</a>.</p>
{{ view.frame }}
{% endfor %}

{% for figure in figures %}
<h2>{{ figure.title }}</h2>
<p class="note">{{ figure.caption }}</p>
<img src="data:{{ figure.mime }};base64,{{ figure.png }}" alt="{{ figure.title }}" data-figure="{{ figure.name }}">
{% endfor %}

<h2>Means per planner</h2>
<p class="note">Means of successful runs with bootstrap 95 % intervals.</p>
{{ show('means') }}
{% if 'statistics' in tables %}
<h2>Planner statistics</h2>
<p class="note">Every statistic each planner declares (kinolab list metrics), median over all
its runs with bootstrap 95 % intervals; clock figures vary from run to run.</p>
{{ tables['statistics'] }}
{% endif %}
{% for key, title in [('per_world', 'Per world'), ('per_sampler', 'Per sampler'),
                      ('sweep', 'Per sweep value'), ('sweep_winners', 'Where each wins')] %}{% if key in tables %}
<h2>{{ title }}</h2>
{{ show(key) }}
{% endif %}{% endfor %}

<script>
// For headless checks: how many figures decoded.
window.addEventListener("load", () => {
  const images = [...document.querySelectorAll("img[data-figure]")];
  document.body.dataset.figuresLoaded = images.filter(i => i.complete && i.naturalWidth > 0).length;
});
</script>
</body></html>
"""


@dataclass
class Figure:
    name: str
    title: str
    caption: str
    png: str = ""  # base64 of the image
    mime: str = "image/png"


@dataclass
class View:
    """A 3D view (kinolab's viewer) inline in the report and as its own file."""
    title: str
    caption: str
    file: str
    frame: str  # the iframe, its page inline (markup, not escaped again)


@dataclass
class Report:
    out: Path
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    figures: list[Figure] = field(default_factory=list)
    views: list[View] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    # Under a table (by its name): the metrics undefined for its runs, and why.
    notes: dict[str, list[str]] = field(default_factory=dict)


def _parts(name: str, table: pd.DataFrame) -> str:
    """A report table as HTML: whole, or in SPLIT's parts, each with its heading and each row
    once (compare repeats its side-by-side columns on every test)."""
    if name not in SPLIT:
        return _html(table)
    heading, keys, first, groups = SPLIT[name]
    parts = tables.split(table, [key for key in keys if key in table], groups)
    return '<div class="parts">' + "".join(
        f'<div class="part"><h3>{html.escape(heading)}: {html.escape(group or first)}</h3>'
        + _html(part.drop_duplicates()) + "</div>" for group, part in parts.items()) + "</div>"


def _html(table: pd.DataFrame) -> str:
    """A table as HTML: cells as tables.text, an interval's bounds on a second line, headings
    that may break after an underscore (planning_time_ms), and a scrolling box should it
    still be wider than the page."""
    def cell(column):
        def formatted(value):
            text = html.escape(tables.text(value, column=column))
            if isinstance(value, stats.Interval) and " [" in text:
                estimate, bounds = text.split(" [", 1)
                return f'{estimate}<br><span class="ci">[{bounds}</span>'
            return text
        return formatted
    frame = table.copy()
    for column in frame.columns:
        frame[column] = frame[column].map(cell(column))
    frame.columns = [html.escape(tables.header(c)).replace("_", "_<wbr>") for c in frame.columns]
    return ('<div class="wide">' + frame.to_html(index=False, escape=False, border=0) +
            "</div>")


def _save(figure: plt.Figure, report: Report, name: str, title: str, caption: str) -> None:
    directory = report.out / "figures"
    directory.mkdir(parents=True, exist_ok=True)
    figure.savefig(directory / f"{name}.svg")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    (directory / f"{name}.png").write_bytes(buffer.getvalue())
    plt.close(figure)
    report.figures.append(Figure(name, title, caption,
                                 base64.b64encode(buffer.getvalue()).decode("ascii")))


def _summary_columns(summary: pd.DataFrame, statistic: str = "median") -> pd.DataFrame:
    """A tables.summary with its medians (or means) only, named by their metrics."""
    other = "mean " if statistic == "median" else "median "
    keep = [c for c in summary.columns if not c.startswith(other)]
    return summary[keep].rename(columns={c: c.replace(f"{statistic} ", "") for c in keep})


def _undefined_notes(report: Report, name: str, runs: pd.DataFrame) -> None:
    """The notes under a table: each metric of it undefined for some of its runs, and why."""
    if notes := tables.undefined_notes(runs, [str(c) for c in report.tables[name].columns]):
        report.notes[name] = notes


# Tables shown in parts (tables.split), each under "HEADING: GROUP", side by side where the
# page is wide enough and none wider than the page: name -> (heading, key columns, the name of
# the part of no group's columns, groups; None: tables.GROUPS). Their Markdown and LaTeX stay
# whole.
SPLIT = {"summary": ("Per planner", ["planner"], "runs", None),
         "means": ("Means per planner", ["planner"], "runs", None),
         "which_planner": ("Which planner when", ["world", "planner"], "runs", None),
         "paper_table2": ("Table II", ["variant", "world", "planner"], "runs",
                          {"planning time T": ["T"], "expansions N": ["N"],
                           "distance to goal D": ["D"]}),
         "lazy_regime": ("Where lazy pays off", ["experiment", "value"], "cases",
                         {"planning time and speedup": ["T", "speedup"]}),
         "compare": ("Compared", ["planner"], "tests",
                     {"success and planning time side by side": ["A", "B"]})}


def _slug(text: str) -> str:
    """A world's label as part of a file name ("forest (density=0.2)": forest_density=0.2)."""
    return re.sub(r"[^\w.=-]+", "_", text).strip("_")


def _tree_run(results: Results) -> pd.Series | None:
    """The run whose stored search tree the report draws: the first (by planner, then
    query) whose tree has partially evaluated edges, else the first with any tree."""
    runs = results.runs.sort_values(["planner", "query"])
    with_trees = []
    for database in runs["database"].unique():
        with sqlite3.connect(database) as db:
            with_trees += [row[0] for row in db.execute("SELECT run_hash FROM trees")]
    if not with_trees:
        return None
    candidates = runs[runs["run_hash"].isin(with_trees)]
    for _, run in candidates.iterrows():
        tree = results.tree(run["run_hash"])
        if tree is not None and (tree["state"] == "partial").any():
            return run
    return candidates.iloc[0]


def find_lazy_regime(directory: Path) -> list[Path]:
    """The lazy-regime result sets beside a results directory (DIR/lazy_regime/*/)."""
    return sorted(p.parent for p in directory.glob("lazy_regime/*/results.sqlite"))


def _lazy_regime(report: Report, results: Results, directory: Path) -> str:
    """The speedup table and figures: of this experiment when it sweeps eager and lazy,
    and of every lazy-regime experiment beside it (with the reproduced paper's speedup, when
    this experiment reproduces one). Returns where they came from."""
    reproduced = results.reproduces()
    reference = None
    if reproduced and math.isfinite(claimed := paper.load(reproduced[0]).speedup):
        reference = (f"the paper's {claimed:.2f}x", claimed)
    sets = [(results.meta.get("name", "this experiment"), results.runs)]
    for path in find_lazy_regime(directory):
        other = load(path)
        sets.append((other.meta.get("name", path.name), other.runs))
    parts = []
    for name, runs in sets:
        table = tables.lazy_speedup(runs)
        if table.empty or runs["sweep"].fillna("").nunique() < 2:
            continue
        if (figure := plots.lazy_speedup(table, name, reference)) is not None:
            heat_map = len([c for c in table.columns if c not in tables.SPEEDUP_COLUMNS]) >= 2
            _save(figure, report, f"lazy_speedup_{name}", f"Lazy speedup: {name}",
                  ("Median eager T / lazy T over the cases both answered at the same cost, per "
                   "pair of swept values (colour and label)." if heat_map else
                   "Median eager T / lazy T over the cases both answered at the same cost, "
                   "bootstrap 95 % interval and range; dashed: parity"
                   + (f"; dotted: {reference[0]}." if reference else ".")))
        parts.append(table.assign(experiment=name, value=table["sweep"].map(tables.sweep_name))[
            ["experiment", "value", *tables.SPEEDUP_COLUMNS[1:]]])
    if parts:
        report.tables["lazy_regime"] = pd.concat(parts, ignore_index=True)
    return ", ".join(name for name, _ in sets[1:])


def _view(report: Report, results, world, queries: list[int]) -> None:
    """The world in 3D with the queries' stored trajectories, trees and flights, when the
    database has its obstacle boxes (schema 5) and `kinolab report` gave the viewer."""
    template = view.template_path()
    if world.boxes is None or template is None:
        return
    page = view.page(view.scene(results, world, queries), template)
    name = f"view_{_slug(world.label)}.html"
    (report.out / name).write_text(page)
    report.views.append(View(
        f"{world.label} in 3D", f"Queries {', '.join(map(str, queries))}: the obstacles, every "
        "planner's stored trajectory in its colour of the figures, search tree (partial, full, "
        "certified and rejected edges in the search-tree figure's colours; a dense tree thinned, "
        "its legend says how far) and flight (replayed with its known map growing); start: black "
        "ball, goal: grey diamond; drag to orbit, right-drag to pan, wheel to zoom, a checkbox "
        "per layer.", name,
        jinja2.utils.markupsafe.Markup(view.iframe(page, world.label))))


def find_sampling_study(directory: Path) -> Path | None:
    found = sorted(directory.glob("sampling_study/*/summary.csv"))
    return found[0] if found else None


def _tables(report: Report, results, paths: list[Path], compare: Path | None,
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


def _summary_figures(report: Report, results, sampling_csv: Path | None,
                     readings: pd.DataFrame | None, readings_verdict: str) -> None:
    """The figures over all runs: time to solve, metrics, worlds, sweep, the sampling study."""
    runs = results.runs
    _save(plots.ecdf(runs), report, "ecdf_planning_time", "Time to solve",
          "ECDF of planning time per planner; every run but a success (exact and "
          "checker-valid) counts as never solved: approximate answers and timeouts too.")
    _save(plots.boxes(runs, tables.metrics(results.metrics,
                                           ("planning_time_ms", "expansions", "duration",
                                            "length", "acceleration_integral"))),
          report, "metrics", "Metrics per planner",
          "Box plots over successful runs (N is each planner's own count of expansions).")
    if runs["world"].nunique() > 1:
        _save(plots.per_world(runs), report, "per_world", "Success and planning time per world",
              "Success rate (exact and checker-valid; approximate answers and timeouts are not "
              "successes; Wilson 95 %) and median planning time per world.")
    if "which_planner" in report.tables:
        for world in dict.fromkeys(runs["world"]):
            if (figure := plots.pareto(runs, world)) is not None:
                _save(figure, report, f"pareto_{_slug(world)}", f"Time against quality: {world}",
                      "Median planning time against median trajectory duration of the "
                      "successful runs (bars: interquartile ranges), success (exact and "
                      "checker-valid) in the legend; "
                      "dashed: the Pareto front (no planner both faster and shorter).")
    if (figure := plots.sweep(runs)) is not None:
        _save(figure, report, "sweep", "Planning time over the sweep", "Median planning time "
              "of the successful runs (bootstrap 95 %) against the swept value.")
    if (figure := plots.sweep_success(runs)) is not None:
        _save(figure, report, "sweep_success", "Success over the sweep",
              "Success rate (exact and checker-valid; approximate answers and timeouts are "
              "not successes; Wilson 95 %) per planner against the swept value.")
    if (figure := plots.success_grid(runs)) is not None:
        _save(figure, report, "success_grid", "Success over the sweep's dimensions",
              "Success rate (exact and checker-valid, Wilson 95 %) against the sweep's first "
              "dimension of three values or "
              "more, a line per planner and value of the next, a panel per value of the third "
              "(flights: over density, per planner and speed, a panel per camera range).")
    if "sweep_winners" in report.tables and (figure := plots.sweep_winners(
            report.tables["sweep_winners"], colours=plots.planner_colours(runs["planner"]))
            ) is not None:
        _save(figure, report, "sweep_winners", "Where each wins, by sweep value",
              "Per sweep value, the planner with the least median planning time over the "
              "cases every planner solved, its median, the runner-up and the ratio of the "
              "runner-up's median to it. Hatched: the two are not told apart (paired Wilcoxon, "
              "Holm over the sweep values, p >= 0.05).")
    if sampling_csv is not None:
        _save(plots.sampling_study(report.tables["paper_table1"]), report, "sampling_study",
              "Sampling study (Table I)", "alpha and L per sampler, kinolab beside the paper.")
    if readings is not None:
        _save(plots.sampling_readings(readings, paper.load(results.reproduces()[0]).samplers),
              report, "sampling_readings",
              "Table I under every reading: alpha and L",
              "Per reading (distance, propagation, pooling): alpha against the threshold for "
              "each sampler and M, and L against M; stars and dashed lines: the paper's "
              "figures. With one Euler step the end position p + v tau does not depend on the "
              "control, so position-only Euler readings have alpha = L = 0. " + readings_verdict)


def _case_figures(report: Report, results, out: Path) -> None:
    """The figures of single cases: per world its 3D view, trajectories, speeds and known
    maps; a flight animation per planner; replan times; the search tree."""
    runs = results.runs
    reproduced = results.reproduces()
    tree_run = _tree_run(results)
    for world in results.worlds.values():
        # The query most planners solved, the first on ties.
        cases = runs[runs["world_hash"] == world.world_hash].groupby("query")["success"].sum()
        if cases.empty:
            continue
        query = int(cases.idxmax())
        _view(report, results, world, [query] + (
            [int(tree_run["query"])] if tree_run is not None
            and tree_run["world_hash"] == world.world_hash and tree_run["query"] != query else []))
        if (figure := plots.trajectories(results, world, query)) is not None:
            _save(figure, report, f"trajectories_{_slug(world.label)}",
                  f"Trajectories in {world.label}",
                  f"Query {query}: every planner's trajectory (dashed: not a success) from "
                  "above and from the side; start: black circle, goal: grey star.")
        if "time_to_goal" in runs.columns and (
                figure := plots.speeds(results, world, query)) is not None:
            _save(figure, report, f"speeds_{_slug(world.label)}",
                  f"Speed and clearance in {world.label}",
                  f"Query {query}: each planner's flight, its speed and its clearance to the "
                  "ground truth (the ESDF less the body's radius) against time.")
        if (figure := plots.known_maps(results, world, query)) is not None:
            _save(figure, report, f"known_maps_{_slug(world.label)}",
                  f"Known maps in {world.label}",
                  f"Query {query}: what each flight had seen at its end, from above in the "
                  "band of its heights (black: obstacle, white: known free, grey: unknown), "
                  "and its flown path.")
    # One animated flight per planner: the first stored map of each.
    animated = set()
    for _, run in runs.sort_values(["planner", "query"]).iterrows():
        if run["planner"] in animated or (gif := plots.flight_animation(results, run)) is None:
            continue
        animated.add(run["planner"])
        name = f"flight_{run['planner']}"
        (out / "figures").mkdir(parents=True, exist_ok=True)
        (out / "figures" / f"{name}.gif").write_bytes(gif)
        report.figures.append(Figure(name, f"Flight of {run['planner']} (animation)",
                                     f"Query {run['query']} in {run['world']}: the known map "
                                     "growing from above (black: obstacle, white: known free, "
                                     "grey: unknown) and the path flown so far.",
                                     base64.b64encode(gif).decode("ascii"), "image/gif"))
    if (figure := plots.replan_times(results.replans(),
                                     plots.planner_colours(runs["planner"]))) is not None:
        _save(figure, report, "replan_times", "Replan times",
              "Every replan of every flight: its planning time, per planner.")
    if (run := tree_run) is not None:
        world = results.worlds.get(run["world_hash"])
        if (figure := plots.search_tree(results, run, world)) is not None:
            _save(figure, report, "search_tree", f"Search tree of {run['planner']}"
                  + (" (the paper's Fig. 6)" if reproduced else ""),
                  "Edges only partially evaluated (queued on their lower bound) and fully "
                  "evaluated ones, in two colours; the trajectory in black.")


def _write_page(report: Report, results, out: Path, compare_name: str,
                readings_verdict: str, regime_sources: str) -> None:
    """The tables as Markdown and LaTeX, and index.html."""
    runs = results.runs
    reproduced = results.reproduces()
    table_directory = out / "tables"
    table_directory.mkdir(exist_ok=True)
    for name, table in report.tables.items():
        (table_directory / f"{name}.md").write_text(tables.to_markdown(table))
        (table_directory / f"{name}.tex").write_text(
            tables.to_latex(table, f"{results.meta.get('name', '')}: {name.replace('_', ' ')}"))

    provenance = [("experiment", results.meta.get("name", "?")),
                  ("source", results.meta.get("source", "?")),
                  ("runs stored / planned", f"{len(runs)} / {results.meta.get('runs_planned', '?')}"),
                  ("merged from", results.meta.get("merged_from", "one database")),
                  ("started", results.meta.get("started_at", "?")),
                  ("machine", results.meta.get("machine", "not recorded")),
                  ("finished", results.meta.get("finished_at", "not finished"))]
    provenance += [(k[len("provenance."):], v) for k, v in sorted(results.meta.items())
                   if k.startswith("provenance.")]
    html = jinja2.Environment(autoescape=True).from_string(TEMPLATE).render(
        name=results.meta.get("name", "results"), meta=results.meta,
        databases=", ".join(str(p) for p in results.paths), provenance=provenance,
        tables={name: jinja2.utils.markupsafe.Markup(_parts(name, table))
                for name, table in report.tables.items()},
        figures=report.figures, views=report.views, warnings=report.warnings,
        notes=report.notes, paired_metrics=", ".join(
            metric for metric in tables.comparable(results.metrics, tables.PAIRED)
            if metric in runs and metric != "cost"),
        compare_name=compare_name,
        timing_protocol=timing_protocol(results.meta), readings_verdict=readings_verdict,
        regime_sources=f": {regime_sources}" if regime_sources else "",
        field_reference=tables.reference_planner(runs) if not runs.empty else "",
        paper_rows=", ".join(f"{row} = {planner}" for planner, row in reproduced[1].items())
        if reproduced else "", paper_speedup=_paper_speedup(reproduced))
    (out / "index.html").write_text(html)


def _paper_speedup(reproduced: tuple[str, dict[str, str]] | None) -> str:
    """The reproduced paper's speedup claim as a clause, or nothing."""
    if not reproduced:
        return ""
    claimed = paper.load(reproduced[0])
    if not math.isfinite(claimed.speedup):
        return ""
    return f"; the paper's figure is {claimed.speedup:.2f}x ({claimed.title})"

def _progress_figures(report: Report, results: Results) -> None:
    """One figure per declared progress series (the planners' anytime progress)."""
    for name, declared in results.series().groupby("name", sort=True):
        unit = str(declared["unit"].iloc[0] or "")
        figure = plots.anytime(results.runs, results.progress, name, unit)
        if figure is None:
            continue
        own = name not in tables.comparable(results.metrics, (name,))
        _save(figure, report, f"progress_{name}",
              f"Anytime progress: {name}" + (" (own objective)" if own else ""),
              f"{declared['doc'].iloc[0]}" + (
                  ": each planner's own quantity, to be set side by side only between planners "
                  "of one objective" if own else "") +
              ". Per planner, the median (line) and interquartile "
              "range (band) over all its runs, each read as a step function of its planning "
              "time: before a run's first value it counts as infinite (unsolved), after its "
              "last one it keeps that value, so no run drops out. Below: the share of runs "
              "with a value. Times are the last timed plan's (a clock figure).")


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
    sampling_csv, readings, readings_verdict, compare_name = _tables(
        report, results, paths, compare, sampling_csv)
    out.mkdir(parents=True, exist_ok=True)
    _summary_figures(report, results, sampling_csv, readings, readings_verdict)
    _case_figures(report, results, out)
    regime_sources = _lazy_regime(report, results,
                                  paths[0] if paths[0].is_dir() else paths[0].parent)
    _progress_figures(report, results)
    _write_page(report, results, out, compare_name, readings_verdict, regime_sources)
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


def timing_protocol(meta: dict[str, str]) -> str:
    """The experiment's timing protocol in words, from its stored configuration."""
    config = yaml.safe_load(meta.get("config", "").split("\n--- # variants")[0]) or {}
    if int(meta.get("schema_version", "1")) < 3:
        return ("Cold: each run's planning time is its one plan in a fresh worker process "
                "(written before the timing protocol was recorded).")
    if config.get("kind") == "flight":
        timings = {((config.get("flight") or {}).get("timing") or "real_time")}
        # The sweep's variants are listed by label ("- flight.timing=deterministic, ...").
        variants = meta.get("config", "").partition("\n--- # variants")[2]
        timings |= set(re.findall(r"timing=(real_time|deterministic)", variants))
        modes = {
            "real_time": "real time (a plan measured past its latency is discarded as late, "
                         "so a flight whose plans come near the latency need not repeat)",
            "deterministic": "deterministic (every plan is taken as if on time, so a flight "
                             "repeats bit for bit)"}
        return ("Flights: each replan is timed once inside its flight, around the planner's "
                "own call; planning_time_ms (T) is a flight's median replan time, and the "
                "flight metrics give its 95th percentile and maximum. A plan starts from the "
                "committed state its latency after its frame; timing: "
                + "; ".join(modes.get(mode, mode) for mode in sorted(timings))
                + (". The sweep runs both: its variants are reported apart."
                   if len(timings) > 1 else "."))
    protocol = config.get("timing") or {}
    warmup, repeats = int(protocol.get("warmup", 1)), int(protocol.get("repeats", 3))
    return (f"Warm: in each run's worker, {warmup} discarded plan(s) of the run's query, then "
            f"{repeats} timed plan(s); planning_time_ms (T) is the median of the timed plans, "
            "the fastest is kept as planning_time_min_ms and the first plan of the fresh "
            "process (cold caches, page faults on first touch) as planning_time_cold_ms. Warm "
            "is the figure to set beside a planner running in a long-lived process, as on a "
            "vehicle; the cold time is the worst case of a planner started per query. Only "
            "the planner's own call is timed (no checking, no figures); the run's other "
            "metrics are those of the last plan, which repeats the first (planners are "
            "deterministic in their seed).")


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
