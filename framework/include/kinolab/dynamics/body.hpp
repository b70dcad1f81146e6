#pragma once

#include <algorithm>

#include "kinolab/dynamics/integrator_chain.hpp"

namespace kinolab {

/// The vehicle's body, declared once: a sphere of `radius` whose collision verdict is exact to
/// `tolerance`, and the band beyond the radius where an obstacle cost counts. A planner reads
/// it from its parameters once (configurePlanner: `robot_radius`, `collision_tolerance`,
/// `safety_distance`); its edges, heuristics and the independent checker all take this value.
struct Body {
  static constexpr double kSafetyBand = 0.5;  ///< m

  double radius = MotionDefaults::kRobotRadius;  ///< m (0: a point)
  /// m: a trajectory called free keeps keptRadius() from every occupied voxel cube.
  double tolerance = MotionDefaults::kCollisionTolerance;
  double safety_band = kSafetyBand;  ///< m beyond the radius (0: no obstacle cost band)

  /// The radius a verdict tests a point against: the radius, or the tolerance when that is
  /// larger (sphere tracing then steps at least the tolerance, and a point never enters a
  /// cube).
  double verdictRadius() const { return std::max(radius, tolerance); }
  /// The clearance every collision verdict keeps from the occupied cubes: the verdict radius
  /// less the tolerance, the radius less the tolerance and never below 0 (a point body, or
  /// one thinner than its tolerance, keeps 0). The one expression of it: the start rule, the
  /// edges, the heuristics and the checker all call this.
  double keptRadius() const { return verdictRadius() - tolerance; }
  /// Where the obstacle cost ends: the radius and the safety band.
  double costReach() const { return radius + safety_band; }
  /// This body with its radius grown by `margin` (a flight's planning margin).
  Body grown(double margin) const {
    Body body = *this;
    body.radius += margin;
    return body;
  }
};

}  // namespace kinolab
