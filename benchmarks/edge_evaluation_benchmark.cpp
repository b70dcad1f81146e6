// Partial and full edge evaluation on the forest world (the paper's Fig. 2: 120 ns partial,
// 320 ns full), and control-set generation for every registered sampler.
#include <benchmark/benchmark.h>

#include <vector>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/primitives/edge_evaluator.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {
namespace {

const std::shared_ptr<const World>& forest() {
  static const auto world =
      World::build(WorldSpec::fromFile(KINOLAB_SOURCE_DIR "/configs/worlds/forest.yaml"));
  return world;
}

/// Primitives as a search meets them: starts in free space at flight height with velocities
/// within the limits, and from each start every control of the 5-per-axis uniform grid (125
/// edges), in that order, as an expansion evaluates them. `free_only` keeps the edges whose
/// full evaluation passes (every sample looked up: the worst case per edge); `scattered`
/// shuffles the edges over the whole 40 m x 40 m world, so almost every edge starts with
/// cold caches (a lower bound on what any search sees).
struct Workload {
  std::vector<ChainState> starts;
  std::vector<Eigen::Vector3d> controls;

  Workload(const EdgeEvaluator& evaluator, bool free_only, bool scattered) {
    const World& world = evaluator.world();
    Rng rng(8);
    while (starts.size() < 8192) {
      ChainState start = ChainState::Zero();
      start.col(0) = Eigen::Vector3d(rng.uniform(1, 39), rng.uniform(1, 39), rng.uniform(0.8, 2.5));
      if (!world.isFree(start.col(0), evaluator.settings().body.radius)) continue;
      start.col(1) =
          Eigen::Vector3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-0.5, 0.5));
      for (int x = -2; x <= 2; ++x) {
        for (int y = -2; y <= 2; ++y) {
          for (int z = -2; z <= 2; ++z) {
            const Eigen::Vector3d control(1.5 * x, 1.5 * y, 1.5 * z);
            if (free_only && !evaluator.full(start, control).valid()) continue;
            starts.push_back(start);
            controls.push_back(control);
          }
        }
      }
    }
    starts.resize(8192);
    controls.resize(8192);
    if (scattered) {
      for (std::size_t i = starts.size() - 1; i > 0; --i) {
        const auto j = static_cast<std::size_t>(rng.uniformInt(0, static_cast<std::int64_t>(i)));
        std::swap(starts[i], starts[j]);
        std::swap(controls[i], controls[j]);
      }
    }
  }
};

EdgeEvaluatorSettings benchmarkSettings(bool spacing) {
  EdgeEvaluatorSettings settings;
  settings.order = 2;
  settings.duration = 0.4;
  settings.limits = DynamicLimits::uniform(3.0, 3.0);
  settings.body.radius = 0.25;
  settings.sampling.samples = 10;
  if (spacing) {
    settings.sampling.mode = EdgeSampling::Mode::kSpacing;
    settings.sampling.spacing = 0.05;
  }
  return settings;
}

/// Arguments: full (0 = partial, 1 = full), free_only (0 = every edge, 1 = passing edges),
/// spacing (0 = K = 10, 1 = samples every 5 cm), scattered (0 = expansion order, 1 = shuffled).
void BM_EdgeEvaluation(benchmark::State& state) {
  const bool full = state.range(0) != 0;
  const EdgeEvaluator evaluator(forest(), benchmarkSettings(state.range(2) != 0));
  const Workload workload(evaluator, state.range(1) != 0, state.range(3) != 0);
  std::size_t i = 0;
  long long queries = 0;
  for (auto _ : state) {
    const EdgeEvaluation result = full
                                      ? evaluator.full(workload.starts[i], workload.controls[i])
                                      : evaluator.partial(workload.starts[i], workload.controls[i]);
    benchmark::DoNotOptimize(result.cost);
    queries += result.esdf_queries;
    i = (i + 1) & 8191;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["esdf_queries_per_edge"] =
      static_cast<double>(queries) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_EdgeEvaluation)
    ->ArgNames({"full", "free_only", "spacing", "scattered"})
    ->Args({0, 0, 0, 0})
    ->Args({1, 0, 0, 0})
    ->Args({0, 1, 0, 0})
    ->Args({1, 1, 0, 0})
    ->Args({1, 1, 1, 0})
    ->Args({0, 1, 0, 1})
    ->Args({1, 1, 0, 1});

/// The control set of each sampler with its defaults (5 per axis, 125 controls).
void BM_ControlSet(benchmark::State& state, const std::string& key) {
  registerBuiltinPlugins();
  const auto sampler = pluginRegistry<ControlSampler>().create(key, {});
  std::uint64_t seed = 1;
  for (auto _ : state) {
    auto controls = sampler->sample(Eigen::Vector3d(3, 3, 3), seed++);
    benchmark::DoNotOptimize(controls.data());
  }
}
BENCHMARK_CAPTURE(BM_ControlSet, uniform, std::string("uniform"));
BENCHMARK_CAPTURE(BM_ControlSet, normal, std::string("normal"));
BENCHMARK_CAPTURE(BM_ControlSet, random, std::string("random"));

}  // namespace
}  // namespace kinolab
