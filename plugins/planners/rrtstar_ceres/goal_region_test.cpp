// Sampling planners whose states keep more than the body (RRT*'s clearance_margin,
// ompl_control's half step): a goal region without room for one is refused up front.
#include <gtest/gtest.h>

#include "kinolab/planner/planner.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

ConfiguredPlanner makePlanner(const std::string& key, std::vector<std::string> items) {
  items.push_back("time_limit=0");  // iteration-bounded: the same on every machine
  items.push_back("max_iterations=20000");
  ConfiguredPlanner configured = configurePlanner(key, test::assignments(items));
  configured.planner->setup({test::smallWorld("forest"), 5});
  return configured;
}

/// A voxel centre of the forest at 1.5 m high whose clearance lies in [low, high].
Eigen::Vector3d forestPointWithClearance(double low, double high) {
  const World& world = *test::smallWorld("forest");
  const VoxelGrid& grid = world.grid();
  for (int ix = 0; ix < grid.dims().x(); ++ix) {
    for (int iy = 0; iy < grid.dims().y(); ++iy) {
      const Eigen::Vector3d centre = grid.center(VoxelIndex(ix, iy, 15));
      const double clearance = world.clearance(centre);
      if (clearance >= low && clearance <= high) return centre;
    }
  }
  ADD_FAILURE() << "no forest point " << low << "-" << high << " m clear";
  return Eigen::Vector3d::Zero();
}

TEST(RrtStar, AGoalRegionWithoutRoomForItsStatesIsRefusedBeforeAnyIteration) {
  // clearance_margin 0.8: every RRT* state keeps 1.05 m. A goal about 0.3 m clear has room
  // for the body (0.25 m) but none for a state within its 0.5 m region (at most 0.93 m
  // there): before, RRT* searched until its budget was spent.
  PlanningQuery query =
      test::randomQueries(*test::smallWorld("forest"), 1, 5, 3.0, 5.0, 1.2).front();
  query.goal = forestPointWithClearance(0.26, 0.34);
  const PlanResult refused =
      makePlanner("rrtstar", {"clearance_margin=0.8"}).planner->plan(query, Budget{});
  EXPECT_EQ(refused.status, PlanStatus::kInvalidGoal) << refused.message;
  EXPECT_NE(refused.message.find("clearance_margin"), std::string::npos) << refused.message;
  EXPECT_TRUE(refused.statistics.empty());  // no iteration ran
  // A wider region has room somewhere: the goal is planned for, not refused.
  const PlanResult planned = makePlanner("rrtstar", {"clearance_margin=0.8", "goal_radius=1.5"})
                                 .planner->plan(query, Budget{});
  EXPECT_NE(planned.status, PlanStatus::kInvalidGoal) << planned.message;
  EXPECT_FALSE(planned.statistics.empty());
}

TEST(OmplControl, AGoalRegionWithoutRoomForItsStatesIsRefusedBeforeAnyPropagation) {
  // Its states keep the radius plus half a step's travel (here 0.5 sqrt(3) 2 m/s 0.5 s =
  // 0.87 m): a goal about 0.3 m clear has none of that within 0.5 m.
  PlanningQuery query =
      test::randomQueries(*test::smallWorld("forest"), 1, 5, 3.0, 5.0, 1.3).front();
  query.goal = forestPointWithClearance(0.26, 0.34);
  const PlanResult refused =
      makePlanner("ompl_control", {"max_velocity=2", "step=0.5"}).planner->plan(query, Budget{});
  EXPECT_EQ(refused.status, PlanStatus::kInvalidGoal) << refused.message;
  EXPECT_NE(refused.message.find("propagation step"), std::string::npos) << refused.message;
  EXPECT_TRUE(refused.statistics.empty());
}

}  // namespace
}  // namespace kinolab
