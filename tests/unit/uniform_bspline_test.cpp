#include "kinolab/trajectory/uniform_bspline.hpp"

#include <gtest/gtest.h>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"

namespace kinolab {
namespace {

Eigen::Matrix3Xd randomControlPoints(Rng& rng, int count) {
  Eigen::Matrix3Xd points(3, count);
  for (int i = 0; i < count; ++i) {
    points.col(i) = Eigen::Vector3d(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(0, 2));
  }
  return points;
}

TEST(UniformBspline, PiecewisePolynomialMatchesTheBasis) {
  Rng rng(5);
  const UniformBspline spline(randomControlPoints(rng, 9), 0.3);
  const Trajectory trajectory = spline.toTrajectory();
  ASSERT_EQ(static_cast<int>(trajectory.segments().size()), spline.spans());
  EXPECT_DOUBLE_EQ(trajectory.duration(), 6 * 0.3);
  for (int span = 0; span < spline.spans(); ++span) {
    for (const double u : {0.0, 0.25, 0.5, 0.9}) {
      const Eigen::Vector3d expected =
          spline.controlPoints().middleCols<4>(span) * UniformBspline::basis(u);
      EXPECT_LT((trajectory.evaluate((span + u) * 0.3) - expected).norm(), 1e-12);
    }
  }
  EXPECT_NEAR(UniformBspline::basis(0.37).sum(), 1.0, 1e-15);
}

TEST(UniformBspline, DerivativesAreContinuousAndMatchFiniteDifferences) {
  Rng rng(6);
  const UniformBspline spline(randomControlPoints(rng, 8), 0.4);
  const Trajectory trajectory = spline.toTrajectory();
  const double h = 1e-6;
  for (double t = 0.05; t < trajectory.duration() - 0.05; t += 0.13) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d numeric =
          (trajectory.evaluate(t + h, k) - trajectory.evaluate(t - h, k)) / (2 * h);
      EXPECT_LT((trajectory.evaluate(t, k + 1) - numeric).norm(), 1e-5) << "t " << t << " k " << k;
    }
  }
  // Position, velocity and acceleration agree on both sides of every joint.
  const auto& segments = trajectory.segments();
  for (std::size_t i = 1; i < segments.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT((segments[i - 1].evaluate(0.4, k) - segments[i].evaluate(0.0, k)).norm(), 1e-9);
    }
  }
}

TEST(UniformBspline, DerivativeControlPointsBoundTheCurve) {
  Rng rng(7);
  const UniformBspline spline(randomControlPoints(rng, 10), 0.25);
  const Trajectory trajectory = spline.toTrajectory();
  for (int k = 1; k <= 3; ++k) {
    const Eigen::Matrix3Xd points = spline.derivativeControlPoints(k);
    EXPECT_EQ(points.cols(), 10 - k);
    const Eigen::Vector3d hull = points.cwiseAbs().rowwise().maxCoeff();
    double touched = 0.0;
    for (double t = 0.0; t <= trajectory.duration(); t += 0.001) {
      const Eigen::Vector3d value = trajectory.evaluate(t, k).cwiseAbs();
      EXPECT_TRUE((value.array() <= hull.array() + 1e-9).all()) << "derivative " << k;
      touched = std::max(touched, (value.array() / hull.array()).maxCoeff());
    }
    EXPECT_GT(touched, 0.5);  // the bound is not vacuous
  }
  // Jerk is constant on a span: the third-derivative control points themselves.
  const Eigen::Matrix3Xd jerk = spline.derivativeControlPoints(3);
  EXPECT_LT((trajectory.evaluate(0.1, 3) - jerk.col(0)).norm(), 1e-9);
  EXPECT_THROW(spline.derivativeControlPoints(4), InvalidArgument);
}

