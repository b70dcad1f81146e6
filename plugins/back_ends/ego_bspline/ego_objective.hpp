#pragma once

#include <Eigen/Core>
#include <vector>

#include "kinolab/core/stop_condition.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"

/// EGO-Planner's objective over a uniform cubic B-spline's control points (Zhou et al.,
/// "EGO-Planner: An ESDF-free Gradient-based Local Planner for Quadrotors", RA-L 2021, Sec.
/// IV): smoothness, feasibility, the ESDF-free collision term of {p, v} pairs and, when
/// refitting after a time re-allocation, the anisotropic fitness.
namespace kinolab::ego {

/// One {p, v} pair of a control point Q: `anchor` p on the obstacle's surface and the unit
/// `direction` v from the obstacle towards the free guide path. Q is d = (Q - p) . v in front
/// of the obstacle; the collision term asks d >= the safe distance.
struct RepulsionPair {
  Eigen::Vector3d anchor;
  Eigen::Vector3d direction;
};

struct ObjectiveWeights {
  double smoothness = 1.0;
  double collision = 10.0;
  double feasibility = 1.0;
  double fitness = 1.0;
};

class EgoObjective {
 public:
  /// `safe_distance` is EGO's s_f: how far in front of an anchor a control point must be.
  EgoObjective(const ObjectiveWeights& weights, const DynamicLimits& limits, double safe_distance);

  /// The pairs of every control point (index as the control points').
  std::vector<std::vector<RepulsionPair>>& pairs() { return pairs_; }
  const std::vector<std::vector<RepulsionPair>>& pairs() const { return pairs_; }
  /// The curve a refit stays near: positions at the knots (column i at knot i + 1, as the
  /// control points' (Q_i + 4 Q_{i+1} + Q_{i+2}) / 6); empty: no fitness term.
  void setReference(Eigen::Matrix3Xd reference) { reference_ = std::move(reference); }
  double weightCollision() const { return weights_.collision; }
  void scaleCollision(double factor) { weights_.collision *= factor; }

  /// The weighted sum and, with `gradient` (3 x n, overwritten), its gradient by every control
  /// point (the fixed ones' too: the caller ignores them).
  double evaluate(const Eigen::Matrix3Xd& control, double interval,
                  Eigen::Matrix3Xd* gradient) const;
  /// The collision term alone (unweighted): per pair, 0 when d >= s_f, else e^3 for the
  /// shortfall e = s_f - d up to s_f and a quadratic beyond (C^2, as EGO's).
  double collision(const Eigen::Matrix3Xd& control, Eigen::Matrix3Xd* gradient) const;
  /// Sum |Q_{i+3} - 3 Q_{i+2} + 3 Q_{i+1} - Q_i|^2 (unweighted).
  static double smoothness(const Eigen::Matrix3Xd& control, Eigen::Matrix3Xd* gradient);
  /// Per axis, the squared excess of velocity and acceleration control points over the
  /// limits (unweighted).
  double feasibility(const Eigen::Matrix3Xd& control, double interval,
                     Eigen::Matrix3Xd* gradient) const;
  /// EGO's anisotropic fitness to the reference: (x . v)^2 / 25 + |x x v|^2 per knot.
  double fitness(const Eigen::Matrix3Xd& control, Eigen::Matrix3Xd* gradient) const;

 private:
  ObjectiveWeights weights_;
  DynamicLimits limits_;
  double safe_distance_;
  std::vector<std::vector<RepulsionPair>> pairs_;
  Eigen::Matrix3Xd reference_;
};

/// Minimises the objective over control points 3 .. n - 4 (the first three hold the start
/// state, the last three the rest at the end) with L-BFGS (liblbfgs), at most `iterations`,
/// stopping at `stop`'s time limit. Returns the iterations done.
int minimise(const EgoObjective& objective, Eigen::Matrix3Xd& control, double interval,
             int iterations, const StopCondition& stop);

}  // namespace kinolab::ego
