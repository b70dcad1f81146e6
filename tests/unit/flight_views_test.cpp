// What a flight does where its guide or its start gives out (framework/src/flight's
// flight_views and flight_motion): guides over joined levels when the query's band is
// closed, local goals at the map's end, and the back-off moves out of a refused or pressed
// start (a start outside the planning domain moved into it first).
#include "flight/flight_views.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "flight/flight_motion.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/plugins/lidar.hpp"
#include "kinolab/world/world_spec.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

using namespace flight_motion;

using test::worldOf;

/// The ground truth's own columns (as the flight's difficulty reads them).
ObstacleColumns columnsOf(const VoxelGrid& grid) {
  return [&grid](int x, int z0, int z1, std::uint8_t* row) {
    for (int y = 0; y < grid.dims().y(); ++y) {
      row[y] = 0;
      for (int z = z0; z <= z1 && row[y] == 0; ++z) row[y] = grid.occupied(VoxelIndex(x, y, z));
    }
  };
}

/// A low wall (up to 1.5 m) across the map at x = 6 and a high one (from 1.3 m up) at x = 12:
/// over the first, under the second.
const char* kOverAndUnder =
    "  - type: box_list\n"
    "    boxes: [{min: [6, 0, 0], max: [6.4, 10, 1.5]}, {min: [12, 0, 1.3], max: [12.4, 10, 3]}]\n";

TEST(LevelGuideTest, AWayOverOneWallAndUnderTheNextJoinsTwoLevels) {
  const auto world = worldOf(kOverAndUnder);
  const VoxelGrid& grid = world->grid();
  const ObstacleColumns columns = columnsOf(grid);
  const Eigen::Vector3d from(2.0, 5.0, 1.0);
  const Eigen::Vector3d to(18.0, 5.0, 1.0);
  const Eigen::Vector3d froms[] = {from};
  const double radius = 0.4;
  const std::vector<double> levels = {0.55, 0.95, 1.35, 1.75, 2.15};
  // No level alone has a way: the low wall closes every band below 1.9 m, the high one
  // every band above 0.9 m.
  for (const double level : levels) {
    EXPECT_TRUE(
        columnGuides(grid, columns, froms, to, radius, level - radius, level + radius, radius)
            .front()
            .empty())
        << level;
  }
  const std::vector<Eigen::Vector3d> way =
      levelColumnGuides(grid, columns, froms, to, radius, levels, radius).front();
  ASSERT_GE(way.size(), 2u);
  EXPECT_EQ(way.front(), from);
  EXPECT_EQ(way.back(), to);
  for (std::size_t k = 1; k + 1 < way.size(); ++k) {
    const Eigen::Vector3d& p = way[k];
    // Every point at a level; within the body's radius of a wall, the level that passes it.
    EXPECT_NE(std::find(levels.begin(), levels.end(), p.z()), levels.end()) << p.transpose();
    if (p.x() > 6.0 - radius && p.x() < 6.4 + radius) {
      EXPECT_EQ(p.z(), 2.15) << p.transpose();
    }
    if (p.x() > 12.0 - radius && p.x() < 12.4 + radius) {
      EXPECT_EQ(p.z(), 0.55) << p.transpose();
    }
    // One step apart: a cell across (0.1 m, or its diagonal) or a level up or down.
    if (k < 2) continue;  // way[0] is the vehicle itself
    const Eigen::Vector3d step = p - way[k - 1];
    const bool across = step.z() == 0.0 && step.head<2>().norm() < 0.1 * M_SQRT2 + 1e-9;
    const bool up_or_down =
        step.head<2>().norm() == 0.0 && std::abs(std::abs(step.z()) - 0.4) < 1e-9;
    EXPECT_TRUE(across || up_or_down) << k << ": " << step.transpose();
  }
  // The shortest joined way climbs from the start's level (0.95 m) to the top one to pass the
  // first wall and descends to the lowest to pass the second, and changes level no more.
  double climbed = 0.0;
  for (std::size_t k = 2; k + 1 < way.size(); ++k) climbed += std::abs(way[k].z() - way[k - 1].z());
  EXPECT_NEAR(climbed, (2.15 - 0.95) + (2.15 - 0.55), 1e-9);
  // A wall of the map's whole height closes every level.
  const auto closed =
      worldOf("  - type: box_list\n    boxes: [{min: [9, 0, 0], max: [9.4, 10, 3]}]\n");
  EXPECT_TRUE(levelColumnGuides(closed->grid(), columnsOf(closed->grid()), froms, to, radius,
                                levels, radius)
                  .front()
                  .empty());
}

