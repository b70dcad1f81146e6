"""kinolab from Python: worlds, planners, experiments and the 3D viewer.

    import kinolab
    world = kinolab.World.from_file("configs/worlds/dense_forest.yaml")   # see data_path
    lazy = kinolab.Planner("lazy_mp_astar", world, heuristic_weight=1.0)
    result = lazy.plan(start=(2, 2, 1.5), goal=(14, 12, 1.5), time_limit=1.0, tree=True)
    result.status, result.cost, result.metrics["expansions"]

The objects are kinolab's own (the C++ core, kinolab._core): planning and experiment runs
release the GIL, and kinolab's errors are raised as kinolab.Error and its subclasses with the
messages the command line prints. docs/python.md walks through a session.
"""

from __future__ import annotations

import html
import json
import math
import os
import sys
from pathlib import Path
from typing import Any, Callable, Mapping

from . import _core
from ._core import (ConfigError, Error, FileError, InvalidArgument, ParameterConflict,
                    PluginError, Result)

for _error in (Error, ConfigError, ParameterConflict, FileError, PluginError, InvalidArgument,
               Result):
    _error.__module__ = __name__  # kinolab.ConfigError in tracebacks, not kinolab._core's
Error.__doc__ = "Every error kinolab raises, with the message the command line prints."
ConfigError.__doc__ = "A malformed or misspelt configuration, or a value out of its range."
ParameterConflict.__doc__ = ("A parameter that conflicts with another or with the planner "
                             "(the message names it).")
FileError.__doc__ = "A missing, unreadable, corrupt or unwritable file."
PluginError.__doc__ = "A plugin library that cannot be loaded or registers badly."
InvalidArgument.__doc__ = "An argument out of its domain (a NaN, a wrong shape, a bad index)."

__version__ = _core.__version__
__all__ = ["World", "Planner", "Result", "Scene", "plugins", "plugin_kinds", "planners", "samplers", "metrics",
           "load_plugin", "run_experiment", "load_results", "data_path", "Error", "ConfigError",
           "ParameterConflict", "FileError", "PluginError", "InvalidArgument"]

try:  # written at install (python/CMakeLists.txt); the build tree's package has none
    from ._installed import DATA_DIRECTORY as _DATA_FROM_PACKAGE
    _DATA_DIRECTORY: Path | None = (Path(__file__).parent / _DATA_FROM_PACKAGE).resolve()
except ImportError:
    _DATA_DIRECTORY = None


def data_path(path: str | os.PathLike) -> Path:
    """The file kinolab reads for `path`: `path` itself when it is absolute or names a file
    from the current directory; otherwise the file of that name installed with kinolab, when
    there is one (<prefix>/share/kinolab holds the clone's configs/, experiments/ and
    data/maps/). So data_path("configs/worlds/forest.yaml") names the spec in the clone and,
    once kinolab is installed, anywhere else. World.from_file and run_experiment read their
    paths through it."""
    path = Path(path)
    if path.is_absolute() or path.exists() or _DATA_DIRECTORY is None:
        return path
    installed = _DATA_DIRECTORY / path
    return installed if installed.exists() else path


