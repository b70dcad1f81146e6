#!/usr/bin/env python3
"""What calling a plan from Python adds to it: a lazy MP-A* plan of about 2 ms in the dense
forest, called from Python (kinolab.Planner.plan, result object included) and from C++
(the same planner, same query, in a loop inside the extension), interleaved in blocks in one
process so that both see the same machine.

    PYTHONPATH=build/python /usr/bin/python3 benchmarks/python_overhead.py [--blocks 10]
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import kinolab
from kinolab import _core

SOURCE = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=10, help="interleaved blocks")
    parser.add_argument("--plans", type=int, default=50, help="plans per block and side")
    args = parser.parse_args()
    world = kinolab.World.from_file(SOURCE / "configs" / "worlds" / "dense_forest.yaml")
    planner = kinolab.Planner("lazy_mp_astar", world)
    start, goal = (5.0, 5.0, 1.5), (11.0, 9.0, 1.5)
    result = planner.plan(start, goal)
    assert result.success, result
    for _ in range(20):  # warm up both paths
        planner.plan(start, goal)
    _core._plan_wall_ms(planner._core, start, goal, 20)
    ratios = []
    for block in range(args.blocks):
        native = statistics.median(_core._plan_wall_ms(planner._core, start, goal, args.plans))
        python = []
        for _ in range(args.plans):
            begin = time.perf_counter()
            planner.plan(start, goal)
            python.append((time.perf_counter() - begin) * 1000.0)
        ratios.append(statistics.median(python) / native)
        print(f"block {block + 1:2d}: C++ {native:.3f} ms, Python {statistics.median(python):.3f} ms, "
              f"overhead {100 * (ratios[-1] - 1):+.2f} %", flush=True)
    print(f"plan of {result.planning_time_ms:.2f} ms ({result.metrics['expansions']} expansions): "
          f"Python adds {100 * (statistics.median(ratios) - 1):+.2f} % (median of {args.blocks} "
          f"blocks of {args.plans} plans; blocks {100 * (min(ratios) - 1):+.2f} to "
          f"{100 * (max(ratios) - 1):+.2f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
