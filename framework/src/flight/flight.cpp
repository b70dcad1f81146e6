#include "kinolab/flight/flight.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <tuple>
#include <unordered_map>

#include "flight_motion.hpp"
#include "flight_views.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab {

using namespace flight_motion;

namespace {

/// One flight, step by step (fly()): the committed trajectory, the known map and the record.
class FlightLoop {
 public:
  FlightLoop(const std::shared_ptr<const World>& truth, Planner& planner, std::uint64_t seed,
             const PlanningQuery& query, const FlightSetup& setup)
      : truth_(truth),
        planner_(planner),
        planner_seed_(seed),
        query_(query),
        sensor_(*setup.sensor),
        map_model_(setup.map),
        settings_(setup.settings),
        guard_replan_(setup.guard_replan),
        map_(setup.make_map()),
        // The body and limits every replan plans for.
        body_(planner.configuredBody()),
        planning_body_(body_.grown(setup.settings.planning_margin)),
        limits_(planner.limits()),
        checker_(truth, flownCheckerSettings(body_, limits_, setup.tracking)),
        brake_rate_(std::min(settings_.brake_acceleration, limits_.limits.bound[2].minCoeff())),
        dt_(1.0 / sensor_.frameRate()),
        // Snapshots: the map from above over the query's heights, widened by 0.5 m.
        z_band_low_(std::min(query.start(2, 0), query.goal.z()) - 0.5),
        z_band_high_(std::max(query.start(2, 0), query.goal.z()) + 0.5),
        sensor_errors_(sensor_.noise()),
        rays_(sensor_.rayDirections()),
        caster_(*truth),
        noise_(Rng::derive(settings_.seed, "sensor")) {
    tangents_ = elevationTangents(rays_);
    if (setup.tracking.kind == TrackingKind::kQuadrotor) {
      tracker_.emplace(setup.tracking, query.start.col(0), settings_.seed);
    }
    map_model_.reach = planning_body_.radius;      // the window sees what the body reaches
    map_model_.inset = settings_.planning_margin;  // room for tracking error at the map's end
    map_->setup(truth->bounds(), map_model_);
    result_.map = map_;
    result_.body = body_;
    result_.limits = limits_;
  }

  FlightResult run() {
    const Eigen::Vector3d start = query_.start.col(0);
    if (!truth_->isFree(start, body_.radius)) {
      return end("invalid_start", "the start is outside the map or in collision");
    }
    if (!truth_->isFree(query_.goal, body_.radius)) {
      return end("invalid_goal", "the goal is outside the map or in collision");
    }
    result_.difficulty = scenarioDifficulty(*truth_, query_, body_.radius);
    // The committed trajectory from t = 0; at rest at its end (a hover at the start at first).
    committed_.append(hold(start, dt_));
    intended_ = committed_;
    // The vehicle knows its start's surroundings (kStartKnown planning radii) as they are, as
    // if looked round before take-off: the voxels free in the ground truth are known free (the
    // others stay unknown). A forward camera never sees beside, below or above itself, and its
    // frustum (58 degrees high) holds the planning body only from about 2.5 radii ahead, so
    // without this no plan from the start could be vouched for (vouchedTrace()).
    const double half_diagonal = 0.5 * std::sqrt(3.0) * map_model_.resolution;
    map_->markFree(start, kStartKnown * planning_body_.radius, [&](const Eigen::Vector3d& centre) {
      return truth_->isFree(centre, half_diagonal);
    });
    progress_from_ = start;
    way_height_ = query_.goal.z();
    for (int frame = 0; step(frame); ++frame) {
    }
    finish();
    return std::move(result_);
  }

 private:
  FlightResult end(std::string status, std::string message) {
    result_.status = std::move(status);
    result_.message = std::move(message);
    return std::move(result_);
  }

