"""python3 -m kinolab_analysis report DIR [DIR...] [--out REPORT_DIR] [--compare DIR2]
python3 -m kinolab_analysis export DIR [DIR...] --format ompl OUT

Every failure is one line, `kinolab: error: ...`, naming the file, and exit status 1."""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from pathlib import Path

import matplotlib


def main(argv: list[str] | None = None) -> int:
    # The command draws into files only: Agg needs no display. (Importing the package does
    # not choose a backend, so a notebook keeps its own.)
    matplotlib.use("Agg")
    parser = argparse.ArgumentParser(prog="kinolab report",
                                     description="Write an HTML report (figures, tables) of "
                                                 "kinolab results databases.")
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser("report", help="write a report directory")
    rep.add_argument("results", nargs="+", type=Path,
                     help="results directories (or results.sqlite files) of one experiment")
    rep.add_argument("--out", help="report directory (default: RESULTS/report)")
    rep.add_argument("--compare", help="a second result set to compare with")
    rep.add_argument("--sampling-study",
                     help="a sampling study's summary.csv for Table I (default: "
                          "RESULTS/sampling_study/*/summary.csv when present)")
    rep.add_argument("--allow-mixed", action="store_true",
                     help="report databases of different experiments (config hashes) side by "
                          "side, each planner labelled with its experiment (refused otherwise)")
    exp = sub.add_parser("export", help="write the results in another tool's format")
    exp.add_argument("results", nargs="+", type=Path,
                     help="results directories (or results.sqlite files) of one experiment")
    exp.add_argument("--format", required=True, choices=["ompl"],
                     help="ompl: OMPL benchmark logs (ompl_benchmark_statistics -> Planner Arena)")
    exp.add_argument("out", help="output directory")
    args = parser.parse_args(argv)
    try:
        return _export(args) if args.command == "export" else _report(args)
    except (OSError, ValueError) as error:  # a missing database, an OUT that is a file, ...
        print(f"kinolab: error: {_described(error)}", file=sys.stderr)
        return 1
    except Exception as error:  # a defect here: said in one line, the trace on request
        if os.environ.get("KINOLAB_DEBUG"):
            traceback.print_exc()
        print(f"kinolab: error: {args.command} failed: {type(error).__name__}: {error} (set "
              "KINOLAB_DEBUG=1 for the Python traceback, and please report it)", file=sys.stderr)
        return 1


def _described(error: Exception) -> str:
    """An error as one line that names its file."""
    if isinstance(error, OSError) and error.filename is not None:
        return f"{error.filename}: {error.strerror or error}"
    return str(error)


def _out_directory(out: Path, option: str) -> Path:
    """`out` when it is, or can become, a directory; a clear error before anything is written
    otherwise."""
    for path in (out, *out.parents):
        if path.exists() and not path.is_dir():
            raise ValueError(f"{option} {out}" + ("" if path == out else f": {path}") +
                             " exists and is not a directory")
    return out


def _export(args) -> int:
    from . import export
    if args.out == "":  # Path("") would be the current directory
        raise ValueError("OUT is empty: name the output directory")
    out = _out_directory(Path(args.out), "OUT")
    written = export.export_ompl(args.results, out)
    for path in written:
            print(path)
    print(f"{len(written)} OMPL benchmark logs; for Planner Arena: ompl_benchmark_statistics "
          f"{out}/*.log -d benchmark.db")
    return 0


def _report(args) -> int:
    from . import report
    given = {}
    for option in ("out", "compare", "sampling_study"):
        value = getattr(args, option)
        if value == "":  # Path("") would be the current directory
            raise ValueError(f"--{option.replace('_', '-')} is empty: name a path")
        given[option] = Path(value) if value is not None else None
    first = args.results[0]
    out = given["out"] or (first if first.is_dir() else first.parent) / "report"
    written = report.write(args.results, _out_directory(out, "--out"), given["compare"],
                           given["sampling_study"], args.allow_mixed)
    print(report.terminal_summary(written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
