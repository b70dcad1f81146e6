#include "kinolab/validation/trajectory_checker.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/world/trajectory_trace.hpp"
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
  // Nearest obstacle: the box top (its face at z = 2), 0.7 below; radius 0.25. Exact: the
  // samples at x in [5, 5.4] are straight above the face.
  EXPECT_NEAR(checker.evaluate(over).min_clearance, 0.45, 1e-9);
  EXPECT_DOUBLE_EQ(result.body_radius, 0.24);  // radius less the collision tolerance
}

TEST(TrajectoryChecker, MinClearanceIsTheExactDistanceToTheCubes) {
  // Past the box's top edge diagonally, between voxel centres: the closest approach is to the
  // edge (x = 5.4, z = 2), 0.309 m, where the trilinear ESDF reads 0.304. The checker's
  // min_clearance is the exact distance: at least the continuous minimum, at most it plus half
  // the spacing of its samples (0.025 m).
  const TrajectoryChecker checker(room(), {});
  const Trajectory past = line({5.0, 2.03, 2.6}, {1.0, 0, -0.6}, 1.0);  // to (6, 2.03, 2.0)
  const CheckResult result = checker.check(past, queryFor(past));
  ASSERT_TRUE(result.valid) << result.check << ": " << result.detail;
  double least = INFINITY;
  for (int i = 0; i <= 10000; ++i) {
    const Eigen::Vector3d p = past.evaluate(past.duration() * i / 10000, 0);
    const Eigen::Vector2d gap((p.x() - 5.4 > 0 ? p.x() - 5.4 : (p.x() < 5.0 ? 5.0 - p.x() : 0.0)),
                              p.z() - 2.0);
    least = std::min(least, gap.norm());
  }
  const double min_clearance = checker.evaluate(past).min_clearance;
  EXPECT_GE(min_clearance + 0.25, least - 1e-9);
  EXPECT_LE(min_clearance + 0.25, least + 0.0125);
}

TEST(TrajectoryChecker, MeanClearanceIsTheMeanExactDistanceAtItsSamples) {
  // The same pass by the box's edge: one segment, sampled evenly in time at `samples` points
  // (both ends included). The mean of the exact distances to the box at those points, less
  // the radius; the trilinear ESDF would read up to 5 mm less near the edge.
  const TrajectoryChecker checker(room(), {});
  const Trajectory past = line({5.0, 2.03, 2.6}, {1.0, 0, -0.6}, 1.0);
  const CheckResult result = checker.check(past, queryFor(past));
  ASSERT_TRUE(result.valid) << result.check << ": " << result.detail;
  ASSERT_GT(result.samples, 20);
  const auto box = [](const Eigen::Vector3d& p) {
    const double dx = p.x() > 5.4 ? p.x() - 5.4 : (p.x() < 5.0 ? 5.0 - p.x() : 0.0);
    return std::hypot(dx, std::max(p.z() - 2.0, 0.0));
  };
  double sum = 0.0;
  double trilinear = 0.0;
  for (int i = 0; i < result.samples; ++i) {
    const Eigen::Vector3d p = past.evaluate(past.duration() * i / (result.samples - 1), 0);
    sum += box(p);
    trilinear += room()->esdf().distance(p);
  }
  EXPECT_NEAR(checker.evaluate(past).mean_clearance, sum / result.samples - 0.25, 1e-9);
  EXPECT_GT(std::abs(trilinear - sum) / result.samples, 1e-4);  // the test can tell them apart
}

