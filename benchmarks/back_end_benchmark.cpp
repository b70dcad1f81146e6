// Back ends after front ends on the dense forest (configs/worlds/dense_forest.yaml; issue 53's
// goals): 30 seeded queries 8 to 20 m apart, each front end planned once at its defaults with
// no back end, then the back end refines every answer in turn. Reported per front end x back
// end pair over the front end's exact answers: the median refine time (`median_ms`, the
// thread's CPU time: the machine's other load aside), the share the independent checker
// accepts (`valid`), the median ratio of the back end's trajectory duration to the front
// end's (`duration_ratio`; a geometric front end's is its path flown stop-and-go) and the
// share no longer than it (`not_longer`), and the median of every statistic the back end
// reports (`median_NAME`: its iterations, rounds, phase times). The front end ran before.
//   ./build/benchmarks/kinolab_benchmarks --benchmark_filter=BackEnd
#include <benchmark/benchmark.h>

#include <array>
#include <ctime>
#include <map>

#include "forest_queries.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/planner/back_end.hpp"

namespace kinolab {
namespace {

constexpr std::array<const char*, 4> kFrontEnds = {"lazy_mp_astar", "hybrid_astar", "bitstar",
                                                   "grid_astar"};
/// The back ends, with the settings a variant sets (`KEY` or `KEY:NAME=VALUE`).
constexpr std::array<const char*, 4> kBackEnds = {"bspline", "corridor_minco",
                                                  "corridor_minco:order=4", "ego_bspline"};

/// The thread's CPU time, ms.
double threadMilliseconds() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return 1e3 * static_cast<double>(now.tv_sec) + 1e-6 * static_cast<double>(now.tv_nsec);
}

const std::shared_ptr<const World>& denseForest() {
  static const auto world = bench::shippedWorld("dense_forest");
  return world;
}

/// A front end's exact answers, planned once per process, and the planner that made them
/// (its body and limits are the back end's).
struct FrontAnswers {
  ConfiguredPlanner planner;
  std::vector<PlanningQuery> queries;
  std::vector<PlanResult> results;
};

const FrontAnswers& frontAnswers(const std::string& front) {
  // Never destroyed: its planners come from modules loaded on use (OMPL's), whose libraries'
  // statics are torn down at exit before an object made before the module was loaded.
  static auto& cache = *new std::map<std::string, FrontAnswers>;
  if (auto found = cache.find(front); found != cache.end()) return found->second;
  FrontAnswers& answers = cache[front];
  std::vector<std::string> items = {"time_limit=0"};
  std::string key = front;
  if (front == "bitstar") {
    key = "ompl_geometric";
    items = {"planner=bitstar", "stop_at_first=true", "time_limit=1"};
  }
  answers.planner = configurePlanner(key, parseAssignments(items, "benchmark"));
  answers.planner.planner->setup({denseForest(), 1});
  Rng rng(53);
  const FreeQueryRegion region{Box{{1.0, 1.0, 1.0}, {39.0, 39.0, 2.0}}, 0.6, 8.0, 20.0};
  for (const PlanningQuery& query : sampleFreeQueries(*denseForest(), region, 30, rng, "dense")) {
    PlanResult result = answers.planner.planner->plan(query, Budget{INFINITY, 2000000});
    if (result.status != PlanStatus::kExact) continue;
    answers.queries.push_back(query);
    answers.results.push_back(std::move(result));
  }
  return answers;
}

void BM_BackEnd(benchmark::State& state) {
  registerBuiltinPlugins();
  const std::string front = kFrontEnds.at(static_cast<std::size_t>(state.range(0)));
  const std::string variant = kBackEnds.at(static_cast<std::size_t>(state.range(1)));
  const std::string key = variant.substr(0, variant.find(':'));
  std::vector<std::string> settings;
  if (variant.find(':') != std::string::npos) settings.push_back(variant.substr(key.size() + 1));
  state.SetLabel(front + " + " + variant);
  if (!pluginRegistry<BackEnd>().contains(key) ||
      !pluginRegistry<Planner>().contains(front == "bitstar" ? "ompl_geometric" : front)) {
    state.SkipWithError((front + " or " + key + " is not registered").c_str());
    return;
  }
  const FrontAnswers& answers = frontAnswers(front);
  const Planner& planner = *answers.planner.planner;
  const std::unique_ptr<BackEnd> back_end =
      pluginRegistry<BackEnd>().create(key, parseAssignments(settings, "benchmark"));
  back_end->setup(denseForest(), planner.body(), planner.limits());
  const TrajectoryChecker checker(denseForest(), checkerSettings(planner.body(), planner.limits()));
  std::vector<double> times;
  std::vector<double> ratios;
  std::map<std::string, std::vector<double>> own;  // its iterations and phase times
  int valid = 0;
  for (auto _ : state) {
    for (std::size_t q = 0; q < answers.results.size(); ++q) {
      const PlanResult& front_result = answers.results[q];
      BackEndProblem problem{answers.queries[q].start, answers.queries[q].goal,
                             backEndPath(front_result.path, front_result.trajectory),
                             front_result.trajectory.empty() ? nullptr : &front_result.trajectory};
      StopCondition stop(Budget{});
      const double begin = threadMilliseconds();
      const BackEndResult result = back_end->refine(problem, stop);
      times.push_back(threadMilliseconds() - begin);
      for (const auto& [name, value] : result.statistics) {
        own[name].push_back(value);
      }
      if (result.trajectory.empty()) continue;
      CheckQuery query{problem.start, problem.goal, planner.limits().goal_radius};
      query.require_goal = false;
      if (!checker.check(result.trajectory, query).valid) continue;
      ++valid;
      ratios.push_back(result.trajectory.duration() / front_result.trajectory.duration());
    }
  }
  const double answered = static_cast<double>(answers.results.size());
  state.counters["answers"] = answered;
  state.counters["valid"] = answered > 0 ? valid / answered : 0.0;
  state.counters["median_ms"] = bench::median(times);
  state.counters["duration_ratio"] = bench::median(ratios);
  state.counters["not_longer"] =
      ratios.empty() ? 0.0
                     : static_cast<double>(std::count_if(ratios.begin(), ratios.end(),
                                                         [](double r) { return r <= 1.0; })) /
                           static_cast<double>(ratios.size());
  for (const auto& [name, values] : own) state.counters["median_" + name] = bench::median(values);
}
BENCHMARK(BM_BackEnd)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1, 2, 3}})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kinolab
