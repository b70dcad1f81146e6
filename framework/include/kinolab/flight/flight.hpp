#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/metric_specs.hpp"
#include "kinolab/core/parameters.hpp"
#include "kinolab/flight/difficulty.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/flight/tracking.hpp"
#include "kinolab/flight/vehicle_map.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

// ---- the flight ------------------------------------------------------------------------------

/// How a flight treats the planners' measured time.
enum class FlightTiming {
  /// A plan takes effect at its start, `latency` after its frame, only when its measured
  /// planning time is within the latency (else it is late and discarded): real time, so a
  /// flight whose plans come close to the latency need not repeat.
  kRealTime,
  /// Every plan is taken as if it arrived within the latency, whatever it measured: the
  /// flight repeats bit for bit (with searches bounded by max_expansions, not by time).
  kDeterministic,
};

/// Where a committed trajectory may take the vehicle.
enum class CommitSpace {
  /// Every committed trajectory, its stop (the back-up) included, keeps the planning body (the
  /// body's radius plus the planning margin) inside space the known map vouches for: known
  /// free, unknown counted as occupied (FASTER's rule: commit only in known-free space, so that
  /// a stop there is always available). A planner may plan through unseen space (the window's
  /// `unknown`), but the vehicle does not fly into it: a plan, approximate or exact, is cut
  /// where it or its stop would leave that space, and refused when no cut is left; the camera
  /// looks along the whole plan, so that the next frames see on. Only the start's
  /// surroundings are taken on trust (within three planning radii, what a look round would
  /// show: the planning body's place and, r metres out, what the sensor sees up and down).
  kSeen,
  /// Wherever the planning window allows: with `unknown: free` the vehicle may fly into space
  /// it has never seen (the optimistic loop of Fast-Planner and EGO-Planner; not safe, kept
  /// for comparison).
  kPlanned,
};

/// When the loop replans and how it treats time.
struct FlightSettings {
  double replan_period = 0.5;  ///< s between planned replans (and on every collision found)
  double replan_budget = 0.1;  ///< s: each replan's time budget
  /// A replan plans from the committed state this long after its frame (the vehicle flies
  /// the committed trajectory meanwhile); negative: 1.25 times the replan budget, so that a
  /// planner stopped at its budget has a quarter of it left for what a plan costs besides its
  /// search (setting up on the window, building the result).
  double latency = -1.0;
  FlightTiming timing = FlightTiming::kRealTime;
  /// The clock a replan's budget and measured planning time are read on: by default the CPU
  /// time it takes (as on the vehicle's own core), so that what else the machine runs does not
  /// make plans late or cut their search.
  BudgetClock clock = BudgetClock::kCpu;
  double horizon = 3.5;             ///< m: the local goal's distance when the goal is farther
  double max_time = 120.0;          ///< s of flight
  double stuck_time = 15.0;         ///< s without 0.5 m of progress along the guide
  double goal_tolerance = 0.5;      ///< m: reached when this close to the goal
  double brake_acceleration = 3.0;  ///< m/s^2 per axis for braking to a stop
  CommitSpace commit = CommitSpace::kSeen;
  /// A replan's plan is set aside when the committed trajectory comes as near the plan's local
  /// goal no later (the replan is `kept`, not a failure).
  bool keep_faster = true;
  /// At rest, when what the known map cannot vouch for leaves nothing of a plan to commit,
  /// the vehicle steps back from it with its camera turned towards it (recovery step_back).
  bool step_back = true;
  /// At rest, when the planner finds no way for the planning body (no_solution), the vehicle
  /// plans again for the body grown by `escape_margin` only and flies that plan at most
  /// `escape_speed` (recovery escape): a pocket the planning radius barely fits (entered on
  /// plans the known map vouched for, then closed by what the camera saw from inside it) need
  /// not let a search of that radius out. Tried only when escape_margin is below
  /// planning_margin. Off by default: the 0.05 m margin is below the tracking error measured
  /// at low speed in the default wind (up to 0.068 m, docs/flights.md).
  bool escape = false;
  double escape_margin = 0.05;  ///< m beyond the body an escape keeps from what is not known free
  double escape_speed = 0.5;    ///< m/s: an escape plan is slowed to this speed at most
  /// m: the planners keep the body's radius plus this from what the vehicle knows, room for
  /// tracking error, map noise and latency (the flight judges the body).
  double planning_margin = 0.15;
  /// > 0: keep the known map from above (VehicleMap::topView over the query's heights) every
  /// this many seconds of flight, for animations; 0: none. Not a parameter: the caller's.
  double snapshot_period = 0.0;
  /// The seed of the sensor's noise, dropouts and latency (the run's seed). Not a parameter:
  /// the caller's.
  std::uint64_t seed = 0;