TEST(TrajectoryChecker, EvaluatesPiecewiseConstantAccelerationWithoutAJerkOfZero) {
  // Two acceleration primitives in the free part of the room: from (1, 1, 2.5) at 1 m/s
  // along x, pushed along +y for 1 s, then along -y for 1 s. Its acceleration jumps once, by
  // (0, -2, 0): the jerk is impulsive there, so its integral is undefined, never 0.
  ChainState start = ChainState::Zero();
  start.col(0) = Eigen::Vector3d(1, 1, 2.5);
  start.col(1) = Eigen::Vector3d(1, 0, 0);
  const TrajectorySegment first = TrajectorySegment::primitive(start, {0, 1, 0}, 2, 1.0);
  ChainState joint = ChainState::Zero();
  joint.col(0) = first.evaluate(1.0, 0);
  joint.col(1) = first.evaluate(1.0, 1);
  Trajectory turn;
  turn.append(first);
  turn.append(TrajectorySegment::primitive(joint, {0, -1, 0}, 2, 1.0));
  const TrajectoryChecker checker(room(), {});
  const CheckResult result = checker.check(turn, queryFor(turn));
  ASSERT_TRUE(result.valid) << result.check << ": " << result.detail;
  const TrajectoryEvaluation e = checker.evaluate(turn);
  EXPECT_DOUBLE_EQ(e.duration, 2.0);
  EXPECT_TRUE(std::isnan(e.jerk_integral));
  EXPECT_NE(e.undefined.find("jerk_integral: the acceleration jumps at 1 joint"), std::string::npos)
      << e.undefined;
  EXPECT_NEAR(e.acceleration_jumps, 4.0, 1e-12);     // |(0, -2, 0)|^2
  EXPECT_NEAR(e.acceleration_integral, 2.0, 1e-12);  // |a|^2 = 1 for 2 s
  // At t = 0 the velocity (1, 0, 0) is normal to the acceleration (0, 1, 0): curvature
  // |v x a| / |v|^3 = 1, the largest (the speed only grows from there: 1 / (1 + t^2)^1.5).
  EXPECT_NEAR(e.max_curvature, 1.0, 1e-9);
  EXPECT_GT(e.mean_curvature, 0.2);
  EXPECT_LT(e.mean_curvature, 1.0);
  EXPECT_NEAR(e.peak_speed, std::sqrt(2.0), 1e-9);  // (1, 1, 0) at the joint
  EXPECT_NEAR(e.peak_acceleration, 1.0, 1e-12);
  EXPECT_NEAR(e.speed_limit_ratio, 1.0 / MotionDefaults::kMaxVelocity, 1e-9);
  EXPECT_NEAR(e.acceleration_limit_ratio, 1.0 / MotionDefaults::kMaxAcceleration, 1e-12);
}

TEST(TrajectoryChecker, EvaluatesASmoothTrajectoryInFull) {
  // x(t) = 1 + t^3 / 6 + ... : one cubic piece (jerk 1 along x), continuous everything.
  Trajectory cubic;
  TrajectorySegment segment;
  segment.duration = 1.5;
  segment.coefficients = Eigen::Matrix<double, 3, 4>::Zero();
  segment.coefficients.col(0) = Eigen::Vector3d(1, 1, 2.5);
  segment.coefficients(0, 3) = 1.0 / 6.0;
  cubic.append(segment);
  const TrajectoryChecker checker(room(), {});
  const TrajectoryEvaluation e = checker.evaluate(cubic);
  EXPECT_EQ(e.undefined, "");
  EXPECT_NEAR(e.jerk_integral, 1.5, 1e-12);                          // |j|^2 = 1
  EXPECT_NEAR(e.acceleration_integral, 1.5 * 1.5 * 1.5 / 3, 1e-12);  // a = t
  EXPECT_EQ(e.acceleration_jumps, 0.0);
  EXPECT_NEAR(e.max_curvature, 0.0, 1e-12);  // a straight line
  // Every value the metric list reads is the evaluation's, by name.
  for (const auto& [name, value] : evaluationMetrics().values(e)) {
    if (name == "jerk_integral") {
      EXPECT_NEAR(std::get<double>(value), 1.5, 1e-12);
    }
    if (name == "jerk_per_metre") {
      EXPECT_NEAR(std::get<double>(value), 1.5 / e.length, 1e-12);
    }
  }
}

