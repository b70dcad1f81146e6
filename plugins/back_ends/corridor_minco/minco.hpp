#pragma once

#include <Eigen/Core>
#include <vector>

#include "kinolab/trajectory/trajectory.hpp"

namespace kinolab::minco {

/// A square band matrix (lower and upper bandwidth) factorised in place by LU without
/// pivoting, as MINCO's system needs: its rows are ordered so that every pivot is a nonzero
/// derivative coefficient (Wang et al., T-RO 2022, Sec. IV), and the cost is linear in its size.
class BandedSystem {
 public:
  /// A zero matrix of this size and bandwidths (its memory kept from the last, when it fits).
  void reset(int size, int lower, int upper);

  double& operator()(int row, int column) { return data_[index(row, column)]; }
  double operator()(int row, int column) const { return data_[index(row, column)]; }

  void factorise();
  /// Solves A x = b in place (after factorise()).
  void solve(Eigen::MatrixX3d& b) const;
  /// Solves A^T x = b in place (after factorise()): the adjoint MINCO's gradient needs.
  void solveTransposed(Eigen::MatrixX3d& b) const;

 private:
  std::size_t index(int row, int column) const {
    return static_cast<std::size_t>(row - column + upper_) * static_cast<std::size_t>(size_) +
           static_cast<std::size_t>(column);
  }

  int size_ = 0;
  int lower_ = 0;
  int upper_ = 0;
  std::vector<double> data_;
};

/// MINCO (minimum control effort, Wang et al. T-RO 2022): the piecewise polynomial of degree
/// 2s - 1 that minimises the integral of |p^(s)|^2 through inner waypoints q with piece
/// durations T, from a head state (derivatives 0..s-1) to a tail state. Its coefficients are
/// the solution of one banded linear system; the gradient of any cost of the coefficients and
/// durations maps back to q and T through the adjoint of that system.
class Minco {
 public:
  /// s = 3 (minimum jerk, quintic pieces) or 4 (minimum snap, septic pieces); head and tail
  /// hold derivatives 0..s-1 as columns.
  Minco(int s, const Eigen::Matrix3Xd& head, const Eigen::Matrix3Xd& tail);

  /// Solves for the coefficients of `durations.size()` pieces through `waypoints` (one column
  /// per inner joint).
  void setParameters(const Eigen::Matrix3Xd& waypoints, const Eigen::VectorXd& durations);

  int s() const { return s_; }
  int pieces() const { return static_cast<int>(durations_.size()); }
  const Eigen::VectorXd& durations() const { return durations_; }
  /// The 2s coefficients of `piece` as rows (row k multiplies t^k).
  auto coefficients(int piece) const { return coefficients_.middleRows(2 * s_ * piece, 2 * s_); }

  /// The control effort, the sum over pieces of the integral of |p^(s)|^2, and its partial
  /// gradients (added to the arguments) with respect to the coefficients and durations.
  double energy(Eigen::MatrixX3d& gradient_coefficients, Eigen::VectorXd& gradient_durations) const;

  /// Maps a cost's partial gradients with respect to the coefficients and durations to its
  /// total gradients with respect to the waypoints and durations.
  void propagate(const Eigen::MatrixX3d& gradient_coefficients,
                 const Eigen::VectorXd& partial_durations, Eigen::Matrix3Xd& gradient_waypoints,
                 Eigen::VectorXd& gradient_durations) const;

  /// The `derivative`-th derivative of `piece` at local time t.
  Eigen::Vector3d evaluate(int piece, double t, int derivative) const;
  Trajectory trajectory() const;

 private:
  /// The derivative orders constrained at a joint's rows, in the row order whose pivots are
  /// nonzero: s..2s-2 (continuity), the waypoint, then 0..s-1 (continuity).
  int jointDerivative(int row) const;
  /// Coefficient of c_k in the d-th derivative at time t: k!/(k-d)! t^(k-d).
  static double basis(int k, int d, double t);

  int s_;
  Eigen::Matrix3Xd head_;
  Eigen::Matrix3Xd tail_;
  Eigen::VectorXd durations_;
  BandedSystem system_;
  Eigen::MatrixX3d coefficients_;
};

}  // namespace kinolab::minco
