#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// What the checker holds a trajectory to: the body and the limits a planner claims to respect.
struct CheckerSettings {
  double robot_radius = 0.25;
  /// Per-axis limits on derivatives 1..max_derivative (velocity, acceleration, jerk, ...).
  DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0);
  int max_derivative = 2;
  /// Distance between consecutive position samples; 0 picks a quarter voxel (at most 2.5 cm).
  double spacing = 0.0;
  /// Relative slack on limits and absolute slack (m, m/s) on the start state, for rounding.
  double tolerance = 1e-6;
  /// Also collide the body with an OctoMap of the world's occupancy through FCL.
  bool use_fcl = true;
};

/// The query a trajectory should answer.
struct CheckQuery {
  ChainState start = ChainState::Zero();
  Eigen::Vector3d goal = Eigen::Vector3d::Zero();
  double goal_radius = 0.5;
  /// An approximate answer (budget stop) ends short of the goal on purpose.
  bool require_goal = true;
};

/// The checker's verdict: valid, or the first violation found (checks in the order start,
/// limits, bounds, esdf, fcl, goal; within a check, the earliest time).
struct CheckResult {
  bool valid = false;
  std::string check;   ///< "", "empty", "start", "limits", "bounds", "esdf", "fcl", "goal"
  std::string detail;  ///< what was violated, in words
  double time = 0.0;   ///< when, seconds from the trajectory's start
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double min_clearance = 0.0;   ///< smallest ESDF distance minus the robot radius
  double mean_clearance = 0.0;  ///< over the position samples
  int samples = 0;              ///< position samples checked
  double fcl_radius = 0.0;      ///< the sphere FCL collided with the OctoMap
};

/// The independent check every planner's output goes through. It shares nothing with the
/// planners but the world: it samples the trajectory itself at a fine spacing, reads the
/// ESDF (trilinear, radius test), and separately collides a sphere with an OctoMap OcTree of
/// the world's occupied voxels through FCL.
///
/// The two collision models differ by construction: the ESDF measures from voxel centres,
/// FCL from voxel cubes. A trilinear ESDF value >= r guarantees that the distance to every
/// occupied cube is >= r - sqrt(3) voxel (interpolation may overstate the distance to
/// centres by half a voxel diagonal, and a cube reaches half a diagonal beyond its centre),
/// so FCL collides a sphere of that radius: a hit there is a real contradiction, not a
/// modelling difference.
class TrajectoryChecker {
 public:
  TrajectoryChecker(std::shared_ptr<const World> world, CheckerSettings settings);
  ~TrajectoryChecker();
  TrajectoryChecker(TrajectoryChecker&&) noexcept;
  TrajectoryChecker& operator=(TrajectoryChecker&&) noexcept;

  const CheckerSettings& settings() const { return settings_; }
  double spacing() const { return spacing_; }

  CheckResult check(const Trajectory& trajectory, const CheckQuery& query) const;

  /// True when FCL finds the sphere of fcl radius at `position` touching an occupied voxel.
  bool fclCollides(const Eigen::Vector3d& position) const;

 private:
  struct Fcl;
  std::shared_ptr<const World> world_;
  CheckerSettings settings_;
  double spacing_;
  std::unique_ptr<Fcl> fcl_;
};

}  // namespace kinolab
