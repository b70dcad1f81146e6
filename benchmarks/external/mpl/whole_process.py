#!/usr/bin/python3
"""MPL's own process against a whole `kinolab plan` process, query by query, interleaved.

Each query of MPL's benchmark problem is planned by `mpl_plan_query` (MPL alone: read the map,
plan, print) and by `kinolab plan` (start-up, the world from its cache, planning, the
independent check and its figures, the JSON line) in turn, `--runs` times each, alternating.
Per query: the median elapsed time and CPU time (user + system, from the children's rusage) of
each, their ratio, and whether the costs agree. Run from the repository root after
`mpl_vs_kinolab experiments/mpl_benchmark.yaml --write-map MAP` (README.md).

  whole_process.py --mpl BUILD/mpl_plan_query --map MAP --kinolab build/framework/kinolab
"""
import argparse
import json
import resource
import statistics
import subprocess
import sys
import time

# The benchmark's problem for `kinolab plan` (experiments/mpl_benchmark.yaml's `lazy` planner).
PROBLEM = [
    "--world", "configs/worlds/mpl_pillars.yaml", "--planner", "lazy_mp_astar",
    "--set", "order=2", "--set", "tau=1.0", "--set", "max_velocity=2",
    "--set", "max_acceleration=1", "--set", "weight_duration=10", "--set", "weight_control=1",
    "--set", "weight_length=0", "--set", "weight_obstacle=0", "--set", "robot_radius=0",
    "--set", "goal_radius=0.01", "--set", "sampler.samples_per_axis=3",
]


def run(command):
    """Elapsed and CPU seconds of one process, and its standard output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode not in (0, 2):  # mpl_plan_query exits 2 when it finds no plan
        sys.exit(f"{' '.join(command)} failed ({done.returncode}): {done.stderr.strip()}")
    return elapsed, cpu, done.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mpl", required=True, help="mpl_plan_query")
    parser.add_argument("--map", required=True, help="the map of mpl_vs_kinolab --write-map")
    parser.add_argument("--kinolab", required=True, help="the kinolab command")
    parser.add_argument("--runs", type=int, default=10, help="processes per query and side")
    parser.add_argument("--queries", default="", help="query numbers, e.g. 1,4 (default all)")
    args = parser.parse_args()
    if args.runs < 1:
        sys.exit("--runs must be at least 1")
    with open(args.map + ".queries") as lines:
        queries = [line.split() for line in lines if line.strip()]
    chosen = [int(q) for q in args.queries.split(",")] if args.queries else range(len(queries))

    print("query | MPL ms (elapsed, CPU) | kinolab ms (elapsed, CPU) | MPL/kinolab (elapsed, CPU)"
          " | MPL planning ms | costs (MPL, kinolab)")
    ratios = []
    for q in chosen:
        start, goal = queries[q]
        mpl_command = [args.mpl, args.map, start, goal]
        kino_command = [args.kinolab, "plan", *PROBLEM, "--start", start, "--goal", goal]
        mpl, kino = [], []
        for _ in range(args.runs):
            mpl.append(run(mpl_command))
            kino.append(run(kino_command))
        fields = mpl[-1][2].split()
        mpl_cost = float(fields[3]) if fields[1] == "1" else None
        planning = statistics.median(float(r[2].split()[7]) for r in mpl)
        kino_cost = json.loads(kino[-1][2].strip().splitlines()[-1]).get("cost")
        m = [statistics.median(r[i] for r in mpl) * 1e3 for i in (0, 1)]
        k = [statistics.median(r[i] for r in kino) * 1e3 for i in (0, 1)]
        ratios.append((m[0] / k[0], m[1] / k[1]))
        print(f"q{q:02d} | {m[0]:.1f}, {m[1]:.1f} | {k[0]:.1f}, {k[1]:.1f} | "
              f"{ratios[-1][0]:.2f}x, {ratios[-1][1]:.2f}x | {planning:.1f} | {mpl_cost}, "
              f"{kino_cost}", flush=True)
    print(f"median MPL/kinolab over {len(ratios)} queries: elapsed "
          f"{statistics.median(r[0] for r in ratios):.2f}x, CPU "
          f"{statistics.median(r[1] for r in ratios):.2f}x")


if __name__ == "__main__":
    main()
