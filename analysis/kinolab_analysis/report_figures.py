"""The report's figures and 3D views: over all runs, of single cases, of the lazy regime
and of the planners' anytime progress, each saved as PNG and SVG."""

from __future__ import annotations

import base64
import io
import math
import re
import sqlite3
from pathlib import Path

import jinja2
import matplotlib.pyplot as plt
import pandas as pd

from . import files, paper, plots, tables, view
from .data import Results, load
from .report_page import Figure, Report, View


def _save(figure: plt.Figure, report: Report, name: str, title: str, caption: str) -> None:
    directory = files.directory(report.out / "figures")
    for form, options in (("svg", {}), ("png", {"dpi": 110})):
        buffer = io.BytesIO()
        figure.savefig(buffer, format=form, **options)
        files.write_bytes(directory / f"{name}.{form}", buffer.getvalue())
    plt.close(figure)
    report.figures.append(Figure(name, title, caption,
                                 base64.b64encode(buffer.getvalue()).decode("ascii")))


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


def lazy_regime(report: Report, results: Results, directory: Path) -> str:
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
    files.write_text(report.out / name, page)
    report.views.append(View(
        f"{world.label} in 3D", f"Queries {', '.join(map(str, queries))}: the obstacles, every "
        "planner's stored trajectory in its colour of the figures, search tree (partial, full, "
        "certified and rejected edges in the search-tree figure's colours; a dense tree thinned, "
        "its legend says how far) and flight (replayed with its known map growing); start: black "
        "ball, goal: grey diamond; drag to orbit, right-drag to pan, wheel to zoom, a checkbox "
        "per layer.", name,
        jinja2.utils.markupsafe.Markup(view.iframe(page, world.label))))


def summary_figures(report: Report, results, sampling_csv: Path | None,
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


def case_figures(report: Report, results, out: Path) -> None:
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
        files.write_bytes(files.directory(out / "figures") / f"{name}.gif", gif)
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


def progress_figures(report: Report, results: Results) -> None:
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
