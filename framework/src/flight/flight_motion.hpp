// The flight loop's motion helpers (FlightLoop, flight_loop.hpp): slicing and splicing the
// committed trajectory, braking, straight moves, free-space checks along a trajectory (the
// window's, the known map's, the ground truth's least distance), the planning window's centre,
// the local goal on the guide, and what a stuck flight's message says. Private to
// framework/src/flight.
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "kinolab/flight/flight.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/world/trajectory_trace.hpp"

namespace kinolab::flight_motion {

double millisecondsSince(std::chrono::steady_clock::time_point begin);

/// The trajectory's state at time t (clamped to its span), derivatives 0..2.
ChainState stateAt(const Trajectory& trajectory, double t);

/// At rest at `position` for `duration` seconds.
TrajectorySegment hold(const Eigen::Vector3d& position, double duration);

/// The part of `trajectory` before time `end` (whole segments, the last one shortened);
/// past its end the vehicle rests where it ended (every committed trajectory ends at rest).
Trajectory slice(const Trajectory& trajectory, double end);

/// `trajectory` slowed to at most `speed` (m/s, its speed taken at both ends of every segment,
/// where a piece of constant acceleration peaks, and 255 points between): the same path, each
/// segment's time stretched by one factor (velocity scales by it, acceleration by its square, jerk
/// by its cube); unchanged when not faster. Its start keeps its position and, when at rest, its
/// state.
Trajectory slowedTo(const Trajectory& trajectory, double speed);

/// A stop from `state` at constant deceleration along the velocity, each axis within
/// `acceleration`; empty when already at rest.
TrajectorySegment brake(const ChainState& state, double acceleration);

/// The committed trajectory up to `t`, then `plan` (which starts at the state at `t`), then
/// a stop.
Trajectory splice(const Trajectory& committed, double t, const Trajectory& plan,
                  double acceleration);

/// Calls `visit(s)` at times s from `begin` (at least 0) to `end` (excluded), a sample every
/// `spacing` metres of path at `speed` (at least 0.1 m/s; 10,000 samples when the speed is
/// unlimited), at most 100,000, until it returns false; whether every call returned true.
template <typename Visit>
bool everySample(double begin, double end, double spacing, double speed, Visit&& visit) {
  begin = std::max(0.0, begin);
  const double span = end - begin;
  if (!(span > 0.0)) return true;
  const double wanted = std::isfinite(speed) ? span * std::max(0.1, speed) / spacing : 1e4;
  const long long samples = std::clamp(std::llround(std::ceil(wanted)), 1LL, 100000LL);
  for (long long i = 0; i < samples; ++i) {
    if (!visit(begin + span * static_cast<double>(i) / static_cast<double>(samples))) return false;
  }
  return true;
}

/// True when the trajectory from t on stays inside the map's box and the body keeps its
/// radius (less the tolerance) from the window's known obstacles (samples every 2 cm of path
/// at most, and the end). The verdict at each sample is exact (World::clearanceFor), as the
/// planners' is: with the ESDF's lower bound alone, a plan that kept the planner's radius
/// from a trunk by less than the bound's slack was refused at every cut, replan after
/// replan, and a vehicle stood 3.5 m from its goal until it was stuck.
bool freeFrom(const Trajectory& trajectory, double t, const Box& map, const World& window,
              const Body& body, const DynamicLimits& limits);

/// The known map's verdict on `trajectory` from `from` on for `body` (commit: seen): sphere
/// tracing (traceTrajectory) on the distance to the nearest voxel that is not known free,
/// unknown counted as occupied (VehicleMap::unvouchedDistance), so a trajectory called free
/// keeps the body's kept radius less its tolerance from every voxel the known map cannot vouch
/// for, and stays in the map's box less `inset` (the planning margin: room for the tracking
/// error where the map ends; the box still holds the trajectory's first point, as the window's
/// domain holds the vehicle).
TraceResult vouchedTrace(const VehicleMap& map, const Trajectory& trajectory, double from,
                         const Body& body, double inset);

/// The least distance from `flown` to the ground truth's cubes less `radius`: negative when
/// the body was inside one, never clamped. The checker's figure is the least of its samples,
/// which a path passing between two misses; here every interval between samples a centisecond
/// apart whose distances, less what the trajectory's speed bound lets the path cover in half
/// of it, could dip below the least found is searched (golden section) to a microsecond. NaN
/// for an empty trajectory. Exact up to `reach` beyond the radius at least, also on a sparse
/// truth truncated nearer (its cubes are searched out to there, not read from the truncated
/// field): a path that never came that near reads `reach`.
double exactMinClearance(const World& truth, const Trajectory& flown, double radius, double reach);

/// Where the planning window is centred: on the vehicle, moved towards `way_height` (the
/// goal's, or where the guide goes: wayHeight()) by up to a quarter of the window's height, so
/// that the window follows the vehicle in z and a goal above or below it leaves room for a
/// local goal beyond the planner's goal region.
Eigen::Vector3d windowCentre(const Eigen::Vector3d& position, double way_height,
                             double window_height);

/// The height the window reaches towards while the vehicle follows `guide` (its first point
/// where the vehicle is): of the guide's points within `horizon` along it, the height farthest
/// from the first's, or `goal`'s height without a guide. A guide that climbs over what closes
/// the lower levels leaves the window there; reaching towards the goal's height instead, the
/// window held the local goal below the climb, where the guide's way is closed, and the
/// vehicle stood at the obstacle replan after replan (geb079).
double wayHeight(const std::vector<Eigen::Vector3d>& guide, double horizon,
                 const Eigen::Vector3d& goal);

/// The plans taken since `since` (a flight without progress whose plans are taken dithers
/// between local goals): how many, the extent of their local goals and how near `goal` the
/// nearest came ("" when none was taken), as a stuck flight's message says it.
std::string takenSince(const std::vector<FlightReplan>& replans, double since,
                       const Eigen::Vector3d& goal);
/// The failed replans since `since`, by status with the first reason of each, and the
/// recoveries tried ("" when none failed).
std::string failuresSince(const std::vector<FlightReplan>& replans, double since);

/// A straight move at rest at both ends from `from` by `offset`: two primitives (order 2),
/// accelerating then decelerating along it, at most `acceleration` and `speed`.
std::vector<TrajectorySegment> straightMove(const Eigen::Vector3d& from,
                                            const Eigen::Vector3d& offset, double acceleration,
                                            double speed);

/// The point `s` metres along the polyline `way` (its end when it is shorter).
Eigen::Vector3d pointAlong(const std::vector<Eigen::Vector3d>& way, double s);

/// Why no braking tail after a plan could be committed (`vouched`: how long the plan keeps in
/// the space the known map vouches for, s).
std::string notCommittedWhy(CommitSpace commit, double vouched);

/// The map's known occupied voxels, each with when it was first known occupied (`first`, by
/// lattice index), in that order.
std::vector<std::pair<double, Eigen::Vector3d>> knownVoxelsInOrder(
    const VehicleMap& map, const std::unordered_map<std::size_t, double>& first);

/// The length of the way a flight follows from `from` to `goal`: its guide (a polyline), or
/// with none (the known map leaves no way in the guide's band) the straight line, as
/// localGoal() then takes.
double wayLength(const std::vector<Eigen::Vector3d>& guide, const Eigen::Vector3d& from,
                 const Eigen::Vector3d& goal);

/// The largest and the root-mean-square distance between `flown` and `committed`, every
/// centisecond of `flown` (the tracking error).
std::pair<double, double> trackingError(const Trajectory& flown, const Trajectory& committed);

/// The local goal: the goal when it is within `horizon` along the way (wayLength()) and the
/// window, else the point
/// `horizon` metres along the guide (the known map's shortest way; the straight line when it
/// is empty), stopping where the guide would leave the window in x and y (0.5 m inside its
/// sides; the guide's heights are only interpolated, so they are brought into the window's,
/// 0.5 m inside its floor and ceiling); then moved off the window's known obstacles (the goal
/// itself is taken where it is, brought into the window's domain when it lies less than
/// 0.5 m outside). False when no free point is found. The 0.5 m side margin is kept only on
/// the window's sides inside `map` (the map's box less its inset, where plans may go): where the
/// window ends with the map nothing lies beyond, and with the margin there a guide along the
/// map's end (on geb079 the way round a building often is) left no local goal but the
/// vehicle's own place.
bool localGoal(const Eigen::Vector3d& from, const Eigen::Vector3d& goal,
               const std::vector<Eigen::Vector3d>& guide, double horizon, const World& window,
               double radius, const Box& map, Eigen::Vector3d* out);

/// The flight's verdict in `result` (status and message) from the independent checker's `check`
/// of the flown trajectory, whether a frame found a collision (`collided`) and where the vehicle
/// left the map (`left_map`, at time `t`): a collision cuts the flown trajectory where it hit; a
/// vehicle that left the map says so (the checker's bounds finding is the same fact).
void judgeFlown(const CheckResult& check, bool collided,
                const std::optional<Eigen::Vector3d>& left_map, double t, FlightResult& result);

/// How long `trajectory` keeps in the space `map` vouches for, for `body` (vouchedTrace(),
/// `inset` inside the map's box): its duration when it does throughout, else the first traced
/// time it does not.
double vouchedUntil(const VehicleMap& map, const Trajectory& trajectory, const Body& body,
                    double inset);

constexpr double kDegree = M_PI / 180.0;

/// The flown trajectory's checker: the planner's body; its limits only when tracking is
/// perfect (a tracking vehicle's excursions are its controller's, not the planner's).
CheckerSettings flownCheckerSettings(const Body& body, const PlannerLimits& limits,
                                     const TrackingModel& tracking);

}  // namespace kinolab::flight_motion
