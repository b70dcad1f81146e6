#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <memory>
#include <vector>

#include "kinolab/dynamics/body.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// Where the obstacle cost's quadrature (and the length's polyline) samples a primitive: K
/// samples at t = k tau / K (k = 1..K, the last is the end), or as many as it takes for
/// consecutive samples to be at most `spacing` metres apart. The collision verdict does not
/// depend on it.
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
  DynamicLimits limits =
      DynamicLimits::uniform(MotionDefaults::kMaxVelocity, MotionDefaults::kMaxAcceleration);
  CostWeights weights;
  /// The body: an edge called free keeps its keptRadius() from every occupied voxel cube
  /// (each sphere-tracing step gains at least its tolerance); the obstacle cost counts within
  /// its safety band.
  Body body;
  EdgeSampling sampling;
};

/// The result of evaluating one primitive, fully or partially.
struct EdgeEvaluation {
  ChainState end;
  bool within_limits = false;
  bool collision_free = false;  ///< by the evaluation's test (partial: the end only)
  /// Sum of the weighted cost terms; for a partial evaluation a lower bound of the full cost.
  /// Infinite when the edge breaks a limit or collides.
  double cost = INFINITY;
  double obstacle_cost = 0.0;       ///< the obstacle term (weighted) within `cost`
  double length = 0.0;              ///< chord (partial) or polyline through the samples (full)
  int samples = 0;                  ///< quadrature samples of full evaluation (partial: the same)
  int esdf_queries = 0;             ///< ESDF look-ups made
  double collision_time = -1.0;     ///< when the verdict found the collision (or left the map)
  double end_distance = INFINITY;   ///< trilinear ESDF at the end (partial), if looked up
  double end_clearance = INFINITY;  ///< Esdf::clearance at the end (partial), if looked up

  bool valid() const { return within_limits && collision_free; }
};

/// Evaluates motion primitives (a constant control from a state for tau) in a world: end
/// state, dynamic feasibility over the whole interval, collision and cost.
///
/// Collision (the same verdict in every evaluation that gives one, whatever the sampling):
///  - the map: the primitive's positions stay in the map's box, tested on the convex hull of
///    the position polynomial's Bernstein coefficients per axis (exact-conservative);
///  - obstacles: sphere tracing on the distance to every occupied voxel cube. At each traced
///    point the clearance C (Esdf::clearance, a proven lower bound) is looked up; where
///    C < R (the body's radius, or its tolerance tol when larger) the exact distance decides
///    instead (Esdf::exactDistance). A point at distance D >= R covers the next (D - R + tol)
///    metres of path (the distance is 1-Lipschitz), converted to time with the primitive's
///    speed bound; the end is always traced too. The edge collides when a traced point is
///    closer than R. So an edge called free keeps R - tol from every occupied cube, and an
///    edge that keeps R is free: exact both ways, to the tolerance. Far from obstacles that is
///    two ESDF queries (start and end).
///
/// Cost of an edge = w_T tau + w_L length + w_U |u|^2 tau + w_O sum_k phi(I_k) tau / K, where
/// I_k is the trilinear ESDF at quadrature sample k and phi(d) = (1 - (d - R) / d_safe)^2 inside
/// the safety band (0 beyond). Samples the tracing proves outside the band (the trilinear ESDF
/// is sqrt(3)-Lipschitz) are not looked up. A *partial* evaluation looks at the end only: its
/// clearance test and its share of the obstacle sum, and the chord as length; so partial cost
/// <= full cost for every primitive, and partial calls an edge invalid only when full does.
class EdgeEvaluator {
 public:
  EdgeEvaluator(std::shared_ptr<const World> world, EdgeEvaluatorSettings settings);

  const EdgeEvaluatorSettings& settings() const { return settings_; }
  const IntegratorChain& chain() const { return chain_; }
  const World& world() const { return *world_; }

