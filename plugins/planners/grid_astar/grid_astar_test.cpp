// grid_astar and its voxel search: JPS's path length equals A*'s, both are optimal on the
// grid (against a brute-force Dijkstra), every trajectory passes the checker, and JPS
// expands fewer nodes.
#include <gtest/gtest.h>

#include <cstdio>
#include <queue>

#include "grid_path.hpp"
#include "kinolab/planner/planner.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

ConfiguredPlanner makeGridPlanner(const std::string& algorithm, const std::string& world) {
  ConfiguredPlanner configured =
      configurePlanner("grid_astar", test::assignments({"algorithm=" + algorithm, "time_limit=0"}));
  configured.planner->setup({test::smallWorld(world), 1});
  return configured;
}

std::shared_ptr<const World> tinyWorld(const std::string& generators) {
  return World::build(WorldSpec::fromYaml(
      YamlReader::loadString("name: tiny\nseed: 3\nresolution: 0.1\nbounds: {min: [0, 0, 0], "
                             "max: [3, 3, 1]}\n" +
                                 generators,
                             "tiny.yaml"),
      "."));
}

struct GridCase {
  std::string world;
  int queries;  // the walls' mazes cost A* ~30 000 expansions a query: fewer of them
};

class GridAstarWorlds : public ::testing::TestWithParam<GridCase> {};

// Queries 3-12 m apart: A* and JPS find voxel paths of the same length, every trajectory is
// exact and checker-valid, and JPS takes fewer nodes from the open list.
TEST_P(GridAstarWorlds, JpsMatchesAStarLengthWithFewerExpansions) {
  const std::string& world = GetParam().world;
  ConfiguredPlanner astar = makeGridPlanner("astar", world);
  ConfiguredPlanner jps = makeGridPlanner("jps", world);
  const auto queries =
      test::randomQueries(*test::smallWorld(world), GetParam().queries, 29, 3.0, 12.0, 0.6);
  double astar_expansions = 0.0;
  double jps_expansions = 0.0;
  int exact = 0;
  for (const PlanningQuery& query : queries) {
    const PlanResult a = astar.planner->plan(query, Budget{});
    const PlanResult j = jps.planner->plan(query, Budget{});
    ASSERT_EQ(a.status, j.status) << a.message << " / " << j.message;
    if (a.status != PlanStatus::kExact) continue;
    ++exact;
    EXPECT_TRUE(a.check.valid) << a.check.detail;
    EXPECT_TRUE(j.check.valid) << j.check.detail;
    EXPECT_NEAR(test::statistic(a.statistics, "path_length_grid"),
                test::statistic(j.statistics, "path_length_grid"), 1e-9);
    EXPECT_LE(j.cost, test::statistic(j.statistics, "path_length_grid") + 1e-9);
    EXPECT_LT(j.distance_to_goal, 1e-9);
    astar_expansions += test::statistic(a.statistics, "expansions");
    jps_expansions += test::statistic(j.statistics, "expansions");
  }
  std::printf("[ grid_astar on %s ] exact %d / %zu, expansions A* %.0f, JPS %.0f\n", world.c_str(),
              exact, queries.size(), astar_expansions, jps_expansions);
  EXPECT_GE(exact, 0.9 * static_cast<double>(queries.size()));
  EXPECT_LT(jps_expansions, astar_expansions);
}

INSTANTIATE_TEST_SUITE_P(Worlds, GridAstarWorlds,
                         ::testing::Values(GridCase{"forest", 40}, GridCase{"walls", 8}),
                         [](const ::testing::TestParamInfo<GridCase>& param) {
                           return param.param.world;
                         });

/// Every voxel's shortest move-sequence length from `start` (voxels), by plain Dijkstra.
std::vector<double> dijkstra(const grid::FreeVoxels& voxels, const VoxelIndex& start) {
  const VoxelGrid& grid = voxels.grid();
  std::vector<double> cost(grid.size(), INFINITY);
  using Entry = std::pair<double, std::size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  cost[grid.index(start)] = 0.0;
  open.push({0.0, grid.index(start)});
  while (!open.empty()) {
    const auto [c, index] = open.top();
    open.pop();
    if (c > cost[index]) continue;
    const VoxelIndex voxel = grid.voxel(index);
    for (int move = 0; move < 27; ++move) {
      const VoxelIndex step(move / 9 - 1, move / 3 % 3 - 1, move % 3 - 1);
      if (move == 13 || !voxels.canMove(voxel, step)) continue;
      const std::size_t next = grid.index(voxel + step);
      if (c + step.cast<double>().norm() < cost[next]) {
        cost[next] = c + step.cast<double>().norm();
        open.push({cost[next], next});
      }
    }
  }
  return cost;
}