TEST(LevelGuideTest, ADoorTheVehicleFlewThroughStaysOpenToTheGuides) {
  // A wall across the map at x = 10 with a door 0.8 m wide (y 4.6 .. 5.4): no cell centre
  // lies 0.4 m from both its sides (the cells are 0.1 m), so the guides' columns close it for
  // a 0.4 m radius although a body of that radius fits. A trail through the door (where a
  // vehicle flew) opens it, in the band and at the levels within the radius of the trail's
  // height; a trail above the band opens nothing there.
  const auto world = worldOf(
      "  - type: box_list\n"
      "    boxes: [{min: [10, 0, 0], max: [10.4, 4.6, 3]}, {min: [10, 5.4, 0], max: [10.4, 10, "
      "3]}]\n");
  const VoxelGrid& grid = world->grid();
  const ObstacleColumns columns = columnsOf(grid);
  const Eigen::Vector3d from(5.0, 5.0, 1.5);
  const Eigen::Vector3d to(15.0, 5.0, 1.5);
  const Eigen::Vector3d froms[] = {from};
  std::vector<Eigen::Vector3d> trail;
  for (double x = 8.0; x <= 12.0; x += 0.05) trail.emplace_back(x, 5.0, 1.5);
  std::vector<Eigen::Vector3d> high = trail;
  for (Eigen::Vector3d& p : high) p.z() = 2.6;
  EXPECT_TRUE(columnGuides(grid, columns, froms, to, 0.4, 1.0, 2.0, 0.4).front().empty());
  EXPECT_TRUE(
      columnGuides(grid, columns, froms, to, 0.4, 1.0, 2.0, 0.4, 0.0, high).front().empty());
  const std::vector<Eigen::Vector3d> way =
      columnGuides(grid, columns, froms, to, 0.4, 1.0, 2.0, 0.4, 0.0, trail).front();
  ASSERT_GE(way.size(), 2u);
  for (const Eigen::Vector3d& p : way) {
    if (p.x() > 10.0 && p.x() < 10.4) {
      EXPECT_NEAR(p.y(), 5.0, 0.1) << p.transpose();
    }
  }
  const std::vector<double> levels = {0.55, 0.95, 1.35, 1.75, 2.15};
  EXPECT_TRUE(levelColumnGuides(grid, columns, froms, to, 0.4, levels, 0.4).front().empty());
  EXPECT_FALSE(
      levelColumnGuides(grid, columns, froms, to, 0.4, levels, 0.4, 0.0, trail).front().empty());
}

TEST(LevelGuideTest, AFlightsLevelsSpanTheMapWithinItsMargin) {
  // levelGuides() on a vehicle's map that has seen both walls: its levels run from the margin
  // and a body above the floor to as far below the ceiling, 0.4 m apart (0.55 .. 2.15 m in a
  // 3 m map with a 0.15 m margin and a 0.4 m radius), so the way over the low wall is at the
  // highest and the way under the high one at the lowest.
  const auto world = worldOf(kOverAndUnder);
  registerBuiltinPlugins();
  MapModel model;
  model.inset = 0.15;
  auto map = pluginRegistry<VehicleMap>().create("octomap", {});
  map->setup(world->bounds(), model);
  // Unknown is free to a guide: the walls must be seen, from both sides at several heights.
  Lidar lidar;
  lidar.range = 7.0;
  Rng noise(1);
  for (const double x : {3.0, 9.0, 15.0}) {
    for (const double z : {0.5, 1.0, 1.5, 2.0, 2.5}) {
      map->insert(senseFrame(*world, lidar, Eigen::Vector3d(x, 5.0, z), 0.0, noise), lidar.range);
    }
  }
  const Eigen::Vector3d from(2.0, 5.0, 1.0);
  const Eigen::Vector3d to(18.0, 5.0, 1.0);
  const Eigen::Vector3d froms[] = {from};
  EXPECT_TRUE(map->guides(froms, to, 0.4, 0.5, 1.5, 0.4).front().empty());  // the query's band
  const std::vector<Eigen::Vector3d> way = levelGuides(*map, froms, to, 0.4, 0.15).front();
  ASSERT_GE(way.size(), 2u);
  double highest = 0.0;
  double lowest = INFINITY;
  for (std::size_t k = 1; k + 1 < way.size(); ++k) {
    highest = std::max(highest, way[k].z());
    lowest = std::min(lowest, way[k].z());
  }
  EXPECT_NEAR(highest, 2.15, 1e-9);
  EXPECT_NEAR(lowest, 0.55, 1e-9);
}

/// The plannable box of worldOf()'s default 20 x 10 x 3 m map: the map less the planning margin.
const Box kMapBox{Eigen::Vector3d::Constant(0.15), Eigen::Vector3d(19.85, 9.85, 2.85)};