class World:
    """A built world: the occupancy grid and its exact signed distance field (ESDF).

    `occupancy` (uint8, 1 = occupied) and `esdf` (float32, metres) are read-only NumPy views
    of kinolab's own arrays, shape (nx, ny, nz), index [ix, iy, iz]; the centre of voxel
    (ix, iy, iz) is origin + (index + 0.5) * resolution.
    """

    def __init__(self, core: _core.World):
        self._core = core

    @classmethod
    def from_file(cls, path: str | os.PathLike, cache: bool = True,
                  cache_dir: str | os.PathLike | None = None) -> "World":
        """Builds a world from a spec file (configs/worlds/*.yaml, found by data_path), or
        loads it from the world cache (the one `kinolab` uses, keyed by the spec's hash) when
        it was built before."""
        return cls(_core.world_from_file(os.fspath(data_path(path)), cache,
                                         os.fspath(cache_dir or "")))

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], cache: bool = True,
                  cache_dir: str | os.PathLike | None = None,
                  directory: str | os.PathLike = ".") -> "World":
        """Builds a world from a spec given as a dict (the YAML file's keys); relative map
        paths are resolved against `directory`."""
        if not isinstance(spec, Mapping):
            raise InvalidArgument(f"from_spec: expected a dict of the spec's keys, got "
                                  f"{type(spec).__name__}")
        text = json.dumps(spec, default=_plain)  # JSON is YAML
        return cls(_core.world_from_text(text, "<dict>", os.fspath(directory), cache,
                                         os.fspath(cache_dir or "")))

    name = property(lambda self: self._core.name, doc="the spec's name")
    spec_hash = property(lambda self: self._core.spec_hash,
                         doc="the hash of the expanded spec (the world cache's key), hex")
    resolution = property(lambda self: self._core.resolution, doc="the voxel size, metres")
    origin = property(lambda self: self._core.origin,
                      doc="the grid's low corner (x, y, z), metres")
    shape = property(lambda self: self._core.shape, doc="voxels per axis (nx, ny, nz)")
    bounds = property(lambda self: self._core.bounds,
                      doc="the map's box: ((x, y, z) low, (x, y, z) high), metres")
    occupancy = property(lambda self: self._core.occupancy,
                         doc="read-only uint8 NumPy view (nx, ny, nz): 1 = occupied")
    esdf = property(lambda self: self._core.esdf,
                    doc="read-only float32 NumPy view (nx, ny, nz): the signed distance from "
                        "each voxel's centre to the nearest cube of the other kind, metres")
    source = property(lambda self: self._core.source, doc="'built' or 'cache'")
    seconds = property(lambda self: self._core.seconds, doc="time to build or load, s")

    def distance(self, points):
        """Trilinear signed distance (m) at a point (3,) or at points (n, 3)."""
        return self._core.distance(points)

    def distance_with_gradient(self, points):
        """The distance and its analytic gradient: (d, g) with d (n,) and g (n, 3)."""
        return self._core.distance_with_gradient(points)

    def segment_free(self, a, b, radius: float) -> bool:
        """Whether a body of `radius` can follow the straight line from a to b."""
        return self._core.segment_free(a, b, radius)

    def __repr__(self) -> str:
        return (f"World({self.name!r}, shape={self.shape}, resolution={self.resolution}, "
                f"{self.source})")


def _plain(value):
    """NumPy scalars and arrays in a spec dict as plain numbers and lists."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not a spec value")


def _text(value) -> str:
    """A keyword parameter's value as the text `--set NAME=VALUE` would carry."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if hasattr(value, "item"):  # a NumPy scalar
        return _text(value.item())
    return str(value)


class Planner:
    """A planner plugin by its key (`kinolab.planners()`), configured by keyword parameters
    as `--set` would set them: `Planner("lazy_mp_astar", world, sampler="normal",
    **{"sampler.sigma": 0.4})`. Unknown keys, parameters and out-of-range values raise
    ConfigError (or PluginError) with the command line's message."""

    def __init__(self, key: str, world: World | None = None, seed: int = 1, **parameters):
        assignments = [_core.Assignment(name, _text(value), f"keyword argument '{name}'")
                       for name, value in parameters.items()]
        self._core = _core.Planner(key, assignments)
        self.key = key
        if world is not None:
            self.setup(world, seed)

    def setup(self, world: World, seed: int = 1) -> "Planner":
        """Sets the planner up on a world (and seeds its random streams)."""
        if not isinstance(world, World):
            raise InvalidArgument(f"setup: expected a kinolab.World, got {type(world).__name__}")
        self._core.setup(world._core, seed)
        self.world = world
        return self

    @property
    def parameters(self) -> dict:
        """Every parameter's value (defaults included), sampler parameters as sampler.NAME."""
        return self._core.parameters

    def plan(self, start, goal, start_velocity=None, start_acceleration=None,
             time_limit: float = math.inf, max_iterations: int | None = None,
             tree: bool = False) -> Result:
        """Plans from `start` (at rest unless start_velocity/acceleration are given) to
        `goal` within the budget (and the planner's own `time_limit`); with `tree`, the
        search tree is kept (built after the clock stopped). The GIL is released while it
        plans, so threads with their own planners plan in parallel."""
        return self._core.plan(start, goal, start_velocity, start_acceleration, time_limit,
                               max_iterations if max_iterations is not None else 2**62, tree)

    def reset(self) -> None:
        """Forgets what the planner kept between plans (a new query starts afresh)."""
        self._core.reset()

    def __repr__(self) -> str:
        return f"Planner({self.key!r})"


def plugins(kind: str) -> list[dict]:
    """Every registered plugin of a kind (one of plugin_kinds(), as `kinolab list KIND`):
    key, description, origin, parameters (name, type, default, range, doc) and the statistics
    it reports."""
    return _core.plugins(kind)


def plugin_kinds() -> list[str]:
    """The plugin kinds, in the order `kinolab list` shows them."""
    return _core.plugin_kinds()


def planners() -> list[dict]:
    """Every registered planner: plugins("planners")."""
    return plugins("planners")


