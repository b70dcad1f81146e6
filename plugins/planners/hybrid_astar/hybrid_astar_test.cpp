// hybrid_astar and hybrid_astar_bspline: they plan, their trajectories pass the independent
// checker, the analytic shot is what ends their searches, and they close far fewer states
// than eager MP-A* (their cost gap is measured, not asserted: docs/hybrid_astar.md).
#include <gtest/gtest.h>

#include "kinolab/planner/planner.hpp"
#include "support/planning.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

double statistic(const PlanResult& result, const std::string& name) {
  for (const auto& [key, value] : result.statistics) {
    if (key == name) return value;
  }
  ADD_FAILURE() << "no statistic " << name;
  return NAN;
}

PlanResult planWith(const std::string& planner, const std::string& world,
                    const PlanningQuery& query, const std::vector<std::string>& settings = {}) {
  test::loadTestPlugins();
  ConfiguredPlanner configured = configurePlanner(planner, test::assignments(settings));
  configured.planner->setup({test::smallWorld(world), 1});
  return configured.planner->plan(query, Budget{});
}

TEST(HybridAstar, PlansCheckedTrajectoriesThatEndWithTheShot) {
  for (const std::string world : {"forest", "walls"}) {
    const auto queries = test::randomQueries(*test::smallWorld(world), 8, 17, 5.0, 10.0, 0.6);
    int shots = 0;
    for (const PlanningQuery& query : queries) {
      const PlanResult result = planWith("hybrid_astar", world, query);
      ASSERT_EQ(result.status, PlanStatus::kExact) << world << ": " << result.message;
      EXPECT_TRUE(result.check.valid) << world << ": " << result.check.detail;
      // The search ended with an accepted shot (one more tried than refused) unless the goal
      // region was reached first.
      shots += statistic(result, "shots") > statistic(result, "shots_rejected");
      EXPECT_EQ(statistic(result, "controls"), 125.0);  // Fast-Planner's 5 per axis
    }
    EXPECT_GE(shots, 6) << world << ": most searches end with the analytic expansion";
  }
}

TEST(HybridAstar, ClosesFewerStatesThanEagerMpAstar) {
  const auto queries = test::randomQueries(*test::smallWorld("forest"), 6, 23, 6.0, 10.0, 0.6);
  double hybrid = 0.0;
  double eager = 0.0;
  for (const PlanningQuery& query : queries) {
    const PlanResult fast = planWith("hybrid_astar", "forest", query);
    const PlanResult optimal = planWith("eager_mp_astar", "forest", query,
                                        {"sampler.samples_per_axis=5", "weight_obstacle=0"});
    ASSERT_EQ(fast.status, PlanStatus::kExact) << fast.message;
    ASSERT_EQ(optimal.status, PlanStatus::kExact) << optimal.message;
    hybrid += statistic(fast, "expansions");
    eager += statistic(optimal, "expansions");
  }
  EXPECT_LT(hybrid, 0.5 * eager) << hybrid << " against " << eager;
}

TEST(HybridAstar, TheBsplineBackEndSmoothsWithinTheLimitsOrSaysWhyNot) {
  const auto queries = test::randomQueries(*test::smallWorld("forest"), 6, 31, 5.0, 10.0, 0.6);
  int smoothed = 0;
  for (const PlanningQuery& query : queries) {
    const PlanResult result = planWith("hybrid_astar_bspline", "forest", query);
    EXPECT_TRUE(std::isfinite(statistic(result, "front_end_cost")));  // the front end planned
    EXPECT_GE(statistic(result, "time_back_end_ms"), 0.0);
    if (result.status == PlanStatus::kBackEndFailed) {
      EXPECT_TRUE(result.trajectory.empty());
      EXPECT_EQ(result.message.rfind("back end bspline: ", 0), 0u) << result.message;
      continue;
    }
    ASSERT_EQ(result.status, PlanStatus::kExact) << result.message;
    EXPECT_TRUE(result.check.valid) << result.check.detail;
    ++smoothed;
    // A B-spline: continuous acceleration, so a finite jerk integral (the front end's
    // piecewise-constant accelerations have none between their jumps).
    EXPECT_GT(result.evaluation.jerk_integral, 0.0);
    EXPECT_EQ(result.evaluation.undefined, "");
    EXPECT_EQ(result.objective, "trajectory length");
    EXPECT_NEAR(result.cost, result.trajectory.length(), 1e-9);
  }
  EXPECT_GE(smoothed, 4);
}

TEST(HybridAstar, ItsParametersAreCheckedWhereTheyAreSet) {
  test::loadTestPlugins();
  EXPECT_THROW(configurePlanner("hybrid_astar", test::assignments({"acceleration_steps=1"})),
               ConfigError);
  EXPECT_THROW(configurePlanner("hybrid_astar", test::assignments({"cell_sise=0.2"})), ConfigError);
}

}  // namespace
}  // namespace kinolab
