#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

namespace kinolab {

/// State of a 3-D integrator chain: column k holds the k-th time derivative of position
/// (0 = position, 1 = velocity, 2 = acceleration, 3 = jerk). Only the first `order` columns
/// are used; the control is the order-th derivative.
using ChainState = Eigen::Matrix<double, 3, 4>;

/// The motion defaults every planner, the edge evaluator and the checker share (one place):
/// per-axis velocity and acceleration limits, the body's radius, the collision verdict's
/// tolerance and the goal region's radius.
struct MotionDefaults {
  static constexpr double kMaxVelocity = 2.0;          ///< m/s
  static constexpr double kMaxAcceleration = 3.0;      ///< m/s^2
  static constexpr double kRobotRadius = 0.25;         ///< m
  static constexpr double kCollisionTolerance = 0.01;  ///< m
  static constexpr double kGoalRadius = 0.5;           ///< m
};

/// Per-axis bounds on the absolute value of each derivative; `bound[k]` limits the k-th
/// derivative (1 = velocity ... 4 = snap). bound[0] (position) is unused: the map bounds
/// position. An infinite entry means unbounded.
struct DynamicLimits {
  std::array<Eigen::Vector3d, 5> bound;

  DynamicLimits();
  /// The same limit on every axis: velocity, acceleration, jerk, snap.
  static DynamicLimits uniform(double velocity, double acceleration, double jerk = INFINITY,
                               double snap = INFINITY);
};

/// Where a primitive first breaks a limit.
struct LimitViolation {
  int derivative = 0;  // 1 = velocity, ..., order = the control
  int axis = 0;        // 0 = x, 1 = y, 2 = z
  double time = 0.0;   // seconds from the primitive's start
  double value = 0.0;  // the offending value
};

/// How the end state of a constant-control primitive is computed.
enum class Propagation {
  kExact,  ///< closed form (the integrator chain is exactly a polynomial in time)
  kEuler,  ///< the paper's eq. (2): forward Euler steps x_k += dt * x_{k+1}, x_{n-1} += dt * u
};

/// The linear integrator chain of the paper's eq. (1): d/dt x_k = x_{k+1}, d/dt x_{n-1} = u,
/// per axis, with order n = 2 (acceleration control), 3 (jerk) or 4 (snap). Under a constant
/// control every derivative is a polynomial in time, which gives closed-form propagation and
/// an exact limit check over the whole interval (extrema at the ends or at the roots of the
/// next derivative, a polynomial of degree <= 2), not only at the end points.
class IntegratorChain {
 public:
  explicit IntegratorChain(int order, Propagation propagation = Propagation::kExact,
                           int euler_steps = 1);

  int order() const { return order_; }
  Propagation propagation() const { return propagation_; }

  /// The state after applying `control` for `duration` seconds (by the propagation mode).
  ChainState propagate(const ChainState& state, const Eigen::Vector3d& control,
                       double duration) const;
  /// The exact state at time t of the primitive (closed form, whatever the mode).
  ChainState stateAt(const ChainState& state, const Eigen::Vector3d& control, double t) const;

  /// Exact per-axis maximum of |d^k/dt^k position| over [0, duration], 1 <= k < order.
  Eigen::Vector3d maxAbsDerivative(const ChainState& state, const Eigen::Vector3d& control,
                                   double duration, int derivative) const;
  /// The first limit the primitive breaks over [0, duration] (control included), if any.
  std::optional<LimitViolation> checkLimits(const ChainState& state, const Eigen::Vector3d& control,
                                            double duration, const DynamicLimits& limits) const;
  /// The same verdict as `!checkLimits(...)`, without locating the violation: closed-form
  /// per-axis tests for orders 2 and 3 (the hot path of edge evaluation).
  bool withinLimits(const ChainState& state, const Eigen::Vector3d& control, double duration,
                    const DynamicLimits& limits) const;

 private:
  int order_;
  Propagation propagation_;
  int euler_steps_;
};

}  // namespace kinolab
