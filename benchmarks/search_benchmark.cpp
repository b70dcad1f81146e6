// Lazy against eager MP-A*, side by side: every variant plans each query in turn, a few
// rounds, and keeps its fastest time per query (the machine is shared: the minimum is the
// least disturbed figure). Reported per variant over the queries: median planning time,
// median expansions, the median of the per-query ratio eager time / variant time
// (`speedup`), and how many costs differ from eager's (must be 0 for every lwa variant).
//
// Two problem sets:
//  - Forest: configs/worlds/forest.yaml, 50 seeded queries 10 to 30 m apart at 1-2 m, the
//    planners' defaults (epsilon 1, uniform 5 per axis, tau 0.4, the lattice heuristic): the
//    paper's scale; `*_paper` with the paper's heuristic (time_optimal).
//  - Mpl: experiments/mpl_benchmark.yaml, the standard motion-primitive benchmark problem
//    (60 pillars, order 2, tau 1, 27 controls, point robot), with that file's parameters
//    (its `*_paper` planners with the paper's heuristic, the others at kinolab's default).
#include <benchmark/benchmark.h>

#include <array>
#include <map>

#include "forest_queries.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace kinolab {
namespace {

using bench::median;
using bench::statistic;

struct Variant {
  std::string id;
  std::string planner;
  std::vector<ParameterAssignment> assignments;
};

struct Problem {
  std::shared_ptr<const World> world;
  std::vector<PlanningQuery> queries;
  std::vector<Variant> variants;  ///< the first is eager, the reference
};

std::vector<ParameterAssignment> assignments(const std::vector<std::string>& items) {
  return parseAssignments(items, "benchmark");
}

const Problem& forestProblem() {
  static const Problem problem = [] {
    registerBuiltinPlugins();  // the forest's generator is a plugin
    Problem p{bench::forest(), bench::paperScaleQueries(), {}};
    const std::vector<std::string> base = {"time_limit=0"};
    const auto with = [&](std::vector<std::string> extra) {
      extra.insert(extra.end(), base.begin(), base.end());
      return assignments(extra);
    };
    p.variants = {{"eager", "eager_mp_astar", with({})},
                  {"lazy", "lazy_mp_astar", with({})},
                  {"lazy_lipschitz", "lazy_mp_astar", with({"lower_bound=lipschitz"})},
                  {"lazy_control_only", "lazy_mp_astar", with({"lower_bound=control_only"})},
                  {"eager_paper", "eager_mp_astar", with({"heuristic=time_optimal"})},
                  {"lazy_paper", "lazy_mp_astar", with({"heuristic=time_optimal"})}};
    return p;
  }();
  return problem;
}

const Problem& mplProblem() {
  static const Problem problem = [] {
    registerBuiltinPlugins();
    const Experiment experiment =
        Experiment::fromFile(KINOLAB_SOURCE_DIR "/experiments/mpl_benchmark.yaml");
    const ExperimentVariant& variant = experiment.variants.front();
    const ExperimentWorld& world_spec = variant.worlds.front();
    Problem p;
    p.world = WorldCache(WorldCache::defaultDirectory()).loadOrBuild(world_spec.spec).world;
    p.queries = variant.queries.make(*p.world, world_spec.id, experiment.seed);
    for (const ExperimentPlanner& planner : variant.planners) {
      auto items = planner.assignments;
      items.push_back({"time_limit", "0", "benchmark"});
      p.variants.push_back({planner.id, planner.type, items});
    }
    return p;
  }();
  return problem;
}

void planSideBySide(benchmark::State& state, const Problem& problem) {
  registerBuiltinPlugins();
  std::vector<ConfiguredPlanner> planners;
  for (const Variant& variant : problem.variants) {
    planners.push_back(configurePlanner(variant.planner, variant.assignments));
    planners.back().planner->setup({problem.world, 1});
  }
  const std::size_t n = problem.queries.size();
  const std::size_t v = planners.size();
  // Fastest time, expansions, cost per (variant, query).
  std::vector<std::vector<double>> times(v, std::vector<double>(n, INFINITY));
  std::vector<std::vector<double>> expansions(v, std::vector<double>(n, 0.0));
  std::vector<std::vector<double>> costs(v, std::vector<double>(n, INFINITY));
  std::vector<int> solved(v, 0);
  const int rounds = static_cast<int>(state.range(0));
  for (auto _ : state) {
    for (int round = 0; round < rounds; ++round) {
      for (std::size_t q = 0; q < n; ++q) {
        for (std::size_t i = 0; i < v; ++i) {
          planners[i].planner->reset();
          const PlanResult result = planners[i].planner->plan(problem.queries[q], Budget{});
          times[i][q] = std::min(times[i][q], result.planning_time_ms);
          expansions[i][q] = statistic(result, "expansions");
          costs[i][q] = result.cost;
          if (round == 0) solved[i] += result.status == PlanStatus::kExact && result.check.valid;
        }
      }
    }
  }
  for (std::size_t i = 0; i < v; ++i) {
    const std::string& id = problem.variants[i].id;
    std::vector<double> ratios;
    int differs = 0;
    for (std::size_t q = 0; q < n; ++q) {
      ratios.push_back(times[0][q] / times[i][q]);
      differs += std::abs(costs[0][q] - costs[i][q]) > 1e-9 * std::max(1.0, costs[0][q]);
    }
    state.counters[id + "_ms"] = median(times[i]);
    state.counters[id + "_N"] = median(expansions[i]);
    state.counters[id + "_solved"] = solved[i];
    if (i > 0) {
      state.counters[id + "_speedup"] = median(ratios);
      state.counters[id + "_cost_differs"] = differs;
    }
  }
}

// Parallel edge evaluation (`threads`) on evaluation-heavy problems, with 80 obstacle-cost
// samples an edge and the paper's heuristic (so that the search expands thousands of states),
// at 1, 2, 4 and 8 threads: eager (a state's successors at once) and lazy (the open list's next
// edges made ahead); `speedup` is against the same planner at one thread, `cost_differs` must
// be 0. The forest at the paper's scale, its first 20 queries; and the walls (a maze of 5 m
// cells with doorways, configs/worlds/walls.yaml), 10 seeded joined queries 8-16 m apart (3 of
// them no_solution: searches that expand every state).
Problem threadsProblem(const std::string& planner, const std::string& id, bool walls) {
  registerBuiltinPlugins();
  std::vector<PlanningQuery> queries;
  std::shared_ptr<const World> world = bench::forest();
  if (walls) {
    world = bench::shippedWorld("walls");
    Rng rng(54);
    FreeQueryRegion region{Box{{1.0, 1.0, 1.0}, {29.0, 29.0, 2.0}}, 0.6, 8.0, 16.0};
    region.connected_radius = 0.3;  // no pair in cells the maze does not join
    queries = sampleFreeQueries(*world, region, 10, rng, "walls");
  } else {
    queries = bench::paperScaleQueries();
    queries.resize(std::min<std::size_t>(queries.size(), 20));
  }
  Problem p{world, queries, {}};
  for (const int threads : {1, 2, 4, 8}) {
    p.variants.push_back({id + "_t" + std::to_string(threads), planner,
                          assignments({"time_limit=0", "edge_samples=80", "heuristic=time_optimal",
                                       "threads=" + std::to_string(threads)})});
  }
  return p;
}

void BM_ForestPaperScale(benchmark::State& state) { planSideBySide(state, forestProblem()); }
void BM_ParallelEvaluation(benchmark::State& state) {
  static const Problem problem = threadsProblem("eager_mp_astar", "eager", false);
  planSideBySide(state, problem);
}
void BM_ParallelLazyEvaluation(benchmark::State& state) {
  static const Problem problem = threadsProblem("lazy_mp_astar", "lazy", false);
  planSideBySide(state, problem);
}
void BM_ParallelEvaluationWalls(benchmark::State& state) {
  static const Problem problem = threadsProblem("eager_mp_astar", "eager", true);
  planSideBySide(state, problem);
}
void BM_ParallelLazyEvaluationWalls(benchmark::State& state) {
  static const Problem problem = threadsProblem("lazy_mp_astar", "lazy", true);
  planSideBySide(state, problem);
}
void BM_MplProblem(benchmark::State& state) { planSideBySide(state, mplProblem()); }

// The argument is the number of rounds (the fastest of them is kept per query).
BENCHMARK(BM_ForestPaperScale)->Arg(3)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MplProblem)->Arg(3)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ParallelEvaluation)->Arg(2)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ParallelLazyEvaluation)->Arg(2)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ParallelEvaluationWalls)->Arg(2)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ParallelLazyEvaluationWalls)->Arg(2)->Iterations(1)->Unit(benchmark::kMillisecond);

