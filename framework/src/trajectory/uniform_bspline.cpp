#include "kinolab/trajectory/uniform_bspline.hpp"

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"

namespace kinolab {
namespace {

/// The cubic uniform B-spline basis matrix (times 6): row k holds the u^k coefficients.
Eigen::Matrix4d basisMatrix() {
  Eigen::Matrix4d m;
  m << 1, 4, 1, 0,  //
      -3, 0, 3, 0,  //
      3, -6, 3, 0,  //
      -1, 3, -3, 1;
  return m / 6.0;
}

}  // namespace

UniformBspline::UniformBspline(Eigen::Matrix3Xd control_points, double interval)
    : control_points_(std::move(control_points)), interval_(interval) {
  if (control_points_.cols() < 4) {
    throw InvalidArgument("uniform B-spline: needs at least 4 control points, got " +
                          std::to_string(control_points_.cols()));
  }
  if (!(interval_ > 0.0) || !std::isfinite(interval_)) {
    throw InvalidArgument("uniform B-spline: the knot interval must be positive and finite");
  }
}

Eigen::Matrix3Xd UniformBspline::derivativeControlPoints(int derivative) const {
  if (derivative < 0 || derivative > 3) {
    throw InvalidArgument("uniform B-spline: derivative " + std::to_string(derivative) +
                          " of a cubic (0..3)");
  }
  Eigen::Matrix3Xd points = control_points_;
  for (int k = 0; k < derivative; ++k) {
    const Eigen::Index n = points.cols() - 1;
    points = ((points.rightCols(n) - points.leftCols(n)) / interval_).eval();
  }
  return points;
}

Trajectory UniformBspline::toTrajectory() const {
  static const Eigen::Matrix4d kBasis = basisMatrix();
  Trajectory trajectory;
  for (int span = 0; span < spans(); ++span) {
    TrajectorySegment segment;
    segment.duration = interval_;
    // Coefficients in u, then u = t / dt scales the u^k coefficient by dt^-k.
    segment.coefficients = control_points_.middleCols<4>(span) * kBasis.transpose();
    double scale = 1.0;
    for (int k = 1; k < 4; ++k) {
      scale /= interval_;
      segment.coefficients.col(k) *= scale;
    }
    trajectory.append(std::move(segment));
  }
  return trajectory;
}

Eigen::Vector4d UniformBspline::basis(double u) {
  static const Eigen::Matrix4d kBasis = basisMatrix();
  return kBasis.transpose() * Eigen::Vector4d(1.0, u, u * u, u * u * u);
}

Eigen::Matrix3d UniformBspline::startControlPoints(const ChainState& state, double interval) {
  // p = (P0 + 4 P1 + P2) / 6, v = (P2 - P0) / (2 dt), a = (P0 - 2 P1 + P2) / dt^2.
  const Eigen::Vector3d p = state.col(0);
  const Eigen::Vector3d v = state.col(1);
  const Eigen::Vector3d a = state.col(2);
  const double dt2 = interval * interval;
  Eigen::Matrix3d points;
  points.col(1) = p - a * dt2 / 6.0;
  points.col(0) = p + a * dt2 / 3.0 - v * interval;
  points.col(2) = p + a * dt2 / 3.0 + v * interval;
  return points;
}

Trajectory stopAndGo(const std::vector<Eigen::Vector3d>& waypoints, const DynamicLimits& limits) {
  if (waypoints.empty()) throw InvalidArgument("stop-and-go timing: no waypoints");
  Trajectory trajectory;
  const auto quadratic = [](const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                            const Eigen::Vector3d& a, double duration) {
    TrajectorySegment segment;
    segment.duration = duration;
    segment.coefficients.resize(3, 3);
    segment.coefficients << p, v, 0.5 * a;
    return segment;
  };
  for (std::size_t i = 1; i < waypoints.size(); ++i) {
    const Eigen::Vector3d leg = waypoints[i] - waypoints[i - 1];
    const double length = leg.norm();
    if (!(length > 0.0)) continue;
    const Eigen::Vector3d direction = leg / length;
    // The largest speed and acceleration along `direction` within every axis's limit.
    double speed = INFINITY;
    double acceleration = INFINITY;
    for (int axis = 0; axis < 3; ++axis) {
      const double share = std::abs(direction[axis]);
      if (share == 0.0) continue;
      speed = std::min(speed, limits.bound[1][axis] / share);
      acceleration = std::min(acceleration, limits.bound[2][axis] / share);
    }
    speed = std::min(speed, std::sqrt(length * acceleration));  // triangular when short
    const double ramp_time = speed / acceleration;
    const double cruise_time = length / speed - ramp_time;
    const Eigen::Vector3d up = acceleration * direction;
    Eigen::Vector3d position = waypoints[i - 1];
    trajectory.append(quadratic(position, Eigen::Vector3d::Zero(), up, ramp_time));
    position += 0.5 * up * ramp_time * ramp_time;
    if (cruise_time > 1e-12) {
      trajectory.append(
          quadratic(position, speed * direction, Eigen::Vector3d::Zero(), cruise_time));
      position += speed * direction * cruise_time;
    }
    trajectory.append(quadratic(position, speed * direction, -up, ramp_time));
  }
  return trajectory;
}

}  // namespace kinolab
