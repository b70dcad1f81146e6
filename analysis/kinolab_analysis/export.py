"""`kinolab export DIR --format ompl OUT`: a results database as OMPL benchmark logs, which
OMPL's `ompl_benchmark_statistics` turns into the database Planner Arena reads.

One log per (world, sweep variant), an OMPL "experiment": its runs are every query and
repetition of each planner in that variant (a run the sweep does not change, stored once by
the runner, appears in every variant it belongs to), with the query as a run property so
that cases stay identifiable. The format (OMPL's "Benchmark log file format"):

    kinolab version 0.1.0
    Experiment <name>
    <k> experiment properties           (name TYPE = value)
    Running on <host>
    Starting at <date>
    <<<|  the experiment's configuration  |>>>
    <<<|  the CPU  |>>>
    <seed> is the random seed
    <t> seconds per run
    <m> MB per run
    <n> runs per planner
    <s> seconds spent to collect the data
    1 enum type
    status|exact|approximate|...
    <p> planners
    <planner id>
    <c> common properties               (name TYPE = value: type, sampler, parameters)
    <q> properties for each run         (name TYPE: BOOLEAN, INTEGER, REAL, ENUM)
    <r> runs
    v1; v2; ...; vq;                    (empty for none)
    <k> progress properties for each run  (when the planner's runs have progress series:
    time REAL                              time in seconds, then each series, REAL)
    <r> runs
    t,v1,...,vk,;t,v1,...,vk,;...       (per run, one sample per time any series changed)
    .
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from . import files, stats
from .data import Results, load

# kinolab's metrics under the names OMPL's benchmarks and Planner Arena use.
OMPL_NAMES = {"planning_time_ms": ("time", "REAL"), "length": ("solution length", "REAL"),
              "min_clearance": ("solution clearance", "REAL"),
              "distance_to_goal": ("solution difference", "REAL"),
              "peak_memory_mb": ("memory", "REAL")}
TYPES = {"real": "REAL", "integer": "INTEGER", "boolean": "BOOLEAN"}
# Identity columns of the runs table that are not measurements.
IDENTITY = {"run_hash", "variant", "sweep", "world", "world_hash", "planner", "planner_type",
            "sampler", "seed", "database", "paper", "status", "message", "started_at"}


def _name(text: str) -> str:
    """A property or planner name OMPL's parser keeps whole (no whitespace, no ';')."""
    return re.sub(r"[\s;|]+", "_", str(text)).strip("_") or "unnamed"


def _config(results: Results) -> dict:
    return yaml.safe_load(results.meta.get("config", "").split("\n--- # variants")[0]) or {}


def _properties(results: Results, runs: pd.DataFrame) -> list[tuple[str, str, str]]:
    """(column, OMPL name, OMPL type) of every numeric measurement the runs carry."""
    declared = {}
    if not results.metrics.empty:
        for _, row in results.metrics.iterrows():
            declared.setdefault(row["name"], row["type"])
    properties = [("status", "status", "ENUM"), ("success", "solved", "BOOLEAN"),
                  ("approximate", "approximate solution", "BOOLEAN"),
                  ("checker_valid", "correct solution", "BOOLEAN"),
                  ("query", "query", "INTEGER"), ("repetition", "repetition", "INTEGER")]
    taken = {column for column, _, _ in properties}
    for column in runs.columns:
        if column in taken or column in IDENTITY:
            continue
        kind = declared.get(column, "real")
        if kind not in TYPES or not pd.api.types.is_numeric_dtype(runs[column]):
            continue
        if runs[column].isna().all():
            continue
        # A plugin's statistic may be named anything: as a column of OMPL's SQL table it
        # must be an identifier.
        name, ompl_type = OMPL_NAMES.get(column, (re.sub(r"\W", "_", column), TYPES[kind]))
        properties.append((column, name, ompl_type))
    return properties


