// Closed-form propagation of one motion primitive and its exact limit check.
#include <benchmark/benchmark.h>

#include <vector>

#include "kinolab/core/random.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"

namespace kinolab {
namespace {

struct Primitives {
  std::vector<ChainState> states;
  std::vector<Eigen::Vector3d> controls;

  Primitives(int order, std::size_t count) {
    Rng rng(4);
    for (std::size_t i = 0; i < count; ++i) {
      ChainState s = ChainState::Zero();
      for (int k = 0; k < order; ++k) {
        s.col(k) = Eigen::Vector3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2));
      }
      states.push_back(s);
      controls.emplace_back(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    }
  }
};

/// End state of a constant-control primitive; argument = the chain's order.
void BM_PrimitivePropagation(benchmark::State& state) {
  const int order = static_cast<int>(state.range(0));
  const IntegratorChain chain(order);
  const Primitives primitives(order, 1024);
  std::size_t i = 0;
  for (auto _ : state) {
    ChainState end = chain.propagate(primitives.states[i], primitives.controls[i], 0.4);
    benchmark::DoNotOptimize(end.data());
    i = (i + 1) & 1023;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PrimitivePropagation)->DenseRange(2, 4);

/// Exact limit check over the whole primitive; argument = the chain's order.
void BM_PrimitiveLimitCheck(benchmark::State& state) {
  const int order = static_cast<int>(state.range(0));
  const IntegratorChain chain(order);
  const Primitives primitives(order, 1024);
  const DynamicLimits limits = DynamicLimits::uniform(3.0, 3.0, 6.0, 12.0);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        chain.withinLimits(primitives.states[i], primitives.controls[i], 0.4, limits));
    i = (i + 1) & 1023;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PrimitiveLimitCheck)->DenseRange(2, 4);

}  // namespace
}  // namespace kinolab