TEST(TrajectoryChecker, ACornerTurnedInPlaceHasNoMaximumCurvatureAndNoJerkOfZero) {
  // A polyline flown at constant speed: 1 m along x, then 1 m along y. Its velocity jumps at
  // the corner, so neither |a|^2 nor |j|^2 has a finite integral (both would read 0 from the
  // polynomials), and its curvature there is unbounded; its turning per metre is the corner's
  // right angle over the 2 m.
  Trajectory corner;
  corner.append(line({1, 1, 2.5}, {1, 0, 0}, 1.0).segments().front());
  corner.append(line({2, 1, 2.5}, {0, 1, 0}, 1.0).segments().front());
  const TrajectoryChecker checker(room(), {});
  const TrajectoryEvaluation e = checker.evaluate(corner);
  EXPECT_TRUE(std::isnan(e.acceleration_integral));
  EXPECT_TRUE(std::isnan(e.jerk_integral));
  EXPECT_TRUE(std::isnan(e.acceleration_jumps));
  EXPECT_TRUE(std::isnan(e.max_curvature));
  EXPECT_NEAR(e.mean_curvature, (M_PI / 2) / 2.0, 0.02);
  for (const char* name : {"acceleration_integral", "acceleration_per_metre", "jerk_integral",
                           "jerk_per_metre", "acceleration_jumps", "max_curvature"}) {
    EXPECT_NE(e.undefined.find(std::string(name) + ": "), std::string::npos) << name;
  }
  EXPECT_NE(e.undefined.find("the velocity jumps at 1 joint"), std::string::npos) << e.undefined;
}

TEST(TrajectoryChecker, AnEmptyOrNonFiniteTrajectoryHasNoFigures) {
  const TrajectoryChecker checker(room(), {});
  EXPECT_TRUE(std::isnan(checker.evaluate(Trajectory()).length));
  Trajectory broken = line({1, 1, 2.5}, {1, 0, 0}, 1.0);
  TrajectorySegment bad = broken.segments().front();
  bad.coefficients(1, 1) = NAN;
  Trajectory nan;
  nan.append(bad);
  const TrajectoryEvaluation e = checker.evaluate(nan);
  EXPECT_TRUE(std::isnan(e.min_clearance));
  EXPECT_NE(e.undefined.find("not finite"), std::string::npos);
}

