// ESDF build and query kernels. Figures are per voxel (build) and per query.
#include <benchmark/benchmark.h>

#include <span>
#include <vector>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/world/esdf.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {
namespace {

VoxelGrid randomGrid(const Eigen::Vector3i& dims, double occupancy, double resolution = 0.1) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * resolution}, resolution);
  Rng rng(1);
  for (std::size_t i = 0; i < grid.size(); ++i) grid.setOccupied(i, rng.uniform01() < occupancy);
  return grid;
}

/// Queries in batches of kBatch points summed together, as edge evaluation does; the figure
/// is per query (items_per_second), not per batch.
constexpr std::size_t kBatch = 256;

/// With `batched`, each batch is one Esdf::distancesWithGradients() call (the same values).
void runGradientQueries(benchmark::State& state, const Esdf& esdf,
                        const std::vector<Eigen::Vector3d>& points, bool batched = false) {
  std::size_t start = 0;
  std::vector<double> distances(kBatch);
  std::vector<Eigen::Vector3d> gradients(kBatch);
  for (auto _ : state) {
    double sum = 0.0;
    if (batched) {
      esdf.distancesWithGradients(std::span(points).subspan(start, kBatch), distances, gradients);
      for (std::size_t k = 0; k < kBatch; ++k) {
        sum += distances[k] + gradients[k].x() + gradients[k].y() + gradients[k].z();
      }
    } else {
      Eigen::Vector3d gradient;
      for (std::size_t k = 0; k < kBatch; ++k) {
        sum += esdf.distanceWithGradient(points[start + k], &gradient);
        sum += gradient.x() + gradient.y() + gradient.z();
      }
    }
    benchmark::DoNotOptimize(sum);
    start = (start + kBatch) & (points.size() - 1);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kBatch));
  state.SetLabel(batched ? "batched" : "one by one");
}

/// Builds the signed ESDF of `grid` once per iteration on `threads` threads; reports wall ns
/// per voxel (the benchmarks use real time, so that threads show as a speed-up).
void runEsdfBuild(benchmark::State& state, const VoxelGrid& grid, int threads = 1) {
  for (auto _ : state) {
    Esdf esdf(grid, threads);
    benchmark::DoNotOptimize(esdf.values().data());
  }
  state.counters["ns_per_voxel"] = benchmark::Counter(
      static_cast<double>(grid.size()) * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// The build benchmarks' arguments: occupancy 5 and 20 %, on 1 and 2 threads, wall time.
void buildArguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"occupancy", "threads"});
  for (const int threads : {1, 2}) {
    for (const int occupancy : {5, 20}) b->Args({occupancy, threads});
  }
  b->UseRealTime()->Unit(benchmark::kMillisecond);
}

/// Signed exact ESDF of a 200 x 200 x 60 grid with independent random occupancy (percent in
/// the first argument) on threads (the second): both the outside and the inside transform.
void BM_EsdfBuild(benchmark::State& state) {
  const VoxelGrid grid = randomGrid({200, 200, 60}, state.range(0) / 100.0);
  runEsdfBuild(state, grid, static_cast<int>(state.range(1)));
}
BENCHMARK(BM_EsdfBuild)->Apply(buildArguments);

/// The same build on a world-like 200 x 200 x 60 grid: random boxes standing on the floor
/// until the occupancy (percent in the argument) is reached.
void BM_EsdfBuildBoxesWorld(benchmark::State& state) {
  const double target = state.range(0) / 100.0;
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(20.0, 20.0, 6.0)}, 0.1);
  Rng rng(3);
  while (static_cast<double>(grid.occupiedCount()) < target * grid.size()) {
    const Eigen::Vector3d min(rng.uniform(0, 19), rng.uniform(0, 19), 0.0);
    grid.fillBox(min, min + Eigen::Vector3d(rng.uniform(0.2, 1.5), rng.uniform(0.2, 1.5),
                                            rng.uniform(1.0, 6.0)));
  }
  runEsdfBuild(state, grid, static_cast<int>(state.range(1)));
}
BENCHMARK(BM_EsdfBuildBoxesWorld)->Apply(buildArguments);

