// How a world scales, dense against sparse: the time and memory of its build (the generators),
// its ESDF (on every core; the sparse world's truncated at 1.2 m, what the default obstacle cost
// reads) and a fixed set of lazy MP-A* queries, as the world grows from 10^6 to 10^10 voxels (a
// dense world holds at most 10^9). The world is a forest (0.05 trees per square metre, trunks
// 0.15-0.3 m, 6-8 m tall, a ground plane) 8 m high at 0.1 m, its square side grown with the voxel
// count (11 m to 1.1 km). The 10^8 cases take a few seconds, 10^9 a minute and the dense one 9 GB,
// 10^10 (sparse) several minutes and about 10 GB; the tests' smoke run leaves them out.
//   ./build/benchmarks/kinolab_benchmarks --benchmark_filter=WorldScale
//       --benchmark_out=out/scale.json --benchmark_out_format=json    (one command line)
//   /usr/bin/python3 benchmarks/plot_scale.py out/scale.json docs/images/world_scale.png
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <vector>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {
namespace {

using Clock = std::chrono::steady_clock;

double secondsBetween(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

/// The process's peak resident memory since the last resetPeakMemory(), bytes (Linux's
/// VmHWM; 0 where /proc does not tell).
double peakMemoryBytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return 1024.0 * std::stod(line.substr(6));
  }
  return 0.0;
}

/// Resets the peak to the current resident memory (Linux: "5" into clear_refs).
void resetPeakMemory() { std::ofstream("/proc/self/clear_refs") << "5"; }

void BM_WorldScale(benchmark::State& state) {
  registerBuiltinPlugins();
  const double voxels = static_cast<double>(state.range(0));
  const bool sparse = state.range(1) != 0;
  const double resolution = 0.1;
  const double height = 8.0;
  const double side = std::floor(std::sqrt(voxels / (height / resolution)) * resolution);
  const std::string text =
      "name: scale\nseed: 3\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [" +
      std::to_string(side) + ", " + std::to_string(side) +
      ", 8]}\ngenerators: [{type: forest, density: 0.05, trunk_radius: [0.15, 0.3], "
      "trunk_height: [6, 8], min_spacing: 1.0, ground_plane: true}]\n" +
      (sparse ? "layout: sparse\ntruncation: 1.2\n" : "");
  const WorldSpec spec = WorldSpec::fromYaml(YamlReader::loadString(text, "scale.yaml"), ".");
  for (auto _ : state) {
    resetPeakMemory();
    const double before = peakMemoryBytes();  // the resident memory now
    const auto begin = Clock::now();
    VoxelGrid grid = World::buildGrid(spec);
    const auto built = Clock::now();
    Esdf esdf = sparse ? Esdf::truncated(grid, spec.truncation) : Esdf(grid);
    const auto distances = Clock::now();
    const auto world =
        std::make_shared<const World>("scale", spec.hash(), std::move(grid), std::move(esdf));
    const double peak = peakMemoryBytes();
    // Ten queries of 18-20 m (shorter in the smallest world) at 1-2 m, planned exact.
    Rng rng(5);
    const double distance = std::min(20.0, 0.7 * side);
    const auto queries = sampleFreeQueries(
        *world, {{{0.5, 0.5, 1.0}, {side - 0.5, side - 0.5, 2.0}}, 0.6, 0.9 * distance, distance},
        10, rng, "scale");
    ConfiguredPlanner lazy = configurePlanner(
        "lazy_mp_astar", parseAssignments({"time_limit=0", "max_expansions=500000"}, "benchmark"));
    lazy.planner->setup({world, 1});
    std::vector<double> times;
    int solved = 0;
    for (const PlanningQuery& query : queries) {
      const PlanResult result = lazy.planner->plan(query, Budget{});
      times.push_back(result.planning_time_ms);
      solved += result.status == PlanStatus::kExact && result.check.valid;
    }
    std::sort(times.begin(), times.end());
    state.counters["voxels"] = static_cast<double>(world->grid().size());
    state.counters["side_m"] = side;
    state.counters["build_s"] = secondsBetween(begin, built);
    state.counters["esdf_s"] = secondsBetween(built, distances);
    state.counters["esdf_ns_per_voxel"] =
        1e9 * secondsBetween(built, distances) / static_cast<double>(world->grid().size());
    state.counters["peak_bytes_per_voxel"] =
        (peak - before) / static_cast<double>(world->grid().size());
    state.counters["rest_bytes_per_voxel"] =
        static_cast<double>(world->grid().memoryBytes() + world->esdf().memoryBytes()) /
        static_cast<double>(world->grid().size());
    state.counters["sparse"] = sparse ? 1.0 : 0.0;
    state.counters["plan_median_ms"] = 0.5 * (times[4] + times[5]);
    state.counters["solved"] = solved;
  }
}
BENCHMARK(BM_WorldScale)
    ->ArgNames({"voxels", "sparse"})
    ->ArgsProduct({{1000000, 10000000, 100000000, 1000000000}, {0, 1}})
    ->Args({10000000000, 1})
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace kinolab