  /// One frame: false when the flight ends at it.
  bool step(int frame) {
    // The ground truth: the stretch flown since the last frame, every centimetre of time.
    const double from = t_;
    t_ = frame * dt_;
    if (tracker_) tracker_->advance(committed_, t_);
    const Trajectory& path = flownPath();
    for (double s = from; frame > 0 && s <= t_; s += 0.01) {
      const Eigen::Vector3d position = path.evaluate(std::min(s, path.duration()));
      if (!truth_->bounds().contains(position)) {  // blown or flown off the map: no world there
        t_ = s;
        left_map_ = position;
        return false;
      }
      if (checker_.collides(position)) {
        t_ = s;
        collided_ = true;
        return false;
      }
    }
    const ChainState now = stateAt(path, t_);
    if (ended(now)) return false;
    countBackup();
    ++result_.frames;
    if (settings_.snapshot_period > 0.0 &&
        (result_.snapshots.empty() ||
         t_ >= result_.snapshots.back().first + settings_.snapshot_period - 1e-9)) {
      snapshot();
    }
    const std::shared_ptr<const World> window = sense(now);
    committed_free_ =
        freeFrom(committed_, t_, truth_->bounds(), *window, planning_body_, limits_.limits);
    if (!committed_free_) {
      reason_ = "collision";
      next_replan_ = t_;
    }
    if (t_ + 1e-9 >= next_replan_) replan(window, now.col(0));
    return true;
  }

  /// The vehicle flies onto its back-up (the stop that ends the committed trajectory) while
  /// moving, short of the goal: no plan took over in time. Counted once per committed
  /// trajectory, on the flight and on the last replan.
  void countBackup() {
    if (backup_counted_ || t_ < backup_start_ ||
        stateAt(committed_, t_).col(1).norm() < kMovingSpeed) {
      return;
    }
    backup_counted_ = true;
    ++result_.backups;
    if (!result_.replans.empty()) result_.replans.back().backup = true;
  }

  /// Reached, out of time or stuck (the status set); false while the flight goes on.
  bool ended(const ChainState& now) {
    const double distance = (now.col(0) - query_.goal).norm();
    if (distance <= settings_.goal_tolerance) {
      result_.status = "reached";
      result_.time_to_goal = t_;
      return true;
    }
    if (t_ >= settings_.max_time) {
      result_.status = "timeout";
      result_.message =
          "the goal was not reached within " + formatNumber(settings_.max_time) + " s of flight";
      return true;
    }
    if (t_ - best_time_ > settings_.stuck_time) {
      result_.status = "stuck";
      result_.message = "no progress along the guide to the goal for " +
                        formatNumber(settings_.stuck_time) + " s" +
                        takenSince(result_.replans, best_time_, query_.goal) +
                        failuresSince(result_.replans, best_time_);
      return true;
    }
    return false;
  }

  /// A frame of the sensor into the known map; the planning window around the vehicle.
  std::shared_ptr<const World> sense(const ChainState& now) {
    auto begin = std::chrono::steady_clock::now();
    // The newest frame the map has was taken the sensor's latency (with its jitter) ago.
    const SensorNoise& errors = sensor_errors_;
    const double age =
        errors.latency +
        (errors.latency_jitter > 0.0 ? errors.latency_jitter * noise_.uniform(-1.0, 1.0) : 0.0);
    const double taken = std::clamp(t_ - age, 0.0, t_);
    const SensorFrame sensed =
        senseFrame(caster_, sensor_, rays_, stateAt(flownPath(), taken).col(0),
                   heading(taken) + look_offset_, noise_);
    result_.time_sense_ms += millisecondsSince(begin);
    begin = std::chrono::steady_clock::now();
    map_->insert(sensed, sensor_.maxRange());
    // Where the vehicle is, nothing is: the voxels whose centres its body holds are known free
    // (their cubes meet the body, which the ground truth has not stopped: they are free), and
    // no more, so that what the vehicle assumes never vouches for a plan (vouchedTrace()).
    map_->markFree(now.col(0), body_.radius);
    if (trail_.empty() || (trail_.back() - now.col(0)).norm() > 0.5 * map_model_.resolution) {
      trail_.push_back(now.col(0));  // where the body fits: open to the guides
    }
    result_.time_map_ms += millisecondsSince(begin);
    begin = std::chrono::steady_clock::now();
    std::shared_ptr<const World> window =
        map_->window(windowCentre(now.col(0), way_height_, map_model_.window_height));
    result_.time_window_ms += millisecondsSince(begin);
    return window;
  }

