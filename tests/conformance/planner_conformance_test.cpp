// Every registered planner (built-in, and any library named in $KINOLAB_TEST_PLUGINS) keeps
// the planner contract: a solvable query is solved with a trajectory the checker accepts,
// solving again after reset() gives the same result, invalid starts and goals get their
// status, and unknown parameters are refused before anything runs.
#include <gtest/gtest.h>

#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/planner/planner.hpp"
#include "support/planning.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

std::vector<std::string> registeredPlanners() {
  test::loadTestPlugins();
  return pluginRegistry<Planner>().keys();
}

/// Small, deterministic settings where a planner declares them.
ConfiguredPlanner makePlanner(const std::string& key) {
  const ParameterSpecs& specs = pluginRegistry<Planner>().info(key).parameters;
  std::vector<std::string> items;
  if (specs.find("sampler")) items = {"sampler=uniform", "sampler.samples_per_axis=3"};
  if (specs.find("time_limit")) items.push_back("time_limit=0");
  // Work-bounded instead, where a planner counts its work (one without a time limit must).
  if (specs.find("max_iterations")) items.push_back("max_iterations=20000");
  ConfiguredPlanner configured = configurePlanner(key, test::assignments(items));
  configured.planner->setup({test::smallWorld("forest"), 7});
  return configured;
}

const Budget kBudget{30.0, 20000};

PlanningQuery solvableQuery() {
  return test::randomQueries(*test::smallWorld("forest"), 1, 5, 3.0, 5.0, 0.6).front();
}

/// The centre of an occupied voxel above the ground.
Eigen::Vector3d insideAnObstacle() {
  const World& world = *test::smallWorld("forest");
  const VoxelGrid& grid = world.grid();
  for (int ix = 0; ix < grid.dims().x(); ++ix) {
    for (int iy = 0; iy < grid.dims().y(); ++iy) {
      const VoxelIndex voxel(ix, iy, 15);
      if (grid.occupied(voxel)) return grid.center(voxel);
    }
  }
  ADD_FAILURE() << "the forest has no trunk";
  return Eigen::Vector3d::Zero();
}

class PlannerConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(PlannerConformance, SolvesAndSolvesAgainTheSameAfterReset) {
  ConfiguredPlanner configured = makePlanner(GetParam());
  Planner& planner = *configured.planner;
  const PlanningQuery query = solvableQuery();
  const PlanResult first = planner.plan(query, kBudget);
  ASSERT_EQ(first.status, PlanStatus::kExact) << first.message;
  EXPECT_TRUE(first.check.valid) << first.check.check << ": " << first.check.detail;
  EXPECT_LE(first.distance_to_goal, planner.limits().goal_radius + 1e-9);
  EXPECT_TRUE(std::isfinite(first.cost));
  EXPECT_GT(first.planning_time_ms, 0.0);
  planner.reset();
  const PlanResult second = planner.plan(query, kBudget);
  EXPECT_EQ(second.status, first.status);
  EXPECT_EQ(second.cost, first.cost);
  EXPECT_EQ(second.trajectory.duration(), first.trajectory.duration());
  EXPECT_EQ(second.trajectory.endPosition(), first.trajectory.endPosition());
}

TEST_P(PlannerConformance, InvalidStartsAndGoalsGetTheirStatus) {
  ConfiguredPlanner configured = makePlanner(GetParam());
  Planner& planner = *configured.planner;
  const PlanningQuery valid = solvableQuery();

  PlanningQuery in_obstacle = valid;
  in_obstacle.start.col(0) = insideAnObstacle();
  PlanResult result = planner.plan(in_obstacle, kBudget);
  EXPECT_EQ(result.status, PlanStatus::kInvalidStart);
  EXPECT_TRUE(result.trajectory.empty());
  EXPECT_NE(result.message.find("collision"), std::string::npos) << result.message;

  PlanningQuery outside = valid;
  outside.start.col(0) = Eigen::Vector3d(-5.0, 1.0, 1.0);
  result = planner.plan(outside, kBudget);
  EXPECT_EQ(result.status, PlanStatus::kInvalidStart);
  EXPECT_NE(result.message.find("outside the map"), std::string::npos) << result.message;

  PlanningQuery too_fast = valid;
  too_fast.start.col(1) = Eigen::Vector3d(1000.0, 0.0, 0.0);
  EXPECT_EQ(planner.plan(too_fast, kBudget).status, PlanStatus::kInvalidStart);

  PlanningQuery not_finite = valid;  // NaN passes every limit comparison
  not_finite.start(0, 1) = NAN;
  EXPECT_EQ(planner.plan(not_finite, kBudget).status, PlanStatus::kInvalidStart);

  PlanningQuery goal_blocked = valid;
  goal_blocked.goal = insideAnObstacle();
  EXPECT_EQ(planner.plan(goal_blocked, kBudget).status, PlanStatus::kInvalidGoal);
}

TEST_P(PlannerConformance, AStartInsideTheGoalRegionIsSolvedByStayingPut) {
  ConfiguredPlanner configured = makePlanner(GetParam());
  PlanningQuery query = solvableQuery();
  query.goal = query.start.col(0) + Eigen::Vector3d(0.1, 0.0, 0.0);
  const PlanResult result = configured.planner->plan(query, kBudget);
  EXPECT_EQ(result.status, PlanStatus::kExact) << result.message;
  EXPECT_TRUE(result.check.valid) << result.check.detail;
  EXPECT_LE(result.distance_to_goal, configured.planner->limits().goal_radius);
  if (result.trajectory.empty()) {
    EXPECT_EQ(result.cost, 0.0);  // nothing to fly costs nothing, never infinity
  } else {
    EXPECT_TRUE(std::isfinite(result.cost));
  }
}

TEST_P(PlannerConformance, UnknownParametersAreRefused) {
  EXPECT_THROW(configurePlanner(GetParam(), test::assignments({"no_such_parameter=1"})),
               ConfigError);
}

INSTANTIATE_TEST_SUITE_P(Registered, PlannerConformance, ::testing::ValuesIn(registeredPlanners()),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace kinolab
