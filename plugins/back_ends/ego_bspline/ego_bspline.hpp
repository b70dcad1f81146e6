#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <vector>

#include "ego_objective.hpp"
#include "kinolab/planner/back_end.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

/// `ego_bspline`: EGO-Planner's ESDF-free B-spline back end (Zhou, Wang, Xu and Gao,
/// "EGO-Planner: An ESDF-free Gradient-based Local Planner for Quadrotors", RA-L 2021).
namespace kinolab::ego {

struct EgoSettings {
  double knot_spacing = 0.3;    ///< control points along the path this far apart at first, m
  double initial_speed = 0.7;   ///< first time allocation: this share of the velocity limit
  double safety_margin = 0.15;  ///< s_f = keptRadius() + this, m
  ObjectiveWeights weights;
  int max_iterations = 200;   ///< L-BFGS iterations per optimisation
  int max_rebounds = 12;      ///< optimisations after finding a collision
  int max_reallocations = 4;  ///< time re-allocations with a refit
  double guide_window = 1.5;  ///< the guide path's A* searches this far around its ends, m
  double budget_share = 0.25;

  template <typename Fields>
  void fields(Fields& f) {
    f.real("knot_spacing", knot_spacing, 0.02, 10.0, "first control points' spacing, m");
    f.real("initial_speed", initial_speed, 0.05, 1.0,
           "first time allocation: this share of max_velocity");
    f.real("safety_margin", safety_margin, 0.0, 10.0,
           "control points are pushed this far beyond the kept radius from an obstacle's "
           "surface (EGO's s_f less the radius), m");
    f.real("weight_smoothness", weights.smoothness, 0.0, 1e6, "weight of the jerk term");
    f.real("weight_collision", weights.collision, 0.0, 1e6, "weight of the {p, v} term");
    f.real("weight_feasibility", weights.feasibility, 0.0, 1e6,
           "weight of the velocity and acceleration excess");
    f.real("weight_fitness", weights.fitness, 0.0, 1e6,
           "weight of the anisotropic fitness in the refit after a time re-allocation");
    f.integer("max_iterations", max_iterations, 1, 100000, "L-BFGS iterations per optimisation");
    f.integer("max_rebounds", max_rebounds, 0, 1000,
              "optimisations again after a collision is found (new {p, v} pairs)");
    f.integer("max_reallocations", max_reallocations, 0, 100,
              "time re-allocations followed by a refit (then only the time is stretched)");
    f.real("guide_window", guide_window, 0.1, 100.0,
           "a guide path's A* stays within this many metres of its end points' box, m");
    f.real("budget_share", budget_share, 0.0, 0.9,
           "share of the time budget kept for the back end");
  }
};

/// What one refine() did, for the statistics.
struct EgoTally {
  int iterations = 0;
  int rebounds = 0;
  int guide_paths = 0;
  int guide_failures = 0;
  int reallocations = 0;
  double final_cost = NAN;
};

class EgoBspline final : public BackEnd {
 public:
  explicit EgoBspline(const EgoSettings& settings) : settings_(settings) {}

  void setup(std::shared_ptr<const World> world, const Body& body,
             const PlannerLimits& limits) override;
  BackEndResult refine(const BackEndProblem& problem, StopCondition& stop) const override;
  double budgetShare() const override { return settings_.budget_share; }

  /// The spans (0 .. n - 4) of the spline where a sample's clearance proves nothing about the
  /// body: sampled at most half a voxel apart (by the velocity control points' bound), a
  /// span is clear when each sample's ESDF lower bound is at least keptRadius() plus half
  /// that spacing (the distance is 1-Lipschitz).
  std::vector<int> collidingSpans(const Eigen::Matrix3Xd& control, double interval) const;
  /// EGO's step: for runs of control points near colliding spans, an A* guide path around the
  /// obstacle and {p, v} pairs on the objective. Returns the pairs added.
  int addPairs(const Eigen::Matrix3Xd& control, const std::vector<int>& spans,
               EgoObjective& objective, EgoTally& tally) const;
  double safeDistance() const { return body_.keptRadius() + settings_.safety_margin; }

 private:
  /// The free polyline from `from` to `to` through the voxels (A*), or none.
  std::optional<std::vector<Eigen::Vector3d>> guidePath(const Eigen::Vector3d& from,
                                                        const Eigen::Vector3d& to) const;
  /// The pair of control point `index` from a guide path, or none (no crossing).
  std::optional<RepulsionPair> pairFor(const Eigen::Matrix3Xd& control, int index,
                                       const std::vector<Eigen::Vector3d>& guide) const;
  /// Optimises with rebounds until no span collides; false when one still does.
  bool rebound(Eigen::Matrix3Xd& control, double interval, EgoObjective& objective,
               StopCondition& stop, EgoTally& tally) const;
  /// Re-allocates time (and refits) until the limits hold; false when they cannot.
  bool reallocate(const ChainState& start, Eigen::Matrix3Xd& control, double& interval,
                  EgoObjective& objective, StopCondition& stop, EgoTally& tally) const;
  bool occupied(const Eigen::Vector3d& point) const;

  EgoSettings settings_;
  std::shared_ptr<const World> world_;
  Body body_;
  PlannerLimits limits_;
  std::unique_ptr<TrajectoryChecker> checker_;
};

/// The statistics refine() reports.
MetricSpecs egoStatistics();

}  // namespace kinolab::ego