  /// A replan from the committed state `latency` ahead towards a local goal on the guide;
  /// an accepted plan is spliced in, and without one the vehicle brakes if its committed
  /// trajectory is no longer free.
  void replan(std::shared_ptr<const World> shared_window, const Eigen::Vector3d& position) {
    FlightReplan replan;
    blocker_.reset();
    replan.time = t_;
    replan.reason = reason_;
    const double t_start = t_ + settings_.replanLatency();
    PlanningQuery local;
    local.start = stateAt(committed_, t_start);
    replan.start = local.start.col(0);
    const auto begin = std::chrono::steady_clock::now();
    const double z_low = std::min(local.start(2, 0), query_.goal.z()) - 0.5;
    const double z_high = std::max(local.start(2, 0), query_.goal.z()) + 0.5;
    const Eigen::Vector3d from = local.start.col(0);
    const auto guides = flightGuides(*map_, query_, {from, progress_from_}, {z_low, z_high},
                                     planning_body_.radius, settings_.planning_margin, trail_);
    const std::vector<Eigen::Vector3d>& guide = guides[0];
    result_.time_guide_ms += millisecondsSince(begin);
    measureProgress(from, guide, guides[1]);
    // The window reaches where the guide goes (kept while it holds that, VehicleMap::window()).
    way_height_ = wayHeight(guide, settings_.horizon, query_.goal);
    shared_window = map_->window(windowCentre(position, way_height_, map_model_.window_height));
    bool accepted = false;
    bool found = localGoal(local.start.col(0), query_.goal, guide, settings_.horizon,
                           *shared_window, planning_body_.radius, mapDomain(), &local.goal);
    const double region = limits_.goal_radius;
    if (found && (local.goal - local.start.col(0)).norm() <= region &&
        (query_.goal - local.start.col(0)).norm() > region) {
      // The kept window leaves no room beyond the planner's goal region (it follows the
      // vehicle in z a quarter of its height late: a goal above or below): the window is built
      // anew around the vehicle and the local goal chosen again. Before, a vehicle below a
      // higher goal failed hundreds of replans at its local goal 0.5 m above it.
      shared_window = map_->window(windowCentre(position, way_height_, map_model_.window_height),
                                   /*rebuild=*/true);
      found = localGoal(local.start.col(0), query_.goal, guide, settings_.horizon, *shared_window,
                        planning_body_.radius, mapDomain(), &local.goal);
    }
    const World& window = *shared_window;
    if (found) {
      replan.local_goal = local.goal;
      planner_.setup({shared_window, planner_seed_, settings_.planning_margin});
      const std::shared_ptr<void> guard =
          guard_replan_ ? guard_replan_(settings_.replan_budget) : nullptr;
      const PlanResult plan = planner_.plan(
          local,
          Budget{settings_.replan_budget, std::numeric_limits<long long>::max(), settings_.clock});
      replan.status = std::string(toString(plan.status));
      replan.planning_time_ms = plan.planning_time_ms;
      replan.distance_to_goal = plan.distance_to_goal;
      accepted = take(plan, t_start, local.goal, window, replan);
    } else {
      replan.status = "no_local_goal";
      replan.why = "no free point on the way to the goal within the window";
    }
    replan.accepted = accepted;
    const bool settled = accepted || replan.kept;
    if (settled) {
      failed_in_a_row_ = 0;
      look_offset_ = 0.0;
      if (accepted) look_yaw_.reset();  // the camera looks along the plan again
    } else {
      recover(replan, window);
    }
    result_.replans.push_back(std::move(replan));
    // (A kept plan's committed trajectory is clear for the planning margin, so for the body.)
    if (!settled && !freeFrom(committed_, t_, truth_->bounds(), window, body_, limits_.limits)) {
      // Nothing safe to fly on (for the body: inside the planning margin it goes on): stop
      // now.
      const ChainState here = stateAt(committed_, t_);
      Trajectory stop = slice(committed_, t_);
      const TrajectorySegment braking = brake(here, brake_rate_);
      if (braking.duration > 0.0) stop.append(braking);
      if (stop.empty()) stop.append(hold(here.col(0), dt_));  // at rest at the very start
      committed_ = std::move(stop);
      intended_ = committed_;
      backup_start_ = t_;  // the stop is flown at once
      backup_counted_ = false;
    }
    reason_ = settled ? "period" : "retry";
    next_replan_ = std::max(next_replan_, t_ + (settled ? settings_.replan_period : dt_));
  }

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
            const World& window, FlightReplan& replan) {
    if (settings_.timing == FlightTiming::kRealTime &&
        plan.planning_time_ms > 1000.0 * settings_.replanLatency()) {
      replan.status = "late";
      replan.why = "planning took " + formatNumber(plan.planning_time_ms) + " ms, past the " +
                   formatNumber(1000.0 * settings_.replanLatency()) + " ms latency";
      return false;
    }
    if (plan.status == PlanStatus::kExact && plan.trajectory.empty()) {
      replan.status = "at_local_goal";  // recover() moves onto it
      replan.why = "the start is already within the planner's goal region of the local goal";
      return false;
    }
    if (plan.trajectory.empty() || !plan.check.valid ||
        (plan.status != PlanStatus::kExact && plan.status != PlanStatus::kApproximate)) {
      replan.why = !plan.trajectory.empty() && !plan.check.valid
                       ? "the checker: " + plan.check.check + ": " + plan.check.detail
                       : (plan.message.empty() ? "no trajectory" : plan.message);
      return false;
    }
    if (settings_.keep_faster && committed_free_ &&
        arrivesFirst(committed_, plan.trajectory, t_start, goal, 0.5 * map_model_.resolution,
                     limits_.limits.bound[1].norm())) {
      replan.kept = true;
      replan.trajectory = plan.trajectory;
      replan.why = "the committed trajectory comes as near the local goal no later";
      return false;
    }
    const double vouched =
        settings_.commit == CommitSpace::kPlanned
            ? plan.trajectory.duration()
            : vouchedUntil(*map_, plan.trajectory, planning_body_, settings_.planning_margin);
    blocker_.reset();
    if (settings_.commit == CommitSpace::kSeen && vouched < plan.trajectory.duration()) {
      blocker_ = planBlocker(*map_, plan.trajectory, planning_body_, settings_.planning_margin);
    }
    const ChainState here = stateAt(committed_, t_);
    const bool at_rest = atRest(here);
    for (double cut = std::min(plan.trajectory.duration(), vouched); cut > 0.0; cut -= 0.1) {
      Trajectory spliced = splice(committed_, t_start, slice(plan.trajectory, cut), brake_rate_);
      if (committable(spliced, t_start, window, planning_body_)) {
        if (settings_.step_back && at_rest && blocker_ &&
            (spliced.endPosition() - here.col(0)).norm() < kStalled &&
            stepBack(here.col(0), *blocker_, window)) {
          // At rest, a plan that stops again within centimetres held the vehicle where it
          // stood, replan after replan: it steps back to see instead (else takes it).
          replan.why = "the plan commits less than " + formatNumber(kStalled) +
                       " m before it leaves the space the known map vouches for (commit: seen)";
          replan.recovery = "step_back";
          return false;
        }
        replan.trajectory = plan.trajectory;
        intended_ = splice(committed_, t_start, plan.trajectory, brake_rate_);
        committed_ = std::move(spliced);
        backup_start_ = t_start + cut;
        backup_counted_ = false;
        return true;
      }
    }
    replan.why = notCommittedWhy(settings_.commit, vouched);
    return false;
  }