TEST(UniformBspline, StartControlPointsReproduceTheStartState) {
  ChainState state = ChainState::Zero();
  state.col(0) = Eigen::Vector3d(1, 2, 1.5);
  state.col(1) = Eigen::Vector3d(0.5, -1, 0.2);
  state.col(2) = Eigen::Vector3d(-2, 0.3, 1);
  const double dt = 0.35;
  Eigen::Matrix3Xd points(3, 5);
  points.leftCols<3>() = UniformBspline::startControlPoints(state, dt);
  points.col(3) = Eigen::Vector3d(3, 3, 3);
  points.col(4) = Eigen::Vector3d(4, 3, 2);
  const Trajectory trajectory = UniformBspline(points, dt).toTrajectory();
  for (int k = 0; k < 3; ++k) EXPECT_LT((trajectory.evaluate(0.0, k) - state.col(k)).norm(), 1e-12);
  // At rest the three points coincide with the position.
  state.rightCols<3>().setZero();
  const Eigen::Matrix3d rest = UniformBspline::startControlPoints(state, dt);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(rest.col(i), state.col(0));
}

TEST(UniformBspline, RejectsTooFewPointsAndBadIntervals) {
  EXPECT_THROW(UniformBspline(Eigen::Matrix3Xd::Zero(3, 3), 0.1), InvalidArgument);
  EXPECT_THROW(UniformBspline(Eigen::Matrix3Xd::Zero(3, 4), 0.0), InvalidArgument);
  EXPECT_THROW(UniformBspline(Eigen::Matrix3Xd::Zero(3, 4), INFINITY), InvalidArgument);
}

TEST(StopAndGo, TrapezoidAndTriangleDurationsByHand) {
  const DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0);
  // 10 m along x: ramp 2/3 s, cruise (10 - 4/3) / 2 s, ramp 2/3 s.
  const Trajectory long_leg = stopAndGo({{0, 0, 0}, {10, 0, 0}}, limits);
  EXPECT_NEAR(long_leg.duration(), 10.0 / 2.0 + 2.0 / 3.0, 1e-12);
  EXPECT_EQ(long_leg.segments().size(), 3u);
  // 1 m: triangular, peak speed sqrt(3) < 2, duration 2 sqrt(1 / 3).
  const Trajectory short_leg = stopAndGo({{0, 0, 0}, {1, 0, 0}}, limits);
  EXPECT_NEAR(short_leg.duration(), 2.0 * std::sqrt(1.0 / 3.0), 1e-12);
  EXPECT_EQ(short_leg.segments().size(), 2u);
  EXPECT_TRUE(stopAndGo({{1, 1, 1}}, limits).empty());
  EXPECT_THROW(stopAndGo({}, limits), InvalidArgument);
}

TEST(StopAndGo, StopsAtEveryWaypointWithinThePerAxisLimits) {
  const DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0);
  const std::vector<Eigen::Vector3d> waypoints = {
      {0, 0, 1}, {4, 3, 1}, {4, 3, 1}, {4, 3, 2.5}, {-1, 5, 0.5}};
  const Trajectory trajectory = stopAndGo(waypoints, limits);
  for (const TrajectorySample& s : trajectory.sample(0.001)) {
    EXPECT_LE(s.velocity.cwiseAbs().maxCoeff(), 2.0 + 1e-9);
    EXPECT_LE(s.acceleration.cwiseAbs().maxCoeff(), 3.0 + 1e-9);
  }
  // The joints where it is at rest are the waypoints, in order, the repeated one once.
  std::vector<Eigen::Vector3d> stops;
  for (const TrajectorySegment& segment : trajectory.segments()) {
    if (segment.evaluate(0.0, 1).norm() < 1e-9) stops.push_back(segment.evaluate(0.0));
  }
  stops.push_back(trajectory.endPosition());
  const std::vector<Eigen::Vector3d> expected = {waypoints[0], waypoints[1], waypoints[3],
                                                 waypoints[4]};
  ASSERT_EQ(stops.size(), expected.size());
  for (std::size_t i = 0; i < stops.size(); ++i) EXPECT_LT((stops[i] - expected[i]).norm(), 1e-9);
  EXPECT_LT((trajectory.endPosition() - waypoints.back()).norm(), 1e-12);
  EXPECT_LT(trajectory.evaluate(trajectory.duration(), 1).norm(), 1e-12);
}

}  // namespace
}  // namespace kinolab
