"""Loading results databases written by `kinolab run` into tidy frames."""

from __future__ import annotations

import io
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

# Where a run's planner family sits in the paper's Table II.
PAPER_PLANNERS = {"rrtstar_ceres": "TGK", "eager_mp_astar": "MP-A*", "lazy_mp_astar": "Lazy"}


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


@dataclass
class Results:
    """One or more results databases of the same experiment, merged."""

    paths: list[Path]
    runs: pd.DataFrame                 # one row per run, statistics as extra columns
    meta: dict[str, str]               # of the first database
    worlds: dict[str, World] = field(default_factory=dict)

    def connection(self, run_hash: str) -> sqlite3.Connection:
        path = self.runs.loc[self.runs["run_hash"] == run_hash, "database"].iloc[0]
        return sqlite3.connect(path)

    def trajectory(self, run_hash: str) -> pd.DataFrame | None:
        return self._csv("trajectories", run_hash)

    def tree(self, run_hash: str) -> pd.DataFrame | None:
        return self._csv("trees", run_hash)

    def _csv(self, table: str, run_hash: str) -> pd.DataFrame | None:
        with self.connection(run_hash) as db:
            row = db.execute(f"SELECT csv FROM {table} WHERE run_hash = ?", (run_hash,)).fetchone()
        return pd.read_csv(io.StringIO(row[0])) if row else None


def database_path(path: str | Path) -> Path:
    """A results directory or the database file itself."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.sqlite"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no results database (run `kinolab run` first)")
    return path


def load(paths: str | Path | list[str | Path]) -> Results:
    """Loads results databases (directories or files) into one Results."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    files = [database_path(p) for p in paths]
    frames = []
    meta: dict[str, str] = {}
    worlds: dict[str, World] = {}
    for index, file in enumerate(files):
        with sqlite3.connect(file) as db:
            try:
                runs = pd.read_sql("SELECT * FROM runs", db)
                statistics = pd.read_sql("SELECT run_hash, name, value FROM statistics", db)
                this_meta = dict(db.execute("SELECT key, value FROM meta").fetchall())
                world_rows = db.execute("SELECT * FROM worlds").fetchall()
            except (sqlite3.DatabaseError, pd.errors.DatabaseError) as error:
                raise ValueError(f"{file}: not a kinolab results database ({error})") from error
        if index == 0:
            meta = this_meta
        if not statistics.empty:
            wide = statistics.pivot_table(index="run_hash", columns="name", values="value",
                                          aggfunc="first")
            wide = wide[[c for c in wide.columns if c not in runs.columns]]
            runs = runs.merge(wide, left_on="run_hash", right_index=True, how="left")
        runs["database"] = str(file)
        frames.append(runs)
        for row in world_rows:
            (world_hash, world_id, resolution, ox, oy, oz, nx, ny, nz, top, side) = row
            worlds[world_hash] = World(
                world_hash, world_id, resolution, np.array([ox, oy, oz]), (nx, ny, nz),
                np.frombuffer(top, dtype="<u2").reshape(nx, ny),
                np.frombuffer(side, dtype=np.uint8).reshape(nx, nz))
    runs = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    runs = runs.drop_duplicates("run_hash")
    runs["success"] = (runs["status"] == "exact") & (runs["checker_valid"] == 1)
    runs["paper"] = runs["planner_type"].map(PAPER_PLANNERS)
    return Results(files, runs, meta, worlds)
