// The flight loop (fly()): one flight, step by step. Its frames, replans and what it records
// are in flight.cpp; how a plan is committed and how a vehicle at rest recovers after a failed
// replan in flight_recovery.cpp. Private to framework/src/flight.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "flight_motion.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/flight/tracking.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab::flight_motion {

/// One flight, step by step (fly()): the committed trajectory, the known map and the record.
class FlightLoop {
 public:
  FlightLoop(const std::shared_ptr<const World>& truth, Planner& planner, std::uint64_t seed,
             const PlanningQuery& query, const FlightSetup& setup);

  FlightResult run();

 private:
  FlightResult end(std::string status, std::string message) {
    result_.status = std::move(status);
    result_.message = std::move(message);
    return std::move(result_);
  }

  /// One frame: false when the flight ends at it.
  bool step(int frame);

  /// The vehicle flies onto its back-up (the stop that ends the committed trajectory) while
  /// moving, short of the goal: no plan took over in time. Counted once per committed
  /// trajectory, on the flight and on the last replan.
  void countBackup();

  /// Reached, out of time or stuck (the status set); false while the flight goes on.
  bool ended(const ChainState& now);

  /// A frame of the sensor into the known map; the planning window around the vehicle.
  std::shared_ptr<const World> sense(const ChainState& now);

  /// A replan from the committed state `latency` ahead towards a local goal on the guide;
  /// an accepted plan is spliced in, and without one the vehicle brakes if its committed
  /// trajectory is no longer free.
  void replan(std::shared_ptr<const World> shared_window, const Eigen::Vector3d& position);

  /// The planner set up on `window` for its body grown by `margin`, planning `local` within
  /// the replan budget (under the flight's watchdog, if any).
  PlanResult planOn(const std::shared_ptr<const World>& window, double margin,
                    const PlanningQuery& local);

  Box mapDomain() const {  // where plans may go: the map's box less the planning margin
    const Eigen::Vector3d inset = Eigen::Vector3d::Constant(settings_.planning_margin);
    return {map_->bounds().min + inset, map_->bounds().max - inset};
  }

  /// Progress is measured along the way the known map leaves to the goal (the guide), both
  /// ways on this frame's map: the guide from `from` (where this replan starts) is 0.5 m
  /// shorter than the one from where the flight last made progress. A way that first leads
  /// away from the goal (a corridor, a door behind the vehicle) is progress, and a vehicle
  /// that turns between two ways is not, however the map changed meanwhile (a new wall
  /// lengthens both). Measured by the straight distance to the goal instead, vehicles
  /// exploring geb079's rooms on the way were judged stuck.
  void measureProgress(const Eigen::Vector3d& from, const std::vector<Eigen::Vector3d>& guide,
                       const std::vector<Eigen::Vector3d>& guide_before) {
    if (wayLength(guide, from, query_.goal) <
        wayLength(guide_before, progress_from_, query_.goal) - kProgress) {
      progress_from_ = from;
      best_time_ = t_;
    }
  }

  /// Whether a replan's plan becomes the committed trajectory (then spliced in from
  /// `t_start`), with why not in `replan.why`: too late (in real time a plan that took longer
  /// than the latency arrives after its start), nothing to fly (status at_local_goal), no
  /// valid trajectory, the committed trajectory
  /// gets there first (`replan.kept`, arrivesFirst()), or no braking tail that fits. Every
  /// committed trajectory ends at rest: the plan gets a braking tail, which the planner never saw,
  /// so the plan is cut where its tail stays in the map and clear of what is known (the latest such
  /// point, in 0.1 s steps).
  bool take(const PlanResult& plan, double t_start, const Eigen::Vector3d& goal,
            const World& window, FlightReplan& replan);

  /// Whether `trajectory` may be committed from `from` on for `body`: with commit: seen, when
  /// the known map vouches for it (vouchedTrace(): every known obstacle and every unseen voxel kept
  /// at the body's radius; this holds every plan, approximate ones too, and every braking tail
  /// the vehicle may fly as its back-up); with commit: planned, when it stays in the map's box
  /// and clear of the window's obstacles (freeFrom()).
  bool committable(const Trajectory& trajectory, double from, const World& window,
                   const Body& body) const;

  /// A plan cut `at` seconds and spliced into the committed trajectory from a replan's start,
  /// its braking tail after it.
  struct Cut {
    double at;
    Trajectory spliced;
  };
  /// The latest cut of `plan` (from `vouched`, committableFor(), down in 0.1 s steps) whose
  /// splice is committable() for `body`; none when no cut is.
  std::optional<Cut> latestCut(const Trajectory& plan, double vouched, double t_start,
                               const World& window, const Body& body) const;
  /// Makes `cut` of `plan` the committed trajectory for `body` (the whole plan the intended
  /// one, where the camera looks; the back-up starts at the cut).
  void commit(const Trajectory& plan, double t_start, Cut cut, const Body& body);

  /// How long `plan` (from its start) may be committed for `body`: with commit: seen, as long
  /// as the known map vouches for it (vouchedUntil()); with commit: planned, all of it (its cuts
  /// are then judged by committable()).
  double committableFor(const Trajectory& plan, const Body& body) const;

  /// Where the camera looks for a frame taken at t: where stepBack() turned it, else along the
  /// intended trajectory (lookAlong()).
  double heading(double t) const;

