// The corridor_minco back end after lazy MP-A* (order 2, its defaults, no time budget) on 20
// queries 8-20 m apart in the dense forest (configs/worlds/dense_forest.yaml, the paper's
// real-flight forest), with the planner's limits (v 2 m/s, a 3 m/s^2) and body (0.25 m).
// Per back-end order over the front end's exact answers: success (a trajectory that the
// independent checker accepts for the query), the median refine time (thread CPU time; the
// back end's phases, wall clock, from its statistics), and the share whose
// duration is no longer than the front end's. The front end runs once, outside the timing.
#include <benchmark/benchmark.h>

#include <ctime>
#include <map>
#include <string>

#include "forest_queries.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/planner/back_end.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab {
namespace {

struct DenseForest {
  std::shared_ptr<const World> world;
  ConfiguredPlanner front_end;
  std::vector<PlanningQuery> queries;
  std::vector<PlanResult> answers;  ///< the front end's exact answers, by query
};

const DenseForest& denseForest() {
  static const DenseForest forest = [] {
    registerBuiltinPlugins();
    DenseForest made;
    made.world = WorldCache(WorldCache::defaultDirectory())
                     .loadOrBuild(WorldSpec::fromFile(KINOLAB_SOURCE_DIR
                                                      "/configs/worlds/dense_forest.yaml"))
                     .world;
    made.front_end = configurePlanner("lazy_mp_astar", parseAssignments({"time_limit=0"}, "bench"));
    made.front_end.planner->setup({made.world, 1});
    Rng rng(2026);
    const FreeQueryRegion region{Box{{1.0, 1.0, 1.0}, {39.0, 39.0, 2.0}}, 0.6, 8.0, 20.0};
    for (const PlanningQuery& query : sampleFreeQueries(*made.world, region, 20, rng, "dense")) {
      PlanResult result = made.front_end.planner->plan(query, Budget{});
      if (result.status != PlanStatus::kExact || !result.check.valid) continue;
      made.queries.push_back(query);
      made.answers.push_back(std::move(result));
    }
    return made;
  }();
  return forest;
}

/// The thread's CPU time: what the refinement costs, without the machine's other load.
double threadMilliseconds() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return 1e3 * static_cast<double>(now.tv_sec) + 1e-6 * static_cast<double>(now.tv_nsec);
}

void BM_CorridorMincoDenseForest(benchmark::State& state) {
  const DenseForest& forest = denseForest();
  const Planner& front_end = *forest.front_end.planner;
  auto back_end = pluginRegistry<BackEnd>().create(
      "corridor_minco", parseAssignments({"order=" + std::to_string(state.range(0))}, "bench"));
  back_end->setup(forest.world, front_end.body(), front_end.limits());
  const TrajectoryChecker checker(forest.world,
                                  checkerSettings(front_end.body(), front_end.limits()));
  std::vector<double> milliseconds;
  std::vector<double> iterations;
  std::vector<double> duration_ratios;                // back end over front end
  std::map<std::string, std::vector<double>> phases;  // its time statistics
  int runs = 0;
  int valid = 0;
  int not_longer = 0;
  for (auto _ : state) {
    for (std::size_t i = 0; i < forest.answers.size(); ++i) {
      BackEndProblem problem;
      problem.start = forest.queries[i].start;
      problem.goal = forest.queries[i].goal;
      problem.path = backEndPath({}, forest.answers[i].trajectory);
      problem.front = &forest.answers[i].trajectory;
      StopCondition stop(Budget{});
      const double begin = threadMilliseconds();
      const BackEndResult result = back_end->refine(problem, stop);
      milliseconds.push_back(threadMilliseconds() - begin);
      for (const auto& [name, value] : result.statistics) {
        if (name == "minco_iterations") iterations.push_back(value);
        if (name.starts_with("minco_time_")) phases[name].push_back(value);
      }
      ++runs;
      if (!result.failure.empty()) continue;
      CheckQuery query;
      query.start = problem.start;
      query.goal = problem.goal;
      query.goal_radius = front_end.limits().goal_radius;
      if (!checker.check(result.trajectory, query).valid) continue;
      ++valid;
      duration_ratios.push_back(result.trajectory.duration() /
                                forest.answers[i].trajectory.duration());
      not_longer += result.trajectory.duration() <= forest.answers[i].trajectory.duration();
    }
  }
  state.counters["front_end_exact"] = static_cast<double>(forest.answers.size());
  state.counters["success_pct"] = 100.0 * valid / std::max(runs, 1);
  state.counters["not_longer_pct"] = 100.0 * not_longer / std::max(valid, 1);
  state.counters["median_ms"] = bench::median(milliseconds);
  state.counters["median_duration_ratio"] = bench::median(duration_ratios);
  state.counters["median_iterations"] = bench::median(iterations);
  for (const auto& [name, values] : phases) {
    state.counters["median_" + name.substr(std::string("minco_").size())] = bench::median(values);
  }
}
BENCHMARK(BM_CorridorMincoDenseForest)
    ->Arg(3)
    ->Arg(4)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kinolab
