"""Loading results databases written by `kinolab run` into tidy frames."""

from __future__ import annotations

import io
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from . import stats, tables

# The results database layout this package reads (meta `schema_version`); version 1
# databases (written before the schema was declared) are upgraded in memory by `load`;
# version 2 lacks the timing protocol's and the query's columns (version 3), read as missing;
# version 4 added the flights table, version 5 the worlds' obstacle boxes (for the 3D view),
# version 6 the progress table (anytime progress series; empty in older databases), version 7
# the runs' load_average and the meta table's machine and cores (missing in older ones),
# version 8 the checker's evaluation of every trajectory (with `undefined`), the runs'
# objective and time limit, the metrics' direction and comparability, and the planned table
# (older ones: cost is an own objective per planner type, every other result metric compares,
# and every run is current).
SCHEMA_VERSION = 8
# Where the stored configuration's variants (one line each) begin, after the file's YAML.
VARIANTS = "\n--- # variants"

# A stored search tree's edge states (the trees table's `state`), each with the colour every
# figure and the 3D viewer draw it in. The names are kinolab's (SearchTreeEdge::State;
# `kinolab list metrics --json` prints them, and tests/analysis holds this and viewer.js to
# them).
EDGE_COLOURS = {"partial": "#f4a261", "full": "#2a9d8f", "certified": "#264653",
                "rejected": "#e63946"}
EDGE_STATES = tuple(EDGE_COLOURS)
# The columns of the CSVs the trajectories and trees tables store (result_csv.cpp) that the
# figures read; every one a number but a tree's `state`.
STORED_CSV_COLUMNS = {"trajectories": ("t", "x", "y", "z"),
                      "trees": ("edge", "point", "x", "y", "z", "state", "closed")}


@dataclass
class World:
    """A world's views as the runner stored them (see the worlds table)."""

    world_hash: str
    id: str
    resolution: float
    origin: np.ndarray
    dims: tuple[int, int, int]
    top: np.ndarray   # (nx, ny): height of the highest occupied voxel, in voxels
    side: np.ndarray  # (nx, nz): 1 where any voxel along y is occupied
    # (n, 6): the occupied voxels as boxes x0, y0, z0, x1, y1, z1 in voxel indices ([lo, hi)),
    # at a stride of box_stride voxels; None in databases before schema version 5.
    boxes: np.ndarray | None = None
    box_stride: int = 1
    # What the report calls it: its id, or with its sweep values when a sweep varies the world
    # (world_labels).
    label: str = ""

    def __post_init__(self) -> None:
        self.label = self.label or self.id