// The geodesic heuristic's work per query (its search over the map's free space, which counts
// as planning time) on the MPL problem's world (2.4 million voxels), towards each query's goal:
// what a search pays before its first expansion (the field grown until it reaches the start).
void BM_GeodesicHeuristicPerQuery(benchmark::State& state) {
  const Problem& problem = mplProblem();
  EdgeEvaluatorSettings edges;
  edges.duration = 1.0;
  edges.limits = DynamicLimits::uniform(2.0, 1.0);
  edges.body.radius = 0.0;
  const auto heuristic = heuristicFor("geodesic", edges, 0.01);
  std::size_t query = 0;
  for (auto _ : state) {
    StopCondition never(Budget{});
    const PlanningQuery& planning = problem.queries[query++ % problem.queries.size()];
    const auto prepared = heuristicForQuery(heuristic, *problem.world, planning.goal, never);
    benchmark::DoNotOptimize(prepared->estimate(planning.start, planning.goal));
  }
  state.counters["voxels"] = static_cast<double>(problem.world->grid().size());
}
BENCHMARK(BM_GeodesicHeuristicPerQuery)->Unit(benchmark::kMillisecond);

// A planner's setup on the MPL problem's world: the controls sampled and the heuristic built
// and prepared for them (the lattice heuristic's tables), what validation, each worker and
// each flight replan pay before the first query. The argument picks the heuristic.
void BM_PlannerSetup(benchmark::State& state) {
  registerBuiltinPlugins();
  const Problem& problem = mplProblem();
  static const std::array<const char*, 3> kHeuristics = {"time_optimal", "lattice", "max"};
  const char* heuristic = kHeuristics.at(static_cast<std::size_t>(state.range(0)));
  auto items = problem.variants.front().assignments;
  items.push_back({"heuristic", heuristic, "benchmark"});
  const ConfiguredPlanner planner = configurePlanner("lazy_mp_astar", items);
  for (auto _ : state) planner.planner->setup({problem.world, 1});
  state.SetLabel(heuristic);
}
BENCHMARK(BM_PlannerSetup)->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);