def _value(value, ompl_type: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    if ompl_type == "BOOLEAN":
        return "1" if bool(value) else "0"
    if ompl_type in ("INTEGER", "ENUM"):
        return str(int(value))
    return repr(float(value))


def _progress(samples: pd.DataFrame, runs: list[str]) -> list[str]:
    """The progress block of a planner's runs (none when they have no series): per run, a
    sample at every time one of its series changed, each series read as a step function."""
    samples = samples[samples["run_hash"].isin(runs)]
    names = sorted(samples["name"].unique())
    if not names:
        return []
    lines = [f"{len(names) + 1} progress properties for each run", "time REAL",
             *[f"{_name(name)} REAL" for name in names], f"{len(runs)} runs"]
    for run in runs:
        of_run = samples[samples["run_hash"] == run]
        times = np.unique(of_run["time_ms"].to_numpy(dtype=float))
        values = [stats.step_values(of_run[of_run["name"] == name], [run], times)[0]
                  for name in names]
        lines.append("".join(
            ",".join([repr(time / 1000.0), *[_value(series[i], "REAL") for series in values]])
            + ",;" for i, time in enumerate(times)))
    return lines


def _log(results: Results, runs: pd.DataFrame, variant: str, world: str,
         statuses: list[str]) -> str:
    config = _config(results)
    budget = config.get("budget", {}) or {}
    meta = results.meta
    runs = runs.assign(status=runs["status"].map({s: i for i, s in enumerate(statuses)}),
                       approximate=(runs["status"] == "approximate"))
    if "planning_time_ms" in runs:
        runs["planning_time_ms"] = runs["planning_time_ms"] / 1000.0  # OMPL's time is seconds
    properties = _properties(results, runs)
    name = ".".join([meta.get("name", "kinolab"), world] + ([variant] if variant else []))
    experiment_properties = [("world VARCHAR(512)", world),
                             ("variant VARCHAR(512)", variant or "-"),
                             ("queries INTEGER", str(runs["query"].nunique())),
                             ("git_commit VARCHAR(512)", meta.get("provenance.git_commit", "?"))]
    lines = [f"kinolab version {meta.get('provenance.kinolab_version', '0')}",
             f"Experiment {_name(name)}",
             f"{len(experiment_properties)} experiment properties",
             *[f"{key} = {_name(value)}" for key, value in experiment_properties],
             f"Running on {_name(meta.get('provenance.host', 'unknown'))}",
             f"Starting at {meta.get('started_at', '?')}",
             "<<<|", meta.get("config", "").replace("\n|>>>", "\n |>>>").rstrip("\n"), "|>>>",
             "<<<|", meta.get("provenance.cpu", "unknown"), "|>>>",
             f"{int(config.get('seed', 0))} is the random seed",
             f"{float(budget.get('time', 0) or 0)!r} seconds per run",
             f"{float(budget.get('memory_mb', 0) or 0)!r} MB per run",
             f"{int(runs.groupby('planner').size().max())} runs per planner",
             f"{float(runs.get('wall_time_ms', pd.Series(dtype=float)).sum()) / 1000.0!r} "
             "seconds spent to collect the data",
             "1 enum types",
             "|".join(["status", *statuses]),
             f"{runs['planner'].nunique()} planners"]
    for planner, chosen in runs.groupby("planner", sort=True):
        chosen = chosen.sort_values(["query", "repetition"])
        first = chosen.iloc[0]
        # Its type, sampler and the parameters the experiment sets (before any sweep).
        common = [("type VARCHAR(512)", first["planner_type"]),
                  ("sampler VARCHAR(512)", first.get("sampler") or "-")]
        for entry in config.get("planners", []) or []:
            if isinstance(entry, dict) and entry.get("id") == planner:
                common += [(f"{_name(key)} VARCHAR(512)", value)
                           for key, value in sorted((entry.get("params") or {}).items())]
        lines += [_name(planner), f"{len(common)} common properties",
                  *[f"{key} = {_name(value)}" for key, value in common],
                  f"{len(properties)} properties for each run",
                  *[f"{name} {ompl_type}" for _, name, ompl_type in properties],
                  f"{len(chosen)} runs"]
        columns = [chosen[column].to_numpy(dtype=object) for column, _, _ in properties]
        for index in range(len(chosen)):
            lines.append("".join(f"{_value(values[index], ompl_type)}; "
                                 for values, (_, _, ompl_type) in zip(columns, properties)))
        lines += _progress(results.progress, chosen["run_hash"].tolist())
        lines.append(".")
    return "\n".join(lines) + "\n"


def export_ompl(paths: list[Path], out: Path) -> list[Path]:
    """Writes one OMPL benchmark log per (variant, world) into `out`; returns their paths."""
    results = load(paths)
    runs = results.runs.copy()
    if runs.empty:
        raise ValueError(f"{paths[0]}: the database holds no runs")
    if "time_to_goal" in runs.columns:
        raise ValueError(f"{paths[0]}: a flight experiment; OMPL's benchmark format describes "
                         "planning runs")
    runs["sweep"] = runs["sweep"].fillna("") if "sweep" in runs else ""
    variants = runs.drop_duplicates("variant").sort_values("variant")[["variant", "sweep"]]
    # One status enum for every log: ompl_benchmark_statistics keeps the first log's.
    statuses = sorted(runs["status"].dropna().unique())
    files.directory(out)
    written = []
    for world, in_world in runs.groupby("world", sort=True):
        for variant, sweep in variants.itertuples(index=False):
            # A run the sweep does not change is stored once, in the first variant that has
            # it: a planner without runs of its own in this variant ran there unchanged.
            parts = []
            for _, of_planner in in_world.groupby("planner"):
                earlier = of_planner[of_planner["variant"] <= variant]
                if not earlier.empty:
                    parts.append(earlier[earlier["variant"] == earlier["variant"].max()])
            if not parts:
                continue
            path = out / (_name(f"{world}_{sweep}" if sweep else world) + ".log")
            files.write_text(path, _log(results, pd.concat(parts), sweep, world, statuses))
            written.append(path)
    return written