  /// The latency a replan starts after (latency, or 1.25 times the replan budget when
  /// negative).
  double replanLatency() const { return latency < 0.0 ? 1.25 * replan_budget : latency; }

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("replan_period", replan_period, 0.01, 100.0, "s between replans (and on collision)");
    f.real("replan_budget", replan_budget, 0.001, 100.0, "each replan's planning time budget, s");
    f.real("latency", latency, -1.0, 100.0,
           "the plan starts from the committed state this long after its frame, s; -1: 1.25 "
           "times the replan budget (a planner stopped at its budget is still on time)");
    f.choice(
        "timing", timing,
        {{"real_time", FlightTiming::kRealTime}, {"deterministic", FlightTiming::kDeterministic}},
        "real_time: a plan whose measured planning time exceeds the latency is late and "
        "discarded; deterministic: every plan is taken as if on time, so a flight repeats "
        "bit for bit");
    f.choice("clock", clock, {{"cpu", BudgetClock::kCpu}, {"wall", BudgetClock::kWall}},
             "the clock of each replan's budget and planning time (real_time's latency): cpu: "
             "the process's CPU time while planning, what it takes on a core of its own, so "
             "parallel runs and other load do not change a flight (a planner that waits, for a "
             "GPU or a lock, is not charged for the wait); wall: the wall clock, load included");
    f.real("horizon", horizon, 0.5, 1000.0,
           "local goal distance when the goal is farther, m (kept 0.5 m inside the window)");
    f.real("max_time", max_time, 0.1, 1e5, "flight time limit, s (status timeout)");
    f.real("stuck_time", stuck_time, 0.1, 1e5,
           "s without 0.5 m of progress along the guide to the goal (the way the known map "
           "leaves, measured from here and from the last progress on one map; status stuck)");
    f.real("goal_tolerance", goal_tolerance, 0.01, 100.0, "reached: this close to the goal, m");
    f.real("planning_margin", planning_margin, 0.0, 10.0,
           "the planners keep the body's radius plus this from known obstacles (their "
           "robot_radius raised by it; the ground truth judges the body): room for tracking "
           "error, map noise and latency, m");
    f.real("brake_acceleration", brake_acceleration, 0.01, 1000.0,
           "deceleration of the stops that end every committed trajectory, m/s^2 (at most the "
           "planner's max_acceleration is used)");
    f.choice("commit", commit, {{"seen", CommitSpace::kSeen}, {"planned", CommitSpace::kPlanned}},
             "seen: every committed trajectory, its stop included, keeps the body and the "
             "planning margin in space the known map vouches for (known free; unknown counts "
             "as occupied), so unseen space is planned through but not flown into; planned: "
             "wherever the planning window allows (with unknown free, into unseen space: not "
             "safe)");
    f.boolean("keep_faster", keep_faster,
              "true: a replan's plan is set aside when the committed trajectory comes as near "
              "its local goal no later (a lattice search from a state between primitives need "
              "not find the rest of the plan it is on); false: every valid plan is taken");
    f.boolean("step_back", step_back,
              "true (with commit: seen): at rest, when less than 0.1 m of a plan can be "
              "committed before it leaves what the known map vouches for, the vehicle backs "
              "away from the voxel that stops it, its camera turned towards it, until the "
              "sensor's field of view holds it (a forward camera never sees beside, above or "
              "below itself); false: such a plan is taken as it is");
    f.boolean("escape", escape,
              "true: at rest, when the planner finds no way for the planning body "
              "(no_solution), plan again for the body grown by escape_margin only and fly that "
              "plan at escape_speed at most (tried only when escape_margin is below "
              "planning_margin); false (default: escape_margin 0.05 m is below the tracking "
              "error measured at low speed in the default wind, up to 0.068 m): no escape");
    f.real("escape_margin", escape_margin, 0.0, 10.0,
           "m beyond the body that an escape plan keeps from known obstacles and, committed, "
           "from what the known map does not vouch for (the tracking error at escape_speed)");
    f.real("escape_speed", escape_speed, 0.01, 100.0,
           "m/s: an escape plan is slowed in time (the same path) to at most this speed");
  }
};

