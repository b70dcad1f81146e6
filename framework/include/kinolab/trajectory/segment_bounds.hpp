#pragma once

#include <Eigen/Core>
#include <cmath>

#include "kinolab/trajectory/trajectory.hpp"

namespace kinolab {

/// An upper bound on the speed over a segment: the norm of sum_k k |c_k| T^(k-1) per axis.
inline double speedBound(const TrajectorySegment& segment) {
  Eigen::Array3d bound = Eigen::Array3d::Zero();
  for (int k = 1; k < segment.coefficients.cols(); ++k) {
    bound += k * segment.coefficients.col(k).array().abs() * std::pow(segment.duration, k - 1);
  }
  return bound.matrix().norm();
}

}  // namespace kinolab
