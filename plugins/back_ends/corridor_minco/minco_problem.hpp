#pragma once

#include <Eigen/Core>
#include <vector>

#include "corridor.hpp"
#include "kinolab/core/stop_condition.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "minco.hpp"

namespace kinolab::minco {

/// The weights and limits of the unconstrained problem.
struct ProblemWeights {
  double time = 100.0;           ///< rho, per second of duration
  double corridor = 1e4;         ///< on the integral of the cubed excess over the polytope
  double velocity = 1e4;         ///< on the integral of the cubed excess of v_axis^2
  double acceleration = 1e4;     ///< on the integral of the cubed excess of a_axis^2
  int samples = 16;              ///< sample intervals per piece (the integral's trapezoid rule)
  double corridor_margin = 0.0;  ///< the penalty acts this far inside the polytope, m
  /// The limits the penalties hold the samples to (the planner's, less a margin).
  Eigen::Vector3d max_velocity = Eigen::Vector3d::Constant(2.0);
  Eigen::Vector3d max_acceleration = Eigen::Vector3d::Constant(3.0);
};

/// The worst excesses at the samples over the polytopes and the limits the problem was given.
struct Violations {
  double corridor = 0.0;      ///< m
  double velocity = 0.0;      ///< m/s
  double acceleration = 0.0;  ///< m/s^2
};

/// GCOPTER's unconstrained form of the corridor problem (Wang et al., T-RO 2022, Sec. V):
/// variables are the inner waypoints q and tau with T = t(tau), the C2 diffeomorphism of
/// (-inf, inf) onto (0, inf) of eq. (54); the cost is MINCO's control effort, rho times the
/// duration and cubic penalties, integrated over each piece by the trapezoid rule on its
/// samples, of the excess over its polytope and over the per-axis velocity and acceleration
/// limits. The corridor constraint is a penalty (the paper's V-representation transform is not
/// used): a waypoint joins two pieces, so it is held to both polytopes, their overlap.
class MincoProblem {
 public:
  /// Pieces in `corridor_of_piece` order (an index into `corridors`); `waypoints` has one
  /// column fewer than there are pieces.
  MincoProblem(int order, const ChainState& start, const Eigen::Vector3d& end,
               std::vector<Polytope> corridors, std::vector<int> corridor_of_piece,
               ProblemWeights weights);

  ProblemWeights& weights() { return weights_; }
  int pieces() const { return static_cast<int>(corridor_of_piece_.size()); }
  /// The variables (tau, then q column by column) for these waypoints and durations.
  Eigen::VectorXd variables(const Eigen::Matrix3Xd& waypoints,
                            const Eigen::VectorXd& durations) const;
  /// The cost at `x` and its gradient.
  double cost(const Eigen::VectorXd& x, Eigen::VectorXd& gradient);
  Trajectory trajectory(const Eigen::VectorXd& x);
  Violations violations(const Eigen::VectorXd& x);
  /// The factor every duration of `x` must be stretched by for its trajectory to keep the
  /// per-axis limits, 1 when it keeps them: max(v / v_max, sqrt(a / a_max)) over every axis at
  /// kStretchSamples samples a piece. Exact for a start at rest (stretching the durations
  /// then slows the same path uniformly); from a moving start the fixed start state bends the
  /// path a little, and the caller checks again.
  double stretchNeeded(const Eigen::VectorXd& x, const DynamicLimits& limits);
  /// `x` with every duration multiplied by `factor`.
  Eigen::VectorXd stretched(const Eigen::VectorXd& x, double factor) const;
  static constexpr int kStretchSamples = 64;

  /// What optimise() did.
  struct Outcome {
    int status = 0;      ///< liblbfgs's return code
    int iterations = 0;  ///< L-BFGS iterations
    double cost = 0.0;
  };
  /// Minimises from `x` (replaced by the minimiser) with L-BFGS, for at most `max_iterations`
  /// iterations or until the cost falls by less than `relative_tolerance` of itself over three
  /// iterations, stopping early when `stop` expires (its count: `iterations_before` plus this
  /// solve's).
  Outcome optimise(Eigen::VectorXd& x, int max_iterations, double relative_tolerance,
                   StopCondition& stop, long long iterations_before);

 private:
  /// A sample's penalty and its gradient with respect to its position, velocity and
  /// acceleration (columns).
  struct Penalty {
    double value = 0.0;
    Eigen::Matrix3d gradient = Eigen::Matrix3d::Zero();
  };

  void unpack(const Eigen::VectorXd& x);
  /// Adds the penalties of `piece` and their gradients; returns their sum.
  double piecePenalty(int piece, Eigen::MatrixX3d& gradient_coefficients,
                      Eigen::VectorXd& gradient_durations, Violations* violations) const;
  /// piecePenalty() for N = 2s coefficients a piece, in fixed-size storage.
  template <int N>
  double piecePenaltyOf(int piece, Eigen::MatrixX3d& gradient_coefficients,
                        Eigen::VectorXd& gradient_durations, Violations* violations) const;
  /// The penalty of one sample (state: position, velocity, acceleration, jerk), and its worst
  /// excesses into `violations` when given.
  Penalty samplePenalty(const Polytope& polytope, const Eigen::Matrix<double, 3, 4>& state,
                        Violations* violations) const;

  Minco minco_;
  std::vector<Polytope> corridors_;
  std::vector<int> corridor_of_piece_;
  ProblemWeights weights_;
  Eigen::Matrix3Xd waypoints_;
  Eigen::VectorXd durations_;
};

/// T(tau) of GCOPTER's time transform and its derivative.
double durationOf(double tau);
double durationDerivative(double tau);
/// Its inverse.
double tauOf(double duration);

}  // namespace kinolab::minco