TEST(GridSearch, AStarAndJpsAreOptimalOnTheGrid) {
  const auto world = tinyWorld(
      "generators: [{type: forest, density: 0.3, trunk_radius: [0.1, 0.25], trunk_height: "
      "[0.5, 1], min_spacing: 0.4, ground_plane: true}]\n");
  const grid::FreeVoxels voxels(*world, 0.15);
  // The first free voxel of the grid's order at mid height.
  VoxelIndex start(0, 0, 5);
  while (!voxels.free(start)) ++start.y();
  const std::vector<double> cost = dijkstra(voxels, start);
  int compared = 0;
  for (std::size_t index = 0; index < cost.size(); index += 37) {
    const VoxelIndex goal = world->grid().voxel(index);
    for (const auto algorithm : {grid::GridAlgorithm::kAStar, grid::GridAlgorithm::kJps}) {
      StopCondition stop(Budget{});
      const grid::GridSearchResult found = grid::searchGrid(voxels, start, goal, algorithm, stop);
      ASSERT_EQ(found.found, std::isfinite(cost[index]));
      if (!found.found) continue;
      EXPECT_NEAR(found.length, cost[index] * 0.1, 1e-9);
      ++compared;
    }
  }
  std::printf("[ grid search ] %d optimal lengths compared with Dijkstra\n", compared);
  EXPECT_GT(compared, 200);
}

TEST(GridAstar, UnreachableGoalIsNoSolution) {
  const auto world =
      tinyWorld("generators: [{type: box_list, boxes: [{min: [1.4, 0, 0], max: [1.6, 3, 1]}]}]\n");
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(0.5, 1.5, 0.5);
  query.goal = Eigen::Vector3d(2.5, 1.5, 0.5);
  for (const std::string algorithm : {"astar", "jps"}) {
    ConfiguredPlanner planner = configurePlanner(
        "grid_astar", test::assignments({"algorithm=" + algorithm, "time_limit=0"}));
    planner.planner->setup({world, 1});
    const PlanResult result = planner.planner->plan(query, Budget{});
    EXPECT_EQ(result.status, PlanStatus::kNoSolution) << result.message;
    // A* closes every voxel it can reach (the wall's side: 11 x 30 x 10 less the margins);
    // JPS's jumps from the start, in an empty box, reach its sides with no jump point.
    if (algorithm == "astar") {
      EXPECT_GT(test::statistic(result.statistics, "expansions"), 1000.0);
    }
  }
}

TEST(GridAstar, AGoalRegionWithoutRoomForTheBodyIsRefusedBeforeTheSearch) {
  // A block 1.2 m thick from x = 1.8 and a wall 0.2 m thick at x = 1 (y < 1), both the world's
  // height. Refused as invalid_goal before any expansion: a goal in the block's middle (no point
  // of its 0.5 m region has room for the body, 0.25 m), and a goal free for the body in the
  // 0.6 m gap between wall and block, where no voxel next to it has room for the body kept
  // along a segment to it. A goal in the open is searched for and reached.
  const auto world = tinyWorld(
      "generators: [{type: box_list, boxes: [{min: [1.8, 0, 0], max: [3, 3, 1]},\n"
      "                                      {min: [1, 0, 0], max: [1.2, 1, 1]}]}]\n");
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(0.5, 2.0, 0.5);
  for (const std::string algorithm : {"astar", "jps"}) {
    SCOPED_TRACE(algorithm);
    ConfiguredPlanner planner = configurePlanner(
        "grid_astar", test::assignments({"algorithm=" + algorithm, "time_limit=0"}));
    planner.planner->setup({world, 1});
    for (const Eigen::Vector3d& goal :
         {Eigen::Vector3d(2.4, 1.5, 0.5), Eigen::Vector3d(1.5, 0.5, 0.5)}) {
      query.goal = goal;
      ASSERT_EQ(world->clearanceFor(goal, 0.24) >= 0.24, goal.x() < 1.8);  // the kept radius
      const PlanResult refused = planner.planner->plan(query, Budget{});
      EXPECT_EQ(refused.status, PlanStatus::kInvalidGoal) << refused.message;
      const double expanded = test::statistic(refused.statistics, "expansions");
      EXPECT_TRUE(std::isnan(expanded) || expanded == 0.0) << expanded;  // none reported, or 0
    }
    query.goal = Eigen::Vector3d(0.5, 0.5, 0.5);
    const PlanResult planned = planner.planner->plan(query, Budget{});
    EXPECT_EQ(planned.status, PlanStatus::kExact) << planned.message;
    EXPECT_GT(test::statistic(planned.statistics, "expansions"), 0.0);
  }
}

TEST(GridAstar, RefusesAMovingStartAndStopsAtItsExpansionBudget) {
  const PlanningQuery query =
      test::randomQueries(*test::smallWorld("forest"), 1, 5, 8.0, 12.0, 0.6).front();
  PlanningQuery moving = query;
  moving.start(0, 1) = 0.5;
  EXPECT_EQ(makeGridPlanner("jps", "forest").planner->plan(moving, Budget{}).status,
            PlanStatus::kInvalidStart);
  ConfiguredPlanner few = configurePlanner(
      "grid_astar", test::assignments({"algorithm=astar", "max_expansions=10", "time_limit=0"}));
  few.planner->setup({test::smallWorld("forest"), 1});
  const PlanResult result = few.planner->plan(query, Budget{});
  EXPECT_EQ(result.status, PlanStatus::kTimeout);
  EXPECT_EQ(test::statistic(result.statistics, "expansions"), 10.0);
}

}  // namespace
}  // namespace kinolab
