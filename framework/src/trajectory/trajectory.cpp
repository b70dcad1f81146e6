#include "kinolab/trajectory/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "kinolab/core/error.hpp"

namespace kinolab {
namespace {

/// Coefficients of the `derivative`-th derivative of a polynomial given by `coefficients`.
Eigen::Matrix<double, 3, Eigen::Dynamic> derivativeCoefficients(
    const Eigen::Matrix<double, 3, Eigen::Dynamic>& coefficients, int derivative) {
  const int degree = static_cast<int>(coefficients.cols()) - 1;
  const int size = std::max(degree - derivative + 1, 1);
  Eigen::Matrix<double, 3, Eigen::Dynamic> result = Eigen::MatrixXd::Zero(3, size);
  for (int k = derivative; k <= degree; ++k) {
    double factor = 1.0;
    for (int j = 0; j < derivative; ++j) factor *= k - j;
    result.col(k - derivative) = factor * coefficients.col(k);
  }
  return result;
}

}  // namespace

TrajectorySegment TrajectorySegment::primitive(const ChainState& start,
                                               const Eigen::Vector3d& control, int order,
                                               double duration) {
  TrajectorySegment segment;
  segment.duration = duration;
  segment.coefficients.resize(3, order + 1);
  double factorial = 1.0;
  for (int k = 0; k < order; ++k) {
    if (k > 0) factorial *= k;
    segment.coefficients.col(k) = start.col(k) / factorial;
  }
  segment.coefficients.col(order) = control / (factorial * std::max(order, 1));
  return segment;
}

Eigen::Vector3d TrajectorySegment::evaluate(double t, int derivative) const {
  const int degree = static_cast<int>(coefficients.cols()) - 1;
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  // Horner's rule over the derivative's coefficients k (k - 1) ... (k - derivative + 1) c_k.
  for (int k = degree; k >= derivative; --k) {
    double factor = 1.0;
    for (int j = 0; j < derivative; ++j) factor *= k - j;
    value = value * t + factor * coefficients.col(k);
  }
  return value;
}

void Trajectory::append(TrajectorySegment segment) {
  if (!(segment.duration > 0.0) || segment.coefficients.cols() == 0) {
    throw InvalidArgument("trajectory: a segment needs a positive duration and coefficients");
  }
  start_times_.push_back(duration_);
  duration_ += segment.duration;
  segments_.push_back(std::move(segment));
}

Eigen::Vector3d Trajectory::evaluate(double t, int derivative) const {
  if (segments_.empty()) throw InvalidArgument("trajectory: evaluating an empty trajectory");
  t = std::clamp(t, 0.0, duration_);
  // The last segment starting at or before t.
  const auto next = std::upper_bound(start_times_.begin(), start_times_.end(), t);
  const auto index = static_cast<std::size_t>(
      std::max<std::ptrdiff_t>(std::distance(start_times_.begin(), next) - 1, 0));
  const TrajectorySegment& segment = segments_[index];
  return segment.evaluate(std::min(t - start_times_[index], segment.duration), derivative);
}

std::vector<TrajectorySample> Trajectory::sample(double step) const {
  if (!(step > 0.0)) throw InvalidArgument("trajectory: the sampling step must be positive");
  std::vector<TrajectorySample> samples;
  if (segments_.empty()) return samples;
  const auto count = static_cast<std::size_t>(std::ceil(duration_ / step - 1e-9));
  for (std::size_t i = 0; i <= count; ++i) {
    const double t = std::min(static_cast<double>(i) * step, duration_);
    samples.push_back({t, evaluate(t, 0), evaluate(t, 1), evaluate(t, 2), evaluate(t, 3)});
  }
  return samples;
}

double Trajectory::length() const {
  // 5-point Gauss-Legendre nodes and weights on [-1, 1].
  static constexpr std::array<double, 5> kNodes = {-0.9061798459386640, -0.5384693101056831, 0.0,
                                                   0.5384693101056831, 0.9061798459386640};
  static constexpr std::array<double, 5> kWeights = {0.2369268850561891, 0.4786286704993665,
                                                     0.5688888888888889, 0.4786286704993665,
                                                     0.2369268850561891};
  constexpr int kIntervals = 8;
  double total = 0.0;
  for (const auto& segment : segments_) {
    const double half = 0.5 * segment.duration / kIntervals;
    for (int i = 0; i < kIntervals; ++i) {
      const double middle = (2 * i + 1) * half;
      for (std::size_t n = 0; n < kNodes.size(); ++n) {
        total += kWeights[n] * half * segment.evaluate(middle + kNodes[n] * half, 1).norm();
      }
    }
  }
  return total;
}

double Trajectory::squaredIntegral(int derivative) const {
  double total = 0.0;
  for (const auto& segment : segments_) {
    if (segment.coefficients.cols() <= derivative) continue;
    const auto values = derivativeCoefficients(segment.coefficients, derivative);
    const int terms = static_cast<int>(values.cols());
    for (int i = 0; i < terms; ++i) {
      for (int j = 0; j < terms; ++j) {
        total +=
            values.col(i).dot(values.col(j)) * std::pow(segment.duration, i + j + 1) / (i + j + 1);
      }
    }
  }
  return total;
}

Trajectory::Jumps Trajectory::jumps(int derivative, double tolerance) const {
  Jumps jumps;
  for (std::size_t i = 1; i < segments_.size(); ++i) {
    const TrajectorySegment& before = segments_[i - 1];
    const Eigen::Vector3d left = before.evaluate(before.duration, derivative);
    const Eigen::Vector3d right = segments_[i].evaluate(0.0, derivative);
    const double jump = (right - left).norm();
    if (jump > tolerance * std::max({1.0, left.norm(), right.norm()})) {
      ++jumps.count;
      jumps.squared_sum += jump * jump;
    }
  }
  return jumps;
}

double Trajectory::closestDistance(const Eigen::Vector3d& point, double step) const {
  if (empty()) return INFINITY;
  // Evaluated in place, at most a million times (a longer trajectory gets a larger step):
  // a planner's runaway duration must not become a runaway allocation.
  const double steps = std::clamp(std::ceil(duration_ / step), 1.0, 1e6);
  double best = (endPosition() - point).norm();
  for (double k = 0; k < steps; ++k) {
    best = std::min(best, (evaluate(duration_ * k / steps) - point).norm());
  }
  return best;
}

}  // namespace kinolab
