#pragma once

#include <Eigen/Core>
#include <cmath>
#include <functional>

namespace kinolab {

struct Box;
class World;
class Trajectory;

/// Where sphere tracing found a trajectory not free, or that it is.
struct TraceResult {
  bool free = true;
  bool left_domain = false;  ///< not free because a traced point is outside the domain
  double time = INFINITY;    ///< of the first traced point that is not free (s)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  int queries = 0;  ///< clearance look-ups made
};

/// The world's verdict on a trajectory over [from, to] (seconds, clamped to its duration): the
/// verdict every search gives its edges, for a planner that checks its own trajectory before
/// the independent checker does (a back end's rounds, a flight's commit). Sphere tracing: at
/// a traced time the point must lie in the world's domain and keep `radius` from every
/// occupied voxel cube (World::clearanceFor, exact at the threshold); a point at distance D
/// covers the next D - radius + tolerance metres of path, and at most its distance to the
/// domain's faces (never less than the tolerance), converted to time with the segment's speed
/// bound; every segment's ends are traced too. So a trajectory called free keeps
/// radius - tolerance from every cube and leaves the domain by at most the tolerance, and one
/// that keeps radius inside the domain is free. Throws InvalidArgument on a radius < 0, a
/// tolerance <= 0 or either not finite; a non-finite position is not free.
TraceResult traceTrajectory(const World& world, const Trajectory& trajectory, double radius,
                            double tolerance, double from = 0.0, double to = INFINITY);

/// The distance from a point to what a trace avoids, as World::clearanceFor gives it: at least
/// the threshold (the second argument) exactly when the true distance is, and a lower bound of
/// it there.
using TraceClearance = std::function<double(const Eigen::Vector3d&, double)>;

/// traceTrajectory() against any such distance over the domain `domain` (a flight's check of
/// a plan against the space its known map vouches for, VehicleMap::unvouchedDistance()).
TraceResult traceTrajectory(const TraceClearance& clearance, const Box& domain,
                            const Trajectory& trajectory, double radius, double tolerance,
                            double from = 0.0, double to = INFINITY);

}  // namespace kinolab