/// The exact trajectories the problem's first planner finds, with their checks' queries, and
/// a checker for them.
struct PlannedTrajectories {
  std::vector<std::pair<Trajectory, CheckQuery>> plans;
  std::unique_ptr<TrajectoryChecker> checker;
};

PlannedTrajectories plannedTrajectories(const Problem& problem) {
  registerBuiltinPlugins();
  const Variant& first = problem.variants.front();
  ConfiguredPlanner planner = configurePlanner(first.planner, first.assignments);
  planner.planner->setup({problem.world, 1});
  PlannedTrajectories planned;
  for (const PlanningQuery& query : problem.queries) {
    const PlanResult result = planner.planner->plan(query, Budget{});
    if (result.status == PlanStatus::kExact) {
      planned.plans.emplace_back(
          result.trajectory,
          CheckQuery{query.start, query.goal, planner.planner->limits().goal_radius});
    }
  }
  planned.checker = std::make_unique<TrajectoryChecker>(
      problem.world, checkerSettings(planner.planner->body(), planner.planner->limits()));
  return planned;
}

// The independent check of every forest trajectory eager plans (the check every run pays
// after planning, outside its planning time): time per trajectory, and position samples
// checked per trajectory (`samples`); items are trajectories.
void BM_CheckForestTrajectories(benchmark::State& state) {
  const PlannedTrajectories planned = plannedTrajectories(forestProblem());
  double samples = 0.0;
  for (auto _ : state) {
    for (const auto& [trajectory, query] : planned.plans) {
      const CheckResult check = planned.checker->check(trajectory, query);
      benchmark::DoNotOptimize(check.valid);
      samples += check.samples;
    }
  }
  const double checked = static_cast<double>(state.iterations() * planned.plans.size());
  state.SetItemsProcessed(static_cast<std::int64_t>(checked));
  state.counters["samples"] = samples / checked;
}
BENCHMARK(BM_CheckForestTrajectories)->Unit(benchmark::kMillisecond);

// The figures every run reports of its trajectory (TrajectoryChecker::evaluate(): clearance
// from the exact distance at every position sample, the integrals), after the planner's clock
// stopped: time per trajectory of the first planner of the forest (0) and the MPL problem (1).
void BM_TrajectoryFigures(benchmark::State& state) {
  const PlannedTrajectories planned =
      plannedTrajectories(state.range(0) == 0 ? forestProblem() : mplProblem());
  for (auto _ : state) {
    for (const auto& plan : planned.plans) {
      benchmark::DoNotOptimize(planned.checker->evaluate(plan.first).mean_clearance);
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * planned.plans.size()));
  state.SetLabel(state.range(0) == 0 ? "forest" : "mpl");
}
BENCHMARK(BM_TrajectoryFigures)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kinolab