  /// After a failed replan with the vehicle at rest (or about to be): step back to see what
  /// stops a plan (stepBack()); back off (backOffMoves()); move straight onto the local goal when
  /// the planner had nothing to fly (the vehicle within its goal region of the local goal, which
  /// near an obstructed goal stands in for it, but not within the flight's goal tolerance);
  /// else, from the second failure in a row, turn the camera 90 degrees to look for a way.
  /// At rest after a no_solution, an escape (escape()) before the camera turns.
  void recover(FlightReplan& replan, const std::shared_ptr<const World>& window);

  /// A plan from where the vehicle rests to the replan's local goal for the body grown by
  /// escape_margin only (the planning body found no way: a pocket it barely fits), slowed to
  /// escape_speed and committed, cut as take() cuts, when the known map vouches for it for that
  /// body; the committed trajectory is then checked each frame for that body.
  bool escape(FlightReplan& replan, const std::shared_ptr<const World>& window);

  /// At rest: the vehicle stands still and its committed trajectory ends where it is.
  bool atRest(const ChainState& here) const {
    return here.col(1).norm() < 0.05 && (committed_.endPosition() - here.col(0)).norm() < 0.05;
  }

  /// Turns the camera towards `blocker` (planBlocker()) and backs the vehicle away from it until
  /// the sensor's view holds it (the first committable of stepBackMoves()), or only turns; the
  /// camera keeps that heading until a plan is taken. False when already facing it, unmoved.
  bool stepBack(const Eigen::Vector3d& position, const Eigen::Vector3d& blocker,
                const World& window);

  /// A straight rest-to-rest move from `position` by `offset` (half the braking rate, half
  /// the speed limit), committed when it is committable() for `body`; the next replan waits
  /// for its end.
  bool moveStraight(const Eigen::Vector3d& position, const Eigen::Vector3d& offset,
                    const World& window, const Body& body);

  /// The map from above, and when each voxel was first known occupied.
  void snapshot();

  /// What was flown, checked against the ground truth.
  /// Where the vehicle has been: the committed trajectory (perfect tracking) or what the
  /// tracker flew (before its first step, at t = 0, both are the start at rest).
  const Trajectory& flownPath() const {
    return tracker_ && !tracker_->flown().empty() ? tracker_->flown() : committed_;
  }

  void finish();

  const std::shared_ptr<const World>& truth_;
  Planner& planner_;
  std::uint64_t planner_seed_;
  const PlanningQuery& query_;
  const Sensor& sensor_;
  MapModel map_model_;  // the flight's, its reach set to the planning radius
  const FlightSettings& settings_;
  const std::function<std::shared_ptr<void>(double)>& guard_replan_;
  FlightResult result_;
  std::shared_ptr<VehicleMap> map_;
  Body body_;           // the vehicle's body: what is judged
  Body planning_body_;  // the body grown by the planning margin: what is planned
  PlannerLimits limits_;
  TrajectoryChecker checker_;
  double brake_rate_;
  double dt_;
  double z_band_low_;
  double z_band_high_;
  Trajectory committed_;
  // The body the committed trajectory was committed for (the planning body; after a back-off,
  // an escape or a stop, the back-off's, the escape's or the body alone): each frame checks it
  // for that body, and a plan is kept (take()) only while it is the planning body.
  Body committed_body_;
  Trajectory intended_;  // the last plan taken, whole: where the camera looks (heading())
  double t_ = 0.0;
  double next_replan_ = 0.0;
  // Where (a replan's start) and when the flight last made progress (measureProgress()).
  Eigen::Vector3d progress_from_ = Eigen::Vector3d::Zero();
  double best_time_ = 0.0;
  double way_height_ = 0.0;  // where the guide goes (wayHeight()): the window reaches there
  std::vector<Eigen::Vector3d> trail_;      // where the vehicle flew, half a voxel apart
  static constexpr double kProgress = 0.5;  // m shorter along the guide: progress
  std::string reason_ = "start";
  bool collided_ = false;
  std::optional<Eigen::Vector3d> left_map_;  ///< where the vehicle left the map, if it did
  // This frame's verdict: the committed trajectory is clear of the window's known obstacles
  // for the body it was committed for (freeFrom; a replan on collision when not).
  bool committed_free_ = true;
  int failed_in_a_row_ = 0;  // failed replans since the last taken one
  // When the committed trajectory's stop (its back-up) begins, and whether the vehicle was
  // counted flying onto it (countBackup()).
  double backup_start_ = INFINITY;
  bool backup_counted_ = false;
  static constexpr double kMovingSpeed = 0.1;  // m/s: slower is at rest for countBackup()
  static constexpr double kStartKnown = 3.0;   // planning radii round the start known at first
  double look_offset_ = 0.0;        // rad: the camera's turn from its heading, to look for a way
  std::optional<double> look_yaw_;  // rad: set by stepBack() until a plan is taken
  std::optional<Eigen::Vector3d> blocker_;  // what stopped the last plan (planBlocker())
  std::pair<double, double> tangents_;      // of the sensor's largest elevations, up and down
  static constexpr double kStalled = 0.1;   // m: a plan committing less at rest holds the vehicle
  static constexpr double kStepBack = 1.5;  // m: the longest step back (stepBack())
  SensorNoise sensor_errors_;
  std::vector<Eigen::Vector3d> rays_;        // the sensor's, once
  RayCaster caster_;                         // the ground truth's, once
  Rng noise_;                                // the sensor's noise, dropouts and latency
  std::optional<QuadrotorTracker> tracker_;  // unless tracking is perfect
  std::unordered_map<std::size_t, double> first_occupied_;  // lattice index -> time
};

}  // namespace kinolab::flight_motion
