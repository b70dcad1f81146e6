#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "kinolab/primitives/edge_evaluator.hpp"

namespace kinolab {

/// The small policies a motion-primitive planner hands the search core: how an edge is
/// evaluated when its parent is expanded, and the heuristic. The core knows no parameter
/// names; a plugin maps its parameters to policies (see docs/adding_a_planner.md), and a new
/// policy is a class in a plugin folder, not a framework edit.

/// What an EdgeEvaluationPolicy's evaluation of a primitive is.
enum class EdgeEstimate : std::uint8_t {
  kFull,        ///< the full evaluation: the edge's true cost (or invalid)
  kLowerBound,  ///< a lower bound of the true cost; the search evaluates fully when popped
  kCertified,   ///< the true cost, proved without full evaluation
};

/// How the search evaluates an edge when its parent is expanded. Eager search evaluates
/// fully; lazy search queues a lower bound and evaluates fully only when the candidate is
/// popped. A lower bound must be at most the full cost of every valid edge, and may call an
/// edge invalid only when full evaluation would (a limit breach, a collision, or leaving the
/// map); then lazy and eager search return the same cost.
class EdgeEvaluationPolicy {
 public:
  virtual ~EdgeEvaluationPolicy() = default;

  /// Evaluates the primitive `control` from `parent` into `evaluation` (its end state,
  /// validity, cost and ESDF queries) and says what that evaluation is.
  /// `parent_distance` is the ESDF at the parent's position (INFINITY when not looked up).
  virtual EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent,
                                double parent_distance, const Eigen::Vector3d& control,
                                EdgeEvaluation& evaluation) const = 0;
};

/// Eager: every edge fully evaluated (EdgeEvaluator::full).
class FullEvaluationPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.full(parent, control);
    return EdgeEstimate::kFull;
  }
};

/// Lazy, the paper's bound: the end sample's collision test and obstacle share
/// (EdgeEvaluator::partial).
class EndpointBoundPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    return EdgeEstimate::kLowerBound;
  }
};

/// Lazy without a map query: time, length and control terms (EdgeEvaluator::controlOnly).
class ControlOnlyBoundPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.controlOnly(parent, control);
    return EdgeEstimate::kLowerBound;
  }
};

/// Lazy with the endpoint bound, and exact when the ESDF's Lipschitz bound between the two
/// endpoints proves the edge clear of obstacles and of the penalty band
/// (EdgeEvaluator::certify).
class LipschitzBoundPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent,
                        double parent_distance, const Eigen::Vector3d& control,
                        EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    return evaluator.certify(parent, parent_distance, control, evaluation)
               ? EdgeEstimate::kCertified
               : EdgeEstimate::kLowerBound;
  }
};

/// A lower bound on the cost from a state to the goal region, consistent with the edges'
/// lower bounds: h(s) <= c_lower(s, s') + h(s') for every edge. Then the search with weight
/// 1 is optimal, and lazy and eager return the same cost.
class SearchHeuristic {
 public:
  virtual ~SearchHeuristic() = default;
  /// The estimate from `state` to the goal region around `goal`.
  virtual double estimate(const ChainState& state, const Eigen::Vector3d& goal) const = 0;
};

/// w_T |d| / |v_max| + w_L |d|, d the distance to the goal ball.
class EuclideanHeuristic final : public SearchHeuristic {
 public:
  EuclideanHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;

 private:
  double weight_duration_;
  double weight_length_;
  double goal_radius_;
  double inverse_speed_;
};

/// w_T max_i(|d_i| / v_max_i) + w_L |d|, d_i the distance to the goal cube of half-width R
/// on axis i (MPL's minimum-time bound, Liu et al., RA-L 2018).
class MinTimeHeuristic final : public SearchHeuristic {
 public:
  MinTimeHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;

 private:
  double weight_duration_;
  double weight_length_;
  double goal_radius_;
  Eigen::Vector3d inverse_v_max_;
};

}  // namespace kinolab