  /// End state, limits, the map test, and the clearance and obstacle share of the end.
  EdgeEvaluation partial(const ChainState& start, const Eigen::Vector3d& control) const;
  /// The full verdict and the edge's true cost (infinite when it breaks a limit, leaves the
  /// map or collides).
  EdgeEvaluation full(const ChainState& start, const Eigen::Vector3d& control) const;
  /// The same, given Esdf::clearance at the start (computed once for all the primitives of
  /// a state; it is not counted in esdf_queries).
  EdgeEvaluation full(const ChainState& start, const Eigen::Vector3d& control,
                      double start_clearance) const;
  /// No ESDF query: end state, limits, the map test, and the cost terms that need no map (a
  /// lower bound of the full cost, weaker than partial).
  EdgeEvaluation controlOnly(const ChainState& start, const Eigen::Vector3d& control) const;
  /// Upgrades a valid partial evaluation to the full one without tracing when full evaluation
  /// provably gives the same: the start's clearance `start_clearance` (Esdf::clearance at the
  /// start) covers the whole path in one tracing step, and the trilinear ESDF's Lipschitz
  /// bound between the endpoints keeps every quadrature sample out of the penalty band. Then
  /// the cost is exact. Returns false (and leaves `evaluation` as it was) otherwise.
  bool certify(const ChainState& start, double start_clearance, const Eigen::Vector3d& control,
               EdgeEvaluation& evaluation) const;

  /// The end state after tau (closed form, from the precomputed powers of tau); bit for bit
  /// the `end` of every evaluation of this primitive.
  ChainState endState(const ChainState& start, const Eigen::Vector3d& control) const;

  /// The number of quadrature samples K full evaluation uses for this primitive.
  int sampleCount(const ChainState& start, const Eigen::Vector3d& control) const {
    return settings_.sampling.mode == EdgeSampling::Mode::kCount
               ? settings_.sampling.samples
               : sampleCountFor(pathBound(start, control));
  }

 private:
  /// The first points sphere tracing visited: times and trilinear ESDF values (the start's
  /// is its clearance, a lower bound), kept for the obstacle quadrature.
  struct Traced {
    std::array<double, 64> time;
    std::array<double, 64> distance;
    int count = 0;
  };
  /// Sphere tracing from the start to the end: false (with the collision time in `result`)
  /// when the body comes within the collision tolerance of an occupied cube.
  bool traceFree(const ChainState& start, const Eigen::Vector3d& control, double start_clearance,
                 double seconds_per_metre, Traced& traced, EdgeEvaluation& result) const;
  /// The quadrature of the obstacle term over `samples` samples and the length polyline, into
  /// `result` (its cost).
  void integrate(const ChainState& start, const Eigen::Vector3d& control, int samples,
                 double seconds_per_metre, const Traced& traced, EdgeEvaluation& result) const;
  /// An upper bound on the path length over the primitive (speed bound times tau).
  double pathBound(const ChainState& start, const Eigen::Vector3d& control) const;
  int sampleCountFor(double path_bound) const;
  /// The weighted terms that need no map: duration and control effort.
  double mapFreeCost(const Eigen::Vector3d& control) const;
  /// True when every position of the primitive lies in the map's box (Bernstein hull).
  bool insideMap(const ChainState& start, const Eigen::Vector3d& control) const;
  /// Seconds of primitive per metre of path (the path bound is a speed bound times tau); the
  /// one conversion full() and certify() both use, so that they agree bit for bit.
  double secondsPerMetre(double path_bound) const {
    return path_bound > 0.0 ? settings_.duration / path_bound : INFINITY;
  }
  /// The radius a traced point must keep from every cube: the body's radius, or its tolerance
  /// when that is larger (so a step is never shorter than the tolerance, and the body a step
  /// keeps, this less the tolerance, is never below 0: a point robot never enters a cube).
  double verdictRadius() const { return settings_.body.verdictRadius(); }
  /// The path length one tracing step from a point of clearance `clearance` covers.
  double tracingReach(double clearance) const {
    return clearance - verdictRadius() + settings_.body.tolerance;
  }
  /// Position of sample k (1..samples) of a primitive whose end position is `end`.
  Eigen::Vector3d samplePosition(const ChainState& start, const Eigen::Vector3d& control,
                                 const Eigen::Vector3d& end, int k, int samples) const;
  /// phi of the clearance at an ESDF distance (inline: once per sample).
  double penalty(double distance) const {
    const double depth = 1.0 - (distance - settings_.body.radius) * inverse_safety_band_;
    return depth > 0.0 ? depth * depth : 0.0;
  }

  std::shared_ptr<const World> world_;
  EdgeEvaluatorSettings settings_;
  IntegratorChain chain_;
  double inverse_safety_band_;
  /// tau^m / m!, m = 0..order.
  std::array<double, 5> end_powers_;
  /// For the fixed-count mode: t_k^m / m! per sample k (rows), the last row is end_powers_.
  std::vector<std::array<double, 5>> sample_powers_;
  /// Bernstein conversion: bernstein_[k][m] = C(k, m) / C(order, m).
  std::array<std::array<double, 5>, 5> bernstein_{};
};

}  // namespace kinolab
