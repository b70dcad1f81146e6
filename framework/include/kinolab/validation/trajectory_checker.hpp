#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/core/metric_specs.hpp"
#include "kinolab/dynamics/body.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// What the checker holds a trajectory to: the body and the limits a planner claims to respect.
struct CheckerSettings {
  /// The body: the checker holds every sample to its keptRadius() (its radius less the
  /// collision tolerance the planners' verdict is exact to); clearances are of its radius.
  Body body;
  /// Per-axis limits on derivatives 1..max_derivative (velocity, acceleration, jerk, ...).
  DynamicLimits limits =
      DynamicLimits::uniform(MotionDefaults::kMaxVelocity, MotionDefaults::kMaxAcceleration);
  int max_derivative = 2;
  /// Distance between consecutive position samples; 0 picks a quarter voxel (at most 2.5 cm).
  double spacing = 0.0;
  /// Relative slack on limits and absolute slack (m, m/s) on the start state, for rounding.
  double tolerance = 1e-6;
};

/// The query a trajectory should answer.
struct CheckQuery {
  ChainState start = ChainState::Zero();
  Eigen::Vector3d goal = Eigen::Vector3d::Zero();
  double goal_radius = MotionDefaults::kGoalRadius;
  /// An approximate answer (budget stop) ends short of the goal on purpose.
  bool require_goal = true;
};

/// What the checker measures of every trajectory, whoever planned or flew it, from the
/// trajectory itself: the same figures mean the same for every planner. A figure that is not
/// defined for a trajectory is NaN, with the reason in `undefined`.
struct TrajectoryEvaluation {
  double duration = NAN;  ///< s
  double length = NAN;    ///< m
  /// Integral of |a|^2 (m^2/s^3); undefined where the position or velocity jumps at a joint.
  double acceleration_integral = NAN;
  /// Integral of |j|^2 (m^2/s^5); undefined where any lower derivative jumps at a joint (a
  /// piecewise-constant acceleration: its jerk is impulsive).
  double jerk_integral = NAN;
  /// Sum of the squared acceleration jumps at the joints (m^2/s^4): 0 for a trajectory whose
  /// acceleration is continuous; the finite measure where jerk_integral is undefined
  /// (undefined itself where the position or velocity jumps).
  double acceleration_jumps = NAN;
  /// Curvature |v x a| / |v|^3 (1/m) at the samples moving at least kCurvatureMinSpeed: the
  /// largest (undefined where the path turns a corner in place: at rest, as a stop-and-go
  /// path does, or where the velocity jumps), and the turning per metre (the integral of
  /// curvature over arc length plus the corners' angles, over the length of those samples).
  double max_curvature = NAN;
  double mean_curvature = NAN;
  /// The exact distance from the position samples to the occupied voxel cubes, less the robot
  /// radius: the least and the mean.
  double min_clearance = NAN;
  double mean_clearance = NAN;
  double peak_speed = NAN;         ///< largest |v|, m/s
  double peak_acceleration = NAN;  ///< largest |a|, m/s^2
  /// Largest per-axis |v| (|a|) over its limit: above 1 is beyond the limit.
  double speed_limit_ratio = NAN;
  double acceleration_limit_ratio = NAN;
  /// "NAME: REASON" for each undefined figure, one a line.
  std::string undefined;

  /// Below this speed (m/s) the direction of travel, and so the curvature, is not defined:
  /// hovering, starting and stopping.
  static constexpr double kCurvatureMinSpeed = 0.1;
};

/// The evaluation's metrics, declared once (name, unit, doc, direction, comparable): every
/// run's, plan or flight.
const MetricList<TrajectoryEvaluation>& evaluationMetrics();

/// The checker's verdict: valid, or the first violation found (checks in the order start,
/// limits, bounds, collision, goal; within a check, the earliest time).
struct CheckResult {
  bool valid = false;
  std::string check;   ///< "", "empty", "start", "limits", "bounds", "collision", "goal", "numeric"
  std::string detail;  ///< what was violated, in words
  double time = 0.0;   ///< when, seconds from the trajectory's start
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  int samples = 0;           ///< position samples checked
  double body_radius = 0.0;  ///< the sphere tested against the cubes (radius - tolerance)
};

/// The independent check every planner's output goes through. It shares nothing with the
/// planners but the world's occupancy: it samples the trajectory itself at a fine spacing and
/// tests the body, a sphere of its keptRadius(), against the occupied
/// voxels' cubes exactly at every sample, at any resolution: through FCL (the sphere against
/// OctoMap OcTrees of the occupied voxels with a free neighbour, whose leaves are exactly the
/// grid's cubes, one per tile of kTileVoxels x kTileVoxels voxels made when a check first
/// reaches it, with the centre tested against every cube) when that radius is positive, and
/// for a point robot by whether an occupied cube contains the point. FCL is loaded with the
/// first checker of a body (a module of its own): checking point robots never loads it. The
/// ESDF only gives the clearance figures.
class BodyCollision;

class TrajectoryChecker {
 public:
  /// The side of the FCL trees' tiles in voxels (x and y; every height): a check builds the
  /// trees of the tiles its body reaches, so smaller tiles cost a short trajectory less.
  static constexpr int kTileVoxels = 64;

  TrajectoryChecker(std::shared_ptr<const World> world, CheckerSettings settings);
  ~TrajectoryChecker();
  TrajectoryChecker(TrajectoryChecker&&) noexcept;
  TrajectoryChecker& operator=(TrajectoryChecker&&) noexcept;

  const CheckerSettings& settings() const { return settings_; }
  double spacing() const { return spacing_; }

  /// The verdict: fast, for planners that check inside their own work (a smoother's time
  /// reallocation, a shot) as for the final check.
  CheckResult check(const Trajectory& trajectory, const CheckQuery& query) const;
  /// Every check but the world's (start, limits, goal; not bounds and collision): for a
  /// planner that tests its own trajectory against the world with the planners' model
  /// (traceTrajectory) before handing it on to check().
  CheckResult checkMotion(const Trajectory& trajectory, const CheckQuery& query) const;
  /// The figures of a trajectory, whatever its verdict, at the checker's position samples
  /// (clearance from the world's exact distance) and from its polynomials (the integrals,
  /// exact): what every run reports, measured once, after the planner's clock stopped.
  TrajectoryEvaluation evaluate(const Trajectory& trajectory) const;

  /// True when the body at `position` touches an occupied voxel cube.
  bool collides(const Eigen::Vector3d& position) const;

  /// Makes the whole collision model now (it is otherwise made tile by tile as checks reach
  /// it), shared by every checker of the world: what the experiment runner does before it
  /// forks workers, which then inherit it. Nothing to make for a point robot.
  void makeCollisionModel() const;

 private:
  /// True when `position` lies in a closed occupied voxel cube.
  bool inOccupiedCube(const Eigen::Vector3d& position) const;
  /// The checks in their order; each returns false, with the violation in `result`, at the
  /// first one it finds.
  bool checkStart(const Trajectory& trajectory, const CheckQuery& query, CheckResult& result) const;
  bool checkLimits(const Trajectory& trajectory, CheckResult& result) const;
  bool checkCollision(const Trajectory& trajectory, CheckResult& result) const;
  bool checkGoal(const Trajectory& trajectory, const CheckQuery& query, CheckResult& result) const;

  std::shared_ptr<const World> world_;
  CheckerSettings settings_;
  double spacing_;
  double body_radius_;
  std::unique_ptr<BodyCollision> body_;  // FCL's test of the body; none for a point robot
};

}  // namespace kinolab