  /// Whether `trajectory` may be committed from `from` on for `body`: with commit: seen, when
  /// the known map vouches for it (vouchedTrace(): every known obstacle and every unseen voxel kept
  /// at the body's radius; this holds every plan, approximate ones too, and every braking tail
  /// the vehicle may fly as its back-up); with commit: planned, when it stays in the map's box
  /// and clear of the window's obstacles (freeFrom()).
  bool committable(const Trajectory& trajectory, double from, const World& window,
                   const Body& body) const {
    if (settings_.commit == CommitSpace::kPlanned) {
      return freeFrom(trajectory, from, truth_->bounds(), window, body, limits_.limits);
    }
    return vouchedTrace(*map_, trajectory, from, body, body.radius - body_.radius).free;
  }

  /// Where the camera looks for a frame taken at t: where stepBack() turned it, else along the
  /// intended trajectory (lookAlong()).
  double heading(double t) const {
    if (look_yaw_) return *look_yaw_;
    return lookAlong(intended_, t, *map_, planning_body_, settings_.commit == CommitSpace::kSeen,
                     limits_.limits.bound[1].norm(), query_.goal);
  }

  /// After a failed replan with the vehicle at rest (or about to be): step back to see what
  /// stops a plan (stepBack()); back off (backOffMoves()); move straight onto the local goal when
  /// the planner had nothing to fly (the vehicle within its goal region of the local goal, which
  /// near an obstructed goal stands in for it, but not within the flight's goal tolerance);
  /// else, from the second failure in a row, turn the camera 90 degrees to look for a way.
  void recover(FlightReplan& replan, const World& window) {
    ++failed_in_a_row_;
    if (!replan.recovery.empty()) return;  // take() stepped back
    const ChainState here = stateAt(committed_, t_);
    if (!atRest(here)) return;
    if (settings_.step_back && blocker_ && replan.status != "invalid_start" &&
        replan.status != "at_local_goal" && stepBack(here.col(0), *blocker_, window)) {
      replan.recovery = "step_back";
      return;
    }
    for (const BackOff& move : backOffMoves(replan.status, here.col(0), window, mapDomain(),
                                            planning_body_.radius, map_model_.resolution)) {
      if (moveStraight(here.col(0), move.offset, window,
                       move.body_alone ? body_ : planning_body_)) {
        replan.recovery = "back_off";
        return;
      }
    }
    if (replan.status == "at_local_goal" && (replan.local_goal - here.col(0)).norm() > 0.05 &&
        moveStraight(here.col(0), replan.local_goal - here.col(0), window, planning_body_)) {
      replan.recovery = "approach";
      return;
    }
    if (failed_in_a_row_ >= 2) {
      look_offset_ = std::fmod(look_offset_ + 90.0 * kDegree, 2.0 * M_PI);
      replan.recovery = "look";
    }
  }

