#include "kinolab/validation/trajectory_checker.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

/// A 10 x 4 x 3 m room with one box across the middle, from x = 5 to 5.4, below z = 2.
std::shared_ptr<const World> room() {
  static const auto world = World::build(WorldSpec::fromYaml(
      YamlReader::loadString("resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 4, 3]}\n"
                             "generators: [{type: box_list, boxes: [{min: [5, 0, 0], "
                             "max: [5.4, 4, 2]}]}]\n",
                             "room.yaml"),
      "."));
  return world;
}

/// Constant velocity from `from` for `duration` seconds.
Trajectory line(const Eigen::Vector3d& from, const Eigen::Vector3d& velocity, double duration) {
  ChainState start = ChainState::Zero();
  start.col(0) = from;
  start.col(1) = velocity;
  Trajectory trajectory;
  trajectory.append(TrajectorySegment::primitive(start, Eigen::Vector3d::Zero(), 2, duration));
  return trajectory;
}

CheckQuery queryFor(const Trajectory& trajectory, double goal_radius = 0.3) {
  CheckQuery query;
  query.start.col(0) = trajectory.startPosition();
  query.start.col(1) = trajectory.evaluate(0.0, 1);
  query.goal = trajectory.endPosition();
  query.goal_radius = goal_radius;
  return query;
}

TEST(TrajectoryChecker, AcceptsAFreeLineAndReportsClearance) {
  const TrajectoryChecker checker(room(), {});
  const Trajectory over = line({1, 2, 2.7}, {1.5, 0, 0}, 4.0);  // above the box
  const CheckResult result = checker.check(over, queryFor(over));
  EXPECT_TRUE(result.valid) << result.check << ": " << result.detail;
  EXPECT_GT(result.samples, 200);
  // Nearest obstacle: the box top (centres at z = 1.95), 0.75 below; radius 0.25.
  EXPECT_NEAR(result.min_clearance, 0.5, 0.06);
  EXPECT_GT(result.fcl_radius, 0.0);
}

TEST(TrajectoryChecker, FindsTheFirstViolationOfEachKind) {
  const TrajectoryChecker checker(room(), {});
  const Trajectory through = line({1, 2, 1}, {1.5, 0, 0}, 4.0);
  CheckResult result = checker.check(through, queryFor(through));
  EXPECT_FALSE(result.valid);
  EXPECT_EQ(result.check, "esdf");
  // The body (0.25) reaches the first voxel centres (x = 5.05) at x = 4.8, t = 2.53 s.
  EXPECT_NEAR(result.time, 2.533, 0.02);
  EXPECT_NEAR(result.position.x(), 4.8, 0.03);

  const Trajectory fast = line({1, 2, 2.7}, {2.5, 0, 0}, 1.0);
  result = checker.check(fast, queryFor(fast));
  EXPECT_EQ(result.check, "limits");
  EXPECT_NE(result.detail.find("velocity x"), std::string::npos) << result.detail;

  const Trajectory leaving = line({1, 2, 2.7}, {0, 0, 1.0}, 1.0);
  result = checker.check(leaving, queryFor(leaving));
  EXPECT_EQ(result.check, "bounds");

  const Trajectory free_line = line({1, 2, 2.7}, {1, 0, 0}, 2.0);
  CheckQuery wrong_start = queryFor(free_line);
  wrong_start.start.col(0).x() += 0.1;
  EXPECT_EQ(checker.check(free_line, wrong_start).check, "start");
  CheckQuery far_goal = queryFor(free_line);
  far_goal.goal.x() += 1.0;
  EXPECT_EQ(checker.check(free_line, far_goal).check, "goal");
  far_goal.require_goal = false;  // an approximate answer
  EXPECT_TRUE(checker.check(free_line, far_goal).valid);
  EXPECT_EQ(checker.check(Trajectory{}, far_goal).check, "empty");

  // A NaN passes every comparison; the checker calls it what it is, never valid.
  const Trajectory not_a_number = line({1, 2, 2.7}, {std::nan(""), 0, 0}, 1.0);
  result = checker.check(not_a_number, queryFor(not_a_number));
  EXPECT_FALSE(result.valid);
  EXPECT_EQ(result.check, "numeric") << result.detail;
}

TEST(TrajectoryChecker, FclAgreesWithTheEsdfWhereTheModelsOverlap) {
  const auto world = test::smallWorld("forest");
  const TrajectoryChecker checker(world, {});
  const double radius = checker.settings().robot_radius;
  Rng rng(9);
  int fcl_hits = 0;
  int esdf_free = 0;
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d p(rng.uniform(0.5, 11.5), rng.uniform(0.5, 11.5), rng.uniform(0.3, 2.5));
    const bool hit = checker.fclCollides(p);
    fcl_hits += hit;
    if (world->distance(p) >= radius) {
      ++esdf_free;
      // ESDF clearance >= r guarantees no cube within r - sqrt(3) voxel.
      EXPECT_FALSE(hit) << "FCL hit at an ESDF-free point " << p.transpose();
    }
  }
  EXPECT_GT(fcl_hits, 100);  // FCL does see the trunks
  EXPECT_GT(esdf_free, 1000);
  // Inside a trunk: both say collision.
  const VoxelGrid& grid = world->grid();
  for (int ix = 0; ix < grid.dims().x(); ++ix) {
    const VoxelIndex voxel(ix, 60, 10);
    if (grid.occupied(voxel)) {
      EXPECT_TRUE(checker.fclCollides(grid.center(voxel)));
    }
  }
}

}  // namespace
}  // namespace kinolab
