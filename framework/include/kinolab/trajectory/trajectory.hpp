#pragma once

#include <Eigen/Core>
#include <vector>

#include "kinolab/dynamics/integrator_chain.hpp"

namespace kinolab {

/// One polynomial piece: p(t) = sum_k coefficients.col(k) t^k for local time t in [0, duration].
struct TrajectorySegment {
  double duration = 0.0;
  Eigen::Matrix<double, 3, Eigen::Dynamic> coefficients;

  /// The primitive of an integrator chain: a constant `control` (the order-th derivative)
  /// applied from `start` for `duration` seconds.
  static TrajectorySegment primitive(const ChainState& start, const Eigen::Vector3d& control,
                                     int order, double duration);
  /// The `derivative`-th time derivative at local time t.
  Eigen::Vector3d evaluate(double t, int derivative = 0) const;
};

/// Position and its first three derivatives at one time.
struct TrajectorySample {
  double time = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();
  Eigen::Vector3d jerk = Eigen::Vector3d::Zero();
};

/// The one trajectory type of every planner: a piecewise polynomial in time, starting at t = 0.
/// Within a segment every derivative is continuous; at a joint the derivatives a planner does
/// not control may jump (the control of a motion primitive is piecewise constant).
class Trajectory {
 public:
  void append(TrajectorySegment segment);

  bool empty() const { return segments_.empty(); }
  const std::vector<TrajectorySegment>& segments() const { return segments_; }
  double duration() const { return duration_; }

  /// The `derivative`-th derivative at time t (clamped to [0, duration]); at a joint, the
  /// value of the segment that starts there.
  Eigen::Vector3d evaluate(double t, int derivative = 0) const;
  Eigen::Vector3d startPosition() const { return evaluate(0.0); }
  Eigen::Vector3d endPosition() const { return evaluate(duration_); }

  /// Samples at t = 0, step, 2 step, ... and always at the end time.
  std::vector<TrajectorySample> sample(double step) const;
  /// Arc length, by Gauss-Legendre quadrature of the speed per segment (8 sub-intervals of
  /// 5 points each).
  double length() const;
  /// The integral of the squared norm of the `derivative`-th derivative over the segments,
  /// exact (polynomial products). It is the trajectory's integral only where the derivative
  /// below it is continuous at every joint (jumps(derivative - 1) finds none): a jump there
  /// makes this derivative impulsive, and its square has no finite integral.
  double squaredIntegral(int derivative) const;
  /// The jumps of the `derivative`-th derivative at the joints: how many exceed `tolerance`
  /// relative to the larger side (and absolute below 1), and the sum of their squared norms.
  struct Jumps {
    int count = 0;
    double squared_sum = 0.0;
  };
  Jumps jumps(int derivative, double tolerance = 1e-6) const;
  /// The smallest distance from a trajectory point (sampled at `step`) to `point`.
  double closestDistance(const Eigen::Vector3d& point, double step) const;

 private:
  std::vector<TrajectorySegment> segments_;
  std::vector<double> start_times_;
  double duration_ = 0.0;
};

}  // namespace kinolab
