#include "kinolab/search/search_policies.hpp"

#include <algorithm>
#include <cmath>

namespace kinolab {

EuclideanHeuristic::EuclideanHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius)
    : weight_duration_(edges.weights.duration),
      weight_length_(edges.weights.length),
      goal_radius_(goal_radius) {
  const double speed = edges.limits.bound[1].norm();
  inverse_speed_ = std::isfinite(speed) ? 1.0 / speed : 0.0;  // no limit: no time bound
}

double EuclideanHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  const double distance = std::max((state.col(0) - goal).norm() - goal_radius_, 0.0);
  return weight_duration_ * distance * inverse_speed_ + weight_length_ * distance;
}

MinTimeHeuristic::MinTimeHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius)
    : weight_duration_(edges.weights.duration),
      weight_length_(edges.weights.length),
      goal_radius_(goal_radius),
      inverse_v_max_(edges.limits.bound[1].cwiseInverse()) {}  // infinite limits give 0

double MinTimeHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  const Eigen::Vector3d offset = (state.col(0) - goal).cwiseAbs();
  const double distance = std::max(offset.norm() - goal_radius_, 0.0);
  // The goal ball lies inside the cube of half-width R: per axis, the distance to that cube.
  const double time =
      ((offset.array() - goal_radius_).max(0.0) * inverse_v_max_.array()).maxCoeff();
  return weight_duration_ * time + weight_length_ * distance;
}

}  // namespace kinolab
