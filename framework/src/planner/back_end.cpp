#include "kinolab/planner/back_end.hpp"

#include "kinolab/core/plugin.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(BackEnd, "back_end", "back_ends",
                               "optimisation back ends run after a planner's front end (every "
                               "planner's `back_end`)",
                               9)

std::vector<Eigen::Vector3d> backEndPath(const std::vector<Eigen::Vector3d>& path,
                                         const Trajectory& trajectory) {
  if (!path.empty() || trajectory.empty()) return path;
  std::vector<Eigen::Vector3d> points;
  for (const TrajectorySample& sample : trajectory.sample(kBackEndPathStep)) {
    points.push_back(sample.position);
  }
  return points;  // sample() ends at the end time
}

}  // namespace kinolab
