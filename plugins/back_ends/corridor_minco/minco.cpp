#include "minco.hpp"

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"

namespace kinolab::minco {

void BandedSystem::reset(int size, int lower, int upper) {
  size_ = size;
  lower_ = lower;
  upper_ = upper;
  data_.assign(static_cast<std::size_t>(size) * static_cast<std::size_t>(lower + upper + 1), 0.0);
}

void BandedSystem::factorise() {
  for (int k = 0; k + 1 < size_; ++k) {
    const int last_row = std::min(k + lower_, size_ - 1);
    const int last_column = std::min(k + upper_, size_ - 1);
    const double pivot = (*this)(k, k);
    for (int i = k + 1; i <= last_row; ++i) (*this)(i, k) /= pivot;
    for (int j = k + 1; j <= last_column; ++j) {
      const double factor = (*this)(k, j);
      if (factor == 0.0) continue;
      for (int i = k + 1; i <= last_row; ++i) (*this)(i, j) -= (*this)(i, k) * factor;
    }
  }
}

void BandedSystem::solve(Eigen::MatrixX3d& b) const {
  for (int j = 0; j < size_; ++j) {  // L (unit diagonal)
    const int last = std::min(j + lower_, size_ - 1);
    for (int i = j + 1; i <= last; ++i) b.row(i) -= (*this)(i, j) * b.row(j);
  }
  for (int j = size_ - 1; j >= 0; --j) {  // U
    b.row(j) /= (*this)(j, j);
    const int first = std::max(0, j - upper_);
    for (int i = first; i < j; ++i) b.row(i) -= (*this)(i, j) * b.row(j);
  }
}

void BandedSystem::solveTransposed(Eigen::MatrixX3d& b) const {
  for (int j = 0; j < size_; ++j) {  // U^T
    b.row(j) /= (*this)(j, j);
    const int last = std::min(j + upper_, size_ - 1);
    for (int i = j + 1; i <= last; ++i) b.row(i) -= (*this)(j, i) * b.row(j);
  }
  for (int j = size_ - 1; j >= 0; --j) {  // L^T (unit diagonal)
    const int first = std::max(0, j - lower_);
    for (int i = first; i < j; ++i) b.row(i) -= (*this)(j, i) * b.row(j);
  }
}

Minco::Minco(int s, const Eigen::Matrix3Xd& head, const Eigen::Matrix3Xd& tail)
    : s_(s), head_(head), tail_(tail) {
  if ((s != 3 && s != 4) || head.cols() != s || tail.cols() != s) {
    throw InvalidArgument("MINCO: order s must be 3 or 4 with s head and tail derivatives");
  }
}

double Minco::basis(int k, int d, double t) {
  if (k < d) return 0.0;
  double value = 1.0;
  for (int i = 0; i < d; ++i) value *= k - i;
  for (int i = 0; i < k - d; ++i) value *= t;
  return value;
}

int Minco::jointDerivative(int row) const { return row < s_ - 1 ? s_ + row : row - s_; }

void Minco::setParameters(const Eigen::Matrix3Xd& waypoints, const Eigen::VectorXd& durations) {
  const int m = static_cast<int>(durations.size());
  const int n = 2 * s_;
  durations_ = durations;
  system_.reset(n * m, n, n);
  coefficients_.setZero(n * m, 3);
  for (int d = 0; d < s_; ++d) {
    system_(d, d) = basis(d, d, 0.0);
    coefficients_.row(d) = head_.col(d).transpose();
  }
  for (int i = 0; i + 1 < m; ++i) {
    const int base = s_ + n * i;
    for (int j = 0; j < n; ++j) {
      const int row = base + j;
      if (j == s_ - 1) {  // the waypoint
        for (int k = 0; k < n; ++k) system_(row, n * i + k) = basis(k, 0, durations(i));
        coefficients_.row(row) = waypoints.col(i).transpose();
        continue;
      }
      const int d = jointDerivative(j);
      for (int k = d; k < n; ++k) system_(row, n * i + k) = basis(k, d, durations(i));
      system_(row, n * (i + 1) + d) = -basis(d, d, 0.0);
    }
  }
  for (int d = 0; d < s_; ++d) {
    const int row = n * m - s_ + d;
    for (int k = d; k < n; ++k) system_(row, n * (m - 1) + k) = basis(k, d, durations(m - 1));
    coefficients_.row(row) = tail_.col(d).transpose();
  }
  system_.factorise();
  system_.solve(coefficients_);
}

double Minco::energy(Eigen::MatrixX3d& gradient_coefficients,
                     Eigen::VectorXd& gradient_durations) const {
  const int n = 2 * s_;
  double total = 0.0;
  for (int i = 0; i < pieces(); ++i) {
    const double duration = durations_(i);
    double powers[8] = {1.0};  // duration^p, p <= 2 (n - 1 - s)
    for (int p = 1; p < 8; ++p) powers[p] = powers[p - 1] * duration;
    for (int k = s_; k < n; ++k) {
      for (int l = s_; l < n; ++l) {
        const int power = k + l - 2 * s_;
        const double scale = basis(k, s_, 1.0) * basis(l, s_, 1.0);
        const double t_power = powers[power];
        const double dot = coefficients_.row(n * i + k).dot(coefficients_.row(n * i + l));
        total += scale * dot * t_power * duration / (power + 1);
        gradient_coefficients.row(n * i + k) +=
            2.0 * scale * t_power * duration / (power + 1) * coefficients_.row(n * i + l);
        gradient_durations(i) += scale * dot * t_power;
      }
    }
  }
  return total;
}

void Minco::propagate(const Eigen::MatrixX3d& gradient_coefficients,
                      const Eigen::VectorXd& partial_durations,
                      Eigen::Matrix3Xd& gradient_waypoints,
                      Eigen::VectorXd& gradient_durations) const {
  const int m = pieces();
  const int n = 2 * s_;
  Eigen::MatrixX3d adjoint = gradient_coefficients;
  system_.solveTransposed(adjoint);
  gradient_waypoints.resize(3, m - 1);
  gradient_durations = partial_durations;
  // d cost / d T_i = partial - adjoint^T (dA / dT_i) c, and a row constraining the d-th
  // derivative of piece i at T_i has (dA / dT_i) c = its (d + 1)-th derivative there.
  for (int i = 0; i + 1 < m; ++i) {
    const int base = s_ + n * i;
    gradient_waypoints.col(i) = adjoint.row(base + s_ - 1).transpose();
    for (int j = 0; j < n; ++j) {
      const int d = j == s_ - 1 ? 0 : jointDerivative(j);
      gradient_durations(i) -= adjoint.row(base + j).dot(evaluate(i, durations_(i), d + 1));
    }
  }
  for (int d = 0; d < s_; ++d) {
    gradient_durations(m - 1) -=
        adjoint.row(n * m - s_ + d).dot(evaluate(m - 1, durations_(m - 1), d + 1));
  }
}

Eigen::Vector3d Minco::evaluate(int piece, double t, int derivative) const {
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  const int n = 2 * s_;
  for (int k = derivative; k < n; ++k) {
    value += basis(k, derivative, t) * coefficients_.row(n * piece + k).transpose();
  }
  return value;
}

Trajectory Minco::trajectory() const {
  Trajectory trajectory;
  for (int i = 0; i < pieces(); ++i) {
    TrajectorySegment segment;
    segment.duration = durations_(i);
    segment.coefficients = coefficients(i).transpose();
    trajectory.append(std::move(segment));
  }
  return trajectory;
}

}  // namespace kinolab::minco
