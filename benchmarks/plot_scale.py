#!/usr/bin/python3
"""Plot the scale benchmark (BM_WorldScale): cost against world size, dense and sparse, log-log.

    ./build/benchmarks/kinolab_benchmarks --benchmark_filter=WorldScale \\
        --benchmark_out=out/scale.json --benchmark_out_format=json
    /usr/bin/python3 benchmarks/plot_scale.py out/scale.json [more.json ...] docs/images/world_scale.png
"""
import argparse
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="+", help="the benchmark's --benchmark_out JSON (one or more runs)")
    parser.add_argument("png", help="the figure to write")
    args = parser.parse_args()
    runs = []
    for path in args.json:
        try:
            with open(path, encoding="utf-8") as handle:
                runs += [b for b in json.load(handle)["benchmarks"] if b["name"].startswith("BM_WorldScale/")]
        except (OSError, ValueError, KeyError) as error:
            print(f"plot_scale: error: {path}: {error}", file=sys.stderr)
            return 1
    if not runs:
        print(f"plot_scale: error: {', '.join(args.json)}: no BM_WorldScale results", file=sys.stderr)
        return 1
    runs.sort(key=lambda b: b["voxels"])
    figure, (times, memory) = plt.subplots(1, 2, figsize=(11, 4.2))
    for sparse, style, name in ((0, "o-", "dense"), (1, "s--", "sparse")):
        layout = [b for b in runs if int(b.get("sparse", 0)) == sparse]
        if not layout:
            continue
        voxels = [b["voxels"] for b in layout]
        for key, label in (("build_s", "world build (generators)"),
                           ("esdf_s", "ESDF (every core; sparse: truncated at 1.2 m)"),
                           ("plan_median_ms", "lazy MP-A*, median of ten 18-20 m queries")):
            scale = 1e-3 if key.endswith("_ms") else 1.0
            times.loglog(voxels, [b[key] * scale for b in layout], style, label=f"{name}: {label}")
        # The peak is Linux's VmHWM less the resident memory before: after a larger world in
        # the same process the allocator reuses its pages, so it is shown for dense runs only.
        if not sparse:
            memory.loglog(voxels,
                          [b["peak_bytes_per_voxel"] * b["voxels"] / 2**30 for b in layout],
                          style, label=f"{name}: peak while building")
        memory.loglog(voxels, [b["rest_bytes_per_voxel"] * b["voxels"] / 2**30 for b in layout],
                      style, alpha=0.5, label=f"{name}: at rest")
    times.set_xlabel("voxels")
    times.set_ylabel("seconds")
    times.set_title("time")
    times.grid(True, which="both", alpha=0.3)
    times.legend(fontsize=7)
    memory.set_xlabel("voxels")
    memory.set_ylabel("GiB")
    memory.set_title("memory")
    memory.grid(True, which="both", alpha=0.3)
    memory.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(args.png, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
