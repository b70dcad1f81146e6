// ego_bspline on the small forest: paths from grid_astar's search and from lazy_mp_astar's
// trajectories become checker-valid splines from the start state, deterministically; bad
// input is a failure; the collision term's gradient is its derivative.
#include "ego_bspline.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdio>

#include "../../planners/grid_astar/grid_path.hpp"
#include "kinolab/core/random.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

/// The back end as the registry makes it, set up for the default body and limits.
std::unique_ptr<BackEnd> makeBackEnd(const std::shared_ptr<const World>& world,
                                     const std::vector<std::string>& items = {}) {
  const ConfiguredPlanner planner = configurePlanner("grid_astar", {});
  std::unique_ptr<BackEnd> back_end =
      pluginRegistry<BackEnd>().create("ego_bspline", test::assignments(items));
  back_end->setup(world, planner.planner->configuredBody(), planner.planner->limits());
  return back_end;
}

struct Refined {
  int valid = 0;
  int tried = 0;
  double rebounds = 0.0;  // summed over the problems, with the guide paths and pairs
  double guide_paths = 0.0;
  double reallocations = 0.0;
  double iterations = 0.0;
};

void refineAndCheck(const BackEnd& back_end, const BackEndProblem& problem, Refined& tally) {
  StopCondition stop(Budget{});
  const BackEndResult result = back_end.refine(problem, stop);
  ++tally.tried;
  tally.rebounds += test::statistic(result.statistics, "ego_rebounds");
  tally.guide_paths += test::statistic(result.statistics, "ego_guide_paths");
  tally.reallocations += test::statistic(result.statistics, "ego_reallocations");
  tally.iterations += test::statistic(result.statistics, "ego_iterations");
  if (!result.failure.empty()) {
    std::printf("  failure: %s\n", result.failure.c_str());
    return;
  }
  ++tally.valid;
  const Trajectory& t = result.trajectory;
  for (int derivative = 0; derivative < 3; ++derivative) {
    EXPECT_LT((t.evaluate(0.0, derivative) - problem.start.col(derivative)).norm(), 1e-6);
  }
  EXPECT_LT((t.endPosition() - problem.path.back()).norm(), 1e-6);
  EXPECT_LT(t.evaluate(t.duration(), 1).norm(), 1e-6);
}

struct GridCase {
  std::string world;
  int queries;
  double min_valid;  // share of the refined paths; measured: see the printed line
};

class EgoOnGridPaths : public ::testing::TestWithParam<GridCase> {};

TEST_P(EgoOnGridPaths, MostBecomeCheckerValidSplines) {
  const auto world = test::smallWorld(GetParam().world);
  const auto back_end = makeBackEnd(world);
  const Body body = configurePlanner("grid_astar", {}).planner->configuredBody();
  Refined tally;
  for (const PlanningQuery& query :
       test::randomQueries(*world, GetParam().queries, 31, 3.0, 12.0, 0.6)) {
    StopCondition stop(Budget{});
    const grid::GridPath path = grid::findGridPath(*world, body, query.start.col(0), query.goal,
                                                   grid::GridAlgorithm::kJps, stop);
    if (path.outcome != grid::GridPath::Outcome::kFound) continue;
    BackEndProblem problem;
    problem.start = query.start;
    problem.goal = query.goal;
    problem.path = path.path;
    refineAndCheck(*back_end, problem, tally);
  }
  std::printf(
      "[ ego_bspline on grid_astar paths, %s ] checker-valid %d / %d; rebounds %.0f, guide "
      "paths %.0f, reallocations %.0f, L-BFGS iterations %.0f\n",
      GetParam().world.c_str(), tally.valid, tally.tried, tally.rebounds, tally.guide_paths,
      tally.reallocations, tally.iterations);
  EXPECT_GE(tally.tried, 0.9 * GetParam().queries);
  EXPECT_GE(tally.valid, GetParam().min_valid * tally.tried);
}

