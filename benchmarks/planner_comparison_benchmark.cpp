// The paper's Table II comparison on kinolab's planners: the TGK analogue (rrtstar_ceres),
// its front end alone (rrtstar), eager and lazy MP-A* (order 2 and 3, their defaults:
// epsilon 1), on the 50 forest queries of 8-20 m, with the same limits (v 2 m/s,
// a 3 m/s^2), robot radius 0.25 m and goal radius 0.5 m. Per planner over the queries:
// success (exact and accepted by the independent checker), median planning time, median
// trajectory duration, length and jerk integral of the successful ones. RRT* runs are
// iteration-bounded: 0, 200 or 1000 refinement iterations after the first solution.
#include <benchmark/benchmark.h>

#include "forest_queries.hpp"
#include "kinolab/builtin_plugins.hpp"

namespace kinolab {
namespace {

void compare(benchmark::State& state, const std::string& planner,
             const std::vector<std::string>& items) {
  registerBuiltinPlugins();
  ConfiguredPlanner configured = configurePlanner(planner, parseAssignments(items, "benchmark"));
  configured.planner->setup({bench::forest(), 1});
  std::vector<double> times;
  std::vector<double> durations;
  std::vector<double> lengths;
  std::vector<double> efforts;  // the integral of |a|^2: defined for every planner's trajectory
  int runs = 0;
  for (auto _ : state) {
    for (const PlanningQuery& query : bench::queries()) {
      configured.planner->reset();
      const PlanResult result = configured.planner->plan(query, Budget{});
      ++runs;
      times.push_back(result.planning_time_ms);
      if (result.status != PlanStatus::kExact || !result.check.valid) continue;
      durations.push_back(result.trajectory.duration());
      lengths.push_back(result.trajectory.length());
      efforts.push_back(result.evaluation.acceleration_integral);
    }
  }
  state.counters["success_pct"] = 100.0 * static_cast<double>(durations.size()) / runs;
  state.counters["median_ms"] = bench::median(times);
  state.counters["median_duration_s"] = bench::median(durations);
  state.counters["median_length_m"] = bench::median(lengths);
  state.counters["median_acceleration_integral"] = bench::median(efforts);
}

// The searches at their defaults: optimal (epsilon 1), 27 controls, tau 0.6 s.
const std::vector<std::string> kSearch = {"time_limit=0"};
std::vector<std::string> search(int order) {
  std::vector<std::string> items = kSearch;
  items.push_back("order=" + std::to_string(order));
  return items;
}

// The argument: RRT* refinement iterations after the first solution.
std::vector<std::string> sampling(const benchmark::State& state) {
  return {"time_limit=0", "refine_iterations=" + std::to_string(state.range(0))};
}
void BM_RrtStarCeres(benchmark::State& state) { compare(state, "rrtstar_ceres", sampling(state)); }
void BM_RrtStar(benchmark::State& state) { compare(state, "rrtstar", sampling(state)); }
void BM_EagerOrder2(benchmark::State& state) { compare(state, "eager_mp_astar", search(2)); }
void BM_LazyOrder2(benchmark::State& state) { compare(state, "lazy_mp_astar", search(2)); }
void BM_EagerOrder3(benchmark::State& state) { compare(state, "eager_mp_astar", search(3)); }
void BM_LazyOrder3(benchmark::State& state) { compare(state, "lazy_mp_astar", search(3)); }

#define KINOLAB_COMPARISON(name) BENCHMARK(name)->Iterations(1)->Unit(benchmark::kMillisecond)
KINOLAB_COMPARISON(BM_RrtStarCeres)->Arg(0)->Arg(200)->Arg(1000);
KINOLAB_COMPARISON(BM_RrtStar)->Arg(0)->Arg(1000);
KINOLAB_COMPARISON(BM_EagerOrder2);
KINOLAB_COMPARISON(BM_LazyOrder2);
KINOLAB_COMPARISON(BM_EagerOrder3);
KINOLAB_COMPARISON(BM_LazyOrder3);

}  // namespace
}  // namespace kinolab
