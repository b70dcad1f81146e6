// What a flight's camera looks at and what it must see before a move is committed
// (the flight loop's, flight_loop.hpp): the heading along the intended trajectory, the step back
// that brings an unseen voxel into view, the sensor's vertical reach, and the guides that always
// leave the vehicle. Private to framework/src/flight.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "flight_motion.hpp"

namespace kinolab::flight_motion {

/// Where the camera looks for a frame taken at t: towards where `intended` (the last plan
/// taken, whole, not cut where the vehicle would have to stop) will be a second later, so that
/// a turn is seen before it is flown. When that second barely moves the vehicle (a plan that
/// starts slowly, or at rest), towards the first point of `intended` at least 0.5 m away
/// horizontally (nearer, the frustum is too narrow to hold it) that `map` does not vouch for
/// for `body` (only when `seen_only`, commit: seen: what keeps the plan from being committed),
/// else the first such point, vouched for or not, else `goal`. Looking at the goal there left
/// a plan that started slowly and turned back outside the frustum: the vehicle crept on the few
/// centimetres it could commit, replan after replan, 2 m from its goal. `speed`: the limit,
/// for sampling.
double lookAlong(const Trajectory& intended, double t, const VehicleMap& map, const Body& body,
                 bool seen_only, double speed, const Eigen::Vector3d& goal);

/// The tangents of the largest elevation above and below the horizontal among `rays` (the
/// sensor's, vehicle frame): how steeply the sensor sees up and down.
std::pair<double, double> elevationTangents(const std::vector<Eigen::Vector3d>& rays);

/// What keeps `plan` from being committed further: the nearest point of a voxel `map` cannot
/// vouch for, where the plan (traced for `body`, `inset` inside the map) first meets one;
/// none when it keeps in vouched-for space or leaves the map's box first.
std::optional<Eigen::Vector3d> planBlocker(const VehicleMap& map, const Trajectory& plan,
                                           const Body& body, double inset);

/// A straight move at rest that brings `blocker` into view, with the heading that faces it.
struct StepBackMove {
  Eigen::Vector3d offset;
  double yaw = 0.0;
};
/// The step-back moves from `position`, in the order to try them: straight away from
/// `blocker` horizontally (or from `facing`, a unit vector, when it is straight above or
/// below), then turned 45 and 90 degrees either way, each as long as it takes to end `needed`
/// from it horizontally but at most `longest`; then each 0.2 m shorter, down to 0.2 m.
/// `needed`: the blocker's height above or below the vehicle, at least `radius` (a plan near
/// it sweeps the planning radius above and below itself), over the tangent of the sensor's
/// elevation that way (`tangents`, elevationTangents()), and two voxels (`voxel`).
std::vector<StepBackMove> stepBackMoves(const Eigen::Vector3d& position,
                                        const Eigen::Vector3d& blocker,
                                        const Eigen::Vector2d& facing,
                                        std::pair<double, double> tangents, double radius,
                                        double voxel, double longest);

/// The heading from `from` towards `to` (rad about z).
double yawTowards(const Eigen::Vector3d& from, const Eigen::Vector3d& to);

/// When the known map leaves no way over its columns in the query's heights (the guide's
/// band: a desk below, a shelf above, anywhere in it, closes a column): the guides over levels
/// `radius` apart from `margin` + `radius` above the map's floor to as far below its ceiling,
/// each a band one planning body high (`radius` about it), joined where a cell is open at two
/// neighbouring levels (levelColumnGuides(), `radius` of room round each of `froms` and
/// `goal`, the map's inset kept, `trail`'s cells open). Empty guides when the levels leave no
/// way either. Without
/// them the local goal lay on the straight line to the goal, through what closed the band, and
/// every replan failed.
std::vector<std::vector<Eigen::Vector3d>> levelGuides(const VehicleMap& map,
                                                      std::span<const Eigen::Vector3d> froms,
                                                      const Eigen::Vector3d& goal, double radius,
                                                      double margin,
                                                      std::span<const Eigen::Vector3d> trail = {});

/// A flight's guides to `query`'s goal from `froms`' first (where a replan starts) and second
/// (where the flight last made progress): over the columns of `band` (heights, low and high;
/// columnGuides()) from heights within the query's (their heights, interpolated, then do not
/// follow a vehicle that sank or rose), or with no way there over levelGuides() from where the
/// vehicle is (from the query's heights, one that climbed was guided from below, turned);
/// `radius` of room round each, `trail`'s cells open.
std::vector<std::vector<Eigen::Vector3d>> flightGuides(const VehicleMap& map,
                                                       const PlanningQuery& query,
                                                       std::array<Eigen::Vector3d, 2> froms,
                                                       std::pair<double, double> band,
                                                       double radius, double margin,
                                                       std::span<const Eigen::Vector3d> trail);

/// A straight move at rest out of what a failed replan says the vehicle is in, and whether the
/// body alone must keep clear along it (else the planning body).
struct BackOff {
  Eigen::Vector3d offset;
  bool body_alone = false;
};
/// The back-off moves to try, in order, after a replan of `status` failed at rest at
/// `position`: a start outside `domain` (the map's box less the planning margin: a query's
/// start within the margin of the map's end; geb079's query 95 hovered 0.01 m inside its box
/// until the wind blew it out) into it, 5 cm inside; a start the planner refused
/// (`invalid_start`: a planner's own margin, like the TGK analogue's, can exceed the planning
/// radius) 0.3 m away from the nearest known obstacle for the body alone; a start the planning
/// body touches (`radius`, within half a `voxel`: a committed trajectory keeps the radius less
/// 1 cm, so a vehicle can stop a few millimetres inside it, and then every edge from it
/// collides at once: `no_solution` after one expansion, or `timeout`) the same way for the
/// planning body (the body alone, moved along unseen space with the tracking error, hit a
/// wall on geb079). Away is the window ESDF's horizontal gradient, or its whole gradient where
/// the horizontal one is under a fifth of it (below a ceiling, above a desk).
std::vector<BackOff> backOffMoves(const std::string& status, const Eigen::Vector3d& position,
                                  const World& window, const Box& domain, double radius,
                                  double voxel);

/// Whether `committed` (still clear of what is known: the caller's verdict), from `t_start`
/// on, comes as near `goal` as `plan` ends no later than the plan does (samples `spacing`
/// apart at `speed`): then the plan would trade a way for a slower one. A lattice search from
/// a state between its primitives' ends need not find the rest of the plan it is on, so plans
/// from one replan to the next disagreed, and a vehicle in the dense forest cycled through the
/// same four plans (2.4, 3.0, 4.2 and 10.8 s long, two of them turning back) until it was stuck.
bool arrivesFirst(const Trajectory& committed, const Trajectory& plan, double t_start,
                  const Eigen::Vector3d& goal, double spacing, double speed);

}  // namespace kinolab::flight_motion