TEST(LocalGoalTest, TheWindowReachesWhereTheGuideClimbsOverAWall) {
  // The levels' way over the low wall (up to 1.5 m at x = 6) climbs to 2.15 m, beginning within
  // the horizon of a vehicle at 1 m, 3 m before the wall. wayHeight() is that climb's height, and a
  // window centred towards it (windowCentre(), 2 m high) takes the local goal up the climb;
  // centred towards the goal's height (1 m) the window held it at 1.5 m at most, where the
  // way is closed, and the vehicle stood at the wall (geb079).
  const auto world = worldOf(kOverAndUnder);
  const Eigen::Vector3d from(3.0, 5.0, 1.0);
  const Eigen::Vector3d goal(9.0, 5.0, 1.0);
  const Eigen::Vector3d froms[] = {from};
  const std::vector<Eigen::Vector3d> guide =
      levelColumnGuides(world->grid(), columnsOf(world->grid()), froms, goal, 0.4,
                        std::vector<double>{0.55, 0.95, 1.35, 1.75, 2.15}, 0.4)
          .front();
  ASSERT_GE(guide.size(), 2u);
  const double horizon = 3.5;
  EXPECT_GT(wayHeight(guide, horizon, goal), 1.75);  // up the climb, which ends past it
  EXPECT_NEAR(wayHeight(guide, 10.0, goal), 2.15, 1e-9);
  // Within a horizon that ends before the climb the way keeps the vehicle's level; without a
  // guide the window reaches towards the goal.
  EXPECT_NEAR(wayHeight(guide, 1.0, goal), 0.95, 1e-9);
  EXPECT_NEAR(wayHeight({}, horizon, Eigen::Vector3d(9.0, 5.0, 2.5)), 2.5, 1e-9);
  const auto localGoalIn = [&](double way_height) {
    // The window: 10 m across, 2 m high round its centre, within the map.
    const double middle = windowCentre(from, way_height, 2.0).z();
    const auto window = worldOf(
        kOverAndUnder, "{min: [0, 0, " + std::to_string(middle - 1.0) + "], max: [20, 10, " +
                           std::to_string(std::min(middle + 1.0, 3.0)) + "]}");
    Eigen::Vector3d local;
    EXPECT_TRUE(localGoal(from, goal, guide, horizon, *window, 0.4, kMapBox, &local));
    return local;
  };
  EXPECT_GT(localGoalIn(wayHeight(guide, horizon, goal)).z(), 1.9);
  EXPECT_LE(localGoalIn(goal.z()).z(), 1.5 + 1e-9);
}

TEST(LocalGoalTest, AGuideAlongTheMapsEndKeepsItsLocalGoalOnTheGuide) {
  // The window ends with the map (its domain is the map's box less the planning margin): no
  // side margin there, and a guide 0.2 m from the map's side gives a local goal on it, the
  // horizon along. Where the window ends inside the map, its 0.5 m side margin holds.
  const auto window = worldOf("  - type: empty\n");
  const Eigen::Vector3d from(5.0, 0.2, 1.5);
  const Eigen::Vector3d goal(15.0, 0.2, 1.5);
  const std::vector<Eigen::Vector3d> guide = {from, goal};
  Eigen::Vector3d local;
  ASSERT_TRUE(localGoal(from, goal, guide, 3.5, *window, 0.4, kMapBox, &local));
  EXPECT_LT((local - Eigen::Vector3d(8.5, 0.2, 1.5)).norm(), 1e-9) << local.transpose();
  // The same window inside a larger map: the local goal keeps 0.5 m inside its side.
  const Box larger{Eigen::Vector3d(-10, -10, 0.15), Eigen::Vector3d(30, 20, 2.85)};
  ASSERT_TRUE(localGoal(from, goal, guide, 3.5, *window, 0.4, larger, &local));
  EXPECT_LT((local - Eigen::Vector3d(8.5, 0.5, 1.5)).norm(), 1e-9) << local.transpose();
}

/// A wall along x = 10 .. 10.4 for y < 5, the map's whole height.
const char* kWall = "  - type: box_list\n    boxes: [{min: [10, 0, 0], max: [10.4, 5, 3]}]\n";

