// Lazy against eager MP-A* on the forest world (configs/worlds/forest.yaml, 40 m x 40 m of
// trunks, like the paper's real-flight forest): 50 seeded queries 8 to 20 m apart at flight
// height, a small quadrotor's limits (v 2 m/s, a 3 m/s^2), tau 0.4 s, 125 controls (uniform,
// 5 per axis). Reported per variant over the queries: median planning time, expansions and
// full evaluations, and how many costs differ from eager's (lwa must report 0).
#include <benchmark/benchmark.h>

#include <map>
#include <numeric>

#include "forest_queries.hpp"
#include "kinolab/builtin_plugins.hpp"

namespace kinolab {
namespace {

using bench::forest;
using bench::median;
using bench::queries;
using bench::statistic;

/// Eager's cost per query and heuristic weight, to compare every variant against.
std::map<std::pair<std::size_t, int>, double>& eagerCosts() {
  static std::map<std::pair<std::size_t, int>, double> costs;
  return costs;
}

void planQueries(benchmark::State& state, const std::string& planner,
                 const std::vector<std::string>& extra) {
  registerBuiltinPlugins();
  const int weight = static_cast<int>(state.range(0));
  std::vector<std::string> items = {"sampler.samples_per_axis=5", "time_limit=0",
                                    "heuristic_weight=" + std::to_string(weight)};
  items.insert(items.end(), extra.begin(), extra.end());
  ConfiguredPlanner configured = configurePlanner(planner, parseAssignments(items, "benchmark"));
  configured.planner->setup({forest(), configured.sampler, 1});
  const bool eager = planner == "eager_mp_astar";
  std::vector<double> times;
  std::vector<double> expansions;
  std::vector<double> full;
  int solved = 0;
  int mismatches = 0;
  for (auto _ : state) {
    for (std::size_t q = 0; q < queries().size(); ++q) {
      configured.planner->reset();
      const PlanResult result = configured.planner->plan(queries()[q], Budget{});
      times.push_back(result.planning_time_ms);
      expansions.push_back(statistic(result, "expansions"));
      full.push_back(statistic(result, "full_evaluations"));
      solved += result.status == PlanStatus::kExact && result.check.valid;
      auto& costs = eagerCosts();
      if (eager) {
        costs[{q, weight}] = result.cost;
      } else if (auto found = costs.find({q, weight}); found != costs.end()) {
        mismatches += std::abs(found->second - result.cost) > 1e-9 * std::max(1.0, result.cost);
      }
    }
  }
  const double runs = static_cast<double>(times.size());
  state.counters["median_ms"] = median(times);
  state.counters["mean_ms"] = std::accumulate(times.begin(), times.end(), 0.0) / runs;
  state.counters["median_expansions"] = median(expansions);
  state.counters["median_full_evals"] = median(full);
  state.counters["solved_pct"] = 100.0 * solved / runs;
  state.counters["cost_differs"] = mismatches;
}

void BM_EagerMpAstar(benchmark::State& state) { planQueries(state, "eager_mp_astar", {}); }
void BM_LazyEndpoint(benchmark::State& state) {
  planQueries(state, "lazy_mp_astar", {"lower_bound=endpoint"});
}
void BM_LazyControlOnly(benchmark::State& state) {
  planQueries(state, "lazy_mp_astar", {"lower_bound=control_only"});
}
void BM_LazyLipschitz(benchmark::State& state) {
  planQueries(state, "lazy_mp_astar", {"lower_bound=lipschitz"});
}
void BM_LazySeedRule(benchmark::State& state) {
  planQueries(state, "lazy_mp_astar", {"duplicate_rule=seed"});
}

// Heuristic weight 2 (bounded suboptimal; lazy and eager still return the same cost) and 3.
// Eager runs first so the lazy variants can compare costs against it.
#define KINOLAB_SEARCH_BENCHMARK(name) \
  BENCHMARK(name)->Arg(2)->Arg(3)->Iterations(1)->Unit(benchmark::kMillisecond)
KINOLAB_SEARCH_BENCHMARK(BM_EagerMpAstar);
KINOLAB_SEARCH_BENCHMARK(BM_LazyEndpoint);
KINOLAB_SEARCH_BENCHMARK(BM_LazyControlOnly);
KINOLAB_SEARCH_BENCHMARK(BM_LazyLipschitz);
KINOLAB_SEARCH_BENCHMARK(BM_LazySeedRule);

}  // namespace
}  // namespace kinolab