  /// At rest: the vehicle stands still and its committed trajectory ends where it is.
  bool atRest(const ChainState& here) const {
    return here.col(1).norm() < 0.05 && (committed_.endPosition() - here.col(0)).norm() < 0.05;
  }

  /// Turns the camera towards `blocker` (planBlocker()) and backs the vehicle away from it until
  /// the sensor's view holds it (the first committable of stepBackMoves()), or only turns; the
  /// camera keeps that heading until a plan is taken. False when already facing it, unmoved.
  bool stepBack(const Eigen::Vector3d& position, const Eigen::Vector3d& blocker,
                const World& window) {
    const double yaw = yawTowards(position, blocker);
    const bool facing = look_yaw_ && std::abs(std::remainder(*look_yaw_ - yaw, 2.0 * M_PI)) < 0.2;
    look_offset_ = 0.0;
    const double ahead = heading(t_);
    for (const StepBackMove& move :
         stepBackMoves(position, blocker, {std::cos(ahead), std::sin(ahead)}, tangents_,
                       planning_body_.radius, map_model_.resolution, kStepBack)) {
      if (moveStraight(position, move.offset, window, planning_body_)) {
        look_yaw_ = move.yaw;
        return true;
      }
    }
    look_yaw_ = yaw;
    return !facing;
  }