/// A sparse world's truncated field (Esdf::truncated, T = 1.3 m) of a city block at 0.2 m:
/// 102.4 m x 102.4 m x 60 m (78.6 M voxels; configs/worlds/city.yaml's streets, lots and street
/// trees with buildings of 8-55 m), on 1 and 2 threads (the argument), wall time. The 1 km city
/// of docs/worlds.md is this 95 times over.
void BM_EsdfTruncatedBuildCity(benchmark::State& state) {
  registerBuiltinPlugins();
  const WorldSpec spec = WorldSpec::fromYaml(
      YamlReader::loadString("name: city\nseed: 11\nresolution: 0.2\nlayout: sparse\n"
                             "truncation: 1.3\nbounds: {min: [0, 0, 0], max: [102.4, 102.4, 60]}\n"
                             "generators: [{type: city, block_size: [40, 80], street_width: 15, "
                             "lot_size: [12, 30], setback: 2, building_height: [8, 55], "
                             "building_probability: 0.85, tree_spacing: 12, ground_plane: true}]\n",
                             "city.yaml"),
      ".");
  const VoxelGrid grid = World::buildGrid(spec);
  for (auto _ : state) {
    Esdf esdf = Esdf::truncated(grid, spec.truncation, static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(esdf.allocatedBricks());
  }
  state.counters["ns_per_voxel"] = benchmark::Counter(
      static_cast<double>(grid.size()) * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_EsdfTruncatedBuildCity)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

/// A flight's planning window built anew (a 108 x 108 x 28 grid, the default window with its
/// reach; random boxes on the floor to 5 %): Esdf (arg 0) against IncrementalEsdf (arg 1),
/// which keeps every pass's result to update later. Wall ns per voxel, one thread.
void BM_WindowEsdfBuild(benchmark::State& state) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(10.8, 10.8, 2.8)}, 0.1);
  Rng rng(3);
  while (static_cast<double>(grid.occupiedCount()) < 0.05 * grid.size()) {
    const Eigen::Vector3d min(rng.uniform(0, 10), rng.uniform(0, 10), 0.0);
    grid.fillBox(min, min + Eigen::Vector3d(rng.uniform(0.2, 0.6), rng.uniform(0.2, 0.6), 2.8));
  }
  for (auto _ : state) {
    if (state.range(0) == 0) {
      Esdf esdf(grid, 1);
      benchmark::DoNotOptimize(esdf.values().data());
    } else {
      IncrementalEsdf esdf(grid);
      benchmark::DoNotOptimize(&esdf);
    }
  }
  state.SetLabel(state.range(0) == 0 ? "Esdf" : "IncrementalEsdf");
  state.counters["ns_per_voxel"] = benchmark::Counter(
      static_cast<double>(grid.size()) * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_WindowEsdfBuild)->Arg(0)->Arg(1)->UseRealTime()->Unit(benchmark::kMillisecond);

/// Trilinear distance + gradient at random points; `side` = voxels per axis in x and y
/// (16 x 16 x 16 floats = 16 KiB fits in L1/L2; 512 x 512 x 64 floats = 64 MiB does not);
/// `huge_pages` 0: the same values in a copy on ordinary pages (Esdf itself advises huge
/// pages), side by side in one run; `batched` 1: 256 points a call to
/// Esdf::distancesWithGradients() instead of one query at a time.
void BM_DistanceWithGradient(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const int height = side >= 256 ? 64 : side;
  const VoxelGrid grid = randomGrid({side, side, height}, 0.02);
  const Esdf built(grid);
  const Esdf plain =
      state.range(1) ? Esdf()
                     : Esdf(grid, std::vector<float>(built.values().begin(), built.values().end()));
  const Esdf& esdf = state.range(1) ? built : plain;
  Rng rng(2);
  std::vector<Eigen::Vector3d> points(1 << 16);
  const Eigen::Vector3d extent = grid.bounds().size();
  for (auto& p : points) {
    p = {rng.uniform(0, extent.x()), rng.uniform(0, extent.y()), rng.uniform(0, extent.z())};
  }
  runGradientQueries(state, esdf, points, state.range(2) == 1);
  state.counters["grid_MiB"] = static_cast<double>(grid.size() * sizeof(float)) / (1 << 20);
}
BENCHMARK(BM_DistanceWithGradient)
    ->ArgNames({"side", "huge_pages", "batched"})
    ->Args({16, 1, 0})
    ->Args({16, 1, 1})
    ->Args({512, 0, 0})
    ->Args({512, 1, 0})
    ->Args({512, 1, 1});

/// The same query on the 64 MiB grid, but at points 5 cm apart along random 4 m segments:
/// the access pattern of edge evaluation, where consecutive queries share cache lines.
void BM_DistanceWithGradientAlongSegments(benchmark::State& state) {
  const VoxelGrid grid = randomGrid({512, 512, 64}, 0.02);
  const Esdf esdf(grid);
  Rng rng(2);
  std::vector<Eigen::Vector3d> points;
  const Eigen::Vector3d extent = grid.bounds().size();
  while (points.size() < (1 << 16)) {
    const Eigen::Vector3d a(rng.uniform(0, extent.x()), rng.uniform(0, extent.y()),
                            rng.uniform(0, extent.z()));
    Eigen::Vector3d direction(rng.normal(), rng.normal(), 0.2 * rng.normal());
    direction.normalize();
    for (int k = 0; k < 80; ++k) points.push_back(a + direction * (0.05 * k));
  }
  points.resize(1 << 16);
  runGradientQueries(state, esdf, points, state.range(0) == 1);
}
BENCHMARK(BM_DistanceWithGradientAlongSegments)->ArgName("batched")->Arg(0)->Arg(1);

/// Trilinear distance only, and the nearest-voxel lookup, on the in-cache grid.
void BM_DistanceQueries(benchmark::State& state) {
  const VoxelGrid grid = randomGrid({16, 16, 16}, 0.02);
  const Esdf esdf(grid);
  Rng rng(3);
  std::vector<Eigen::Vector3d> points(1 << 12);
  for (auto& p : points) p = {rng.uniform(0, 1.6), rng.uniform(0, 1.6), rng.uniform(0, 1.6)};
  std::size_t start = 0;
  const bool nearest = state.range(0) == 1;
  for (auto _ : state) {
    double sum = 0.0;
    for (std::size_t k = 0; k < kBatch; ++k) {
      const Eigen::Vector3d& p = points[start + k];
      sum += nearest ? esdf.nearestDistance(p) : esdf.distance(p);
    }
    benchmark::DoNotOptimize(sum);
    start = (start + kBatch) & (points.size() - 1);
  }
  state.SetLabel(nearest ? "nearest voxel" : "trilinear");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kBatch));
}
BENCHMARK(BM_DistanceQueries)->Arg(0)->Arg(1);

}  // namespace
}  // namespace kinolab