/// Every parameter of a flight (sensor, map, loop, tracking), declared, typed and ranged like
/// a planner's: the fields of MapModel, FlightSettings and TrackingModel; the sensor and the map
/// are plugin parameters with their own (`kinolab fly --flight NAME=VALUE --flight
/// sensor.NAME=VALUE`, an experiment's `flight:`).
const ParameterSpecs& flightParameters();

/// What a flight is flown with: the sensor, the vehicle's map (its kind, lattice and planning
/// window), the loop's settings and how the vehicle tracks its committed trajectory.
struct FlightSetup {
  std::shared_ptr<const Sensor> sensor;
  /// A new vehicle map of the chosen kind (the `map` parameter), not yet set up.
  std::function<std::unique_ptr<VehicleMap>()> make_map;
  MapModel map;
  FlightSettings settings;
  TrackingModel tracking;
  /// Optional: made before each replan's plan() with its budget, dropped after it returns; a
  /// watchdog that stops a planner ignoring its budget (`kinolab fly`; `kinolab run` kills
  /// its worker instead).
  std::function<std::shared_ptr<void>(double budget)> guard_replan;
};
/// The setup of resolved flight parameters.
FlightSetup flightSetup(const ParameterSet& parameters);

/// One replan of a flight.
struct FlightReplan {
  double time = 0.0;   ///< s: the frame that asked for it
  std::string reason;  ///< "start", "period", "collision", "retry"
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d local_goal = Eigen::Vector3d::Zero();
  /// The planner's status, or the loop's: "late" (real time: past the latency),
  /// "no_local_goal", "at_local_goal" (an exact plan with nothing to fly: the start already in
  /// the planner's goal region of the local goal).
  std::string status;
  double planning_time_ms = 0.0;  ///< the planner's, and an escape's (recovery) added
  double distance_to_goal = 0.0;  ///< the plan's D to its local goal
  bool accepted = false;          ///< it became the committed trajectory
  /// Not taken because the committed trajectory comes as near the local goal no later; not
  /// a failure.
  bool kept = false;
  /// Why it was not taken (empty when it was): the planner's message, the checker's verdict,
  /// a late plan, or no local goal.
  std::string why;
  /// What the loop did about a failure at rest ("" none, "look": the camera turned 90
  /// degrees, "back_off": the vehicle moved away from the nearest known obstacle, "approach":
  /// it moved straight onto the local goal, "step_back": nothing of the plan could be
  /// committed, so the vehicle backed away from what the known map could not vouch for, its
  /// camera turned towards it, until the sensor's field of view holds it, "escape": the
  /// planner found no way for the planning body, and a plan for the body and escape_margin
  /// was committed, slowed to escape_speed).
  std::string recovery;
  /// The vehicle flew onto its back-up (the stop ending the committed trajectory, at speed,
  /// short of the goal) after this replan, before a plan took over.
  bool backup = false;
  /// The plan (planner's time, from 0); after an escape, the escape's plan, slowed.
  Trajectory trajectory;
};