def samplers() -> list[dict]:
    """Every registered control sampler: plugins("samplers")."""
    return plugins("samplers")


def metrics() -> dict:
    """The result schema: every result metric and the statistics every planner reports."""
    return _core.metrics()


def load_plugin(path: str | os.PathLike) -> None:
    """Loads an out-of-tree plugin library (what `kinolab --plugin PATH` does)."""
    _core.load_plugin(os.fspath(path))


class _Progress:
    """The one progress display of run_experiment (the runner's own on stderr is off): a bar
    redrawn in place on a terminal or in a notebook, otherwise a line at every tenth and at
    least every 10 s (a log file gets lines, not one line of carriage returns)."""

    def __init__(self, stream=None):
        self.stream = stream or sys.stdout
        isatty = getattr(self.stream, "isatty", None)
        self.in_place = bool(isatty and isatty()) or "ipykernel" in sys.modules
        self.last_line = -math.inf

    def __call__(self, done: int, total: int, unsolved: int, seconds: float) -> None:
        rate = done / seconds if seconds > 0 else 0.0
        text = f"{done}/{total} done, {unsolved} unsolved, {rate:.1f} runs/s"
        if self.in_place:
            width = 30
            filled = width * done // total if total else width
            self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {text}")
            if done == total:
                self.stream.write("\n")
        else:
            tenth = total > 0 and done * 10 // total != (done - 1) * 10 // total
            if not (tenth or done == total or seconds - self.last_line >= 10.0):
                return
            self.last_line = seconds
            self.stream.write(f"run: {text}\n")
        self.stream.flush()


def run_experiment(path: str | os.PathLike, out: str | os.PathLike, jobs: int = 1,
                   resume: bool = False, shard: str | None = None,
                   cache_dir: str | os.PathLike | None = None,
                   progress: bool | Callable[[int, int, int, float], None] = True) -> dict:
    """Runs an experiment file (found by data_path) with kinolab's runner (isolated worker
    processes, the results database OUT/results.sqlite, resume) and returns its summary.
    `progress` is True (a bar on stdout), False, or a callable(done, total, unsolved,
    seconds). Ctrl-C stops it as it stops `kinolab run` (resumable) and raises
    KeyboardInterrupt."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or not 1 <= jobs <= 1024:
        raise InvalidArgument(f"jobs: expected a whole number in [1, 1024], got {jobs!r}")
    callback = _Progress() if progress is True else (progress or None)
    summary = _core.run_experiment(os.fspath(data_path(path)), os.fspath(out), jobs, resume,
                                   shard or "", os.fspath(cache_dir or ""), callback)
    if summary["interrupted"]:
        raise KeyboardInterrupt(f"the experiment was interrupted; run_experiment(..., "
                                f"resume=True) goes on from {summary['database']}")
    return summary


def load_results(*paths: str | os.PathLike):
    """Loads results directories (or databases) with the analysis package:
    a kinolab_analysis.data.Results (`.runs` is a pandas DataFrame, one row per run)."""
    from kinolab_analysis import data
    return data.load([os.fspath(p) for p in paths])


class Scene:
    """A 3D scene for kinolab's viewer (docs/viewer.md): a world and, per query, the
    trajectories and search trees of any planners; `write(path)` makes a self-contained
    view.html, `html()` its text (for IPython.display.HTML)."""

    def __init__(self, title: str = "kinolab", world: World | None = None):
        self._core = _core.Scene(title)
        if world is not None:
            self._core.set_world(world._core)

    def add_query(self, name: str, start, goal) -> int:
        """Adds a query (start and goal, (x, y, z) each) named `name`; returns its index, for
        add_result."""
        return self._core.add_query(name, start, goal)

    def add_result(self, query: int, planner: str, result: Result) -> "Scene":
        """The result's trajectory and, when it kept one, its search tree."""
        self._core.add_result(query, planner, result)
        return self

    def json(self) -> str:
        """The scene as JSON (viewer/scene.schema.json)."""
        return self._core.json()

    def html(self) -> str:
        """The self-contained viewer page, as text (for IPython.display.HTML)."""
        return self._core.html()

    def _repr_html_(self) -> str:
        """Shown inline by Jupyter: the viewer in an iframe of its own."""
        return (f'<iframe srcdoc="{html.escape(self.html(), quote=True)}" '
                'style="width: 100%; height: 600px; border: 0"></iframe>')

    def write(self, path: str | os.PathLike) -> Path:
        """Writes the self-contained viewer page to `path`; returns the path."""
        self._core.write(os.fspath(path))
        return Path(path)
