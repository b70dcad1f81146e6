// Private to the validation code: where the checker samples a trajectory, shared by its checks
// (trajectory_checker.cpp) and its evaluation (trajectory_evaluation.cpp), which measure the
// same samples.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "kinolab/trajectory/segment_bounds.hpp"
#include "kinolab/trajectory/trajectory.hpp"

namespace kinolab::checker_detail {

/// The derivatives' names, by order.
inline constexpr const char* kDerivatives[] = {"position", "velocity", "acceleration", "jerk",
                                               "snap"};

/// The sample times of a segment `spacing` apart along its path (a bound of it), at least
/// its two ends: (global time, local time).
inline void sampleTimes(const TrajectorySegment& segment, double segment_start, double speed_bound,
                        double spacing, std::vector<std::pair<double, double>>& times) {
  const double path = speed_bound * segment.duration;
  // Clamped before the cast: a diverged trajectory's path overflows an int.
  const double wanted = std::ceil(path / spacing);
  const int steps =
      std::isfinite(wanted) ? static_cast<int>(std::clamp(wanted, 1.0, 1000000.0)) : 1000000;
  times.clear();
  for (int i = 0; i <= steps; ++i) {
    const double local = segment.duration * i / steps;
    times.emplace_back(segment_start + local, local);
  }
}

}  // namespace kinolab::checker_detail