@dataclass
class Results:
    """One or more results databases of the same experiment, merged."""

    paths: list[Path]
    runs: pd.DataFrame                 # one row per run, statistics as extra columns
    meta: dict[str, str]               # of the first database
    worlds: dict[str, World] = field(default_factory=dict)
    # The declaration of every column and statistic (name, kind, planner_type, type, unit,
    # doc, clock, direction, comparable), as `kinolab list metrics` prints it.
    metrics: pd.DataFrame = field(default_factory=pd.DataFrame)
    # Every sample of the planners' progress series (run_hash, name, time_ms, value).
    progress: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(
        columns=["run_hash", "name", "time_ms", "value"]))
    # Runs of an earlier configuration of the same directory (their hashes are not in the
    # planned table): kept in the file, never pooled with `runs`.
    stale: pd.DataFrame = field(default_factory=pd.DataFrame)

    def series(self) -> pd.DataFrame:
        """The declared progress series (the metrics table's kind 'progress'): name,
        planner_type, unit, doc."""
        if self.metrics.empty:
            return pd.DataFrame(columns=["name", "planner_type", "unit", "doc"])
        declared = self.metrics[self.metrics["kind"] == "progress"]
        return declared[["name", "planner_type", "unit", "doc"]].reset_index(drop=True)

    def reproduces(self) -> tuple[str, dict[str, str]] | None:
        """The paper the experiment reproduces and its planner id -> row mapping."""
        paper = self.meta.get("reproduces.paper")
        if not paper:
            return None
        rows = dict(line.split("=", 1) for line in
                    self.meta.get("reproduces.rows", "").splitlines() if "=" in line)
        return paper, rows

    def paper_setting(self) -> set[str]:
        """The sweep variants (labels; "" without a sweep) the experiment declares to run in
        the paper's setting; none when it declares none."""
        text = self.meta.get("reproduces.setting")
        return set() if text is None else set(text.split("\n"))

    def connection(self, run_hash: str) -> sqlite3.Connection:
        path = self.runs.loc[self.runs["run_hash"] == run_hash, "database"].iloc[0]
        return sqlite3.connect(path)

    def trajectory(self, run_hash: str) -> pd.DataFrame | None:
        return self._csv("trajectories", run_hash)

    def tree(self, run_hash: str) -> pd.DataFrame | None:
        return self._csv("trees", run_hash)

    def replans(self) -> pd.DataFrame:
        """Every replan of every flight (kind: flight), with its run's planner and query."""
        frames = []
        for database in self.runs["database"].unique():
            with sqlite3.connect(database) as db:
                tables = {row[0] for row in
                          db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
                if "flights" not in tables:
                    continue
                for run_hash, text in db.execute("SELECT run_hash, replans FROM flights"):
                    frame = pd.read_csv(io.StringIO(text))
                    frame["run_hash"] = run_hash
                    frames.append(frame)
        if not frames:
            return pd.DataFrame()
        replans = pd.concat(frames, ignore_index=True)
        return replans.merge(self.runs[["run_hash", "planner", "world", "query"]], on="run_hash")

    def clearance(self, run_hash: str) -> pd.DataFrame | None:
        """A flight's clearance to the ground truth over time (t, clearance), or None."""
        with self.connection(run_hash) as db:
            tables = {row[0] for row in
                      db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            row = (db.execute("SELECT clearance FROM flights WHERE run_hash = ?",
                              (run_hash,)).fetchone() if "flights" in tables else None)
        return pd.read_csv(io.StringIO(row[0])) if row and row[0] else None

    def known_voxels(self, run_hash: str) -> pd.DataFrame | None:
        """A flight's final known map as voxels (t, x, y, z: the centre and the time it was
        first known occupied), for the queries store.trees names; None when not stored."""
        with self.connection(run_hash) as db:
            columns = {row[1] for row in db.execute("PRAGMA table_info(flights)")}
            row = (db.execute("SELECT known_voxels FROM flights WHERE run_hash = ?",
                              (run_hash,)).fetchone() if "known_voxels" in columns else None)
        return pd.read_csv(io.StringIO(row[0])) if row and row[0] else None

    def known_maps(self, run_hash: str) -> list[tuple[float, np.ndarray, np.ndarray, float]]:
        """A flight's known map from above as it grew: (time, the (nx, ny) array of 0 unknown,
        1 free, 2 obstacle, the origin (x, y), the resolution) per snapshot, the last at the
        flight's end; empty when none was stored."""
        with self.connection(run_hash) as db:
            tables = {row[0] for row in
                      db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            row = (db.execute("SELECT known_map FROM flights WHERE run_hash = ?",
                              (run_hash,)).fetchone() if "flights" in tables else None)
        if not row or not row[0]:
            return []
        snapshots = []
        for block in row[0].split("t=")[1:]:
            time, head, *lines = block.splitlines()
            nx, ny, ox, oy, resolution = head.split(",")
            grid = np.frombuffer("".join(lines).encode(), dtype=np.uint8) - ord("0")
            snapshots.append((float(time), grid.reshape(int(nx), int(ny)),
                              np.array([float(ox), float(oy)]), float(resolution)))
        return snapshots

    def _csv(self, table: str, run_hash: str) -> pd.DataFrame | None:
        with self.connection(run_hash) as db:
            row = db.execute(f"SELECT csv FROM {table} WHERE run_hash = ?", (run_hash,)).fetchone()
        if row is None:
            return None
        file = self.runs.loc[self.runs["run_hash"] == run_hash, "database"].iloc[0]
        where = f"{file}: table {table}, column csv, run {run_hash}"
        _check_csv_header(where, table, row[0])
        try:
            frame = pd.read_csv(io.StringIO(row[0]))
        except (pd.errors.ParserError, pd.errors.EmptyDataError) as error:
            raise ValueError(f"{where}: not a stored CSV ({str(error).splitlines()[0]})") from error
        for column in STORED_CSV_COLUMNS[table]:
            if column != "state" and not pd.api.types.is_numeric_dtype(frame[column]):
                raise ValueError(f"{where}: the CSV's column {column!r} holds text where "
                                 "numbers belong")
        return frame


def _check_csv_header(where: str, table: str, text: object) -> None:
    """Refuses a stored CSV (of the trajectories or trees table) that is not text or whose
    header lacks the columns the figures read; `where` names the database, table and row."""
    if not isinstance(text, str):
        raise ValueError(f"{where}: expected CSV text, got {type(text).__name__}")
    header = text.split("\n", 1)[0].strip().split(",")
    missing = [column for column in STORED_CSV_COLUMNS[table] if column not in header]
    if missing:
        raise ValueError(f"{where}: expected a CSV with the columns "
                         f"{', '.join(STORED_CSV_COLUMNS[table])}; its header "
                         f"{header[0][:40]!r}... lacks {', '.join(missing)}")


def database_path(path: str | Path) -> Path:
    """A results directory or the database file itself."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.sqlite"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no results database (run `kinolab run` first)")
    return path


def _upgrade_v1(runs: pd.DataFrame) -> pd.DataFrame:
    """A version 1 runs table in version 2 terms: `success` is derived with the one
    definition (exact and checker-valid), and a worker the runner killed is `killed`
    (version 1 called it `timeout`, like a planner that spent its own budget)."""
    runs = runs.copy()
    killed = (runs["status"] == "timeout") & runs["message"].fillna("").str.startswith("killed after")
    runs.loc[killed, "status"] = "killed"
    runs["success"] = stats.is_success(runs).astype(int)
    return runs


def experiment_label(meta: dict[str, str]) -> str:
    """An experiment's name and config hash, as a mixed report labels its runs."""
    return f"{meta.get('name', '?')}@{meta.get('config_hash', '?')[:8]}"


def _comparability(metrics: pd.DataFrame) -> pd.DataFrame:
    """The metrics declarations of a database before version 8 with the columns version 8
    added: no direction, and comparable across planners for every declared result metric but
    the planner's own cost (tables.same_objective then pairs cost by planner type)."""
    metrics = metrics.copy()
    metrics["direction"] = ""
    metrics["comparable"] = ((metrics["kind"] == "result") & (metrics["name"] != "cost")
                             & (metrics["type"] != "text")).astype(int)
    return metrics


def _undefined_zero_jerk(runs: pd.DataFrame) -> pd.DataFrame:
    """Before version 8 the jerk integral of a piecewise-constant acceleration (order-2
    motion primitives, stop-and-go paths) was stored as 0, where it is undefined (the jerk is
    impulsive at the joints): such a 0 reads as undefined, with that reason."""
    if "jerk_integral" not in runs:
        return runs
    runs = runs.copy()
    zero = runs["jerk_integral"] == 0
    runs.loc[zero, "jerk_integral"] = np.nan
    reason = ("jerk_integral: stored as 0 before schema version 8, where a piecewise-constant "
              "acceleration's impulsive jerk read 0")
    previous = runs["undefined"].fillna("") if "undefined" in runs else pd.Series("", runs.index)
    runs["undefined"] = previous.where(~zero, (previous + "\n" + reason).str.lstrip("\n"))
    return runs


def world_labels(runs: pd.DataFrame) -> dict[str, str]:
    """Per world hash, the world's name in a report: its id, or, when a sweep varies the world
    (one id, several hashes), the id with the values of the sweep's keys of that world
    ("forest (density=0.2)"), so that each variant is its own world in every table, figure
    and heading, never pooled with the others."""
    labels: dict[str, str] = {}
    known = runs.dropna(subset=["world_hash"])
    for world, group in known.groupby("world", sort=False):
        variants = group.drop_duplicates("world_hash")
        axes = {}
        for world_hash, sweep in zip(variants["world_hash"], variants["sweep"].fillna("")):
            own = [part for part in str(sweep).split(", ") if part.startswith(f"worlds.{world}.")]
            axes[world_hash] = tables.sweep_axes(", ".join(own))
        frame = pd.DataFrame.from_dict(axes, orient="index", dtype=object).fillna("")
        varying = [axis for axis in frame.columns if frame[axis].nunique() > 1]
        for world_hash in variants["world_hash"]:
            values = ", ".join(f"{axis}={frame.at[world_hash, axis]}" for axis in varying)
            labels[world_hash] = (str(world) if len(variants) == 1
                                  else f"{world} ({values or world_hash[:8]})")
    return labels


def load(paths: str | Path | list[str | Path], allow_mixed: bool = False) -> Results:
    """Loads results databases (directories or files) into one Results. Columns are read by
    name; what they mean comes from the database's `metrics` table. The databases must hold
    one experiment (one config hash: its shards or resumed runs) unless `allow_mixed`; then
    every planner is labelled with its experiment ("eager (name@hash)"), so that runs of
    different experiments are never pooled. Runs of an earlier configuration of a directory
    (not in its planned table) go to `stale`, apart. A world a sweep varies is one world per
    variant (world_labels). Databases without a run ended are refused."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    files = [database_path(p) for p in paths]
    frames = []
    stale = []
    meta: dict[str, str] = {}
    worlds: dict[str, World] = {}
    metrics = []
    progress = []
    for index, file in enumerate(files):
        database = _read_database(file)
        if database.metrics is not None:
            metrics.append(database.metrics)
        if database.progress is not None:
            progress.append(database.progress)
        if index == 0:
            meta = database.meta
        runs = _runs_of(database, file, meta, files[0], allow_mixed)
        # No planned table (before version 8), or an empty one: every run is current.
        current = (runs["run_hash"].isin(database.planned) if database.planned
                   else pd.Series(True, runs.index))
        frames.append(runs[current])
        stale.append(runs[~current])
        for _, row in database.worlds.iterrows():
            try:
                worlds[row["world_hash"]] = _world(row)
            except (TypeError, ValueError, KeyError) as error:
                raise ValueError(f"{file}: table worlds, world {row.get('id')!r}: not a stored "
                                 f"world ({type(error).__name__}: {error})") from error
    return _pooled(files, frames, stale, meta, worlds, metrics, progress, allow_mixed)


@dataclass
class _Database:
    """One results database's tables as stored (metrics and progress: None when absent)."""

    runs: pd.DataFrame
    statistics: pd.DataFrame
    meta: dict[str, str]
    worlds: pd.DataFrame
    metrics: pd.DataFrame | None
    progress: pd.DataFrame | None
    planned: set[str]


def _read_database(file: Path) -> _Database:
    """The tables of one results database; refuses a file that is not one."""
    metrics = progress = None
    with sqlite3.connect(file) as db:
        try:
            runs = pd.read_sql("SELECT * FROM runs", db)
            statistics = pd.read_sql("SELECT run_hash, name, value FROM statistics", db)
            meta = dict(db.execute("SELECT key, value FROM meta").fetchall())
            world_rows = pd.read_sql("SELECT * FROM worlds", db)
            tables_in = {row[0] for row in
                         db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if "metrics" in tables_in:
                declared = pd.read_sql("SELECT * FROM metrics", db)
                metrics = declared if "comparable" in declared else _comparability(declared)
            if "progress" in tables_in:
                progress = pd.read_sql("SELECT run_hash, name, time_ms, value FROM progress", db)
            planned = ({row[0] for row in db.execute("SELECT run_hash FROM planned")}
                       if "planned" in tables_in else set())
            # The stored CSVs' headers now, so that a damaged row is refused before the
            # report is begun (their numbers are checked when a figure reads them).
            for table in STORED_CSV_COLUMNS:
                if table not in tables_in:
                    continue
                for run_hash, kind, head in db.execute(
                        f"SELECT run_hash, typeof(csv), substr(csv, 1, 200) FROM {table}"):
                    where = f"{file}: table {table}, column csv, run {run_hash}"
                    if kind != "text":
                        raise ValueError(f"{where}: expected CSV text, got an SQLite {kind}")
                    _check_csv_header(where, table, head)
        except (sqlite3.DatabaseError, pd.errors.DatabaseError) as error:
            raise ValueError(f"{file}: not a kinolab results database ({error})") from error
    return _Database(runs, statistics, meta, world_rows, metrics, progress, planned)


def _listed_ids(config: dict, key: str) -> list[str]:
    """The `id`s of the experiment file's list `key` (planners, worlds) in the file's order."""
    items = config.get(key)
    if not isinstance(items, list):
        return []
    return [str(item["id"]) for item in items if isinstance(item, dict) and "id" in item]


def _in_experiment_order(runs: pd.DataFrame, config_text: str | None) -> pd.DataFrame:
    """The runs in the order the experiment plans them, whatever order its workers finished
    in: variant, sweep, world (as the experiment file lists them), query, repetition, planner
    (as listed), so every table and figure that lists planners or worlds by first appearance
    lists them as the file does. Ids the file does not list come after the listed ones, by
    name. The config was checked (_check_meta)."""
    config = (yaml.safe_load(config_text.split(VARIANTS)[0]) if config_text else None) or {}
    ranks = {}
    for column, listed in (("world", "worlds"), ("planner", "planners")):
        if column in runs:
            order = {name: rank for rank, name in enumerate(_listed_ids(config, listed))}
            ranks[f"_rank_{column}"] = runs[column].map(order).fillna(len(order))
    by = [c for c in ("variant", "sweep", "_rank_world", "world", "query", "repetition",
                      "_rank_planner", "planner", "run_hash") if c in runs or c in ranks]
    ranked = runs.assign(**ranks)
    try:
        ordered = ranked.sort_values(by, kind="stable", na_position="last")
    except TypeError:  # a column of mixed types (a hand-edited database): by their text
        ordered = ranked.sort_values(by, kind="stable", na_position="last",
                                     key=lambda c: c.astype(str) if c.dtype == object else c)
    return ordered.drop(columns=list(ranks)).reset_index(drop=True)


def _check_meta(file: Path, meta: dict[str, str]) -> None:
    """Refuses a meta table whose schema_version is not a whole number or whose config is not
    the experiment's YAML mapping, naming the file, table and key (every reader trusts them)."""
    version = str(meta.get("schema_version", "1"))
    if not version.isdigit():
        raise ValueError(f"{file}: table meta, key 'schema_version': expected a whole number, "
                         f"got {version!r} (a damaged or foreign database)")
    text = meta.get("config")
    if text is None:
        return
    try:
        config = yaml.safe_load(str(text).split(VARIANTS)[0])
    except yaml.YAMLError as error:
        raise ValueError(f"{file}: table meta, key 'config': not the experiment's YAML "
                         f"({str(error).splitlines()[0]})") from error
    if config is not None and not isinstance(config, dict):
        raise ValueError(f"{file}: table meta, key 'config': expected the experiment's mapping, "
                         f"got {type(config).__name__}")


def _runs_of(database: _Database, file: Path, meta: dict[str, str], first: Path,
             allow_mixed: bool) -> pd.DataFrame:
    """One database's runs in this package's schema, its statistics as extra columns; refuses
    a newer schema, and (unless `allow_mixed`) another experiment than the first database's
    (`meta`, of `first`)."""
    runs = database.runs
    _check_meta(file, database.meta)
    version = int(database.meta.get("schema_version", "1"))
    if version > SCHEMA_VERSION:
        raise ValueError(f"{file}: results schema version {version} is newer than this "
                         f"analysis package reads ({SCHEMA_VERSION}); use the kinolab that "
                         "wrote it")
    if version == 1:
        runs = _upgrade_v1(runs)
    if "objective" not in runs:  # before version 8: a planner type's cost is its own
        runs["objective"] = runs["planner_type"]
    if version < 8:
        runs = _undefined_zero_jerk(runs)
    runs = _in_experiment_order(runs, database.meta.get("config"))
    if database.meta.get("config_hash") != meta.get("config_hash") and not allow_mixed:
        raise ValueError(
            f"{file} holds experiment {experiment_label(database.meta)}, {first} holds "
            f"{experiment_label(meta)}: one report pools one experiment's runs (its shards "
            "and resumed runs); --allow-mixed reports them side by side, each planner "
            "labelled with its experiment")
    if allow_mixed:
        runs["experiment"] = experiment_label(database.meta)
    statistics = database.statistics
    if not statistics.empty:
        wide = statistics.pivot_table(index="run_hash", columns="name", values="value",
                                      aggfunc="first")
        wide = wide[[c for c in wide.columns if c not in runs.columns]]
        runs = runs.merge(wide, left_on="run_hash", right_index=True, how="left")
    runs["database"] = str(file)
    return runs


def _world(row: pd.Series) -> World:
    """A World from its row of the worlds table."""
    nx, ny, nz = int(row["nx"]), int(row["ny"]), int(row["nz"])
    return World(
        row["world_hash"], row["id"], float(row["resolution"]),
        np.array([row["origin_x"], row["origin_y"], row["origin_z"]]), (nx, ny, nz),
        np.frombuffer(row["top"], dtype="<u2").reshape(nx, ny),
        np.frombuffer(row["side"], dtype=np.uint8).reshape(nx, nz),
        (np.frombuffer(row["boxes"], dtype="<i4").reshape(-1, 6)
         if row.get("boxes") is not None else None),
        int(row["box_stride"]) if pd.notna(row.get("box_stride")) else 1)


def _pooled(files: list[Path], frames: list[pd.DataFrame], stale: list[pd.DataFrame],
            meta: dict[str, str], worlds: dict[str, World], metrics: list[pd.DataFrame],
            progress: list[pd.DataFrame], allow_mixed: bool) -> Results:
    """The databases' current runs (`frames`) pooled into one Results, `stale` apart; refuses
    databases without a current run ended."""
    if all(frame.empty for frame in frames):
        raise ValueError(f"{', '.join(map(str, files))}: " + (
            "no run has ended yet (an experiment stopped before its first run ended)"
            if all(frame.empty for frame in stale) else "every stored run is of an earlier "
            "configuration of the experiment (none of the experiment as last run has ended)")
            + ": nothing to report")
    runs = pd.concat([frame for frame in frames if not frame.empty], ignore_index=True)
    for column in ("planning_time_min_ms", "planning_time_cold_ms", "line_blocked",
                   "time_limit", "time_limit_own", "undefined"):
        if column not in runs.columns:
            runs[column] = np.nan
    runs = runs.drop_duplicates("run_hash")
    if allow_mixed and runs["experiment"].nunique() > 1:
        runs["planner"] = runs["planner"] + " (" + runs["experiment"] + ")"
    runs["success"] = runs["success"].fillna(0).astype(bool)
    labels = world_labels(runs)
    runs["world"] = runs["world_hash"].map(labels).fillna(runs["world"])
    for world_hash, world in worlds.items():
        world.label = labels.get(world_hash, world.id)
    stale_runs = pd.concat(stale, ignore_index=True)
    results = Results(files, runs, meta, worlds,
                      pd.concat(metrics, ignore_index=True).drop_duplicates(["name", "planner_type"])
                      if metrics else pd.DataFrame(),
                      stale=stale_runs[~stale_runs["run_hash"].isin(runs["run_hash"])])
    if progress:
        samples = pd.concat(progress, ignore_index=True)
        results.progress = samples[samples["run_hash"].isin(runs["run_hash"])].drop_duplicates(
            ["run_hash", "name", "time_ms"]).reset_index(drop=True)
    reproduced = results.reproduces()
    runs["paper"] = runs["planner"].map(reproduced[1]) if reproduced else None
    return results