  /// A straight rest-to-rest move from `position` by `offset` (half the braking rate, half
  /// the speed limit), committed when it is committable() for `body`; the next replan waits
  /// for its end.
  bool moveStraight(const Eigen::Vector3d& position, const Eigen::Vector3d& offset,
                    const World& window, const Body& body) {
    const auto move =
        straightMove(position, offset, 0.5 * brake_rate_, 0.5 * limits_.limits.bound[1].minCoeff());
    Trajectory moved = slice(committed_, t_);
    for (const TrajectorySegment& segment : move) moved.append(segment);
    if (!committable(moved, t_, window, body)) return false;
    committed_ = std::move(moved);
    intended_ = committed_;
    backup_start_ = INFINITY;  // rest to rest: no back-up to fly
    next_replan_ = committed_.duration();
    return true;
  }

  /// The map from above, and when each voxel was first known occupied.
  void snapshot() {
    result_.snapshots.emplace_back(t_, map_->topView(z_band_low_, z_band_high_));
    for (const std::size_t voxel : map_->occupiedVoxels()) first_occupied_.emplace(voxel, t_);
  }

  /// What was flown, checked against the ground truth.
  /// Where the vehicle has been: the committed trajectory (perfect tracking) or what the
  /// tracker flew (before its first step, at t = 0, both are the start at rest).
  const Trajectory& flownPath() const {
    return tracker_ && !tracker_->flown().empty() ? tracker_->flown() : committed_;
  }

  void finish() {
    result_.flown = slice(flownPath(), std::max(t_, dt_));
    std::tie(result_.tracking_error_max, result_.tracking_error_rms) =
        trackingError(result_.flown, committed_);
    if (settings_.snapshot_period > 0.0) {
      snapshot();
      result_.known_voxels = knownVoxelsInOrder(*map_, first_occupied_);
    }
    judgeFlown(checker_.check(result_.flown,
                              {.start = query_.start, .goal = query_.goal, .require_goal = false}),
               collided_, left_map_, t_, result_);
    result_.evaluation = checker_.evaluate(result_.flown);
    result_.min_clearance = exactMinClearance(*truth_, result_.flown, body_.radius,
                                              std::max(1.0, settings_.planning_margin));
    result_.evaluation.min_clearance = result_.min_clearance;
    result_.inside_margin = result_.min_clearance < settings_.planning_margin;
    if (!result_.flown.empty()) {
      result_.distance_to_goal = (result_.flown.endPosition() - query_.goal).norm();
    }
    if (result_.status != "reached") result_.time_to_goal = NAN;
  }

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
  // for the planning margin (freeFrom; a replan on collision when not).
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

}  // namespace

FlightResult fly(const std::shared_ptr<const World>& truth, Planner& planner, std::uint64_t seed,
                 const PlanningQuery& query, const FlightSetup& setup) {
  // Plans keep planning_margin inside the map's box on every side: a margin of half the
  // box's thinnest side leaves nothing to plan in.
  const Eigen::Vector3d extent = truth->bounds().max - truth->bounds().min;
  if (2.0 * setup.settings.planning_margin >= extent.minCoeff()) {
    throw ConfigError("flight planning_margin " + formatNumber(setup.settings.planning_margin) +
                      " m: plans keep it inside the map's box on every side, and world '" +
                      truth->name() + "' is " + formatPoint(extent) +
                      " m: expected less than half its thinnest side, " +
                      formatNumber(0.5 * extent.minCoeff()) + " m");
  }
  return whileDoing("flying over the world '" + truth->name() + "'",
                    [&] { return FlightLoop(truth, planner, seed, query, setup).run(); });
}

}  // namespace kinolab
