#pragma once

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/stop_condition.hpp"
#include "kinolab/dynamics/body.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/trajectory/uniform_bspline.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/world/world.hpp"

namespace ceres {
class Problem;
}  // namespace ceres

namespace kinolab::smoothing {

/// The back end: a uniform cubic B-spline through a collision-free path, optimised with Ceres
/// (Ceres stays inside the .cpp).
struct SmootherSettings {
  double knot_spacing = 0.5;   ///< control points along the path this far apart at first, m
  double initial_speed = 0.7;  ///< first time allocation: this fraction of the speed limit
  /// The planner's body (set at the back end's setup); its safety band is the smoother's own
  /// `safety_distance`: the obstacle penalty acts below the radius and this, m.
  Body body{MotionDefaults::kRobotRadius, MotionDefaults::kCollisionTolerance, 0.25};
  DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0);
  double weight_smoothness = 1.0;    ///< on sum |P_{i+3} - 3 P_{i+2} + 3 P_{i+1} - P_i|^2
  double weight_obstacle = 10.0;     ///< on sum (radius + safety - d)^2 over span samples
  double weight_guide = 0.01;        ///< on sum |P_i - P_i,0|^2 (the time-allocated path)
  double weight_feasibility = 10.0;  ///< on velocity / acceleration excess (scaled to metres)
  int obstacle_samples = 4;          ///< ESDF samples per span
  int max_solver_iterations = 100;   ///< per Ceres solve
  int max_rounds = 4;                ///< re-solves after a collision (denser, heavier)
  double budget_share = 0.25;  ///< of a time budget kept for smoothing (the path gets the rest)

  /// Its parameters (core/fields.hpp), set as `back_end.NAME`; the body's radius and tolerance
  /// and the limits are the planner's.
  template <typename Fields>
  void fields(Fields& f) {
    f.real("knot_spacing", knot_spacing, 0.02, 10.0, "B-spline control points along the path, m");
    f.real("initial_speed", initial_speed, 0.05, 1.0,
           "first time allocation: this share of max_velocity");
    f.real("safety_distance", body.safety_band, 0.0, 10.0,
           "the obstacle penalty acts below the radius plus this, m");
    f.real("weight_smoothness", weight_smoothness, 0.0, 1e6,
           "weight of the jerk (third difference) term");
    f.real("weight_guide", weight_guide, 0.0, 1e6,
           "weight keeping control points near the time-allocated path (0: free)");
    f.real("weight_obstacle", weight_obstacle, 0.0, 1e6, "weight of the ESDF obstacle penalty");
    f.real("weight_feasibility", weight_feasibility, 0.0, 1e6,
           "weight of the velocity/acceleration penalty");
    f.integer("obstacle_samples", obstacle_samples, 1, 100, "ESDF samples per B-spline span");
    f.integer("max_solver_iterations", max_solver_iterations, 1, 100000,
              "Ceres iterations per solve");
    f.integer("max_rounds", max_rounds, 1, 20,
              "solves: after a collision, again with half the knot spacing, 4x obstacle weight");
    f.real("budget_share", budget_share, 0.0, 0.9,
           "share of the time budget kept for smoothing: the path search stops at the rest, so "
           "that path and smoothing together end at the budget");
  }
};

struct SmootherResult {
  Trajectory trajectory;  ///< the last spline tried, valid or not (empty if none was)
  bool valid = false;     ///< it passed the planner's own (ESDF) check
  std::string problem;    ///< why not, in words
  Statistics statistics;
};

class BsplineSmoother {
 public:
  BsplineSmoother(std::shared_ptr<const World> world, const SmootherSettings& settings);

  /// A smooth trajectory from `start` (any state within the limits) along `path` to rest at
  /// its last point. Rounds: fit control points to the path, solve, rescale time until the
  /// velocity and acceleration control points are within the limits, check the clearance;
  /// on a collision, start again from the path with half the knot spacing and four times the
  /// obstacle weight.
  SmootherResult smooth(const ChainState& start, const std::vector<Eigen::Vector3d>& path,
                        StopCondition& stop) const;

 private:
  /// What the rounds did, for the statistics.
  struct Tally {
    int rounds = 0;  ///< solved
    int ceres_iterations = 0;
    int reallocations = 0;
    double initial_cost = NAN;
    double final_cost = NAN;
    double control_points = NAN;  ///< of the last spline
    double knot_interval = NAN;
  };

  /// One Ceres solve of the control points (the budget's time left at most).
  void solve(Eigen::Matrix3Xd& control, double interval, double weight_obstacle,
             StopCondition& stop, Tally& tally) const;
  /// The cost terms over the control points (the first and last three held fixed).
  void addCosts(ceres::Problem& problem, Eigen::Matrix3Xd& control, double interval,
                double weight_obstacle) const;
  /// Rescales the knot interval until the limits are just met; false when no interval fits
  /// the start state.
  bool reallocateTime(const ChainState& start, Eigen::Matrix3Xd& control, double& interval,
                      int& reallocations) const;

  std::shared_ptr<const World> world_;
  SmootherSettings settings_;
  TrajectoryChecker checker_;
};

/// The statistics smooth() reports (SmootherResult::statistics), for the back end's
/// registration.
MetricSpecs smootherStatistics();

/// The Ceres release this plugin was built against, for provenance.
std::string ceresVersion();

}  // namespace kinolab::smoothing
