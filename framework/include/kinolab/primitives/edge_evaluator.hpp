#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <vector>

#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// Where along a primitive the evaluator looks: K samples at t = k tau / K (k = 1..K, the
/// last is the end), or as many as it takes for consecutive samples to be at most `spacing`
/// metres apart (never coarser than half a voxel).
struct EdgeSampling {
  enum class Mode { kCount, kSpacing };
  Mode mode = Mode::kCount;
  int samples = 10;
  double spacing = 0.05;
};

/// Weights of the edge cost terms; every term is non-negative.
struct CostWeights {
  double duration = 1.0;        ///< per second of flight (the paper's rho T)
  double length = 0.0;          ///< per metre travelled
  double control_effort = 0.1;  ///< per (unit of control)^2 second: |u|^2 tau
  double obstacle = 1.0;        ///< per second spent inside the safety band, squared depth
};

struct EdgeEvaluatorSettings {
  int order = 2;          ///< integrator chain order: the control is this derivative
  double duration = 0.5;  ///< tau, seconds per primitive
  DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0);
  CostWeights weights;
  double robot_radius = 0.25;    ///< a sample collides when its clearance is below this
  double safety_distance = 0.5;  ///< obstacle penalty band beyond the radius, metres
  EdgeSampling sampling;
  /// Inflate the collision test of full evaluation by a Lipschitz margin of the ESDF over
  /// half the gap between samples, so that no collision between samples is missed.
  bool certify = true;
};

/// The result of evaluating one primitive, fully or partially.
struct EdgeEvaluation {
  ChainState end;
  bool within_limits = false;
  bool collision_free = false;  ///< at every sample evaluated
  /// Sum of the weighted cost terms; for a partial evaluation a lower bound of the full cost.
  /// Infinite when the edge breaks a limit or collides.
  double cost = INFINITY;
  double obstacle_cost = 0.0;      ///< the obstacle term (weighted) within `cost`
  double length = 0.0;             ///< chord (partial) or polyline through the samples (full)
  int samples = 0;                 ///< samples the full evaluation uses (partial: the same K)
  int esdf_queries = 0;            ///< samples actually looked up
  double collision_time = -1.0;    ///< time of the first colliding sample, or -1
  double end_distance = INFINITY;  ///< ESDF at the end (partial evaluation), if looked up

  bool valid() const { return within_limits && collision_free; }
};

/// Evaluates motion primitives (a constant control from a state for tau) in a world: end
/// state, dynamic feasibility over the whole interval, collision and cost.
///
/// Cost of an edge = w_T tau + w_L length + w_U |u|^2 tau + w_O sum_k phi(c_k) tau / K, where
/// c_k is the clearance (ESDF minus robot radius) at sample k and phi(c) = (1 - c / d_safe)^2
/// inside the safety band (0 beyond). A *partial* evaluation looks at the end sample only: its
/// collision test and its share of the obstacle sum, and the chord as length; a *full*
/// evaluation looks at every sample and measures length along them. So partial cost <= full
/// cost for every primitive, which the lazy search relies on.
///
/// With `certify`, full evaluation treats a sample as colliding when its clearance is below
/// L g / 2, g bounding the distance between consecutive samples and L the Lipschitz constant
/// of the trilinear ESDF (sqrt(3) where the robot radius is at least a voxel diagonal, else
/// 2 sqrt(3)); the first sample, which alone covers the stretch from the start, uses L g.
/// Then every point of the primitive closer than the radius to an obstacle, as dense
/// checking would find it, is caught.
class EdgeEvaluator {
 public:
  EdgeEvaluator(std::shared_ptr<const World> world, EdgeEvaluatorSettings settings);

  const EdgeEvaluatorSettings& settings() const { return settings_; }
  const IntegratorChain& chain() const { return chain_; }
  const World& world() const { return *world_; }

  /// End state, limits, and collision and obstacle share of the end sample only.
  EdgeEvaluation partial(const ChainState& start, const Eigen::Vector3d& control) const;
  /// Every sample: the edge's true cost, or infinity when it breaks a limit or collides.
  EdgeEvaluation full(const ChainState& start, const Eigen::Vector3d& control) const;
  /// No map query: end state, limits, the map bounds at the end, and the cost terms that need
  /// no map (a lower bound of the full cost, weaker than partial).
  EdgeEvaluation controlOnly(const ChainState& start, const Eigen::Vector3d& control) const;
  /// Upgrades a valid partial evaluation to the full one without sampling the ESDF when the
  /// Lipschitz bound proves it: every point of the primitive is within half the path bound l
  /// of an endpoint, so its distance is at least (d_start + d_end - L l) / 2. When that is
  /// beyond both the collision threshold of full evaluation and the penalty band, full
  /// evaluation would find no collision and a zero obstacle term, so the cost is exact.
  /// Returns false (and leaves `evaluation` as it was) when the bound cannot tell.
  bool certify(const ChainState& start, double start_distance, const Eigen::Vector3d& control,
               EdgeEvaluation& evaluation) const;

  /// The end state after tau (closed form, from the precomputed powers of tau); bit for bit
  /// the `end` of every evaluation of this primitive.
  ChainState endState(const ChainState& start, const Eigen::Vector3d& control) const;

  /// The number of samples K full evaluation uses for this primitive.
  int sampleCount(const ChainState& start, const Eigen::Vector3d& control) const {
    return sampleCountFor(pathBound(start, control));
  }

 private:
  /// An upper bound on the path length over the primitive (speed bound times tau).
  double pathBound(const ChainState& start, const Eigen::Vector3d& control) const;
  int sampleCountFor(double path_bound) const;
  /// The weighted terms that need no map: duration and control effort.
  double mapFreeCost(const Eigen::Vector3d& control) const;
  /// The collision threshold of full evaluation for samples after the first and the first.
  double sampleMargin(double path_bound, int samples) const;
  /// Position of sample k (1..samples) of a primitive whose end position is `end`.
  Eigen::Vector3d samplePosition(const ChainState& start, const Eigen::Vector3d& control,
                                 const Eigen::Vector3d& end, int k, int samples) const;
  /// phi of the clearance at an ESDF distance (inline: once per sample).
  double penalty(double distance) const {
    const double depth = 1.0 - (distance - settings_.robot_radius) * inverse_safety_distance_;
    return depth > 0.0 ? depth * depth : 0.0;
  }

  std::shared_ptr<const World> world_;
  EdgeEvaluatorSettings settings_;
  IntegratorChain chain_;
  double lipschitz_;
  double far_slack_;  ///< bound on |trilinear - nearest-voxel| ESDF value
  double inverse_safety_distance_;
  /// tau^m / m!, m = 0..order.
  std::array<double, 5> end_powers_;
  /// For the fixed-count mode: t_k^m / m! per sample k (rows), the last row is end_powers_.
  std::vector<std::array<double, 5>> sample_powers_;
};

}  // namespace kinolab