TEST(TrajectoryChecker, FindsTheFirstViolationOfEachKind) {
  const TrajectoryChecker checker(room(), {});
  const Trajectory through = line({1, 2, 1}, {1.5, 0, 0}, 4.0);
  CheckResult result = checker.check(through, queryFor(through));
  EXPECT_FALSE(result.valid);
  EXPECT_EQ(result.check, "collision");
  // The body (0.25 less the 0.01 tolerance) reaches the box's face (x = 5) at x = 4.76,
  // t = 2.507 s.
  EXPECT_NEAR(result.time, 2.507, 0.02);
  EXPECT_NEAR(result.position.x(), 4.76, 0.03);

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

/// The exact distance from `p` to the nearest occupied voxel cube (0 inside one), by brute
/// force over the voxels within `reach`.
double cubeDistance(const World& world, const Eigen::Vector3d& p, double reach) {
  const VoxelGrid& grid = world.grid();
  const double r = grid.resolution();
  double best = INFINITY;
  grid.forEachVoxelIn(p.array() - reach - r, p.array() + reach + r, [&](std::size_t index) {
    if (!grid.occupied(index)) return;
    const std::size_t nz = grid.dims().z();
    const std::size_t ny = grid.dims().y();
    const VoxelIndex voxel(static_cast<int>(index / (ny * nz)), static_cast<int>(index / nz % ny),
                           static_cast<int>(index % nz));
    const Eigen::Vector3d offset =
        ((p - grid.center(voxel)).cwiseAbs().array() - 0.5 * r).max(0.0).matrix();
    best = std::min(best, offset.norm());
  });
  return best;
}

TEST(TrajectoryChecker, CheckMotionChecksEverythingButTheWorld) {
  const TrajectoryChecker checker(room(), {});
  const Trajectory through = line({1, 2, 1}, {1.5, 0, 0}, 4.0);  // through the box
  EXPECT_TRUE(checker.checkMotion(through, queryFor(through)).valid);
  EXPECT_EQ(checker.check(through, queryFor(through)).check, "collision");
  const Trajectory fast = line({1, 2, 2.7}, {2.5, 0, 0}, 1.0);
  EXPECT_EQ(checker.checkMotion(fast, queryFor(fast)).check, "limits");
  CheckQuery far_goal = queryFor(through);
  far_goal.goal.x() += 1.0;
  EXPECT_EQ(checker.checkMotion(through, far_goal).check, "goal");
  EXPECT_EQ(checker.checkMotion(Trajectory{}, far_goal).check, "empty");
}

/// A chain of 1-3 constant-jerk primitives from a random state in the forest.
Trajectory randomCurve(Rng& rng) {
  ChainState state = ChainState::Zero();
  state.col(0) = drawLastFirst<Eigen::Vector3d>(
      [&](int axis) { return axis < 2 ? rng.uniform(1.0, 11.0) : rng.uniform(0.5, 2.5); });
  state.col(1) = drawLastFirst<Eigen::Vector3d>([&](int) { return rng.uniform(-1.5, 1.5); });
  Trajectory trajectory;
  const int pieces = 1 + static_cast<int>(rng.uniform(0.0, 2.999));
  for (int i = 0; i < pieces; ++i) {
    const Eigen::Vector3d jerk =
        drawLastFirst<Eigen::Vector3d>([&](int) { return rng.uniform(-2.0, 2.0); });
    TrajectorySegment segment = TrajectorySegment::primitive(state, jerk, 3, 1.0);
    for (int k = 0; k < 3; ++k) state.col(k) = segment.evaluate(1.0, k);
    trajectory.append(std::move(segment));
  }
  return trajectory;
}

TEST(TraceTrajectory, IsTheWorldsVerdictExactToTheToleranceAndAgreesWithTheChecker) {
  // Over random curves in the forest: a curve traced free keeps radius - tolerance from every
  // cube (the checker, which holds samples to exactly that, accepts it); where tracing stops,
  // the body of the full radius touches a cube or the point is outside the map.
  const auto world = test::smallWorld("forest");
  CheckerSettings settings;
  settings.limits = DynamicLimits::uniform(100.0, 100.0);
  const TrajectoryChecker checker(world, settings);
  const double radius = settings.body.verdictRadius();
  const double tolerance = settings.body.tolerance;
  Rng rng(17);
  int free = 0;
  int collisions = 0;
  int outside = 0;
  for (int i = 0; i < 400; ++i) {
    const Trajectory curve = randomCurve(rng);
    CheckQuery query = queryFor(curve);
    query.require_goal = false;
    const TraceResult trace = traceTrajectory(*world, curve, radius, tolerance);
    const CheckResult check = checker.check(curve, query);
    if (trace.free) {
      ++free;
      EXPECT_TRUE(check.valid) << i << ": " << check.check << " " << check.detail;
      continue;
    }
    EXPECT_GE(trace.time, 0.0);
    EXPECT_LE(trace.time, curve.duration() + 1e-9);
    EXPECT_TRUE(trace.position.isApprox(curve.evaluate(trace.time), 1e-9));
    if (trace.left_domain) {
      ++outside;
      EXPECT_FALSE(world->bounds().contains(trace.position));
    } else {
      ++collisions;
      EXPECT_LT(cubeDistance(*world, trace.position, radius), radius) << i;
    }
  }
  EXPECT_GT(free, 40);  // the test sees every kind of verdict
  EXPECT_GT(collisions, 40);
  EXPECT_GT(outside, 5);
}

TEST(TraceTrajectory, TracesOnlyTheRangeAskedAndRefusesBadArguments) {
  const auto world = room();
  const Trajectory through = line({1, 2, 1}, {1.5, 0, 0}, 4.0);  // meets the box at ~2.5 s
  const TraceResult whole = traceTrajectory(*world, through, 0.25, 0.01);
  EXPECT_FALSE(whole.free);
  EXPECT_FALSE(whole.left_domain);
  EXPECT_GT(whole.time, 2.3);
  EXPECT_LT(whole.time, 2.51);
  EXPECT_TRUE(traceTrajectory(*world, through, 0.25, 0.01, 0.0, 2.0).free);
  EXPECT_FALSE(traceTrajectory(*world, through, 0.25, 0.01, 3.0, 3.0).free);  // one point
  EXPECT_TRUE(traceTrajectory(*world, through, 0.25, 0.01, 5.0).free);        // beyond the end
  const Trajectory leaving = line({1, 2, 2.7}, {0, 0, 1.0}, 1.0);
  EXPECT_TRUE(traceTrajectory(*world, leaving, 0.0, 0.01).left_domain);
  const Trajectory not_a_number = line({1, 2, 2.7}, {std::nan(""), 0, 0}, 1.0);
  EXPECT_FALSE(traceTrajectory(*world, not_a_number, 0.25, 0.01).free);
  for (const double bad : {double(NAN), -1.0, double(INFINITY)}) {
    EXPECT_THROW(traceTrajectory(*world, through, bad, 0.01), InvalidArgument);
    EXPECT_THROW(traceTrajectory(*world, through, 0.25, bad), InvalidArgument);
  }
  EXPECT_THROW(traceTrajectory(*world, through, 0.25, 0.0), InvalidArgument);
}

TEST(TrajectoryChecker, CollisionIsExactAgainstTheCubesAtAnyRadius) {
  const auto world = test::smallWorld("forest");
  for (const double radius : {0.25, 0.05, 0.0}) {
    CheckerSettings settings;
    settings.body.radius = radius;
    const TrajectoryChecker checker(world, settings);
    const double body = std::max(radius - settings.body.tolerance, 0.0);
    Rng rng(9);
    int hits = 0;
    int ties = 0;
    for (int i = 0; i < 3000; ++i) {
      const auto p = drawLastFirst<Eigen::Vector3d>(  // the same points on every compiler
          [&](int axis) { return axis < 2 ? rng.uniform(0.5, 11.5) : rng.uniform(0.3, 2.5); });
      const double exact = cubeDistance(*world, p, body);
      const bool hit = checker.collides(p);
      hits += hit;
      // The clearance bound never exceeds the exact distance.
      if (std::isfinite(exact)) {
        EXPECT_LE(world->clearance(p), exact + 1e-6) << p.transpose();
      }
      if (body > 0.0 && std::abs(exact - body) < 1e-6) {
        ++ties;  // on the sphere's surface: either answer is exact to rounding
        continue;
      }
      EXPECT_EQ(hit, body > 0.0 ? exact < body : exact == 0.0)
          << "radius " << radius << " at " << p.transpose() << ": exact distance " << exact;
    }
    EXPECT_GT(hits, 100) << radius;  // it does see the trunks
    EXPECT_LT(ties, 10);
  }
}

/// The distance from `p` to the nearest occupied cube within `reach` of it (on every axis), by
/// brute force over the voxels there; infinity when there is none.
double nearestCubeWithin(const VoxelGrid& grid, const Eigen::Vector3d& p, double reach) {
  double nearest = INFINITY;
  Eigen::Vector3i low;
  Eigen::Vector3i high;
  const Eigen::Vector3d box = Eigen::Vector3d::Constant(reach);
  if (!grid.voxelRange(p - box, p + box, low, high)) return nearest;
  for (int x = low.x(); x <= high.x(); ++x) {
    for (int y = low.y(); y <= high.y(); ++y) {
      for (int z = low.z(); z <= high.z(); ++z) {
        if (!grid.occupied(VoxelIndex(x, y, z))) continue;
        const Eigen::Vector3d corner = grid.origin() + Eigen::Vector3d(x, y, z) * grid.resolution();
        const Eigen::Vector3d far = corner.array() + grid.resolution();
        nearest = std::min(nearest, (p - p.cwiseMax(corner).cwiseMin(far)).norm());
      }
    }
  }
  return nearest;
}

/// What expectCollisionsExact() saw: bodies touching a cube, and missing one by less than
/// `near` metres.
struct CollisionCounts {
  int hits = 0;
  int near_misses = 0;
};

/// A world from a spec's text.
std::shared_ptr<const World> worldFrom(const std::string& text, const std::string& source) {
  return World::build(WorldSpec::fromYaml(YamlReader::loadString(text, source), "."));
}

/// A checker of `world` whose body is a sphere of radius `body` (the robot radius less a
/// collision tolerance of 0.05 m).
TrajectoryChecker bodyChecker(std::shared_ptr<const World> world, double body) {
  CheckerSettings settings;
  settings.body.radius = body + 0.05;
  settings.body.tolerance = 0.05;
  return TrajectoryChecker(std::move(world), settings);
}

/// checker.collides() for its body at the points `draw()` gives, against the brute force
/// (ties within a micrometre are left to FCL's rounding).
template <typename Draw>
CollisionCounts expectCollisionsExact(const TrajectoryChecker& checker, const VoxelGrid& grid,
                                      double near, int bodies, Draw&& draw) {
  const double radius = checker.settings().body.radius - checker.settings().body.tolerance;
  CollisionCounts counts;
  for (int i = 0; i < bodies; ++i) {
    const Eigen::Vector3d p = draw(i);
    const double nearest = nearestCubeWithin(grid, p, radius + 2 * grid.resolution());
    if (std::abs(nearest - radius) < 1e-6) continue;
    EXPECT_EQ(checker.collides(p), nearest <= radius) << p.transpose() << " " << nearest;
    counts.hits += nearest <= radius ? 1 : 0;
    counts.near_misses += nearest > radius && nearest < radius + near ? 1 : 0;
  }
  return counts;
}

TEST(TrajectoryCheckerTest, TheBodyCollidesExactlyWhenItMeetsAnOccupiedCube) {
  // The checker's tree holds the obstacles' surface voxels only (with the centre tested
  // against every cube): random bodies in a world of solid blocks, walls and scattered voxels,
  // on both layouts, against the brute force. Bodies of 0.3 m fit inside the 1 m blocks
  // without touching their skin.
  const std::string text =
      "seed: 2\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [6, 4, 3]}\n"
      "generators:\n  - {type: box_list, boxes: [{min: [1, 1, 0], max: [2.2, 2.3, 1.5]}, "
      "{min: [3, 0, 0], max: [3.2, 4, 2]}]}\n  - {type: boxes, count: 15, size_x: [0.1, 0.4], "
      "size_y: [0.1, 0.4], size_z: [0.1, 0.4]}\n";
  for (const char* layout : {"dense", "sparse"}) {
    SCOPED_TRACE(layout);
    const auto world = worldFrom(text + "layout: " + layout + "\n", "blocks.yaml");
    const double radius = 0.3;
    const TrajectoryChecker checker = bodyChecker(world, radius);
    Rng rng(5);
    int inside_blocks = 0;
    const CollisionCounts counts =
        expectCollisionsExact(checker, world->grid(), 0.05, 4000, [&](int) {
          const Eigen::Vector3d p(rng.uniform(0.0, 6.0), rng.uniform(0.0, 4.0),
                                  rng.uniform(0.0, 3.0));
          inside_blocks += world->distance(p) < -radius ? 1 : 0;
          return p;
        });
    EXPECT_GT(inside_blocks, 10);
    EXPECT_GT(counts.near_misses, 20);
  }
}

TEST(TrajectoryCheckerTest, TheBodyCollidesExactlyAcrossTheCheckersTiles) {
  // The checker's trees cover kTileVoxels x kTileVoxels voxels each, made as checks reach
  // them: on a 0.02 m grid 12 m x 6 m, tile borders lie at x = 5.12 and 10.24 m and at
  // y = 5.12 m (and between). A block and a wall straddle them, small boxes lie about; bodies
  // near the borders, on both layouts, against the brute force.
  const double tile_side = TrajectoryChecker::kTileVoxels * 0.02;
  ASSERT_NEAR(std::remainder(5.12, tile_side), 0.0, 1e-9);
  const std::string text =
      "seed: 4\nresolution: 0.02\nbounds: {min: [0, 0, 0], max: [12, 6, 0.6]}\n"
      "generators:\n  - {type: box_list, boxes: [{min: [4.9, 1, 0], max: [5.4, 2, 0.4]}, "
      "{min: [0, 5.0, 0], max: [12, 5.2, 0.3]}, {min: [10.1, 2.5, 0.1], max: [10.3, 2.7, 0.5]}]}\n"
      "  - {type: boxes, count: 60, size_x: [0.04, 0.2], size_y: [0.04, 0.2], "
      "size_z: [0.04, 0.2]}\n";
  for (const std::string layout : {"dense", "sparse\ntruncation: 0.5"}) {
    SCOPED_TRACE(layout);
    const auto world = worldFrom(text + "layout: " + layout + "\n", "tiles.yaml");
    const double radius = 0.1;
    const TrajectoryChecker checker = bodyChecker(world, radius);
    Rng rng(9);
    int across = 0;  // bodies reaching over a border
    const CollisionCounts counts =
        expectCollisionsExact(checker, world->grid(), 0.02, 3000, [&](int i) {
          const double x = i % 3 == 0   ? rng.uniform(4.8, 5.5)
                           : i % 3 == 1 ? rng.uniform(9.9, 10.6)
                                        : rng.uniform(0.0, 12.0);
          const double y = i % 2 == 0 ? rng.uniform(4.8, 5.5) : rng.uniform(0.0, 6.0);
          const Eigen::Vector3d p(x, y, rng.uniform(0.0, 0.6));
          const auto tile = [&](double v) { return std::floor(v / tile_side); };
          across += tile(x - radius) != tile(x + radius) || tile(y - radius) != tile(y + radius);
          return p;
        });
    EXPECT_GT(counts.hits, 300);
    EXPECT_GT(counts.near_misses, 30);
    EXPECT_GT(across, 300);
  }
}

TEST(TrajectoryCheckerTest, AWorldLongerThanOctomapsKeysIsCheckedToItsFarEnd) {
  // 40,000 voxels along x (OctoMap's keys reach 2^15 either way of a tree's centre): boxes near
  // both ends, bodies about them against the brute force.
  const auto world = worldFrom(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4000, 1.6, 1.6]}\nlayout: sparse\n"
      "generators: [{type: box_list, boxes: [{min: [2, 0.4, 0], max: [2.5, 1.2, 1]}, "
      "{min: [3500, 0.4, 0], max: [3500.5, 1.2, 1]}, {min: [3999.5, 0, 0], "
      "max: [4000, 0.3, 0.3]}]}]\n",
      "long.yaml");
  ASSERT_GT(world->grid().dims().x(), 32768);
  const TrajectoryChecker checker = bodyChecker(world, 0.2);
  Rng rng(3);
  const CollisionCounts counts =
      expectCollisionsExact(checker, world->grid(), 0.05, 1500, [&](int i) {
        const double x = i % 3 == 0   ? rng.uniform(1.5, 3.0)
                         : i % 3 == 1 ? rng.uniform(3499.5, 3501.0)
                                      : rng.uniform(3999.0, 4000.0);
        return Eigen::Vector3d(x, rng.uniform(0.0, 1.6), rng.uniform(0.0, 1.6));
      });
  EXPECT_GT(counts.hits, 300);
  EXPECT_GT(counts.near_misses, 20);
  EXPECT_TRUE(checker.collides({3500.25, 0.8, 1.15}));  // 0.15 m above the far box
  EXPECT_FALSE(checker.collides({3500.25, 0.8, 1.25}));
}