TEST(LocalGoalTest, AGoalBehindAWallIsTheLocalGoalOnlyWithinTheHorizonAlongTheGuide) {
  // The goal 3 m away in a straight line, behind the wall; the guide goes round the wall's end
  // (about 9 m). The local goal is the guide's point at the 3.5 m horizon, not the goal: taken
  // as the local goal in a straight line, it had the planner press against the wall replan
  // after replan (geb079: the flight's nearest local goal "0 m from the goal", stuck). Without
  // a guide (the straight line is the way) the goal within the horizon is the local goal.
  const auto world = worldOf(kWall);
  const Eigen::Vector3d from(8.5, 2.0, 1.5);
  const Eigen::Vector3d goal(11.5, 2.0, 1.5);
  const Eigen::Vector3d froms[] = {from};
  const std::vector<Eigen::Vector3d> guide =
      columnGuides(world->grid(), columnsOf(world->grid()), froms, goal, 0.4, 1.0, 2.0, 0.4)
          .front();
  ASSERT_GE(guide.size(), 2u);
  ASSERT_GT(wayLength(guide, from, goal), 7.0);
  Eigen::Vector3d local;
  ASSERT_TRUE(localGoal(from, goal, guide, 3.5, *world, 0.4, kMapBox, &local));
  EXPECT_LT((local - pointAlong(guide, 3.5)).norm(), 0.3) << local.transpose();
  EXPECT_GT((local - goal).norm(), 2.0) << local.transpose();
  ASSERT_TRUE(localGoal(from, goal, {}, 3.5, *world, 0.4, kMapBox, &local));
  EXPECT_EQ(local, goal);
}

TEST(BackOffTest, APressedVehicleBacksOffForThePlanningBodyAwayFromTheWall) {
  // 0.38 m from the wall, inside the 0.4 m planning radius (within half a voxel): after a
  // search that found nothing (no_solution or timeout) the vehicle moves 0.3 m straight away,
  // its planning body kept clear along the move. 1 m away, or after another status, no move.
  const auto window = worldOf(kWall);
  const Box domain{Eigen::Vector3d::Constant(0.15), Eigen::Vector3d(19.85, 9.85, 2.85)};
  const Eigen::Vector3d pressed(9.62, 3.0, 1.5);
  for (const std::string status : {"no_solution", "timeout"}) {
    const std::vector<BackOff> moves = backOffMoves(status, pressed, *window, domain, 0.4, 0.1);
    ASSERT_EQ(moves.size(), 1u) << status;
    EXPECT_LT((moves.front().offset - Eigen::Vector3d(-0.3, 0.0, 0.0)).norm(), 0.01)
        << moves.front().offset.transpose();
    EXPECT_FALSE(moves.front().body_alone);
  }
  EXPECT_TRUE(backOffMoves("exact", pressed, *window, domain, 0.4, 0.1).empty());
  EXPECT_TRUE(backOffMoves("approximate", pressed, *window, domain, 0.4, 0.1).empty());
  EXPECT_TRUE(backOffMoves("no_solution", Eigen::Vector3d(9.0, 3.0, 1.5), *window, domain, 0.4, 0.1)
                  .empty());
  // Below a ceiling (nothing beside): away is down, the whole gradient.
  const auto ceiling =
      worldOf("  - type: box_list\n    boxes: [{min: [0, 0, 2], max: [20, 10, 3]}]\n");
  const std::vector<BackOff> down =
      backOffMoves("timeout", Eigen::Vector3d(5.0, 5.0, 1.62), *ceiling, domain, 0.4, 0.1);
  ASSERT_EQ(down.size(), 1u);
  EXPECT_LT((down.front().offset - Eigen::Vector3d(0.0, 0.0, -0.3)).norm(), 0.01)
      << down.front().offset.transpose();
}

TEST(BackOffTest, ARefusedStartOutsideThePlanningDomainIsFirstMovedIntoIt) {
  // A start 0.05 m from the map's side, outside the domain (the box less the 0.15 m margin):
  // the first move ends 5 cm inside the domain, for the body alone (it is already within the
  // margin); then, as for any refused start, 0.3 m away from the nearest known obstacle.
  const auto window = worldOf(kWall);
  const Box domain{Eigen::Vector3d::Constant(0.15), Eigen::Vector3d(19.85, 9.85, 2.85)};
  const Eigen::Vector3d start(9.0, 0.05, 1.5);
  const std::vector<BackOff> moves =
      backOffMoves("invalid_start", start, *window, domain, 0.4, 0.1);
  ASSERT_EQ(moves.size(), 2u);
  EXPECT_LT((moves[0].offset - Eigen::Vector3d(0.0, 0.15, 0.0)).norm(), 1e-9)
      << moves[0].offset.transpose();
  EXPECT_TRUE(moves[0].body_alone);
  EXPECT_TRUE(domain.contains(start + moves[0].offset));
  EXPECT_NEAR(moves[1].offset.norm(), 0.3, 1e-9);
  EXPECT_LT(moves[1].offset.x(), 0.0);  // away from the wall at x = 10
  EXPECT_TRUE(moves[1].body_alone);
  // Inside the domain a refused start is only backed off.
  EXPECT_EQ(backOffMoves("invalid_start", Eigen::Vector3d(9.0, 3.0, 1.5), *window, domain, 0.4, 0.1)
                .size(),
            1u);
}

}  // namespace
}  // namespace kinolab