struct FlightResult {
  /// reached (within goal_tolerance), collision, stuck, timeout, invalid_start, invalid_goal
  std::string status;
  std::string message;
  Body body;             ///< the planner's body the flight was judged with
  PlannerLimits limits;  ///< and its limits
  Trajectory flown;      ///< from t = 0 to the end of the flight (or the collision)
  std::vector<FlightReplan> replans;
  double time_to_goal = 0.0;   ///< s (NaN unless reached)
  double min_clearance = 0.0;  ///< m: to the ground truth's cubes, less the body radius
  /// The flown trajectory as the checker measures every trajectory, on the ground truth.
  TrajectoryEvaluation evaluation;
  double distance_to_goal = NAN;  ///< m: from where the flight ended to the goal
  /// The body came nearer the ground truth than the planning margin: tracking took it inside
  /// the clearance it was planned with (min_clearance < planning_margin).
  bool inside_margin = false;
  /// m: the flown position's distance from the committed one, largest and root mean square
  /// (every 0.01 s; 0 with perfect tracking).
  double tracking_error_max = 0.0;
  double tracking_error_rms = 0.0;
  /// Times the vehicle flew onto its back-up (FlightReplan::backup).
  int backups = 0;
  /// How hard the query is on the ground truth, before the flight (FlightBench's metrics).
  ScenarioDifficulty difficulty;
  int frames = 0;
  double time_sense_ms = 0.0;  ///< summed wall time: sensor, map insertion, window + ESDF
  double time_map_ms = 0.0;
  double time_window_ms = 0.0;
  double time_guide_ms = 0.0;  ///< summed over the replans: the global guide on the known map
  std::shared_ptr<const VehicleMap> map;  ///< the final known map
  /// (time, VehicleMap::topView) every snapshot_period and at the end, when asked for.
  std::vector<std::pair<double, std::string>> snapshots;
  /// With snapshots: every voxel the final known map holds occupied (its centre) and the
  /// snapshot time it was first known occupied, in that order: the map growing, in 3D.
  std::vector<std::pair<double, Eigen::Vector3d>> known_voxels;
};

/// FlightResult::known_voxels as CSV `t,x,y,z` (the runner's flights table).
std::string knownVoxelsCsv(const FlightResult& result);

/// Flies `query` through `truth`, seeing it only through the setup's sensor into a new map of
/// its kind: simulated time, a replan
/// at every `replan_period` and whenever the committed trajectory collides in the updated
/// map; a replan starts from the committed state `latency` after its frame; a failed replan
/// keeps the committed trajectory (every committed trajectory ends at rest: plans get a
/// braking tail) or, if that collides in the known map, brakes at once. The vehicle tracks
/// the committed trajectory exactly or as the tracking model flies it (its position is what
/// the sensor sees from and what is judged). The flown trajectory goes through the
/// independent checker against `truth` (collisions; the limits too when tracking is
/// perfect): a collision ends the flight there, as `collision`.
/// Recovery at rest (docs/flights.md): after a planner refuses the start, the vehicle backs
/// off 0.3 m from the nearest known obstacle; after two failed replans in a row, the camera
/// turns 90 degrees per failed replan to look for a way. A `stuck` flight's message says why:
/// the plans taken since its last progress (how far apart their local goals lie, how near the
/// goal the nearest) and the failed replans by status, with the first reason of each.
FlightResult fly(const std::shared_ptr<const World>& truth, Planner& planner, std::uint64_t seed,
                 const PlanningQuery& query, const FlightSetup& setup);

/// A flight's run metrics, declared once with how each is read from the flight: the columns
/// it shares with every planning run (status, success, planning time = the replans' median,
/// D at the end, the checker's evaluation of the flown trajectory on the ground truth, the
/// verdict).
const MetricList<FlightResult>& flightRunMetrics();
/// The metrics of a flight (`kinolab list metrics`; the JSON summary of `kinolab fly`): its
/// run metrics, then its statistics (flightStatistics()).
const MetricSpecs& flightMetrics();
/// Every replan of a flight as CSV: replan, time, reason, start and local goal (x, y, z),
/// status, planning_time_ms, distance_to_goal, accepted, kept, backup, recovery, why.
std::string replansCsv(const FlightResult& result);
/// The flight's own figures (time to goal, replans, tracking, difficulty, frames): a flight
/// run's statistics in the runner's database.
const MetricSpecs& flightStatistics();
/// The values of flightStatistics() for a flight, in declaration order.
MetricValues flightStatisticValues(const FlightResult& result);
/// The values of flightMetrics() for a flight, in declaration order.
MetricValues flightValues(const FlightResult& result);

}  // namespace kinolab
