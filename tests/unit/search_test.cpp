#include <gtest/gtest.h>

#include "kinolab/core/random.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"
#include "kinolab/search/motion_primitive_search.hpp"
#include "kinolab/search/search_policies.hpp"
#include "support/planning.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

ChainState randomState(Rng& rng, const World& world, int order) {
  ChainState state = ChainState::Zero();
  for (;;) {
    state.col(0) =
        Eigen::Vector3d(rng.uniform(0.5, 11.5), rng.uniform(0.5, 11.5), rng.uniform(0.5, 2.5));
    if (world.isFree(state.col(0), 0.3)) break;
  }
  for (int k = 1; k < order; ++k) {
    for (int axis = 0; axis < 3; ++axis) state(axis, k) = rng.uniform(-1.5, 1.5);
  }
  return state;
}

TEST(SearchHeuristic, EveryBuiltInHeuristicIsConsistentWithTheWeakestLowerBound) {
  const auto world = test::smallWorld("forest");
  Rng rng(4);
  EdgeEvaluatorSettings settings;
  settings.weights.length = 0.5;
  const EdgeEvaluator evaluator(world, settings);
  const double goal_radius = 0.5;
  const EuclideanHeuristic euclidean(settings, goal_radius);
  const MinTimeHeuristic min_time(settings, goal_radius);
  const auto controls = controlGrid({-1.0, -0.3, 0.0, 0.6, 1.0}, Eigen::Vector3d::Constant(3.0));
  const Eigen::Vector3d goal(10.0, 9.0, 1.5);
  for (const SearchHeuristic* heuristic : {static_cast<const SearchHeuristic*>(&euclidean),
                                           static_cast<const SearchHeuristic*>(&min_time)}) {
    int checked = 0;
    for (int trial = 0; trial < 300; ++trial) {
      const ChainState state = randomState(rng, *world, 2);
      for (const auto& control : controls) {
        const EdgeEvaluation bound = evaluator.controlOnly(state, control);
        if (!bound.valid()) continue;
        ++checked;
        // h(parent) <= c(edge) + h(child) for the weakest edge cost the search queues.
        EXPECT_LE(heuristic->estimate(state, goal),
                  bound.cost + heuristic->estimate(bound.end, goal) + 1e-12);
      }
    }
    EXPECT_GT(checked, 5000);
  }
}

TEST(MotionPrimitiveSearch, CertifiedEdgesCostExactlyWhatFullEvaluationFinds) {
  const auto world = test::smallWorld("forest");
  Rng rng(8);
  for (const double length_weight : {0.0, 0.7}) {
    EdgeEvaluatorSettings settings;
    settings.weights.length = length_weight;
    const EdgeEvaluator evaluator(world, settings);
    int certified = 0;
    int uncertain = 0;
    for (int trial = 0; trial < 3000; ++trial) {
      const ChainState start = randomState(rng, *world, 2);
      const Eigen::Vector3d control(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
      EdgeEvaluation partial = evaluator.partial(start, control);
      const EdgeEvaluation lower = evaluator.controlOnly(start, control);
      const EdgeEvaluation full = evaluator.full(start, control);
      if (lower.valid() && partial.valid()) {
        EXPECT_LE(lower.cost, partial.cost + 1e-12);
      }
      if (!evaluator.certify(start, world->distance(start.col(0)), control, partial)) {
        uncertain += partial.valid();
        continue;
      }
      ++certified;
      ASSERT_TRUE(full.valid());
      EXPECT_EQ(partial.cost, full.cost);
      EXPECT_EQ(partial.obstacle_cost, 0.0);
      EXPECT_EQ(partial.esdf_queries, 1);  // the end sample only
    }
    EXPECT_GT(certified, 20);
    EXPECT_GT(uncertain, 100);
  }
}

TEST(MotionPrimitiveSearch, BudgetStopReturnsThePathToTheNearestState) {
  test::loadTestPlugins();
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar",
      test::assignments({"sampler.samples_per_axis=3", "time_limit=0", "max_expansions=40"}));
  const auto world = test::smallWorld("forest");
  configured.planner->setup({world, configured.sampler, 1});
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  const PlanResult result = configured.planner->plan(query, Budget{});
  ASSERT_EQ(result.status, PlanStatus::kApproximate) << result.message;
  EXPECT_TRUE(result.check.valid) << result.check.detail;  // without the goal condition
  const double start_distance = (query.start.col(0) - query.goal).norm();
  EXPECT_LT(result.distance_to_goal, start_distance - 0.5);
  EXPECT_NEAR((result.trajectory.endPosition() - query.goal).norm(), result.distance_to_goal, 0.05);
}

TEST(MotionPrimitiveSearch, NoSearchOutgrowsItsMemoryBudgetEvenWithoutATimeLimit) {
  test::loadTestPlugins();
  ConfiguredPlanner configured = configurePlanner(
      "eager_mp_astar",
      test::assignments({"sampler.samples_per_axis=5", "time_limit=0", "memory_limit_mb=2"}));
  const auto world = test::smallWorld("forest");
  configured.planner->setup({world, configured.sampler, 1});
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  const PlanResult result = configured.planner->plan(query, Budget{});
  ASSERT_EQ(result.status, PlanStatus::kApproximate) << result.message;
  EXPECT_NE(result.message.find("memory budget spent"), std::string::npos) << result.message;
  const auto& planner = dynamic_cast<const MotionPrimitivePlanner&>(*configured.planner);
  // Stopped once past it: a container that just doubled may hold up to twice the limit.
  EXPECT_LE(planner.search().memoryBytes(), 2.0 * 2.0 * 1024 * 1024);
}

TEST(MotionPrimitiveSearch, AnEnclosedGoalExhaustsTheSearch) {
  test::loadTestPlugins();
  // The goal sits in a closed box: no path exists.
  const auto world = World::build(WorldSpec::fromYaml(
      YamlReader::loadString(
          "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\n"
          "generators: [{type: box_list, boxes: [{min: [2, 2, 0], max: [4, 2.2, 2]}, "
          "{min: [2, 2, 0], max: [2.2, 4, 2]}]}]\n",
          "enclosed.yaml"),
      "."));
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar", test::assignments({"sampler.samples_per_axis=3", "time_limit=0",
                                          "max_velocity=1", "tau=0.5"}));
  configured.planner->setup({world, configured.sampler, 1});
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(0.8, 0.8, 1.0);
  query.goal = Eigen::Vector3d(3.2, 3.2, 1.0);
  const PlanResult result = configured.planner->plan(query, Budget{});
  EXPECT_EQ(result.status, PlanStatus::kNoSolution) << result.message;
}

}  // namespace
}  // namespace kinolab
