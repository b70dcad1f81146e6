#include "kinolab/flight/flight.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>
#include <unordered_map>

#include "flight_loop.hpp"
#include "flight_motion.hpp"
#include "flight_views.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab::flight_motion {

FlightLoop::FlightLoop(const std::shared_ptr<const World>& truth, Planner& planner,
                       std::uint64_t seed, const PlanningQuery& query, const FlightSetup& setup)
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
  committed_body_ = planning_body_;
  map_model_.reach = planning_body_.radius;      // the window sees what the body reaches
  map_model_.inset = settings_.planning_margin;  // room for tracking error at the map's end
  map_->setup(truth->bounds(), map_model_);
  result_.map = map_;
  result_.body = body_;
  result_.limits = limits_;
}

FlightResult FlightLoop::run() {
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
  // without this no plan from the start could be vouched for (vouchedTrace()). What a look
  // round shows is the planning body's own place and, r metres out, what the sensor sees up and
  // down from there (r times its elevations' tangents): a ball would let the vehicle climb in
  // place under space it has never seen (on geb079 vehicles rose 0.7 m and stood there).
  const double half_diagonal = 0.5 * std::sqrt(3.0) * map_model_.resolution;
  map_->markFree(start, kStartKnown * planning_body_.radius, [&](const Eigen::Vector3d& centre) {
    const Eigen::Vector3d offset = centre - start;
    const double out = offset.head<2>().norm();
    const double seen = offset.z() >= 0.0 ? tangents_.first : tangents_.second;
    return std::abs(offset.z()) <= planning_body_.radius + half_diagonal + out * seen &&
           truth_->isFree(centre, half_diagonal);
  });
  progress_from_ = start;
  way_height_ = query_.goal.z();
  for (int frame = 0; step(frame); ++frame) {
  }
  finish();
  return std::move(result_);
}

bool FlightLoop::step(int frame) {
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
      freeFrom(committed_, t_, truth_->bounds(), *window, committed_body_, limits_.limits);
  if (!committed_free_) {
    reason_ = "collision";
    next_replan_ = t_;
  }
  if (t_ + 1e-9 >= next_replan_) replan(window, now.col(0));
  return true;
}

void FlightLoop::countBackup() {
  if (backup_counted_ || t_ < backup_start_ ||
      stateAt(committed_, t_).col(1).norm() < kMovingSpeed) {
    return;
  }
  backup_counted_ = true;
  ++result_.backups;
  if (!result_.replans.empty()) result_.replans.back().backup = true;
}

bool FlightLoop::ended(const ChainState& now) {
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

std::shared_ptr<const World> FlightLoop::sense(const ChainState& now) {
  auto begin = std::chrono::steady_clock::now();
  // The newest frame the map has was taken the sensor's latency (with its jitter) ago.
  const SensorNoise& errors = sensor_errors_;
  const double age =
      errors.latency +
      (errors.latency_jitter > 0.0 ? errors.latency_jitter * noise_.uniform(-1.0, 1.0) : 0.0);
  const double taken = std::clamp(t_ - age, 0.0, t_);
  const SensorFrame sensed = senseFrame(caster_, sensor_, rays_, stateAt(flownPath(), taken).col(0),
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

void FlightLoop::replan(std::shared_ptr<const World> shared_window,
                        const Eigen::Vector3d& position) {
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
  bool found = localGoal(local.start.col(0), query_.goal, guide, settings_.horizon, *shared_window,
                         planning_body_.radius, mapDomain(), &local.goal);
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
    const PlanResult plan = planOn(shared_window, settings_.planning_margin, local);
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
    recover(replan, shared_window);
  }
  result_.replans.push_back(std::move(replan));
  // (A plan is kept only for a committed trajectory clear for the planning margin, so for the
  // body.)
  if (!settled && !freeFrom(committed_, t_, truth_->bounds(), window, body_, limits_.limits)) {
    // Nothing safe to fly on (for the body: inside the planning margin it goes on): stop
    // now.
    const ChainState here = stateAt(committed_, t_);
    Trajectory stop = slice(committed_, t_);
    const TrajectorySegment braking = brake(here, brake_rate_);
    if (braking.duration > 0.0) stop.append(braking);
    if (stop.empty()) stop.append(hold(here.col(0), dt_));  // at rest at the very start
    committed_ = std::move(stop);
    committed_body_ = body_;
    intended_ = committed_;
    backup_start_ = t_;  // the stop is flown at once
    backup_counted_ = false;
  }
  reason_ = settled ? "period" : "retry";
  next_replan_ = std::max(next_replan_, t_ + (settled ? settings_.replan_period : dt_));
}

PlanResult FlightLoop::planOn(const std::shared_ptr<const World>& window, double margin,
                              const PlanningQuery& local) {
  planner_.setup({window, planner_seed_, margin});
  const std::shared_ptr<void> guard =
      guard_replan_ ? guard_replan_(settings_.replan_budget) : nullptr;
  return planner_.plan(local, Budget{settings_.replan_budget, std::numeric_limits<long long>::max(),
                                     settings_.clock});
}

void FlightLoop::snapshot() {
  result_.snapshots.emplace_back(t_, map_->topView(z_band_low_, z_band_high_));
  for (const std::size_t voxel : map_->occupiedVoxels()) first_occupied_.emplace(voxel, t_);
}

void FlightLoop::finish() {
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

}  // namespace kinolab::flight_motion

namespace kinolab {

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
  return whileDoing("flying over the world '" + truth->name() + "'", [&] {
    return flight_motion::FlightLoop(truth, planner, seed, query, setup).run();
  });
}

}  // namespace kinolab