INSTANTIATE_TEST_SUITE_P(Worlds, EgoOnGridPaths,
                         ::testing::Values(GridCase{"forest", 40, 0.9}, GridCase{"walls", 20, 0.9}),
                         [](const ::testing::TestParamInfo<GridCase>& param) {
                           return param.param.world;
                         });

TEST(EgoBspline, RefinesLazyMpAstarTrajectoriesOnTheForest) {
  const auto world = test::smallWorld("forest");
  const auto back_end = makeBackEnd(world);
  ConfiguredPlanner lazy = configurePlanner("lazy_mp_astar", test::assignments({"time_limit=0"}));
  lazy.planner->setup({world, 1});
  Refined tally;
  for (const PlanningQuery& query : test::randomQueries(*world, 20, 37, 3.0, 10.0, 0.6)) {
    const PlanResult found = lazy.planner->plan(query, Budget{});
    if (found.status != PlanStatus::kExact) continue;
    BackEndProblem problem;
    problem.start = query.start;
    problem.goal = query.goal;
    problem.path = backEndPath({}, found.trajectory);
    problem.front = &found.trajectory;
    refineAndCheck(*back_end, problem, tally);
  }
  std::printf(
      "[ ego_bspline on lazy_mp_astar trajectories, forest ] checker-valid %d / %d; rebounds "
      "%.0f, guide paths %.0f, reallocations %.0f, L-BFGS iterations %.0f\n",
      tally.valid, tally.tried, tally.rebounds, tally.guide_paths, tally.reallocations,
      tally.iterations);
  EXPECT_GE(tally.tried, 15);
  EXPECT_GE(tally.valid, 0.9 * tally.tried);
}

BackEndProblem movingProblem() {
  const auto world = test::smallWorld("forest");
  const PlanningQuery query = test::randomQueries(*world, 1, 41, 6.0, 10.0, 0.6).front();
  const Body body = configurePlanner("grid_astar", {}).planner->configuredBody();
  StopCondition stop(Budget{});
  BackEndProblem problem;
  problem.path = grid::findGridPath(*world, body, query.start.col(0), query.goal,
                                    grid::GridAlgorithm::kAStar, stop)
                     .path;
  problem.start = query.start;
  // Moving along the first leg, and accelerating sideways a little.
  const Eigen::Vector3d lead = (problem.path.at(1) - problem.path.at(0)).normalized();
  problem.start.col(1) = 0.8 * lead;
  problem.start.col(2) = 0.5 * lead.cross(Eigen::Vector3d::UnitZ());
  problem.goal = query.goal;
  return problem;
}

TEST(EgoBspline, MatchesAMovingStartAndIsDeterministic) {
  const auto back_end = makeBackEnd(test::smallWorld("forest"));
  const BackEndProblem problem = movingProblem();
  Refined tally;
  refineAndCheck(*back_end, problem, tally);
  EXPECT_EQ(tally.valid, 1);
  StopCondition first_stop(Budget{});
  StopCondition second_stop(Budget{});
  const BackEndResult first = back_end->refine(problem, first_stop);
  const BackEndResult second = back_end->refine(problem, second_stop);
  ASSERT_EQ(first.trajectory.segments().size(), second.trajectory.segments().size());
  EXPECT_EQ(first.trajectory.duration(), second.trajectory.duration());
  for (double t = 0.0; t < first.trajectory.duration(); t += 0.1) {
    EXPECT_EQ(first.trajectory.evaluate(t), second.trajectory.evaluate(t));
  }
  EXPECT_EQ(first.statistics, second.statistics);
}

