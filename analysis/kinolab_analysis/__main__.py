"""python3 -m kinolab_analysis report DIR [DIR...] [--out REPORT_DIR] [--compare DIR2]
python3 -m kinolab_analysis export DIR [DIR...] --format ompl OUT"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib


def main(argv: list[str] | None = None) -> int:
    # The command draws into files only: Agg needs no display. (Importing the package does
    # not choose a backend, so a notebook keeps its own.)
    matplotlib.use("Agg")
    from . import export, report
    parser = argparse.ArgumentParser(prog="kinolab report",
                                     description="Write an HTML report (figures, tables) of "
                                                 "kinolab results databases.")
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser("report", help="write a report directory")
    rep.add_argument("results", nargs="+", type=Path,
                     help="results directories (or results.sqlite files) of one experiment")
    rep.add_argument("--out", type=Path, help="report directory (default: RESULTS/report)")
    rep.add_argument("--compare", type=Path, help="a second result set to compare with")
    rep.add_argument("--sampling-study", type=Path,
                     help="a sampling study's summary.csv for Table I (default: "
                          "RESULTS/sampling_study/*/summary.csv when present)")
    exp = sub.add_parser("export", help="write the results in another tool's format")
    exp.add_argument("results", nargs="+", type=Path,
                     help="results directories (or results.sqlite files) of one experiment")
    exp.add_argument("--format", required=True, choices=["ompl"],
                     help="ompl: OMPL benchmark logs (ompl_benchmark_statistics -> Planner Arena)")
    exp.add_argument("out", type=Path, help="output directory")
    args = parser.parse_args(argv)
    if args.command == "export":
        try:
            written = export.export_ompl(args.results, args.out)
        except (OSError, ValueError) as error:  # a missing database, an OUT that is a file
            print(f"kinolab export: error: {error}", file=sys.stderr)
            return 1
        for path in written:
            print(path)
        print(f"{len(written)} OMPL benchmark logs; for Planner Arena: ompl_benchmark_statistics "
              f"{args.out}/*.log -d benchmark.db")
        return 0
    first = args.results[0]
    out = args.out or ((first if first.is_dir() else first.parent) / "report")
    try:
        written = report.write(args.results, out, args.compare, args.sampling_study)
    except (FileNotFoundError, ValueError) as error:
        print(f"kinolab report: error: {error}", file=sys.stderr)
        return 1
    print(report.terminal_summary(written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
