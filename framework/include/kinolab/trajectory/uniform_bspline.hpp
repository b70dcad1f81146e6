#pragma once

#include <Eigen/Core>

#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/trajectory/trajectory.hpp"

namespace kinolab {

/// A uniform cubic B-spline in 3-D: control points P_0 .. P_{n-1} (n >= 4) and one knot
/// interval dt. It has n - 3 spans of dt seconds; span i is shaped by P_i .. P_{i+3}:
///   p(u) = 1/6 [1 u u^2 u^3] M [P_i P_{i+1} P_{i+2} P_{i+3}]^T,  u = (t - i dt) / dt.
/// Its derivatives are uniform B-splines of lower degree whose control points are scaled
/// differences (velocity V_i = (P_{i+1} - P_i) / dt, and so on), so by the convex-hull
/// property |derivative_k(t)| <= max_i |D_k,i| per axis: limits on the derivative control
/// points bound the whole curve. Position, velocity and acceleration are continuous; jerk
/// is constant on each span.
class UniformBspline {
 public:
  UniformBspline(Eigen::Matrix3Xd control_points, double interval);

  const Eigen::Matrix3Xd& controlPoints() const { return control_points_; }
  double interval() const { return interval_; }
  int spans() const { return static_cast<int>(control_points_.cols()) - 3; }
  double duration() const { return spans() * interval_; }

  /// The control points of the `derivative`-th derivative (0..3): n - derivative of them.
  Eigen::Matrix3Xd derivativeControlPoints(int derivative) const;
  /// The same curve as a piecewise polynomial, one cubic segment per span.
  Trajectory toTrajectory() const;

  /// The weights of P_i .. P_{i+3} at span parameter u in [0, 1] (they sum to 1).
  static Eigen::Vector4d basis(double u);
  /// The three leading control points that give position, velocity and acceleration of
  /// `state` at t = 0 for knot interval `interval`; at rest all three are the position.
  static Eigen::Matrix3d startControlPoints(const ChainState& state, double interval);

 private:
  Eigen::Matrix3Xd control_points_;
  double interval_;
};

/// A polyline flown stop-and-go: along each leg from rest to rest, accelerating at the
/// largest rate the per-axis limits allow in the leg's direction, cruising at the largest
/// such speed when the leg is long enough (a trapezoidal, else a triangular profile).
/// Piecewise quadratic; repeated waypoints are skipped. Needs at least one waypoint.
Trajectory stopAndGo(const std::vector<Eigen::Vector3d>& waypoints, const DynamicLimits& limits);

}  // namespace kinolab
