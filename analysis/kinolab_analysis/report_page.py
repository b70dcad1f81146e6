"""The report's contents (Report, its Figures and Views) and its page: the HTML template,
the tables as HTML, Markdown and LaTeX, and the timing protocol in words."""

from __future__ import annotations

import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import jinja2
import yaml
import pandas as pd

from . import files, paper, stats, tables

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
                      ('sweep', 'Per sweep value'), ('sweep_winners', 'Where each wins'),
                      ('back_ends', 'Front end x back end')] %}{% if key in tables %}
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


def write_page(report: Report, results, out: Path, compare_name: str,
               readings_verdict: str, regime_sources: str) -> None:
    """The tables as Markdown and LaTeX, and index.html."""
    runs = results.runs
    reproduced = results.reproduces()
    table_directory = files.directory(out / "tables")
    for name, table in report.tables.items():
        files.write_text(table_directory / f"{name}.md", tables.to_markdown(table))
        files.write_text(
            table_directory / f"{name}.tex", tables.to_latex(table, f"{results.meta.get('name', '')}: {name.replace('_', ' ')}"))

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
    files.write_text(out / "index.html", html)


def _paper_speedup(reproduced: tuple[str, dict[str, str]] | None) -> str:
    """The reproduced paper's speedup claim as a clause, or nothing."""
    if not reproduced:
        return ""
    claimed = paper.load(reproduced[0])
    if not math.isfinite(claimed.speedup):
        return ""
    return f"; the paper's figure is {claimed.speedup:.2f}x ({claimed.title})"


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