// Straight lines through the trees (paths no front end would give): the collision term, with
// its A* guide paths, must take the spline around them.
TEST(EgoBspline, ReboundsAroundObstaclesAStraightPathCrosses) {
  const auto world = test::smallWorld("forest");
  const auto back_end = makeBackEnd(world);
  const Body body = configurePlanner("grid_astar", {}).planner->configuredBody();
  Refined tally;
  for (const PlanningQuery& query : test::randomQueries(*world, 60, 43, 2.0, 5.0, 0.6)) {
    if (grid::segmentFree(*world, query.start.col(0), query.goal, body)) continue;
    BackEndProblem problem;
    problem.start = query.start;
    problem.goal = query.goal;
    problem.path = {query.start.col(0), query.goal};
    refineAndCheck(*back_end, problem, tally);
  }
  std::printf(
      "[ ego_bspline on straight paths through obstacles, forest ] checker-valid %d / %d; "
      "rebounds %.0f, guide paths %.0f\n",
      tally.valid, tally.tried, tally.rebounds, tally.guide_paths);
  EXPECT_GE(tally.tried, 5);
  EXPECT_GE(tally.guide_paths, tally.tried);
  EXPECT_GE(tally.valid, 0.8 * tally.tried);
}

TEST(EgoBspline, NonFiniteInputIsAFailure) {
  const auto back_end = makeBackEnd(test::smallWorld("forest"));
  BackEndProblem problem = movingProblem();
  problem.path[1].x() = NAN;
  StopCondition stop(Budget{});
  BackEndResult result = back_end->refine(problem, stop);
  EXPECT_TRUE(result.trajectory.empty());
  EXPECT_NE(result.failure.find("not finite"), std::string::npos);
  problem = movingProblem();
  problem.start(1, 1) = INFINITY;
  result = back_end->refine(problem, stop);
  EXPECT_TRUE(result.trajectory.empty());
  EXPECT_FALSE(result.failure.empty());
}

TEST(EgoObjective, CollisionGradientMatchesFiniteDifferences) {
  ego::EgoObjective objective({}, DynamicLimits::uniform(2.0, 3.0), 0.5);
  Rng rng(7);
  Eigen::Matrix3Xd control(3, 10);
  for (int i = 0; i < control.cols(); ++i) {
    control.col(i) = Eigen::Vector3d(i * 0.3, rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2));
  }
  objective.pairs().resize(control.cols());
  // Shortfalls in both pieces of the penalty (below and beyond s_f) and one pair satisfied.
  for (int i = 3; i < 7; ++i) {
    const Eigen::Vector3d direction =
        Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)).normalized();
    const double depth = 0.3 * (i - 3) - 0.1;  // d = -depth: shortfall 0.5 + depth
    objective.pairs()[i].push_back({control.col(i) + depth * direction, direction});
    objective.pairs()[i].push_back({control.col(i) - 0.7 * direction, direction});  // satisfied
  }
  Eigen::Matrix3Xd gradient;
  const double cost = objective.collision(control, &gradient);
  EXPECT_GT(cost, 0.0);
  constexpr double kStep = 1e-6;
  for (int i = 0; i < control.cols(); ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Matrix3Xd plus = control;
      Eigen::Matrix3Xd minus = control;
      plus(axis, i) += kStep;
      minus(axis, i) -= kStep;
      const double numeric =
          (objective.collision(plus, nullptr) - objective.collision(minus, nullptr)) / (2 * kStep);
      EXPECT_NEAR(gradient(axis, i), numeric, 1e-5 * std::max(1.0, std::abs(numeric)));
    }
  }
  // The whole objective too (smoothness, limits: the spline is fast at this interval).
  objective.evaluate(control, 0.1, &gradient);
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Matrix3Xd plus = control;
    Eigen::Matrix3Xd minus = control;
    plus(axis, 4) += kStep;
    minus(axis, 4) -= kStep;
    const double numeric =
        (objective.evaluate(plus, 0.1, nullptr) - objective.evaluate(minus, 0.1, nullptr)) /
        (2 * kStep);
    EXPECT_NEAR(gradient(axis, 4), numeric, 1e-4 * std::max(1.0, std::abs(numeric)));
  }
}

}  // namespace
}  // namespace kinolab