TEST(TrajectoryCheckerTest, APointOnTheMapsOwnFaceIsInTheVoxelInsideOnly) {
  // 0.5 m voxels, one occupied voxel at z in [2, 2.5] under the map's top face (z = 3): a body
  // of 0.24 m on the top face is 0.5 m from it; one on the face between two voxels touches both.
  const auto world = World::build(WorldSpec::fromYaml(
      YamlReader::loadString("resolution: 0.5\nbounds: {min: [0, 0, 0], max: [3, 3, 3]}\n"
                             "generators: [{type: box_list, boxes: [{min: [1, 1, 2], "
                             "max: [1.5, 1.5, 2.5]}]}]\n",
                             "faces.yaml"),
      "."));
  CheckerSettings settings;
  settings.body.radius = 0.29;
  settings.body.tolerance = 0.05;
  const TrajectoryChecker checker(world, settings);
  EXPECT_FALSE(checker.collides({1.25, 1.25, 3.0}));  // the top face, 0.5 m above the voxel
  EXPECT_TRUE(checker.collides({1.25, 1.25, 2.5}));   // on its top face
  EXPECT_TRUE(checker.collides({1.25, 1.25, 2.7}));   // 0.2 m above it
  EXPECT_FALSE(checker.collides({1.25, 1.25, 0.0}));  // the bottom face
  EXPECT_FALSE(checker.collides({3.0, 1.25, 2.25}));  // the side face, 1.5 m away
  EXPECT_TRUE(checker.collides({1.5, 1.25, 2.25}));   // on its side face
}

}  // namespace
}  // namespace kinolab
