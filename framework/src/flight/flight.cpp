#include "kinolab/flight/flight.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <unordered_map>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab {
namespace {

double millisecondsSince(std::chrono::steady_clock::time_point begin) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin)
      .count();
}

/// The trajectory's state at time t (clamped to its span), derivatives 0..2.
ChainState stateAt(const Trajectory& trajectory, double t) {
  ChainState state = ChainState::Zero();
  const double clamped = std::clamp(t, 0.0, trajectory.duration());
  for (int k = 0; k < 3; ++k) state.col(k) = trajectory.evaluate(clamped, k);
  return state;
}

/// At rest at `position` for `duration` seconds.
TrajectorySegment hold(const Eigen::Vector3d& position, double duration) {
  TrajectorySegment segment;
  segment.duration = duration;
  segment.coefficients = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 1);
  segment.coefficients.col(0) = position;
  return segment;
}

/// The part of `trajectory` before time `end` (whole segments, the last one shortened);
/// past its end the vehicle rests where it ended (every committed trajectory ends at rest).
Trajectory slice(const Trajectory& trajectory, double end) {
  Trajectory out;
  double t = 0.0;
  for (const TrajectorySegment& segment : trajectory.segments()) {
    if (t >= end) break;
    TrajectorySegment piece = segment;
    piece.duration = std::min(segment.duration, end - t);
    if (piece.duration > 0.0) out.append(piece);
    t += segment.duration;
  }
  if (end > t + 1e-12 && !trajectory.empty()) out.append(hold(trajectory.endPosition(), end - t));
  return out;
}

/// A stop from `state` at constant deceleration along the velocity, each axis within
/// `acceleration`; empty when already at rest.
TrajectorySegment brake(const ChainState& state, double acceleration) {
  const Eigen::Vector3d v = state.col(1);
  const double largest = v.cwiseAbs().maxCoeff();
  TrajectorySegment segment;
  segment.coefficients = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 3);
  segment.coefficients.col(0) = state.col(0);
  if (largest < 1e-9) return segment;
  // The axis with the largest speed brakes at the full rate; the others in proportion.
  segment.duration = largest / acceleration;
  segment.coefficients.col(1) = v;
  segment.coefficients.col(2) = -0.5 * v / segment.duration;
  return segment;
}

/// The committed trajectory up to `t`, then `plan` (which starts at the state at `t`), then
/// a stop.
Trajectory splice(const Trajectory& committed, double t, const Trajectory& plan,
                  double acceleration) {
  Trajectory out = slice(committed, t);
  for (const TrajectorySegment& segment : plan.segments()) out.append(segment);
  const TrajectorySegment stop = brake(stateAt(out, out.duration()), acceleration);
  if (stop.duration > 0.0) out.append(stop);
  return out;
}

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
              const Body& body, const DynamicLimits& limits) {
  const double radius = body.keptRadius();
  const auto free = [&](const Eigen::Vector3d& p) {
    return map.contains(p) &&
           !(window.bounds().contains(p) && window.clearanceFor(p, radius) < radius);
  };
  // A sample every 2 cm of path at the speed limit.
  return everySample(t, trajectory.duration(), 0.02, limits.bound[1].norm(),
                     [&](double s) { return free(trajectory.evaluate(s)); }) &&
         free(trajectory.endPosition());
}

/// A straight move at rest at both ends from `from` by `offset`: two primitives (order 2),
/// accelerating then decelerating along it, at most `acceleration` and `speed`.
std::vector<TrajectorySegment> straightMove(const Eigen::Vector3d& from,
                                            const Eigen::Vector3d& offset, double acceleration,
                                            double speed) {
  const double length = offset.norm();
  // Half the way each: a t^2 / 2 = length / 2, with the peak speed a t within `speed`.
  const double a = std::min(acceleration, speed * speed / length);
  const double half = std::sqrt(length / a);
  const Eigen::Vector3d push = a * offset / length;
  ChainState state = ChainState::Zero();
  state.col(0) = from;
  const TrajectorySegment speeding_up = TrajectorySegment::primitive(state, push, 2, half);
  state.col(0) = speeding_up.evaluate(half);
  state.col(1) = speeding_up.evaluate(half, 1);
  return {speeding_up, TrajectorySegment::primitive(state, -push, 2, half)};
}

/// The point `s` metres along the polyline `way` (its end when it is shorter).
Eigen::Vector3d pointAlong(const std::vector<Eigen::Vector3d>& way, double s) {
  double along = 0.0;
  for (std::size_t i = 1; i < way.size(); ++i) {
    const double step = (way[i] - way[i - 1]).norm();
    if (along + step > s) return way[i - 1] + (way[i] - way[i - 1]) * ((s - along) / step);
    along += step;
  }
  return way.back();
}

/// The local goal: the goal when it is within `horizon` and the window, else the point
/// `horizon` metres along the guide (the known map's shortest way; the straight line when it
/// is empty), stopping where the guide would leave the window in x and y (0.5 m inside its
/// sides; the guide's heights are only interpolated, so they are brought into the window's,
/// 0.5 m inside its floor and ceiling); then moved off the window's known obstacles (the goal
/// itself is taken where it is, brought into the window's domain when it lies less than
/// 0.5 m outside). False when no free point is found.
bool localGoal(const Eigen::Vector3d& from, const Eigen::Vector3d& goal,
               const std::vector<Eigen::Vector3d>& guide, double horizon, const World& window,
               double radius, Eigen::Vector3d* out) {
  const Box box = window.bounds();
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(0.5);
  const Eigen::Vector3d inner_min = (box.min + margin).cwiseMin(box.max);
  const Eigen::Vector3d inner_max = (box.max - margin).cwiseMax(box.min);
  const auto inside = [&](const Eigen::Vector3d& p) {
    return (p.array() >= inner_min.array()).all() && (p.array() <= inner_max.array()).all();
  };
  std::vector<Eigen::Vector3d> way = guide;
  if (way.size() < 2) way = {from, goal};
  for (Eigen::Vector3d& point : way) {
    point.z() = std::clamp(point.z(), inner_min.z(), inner_max.z());
  }
  // Along the way to the horizon, stopping before the first point outside the window.
  Eigen::Vector3d target = way.front();
  double travelled = 0.0;
  for (std::size_t i = 1; i < way.size() && travelled < horizon; ++i) {
    travelled += (way[i] - way[i - 1]).norm();
    const Eigen::Vector3d next = travelled > horizon ? pointAlong(way, horizon) : way[i];
    if (!inside(next) && !(next - goal).isZero()) break;
    target = next;
  }
  if ((target - from).norm() < 0.5) {
    // The way leaves the window at once (the vehicle at its side): the horizon point along
    // it, clamped into the window.
    target = pointAlong(way, horizon).cwiseMax(inner_min).cwiseMin(inner_max);
  }
  // The goal within the horizon is taken as it is (no margin: nothing lies beyond it), brought
  // into the window's domain when it lies less than 0.5 m outside (at the map's end).
  const Eigen::Vector3d goal_inside = goal.cwiseMax(box.min).cwiseMin(box.max);
  const bool at_goal = (goal - from).norm() <= horizon && (goal_inside - goal).norm() < 0.5;
  if (at_goal) target = goal_inside;
  // Back along the way, then around, in 0.25 m steps, until a free point.
  const Eigen::Vector3d back = (from - target).normalized();
  for (int k = 0; k <= 12; ++k) {
    for (int around = 0; around < (k == 0 ? 1 : 8); ++around) {
      const double angle = 2.0 * M_PI * around / 8.0;
      const Eigen::Vector3d side(std::cos(angle), std::sin(angle), 0.0);
      const Eigen::Vector3d candidate = k == 0 && at_goal
                                            ? target
                                            : (target + 0.25 * k * (around == 0 ? back : side))
                                                  .cwiseMax(inner_min)
                                                  .cwiseMin(inner_max);
      if (window.isFree(candidate, radius)) {
        *out = candidate;
        return true;
      }
    }
  }
  return false;
}

constexpr double kDegree = M_PI / 180.0;

/// The flown trajectory's checker: the planner's body; its limits only when tracking is
/// perfect (a tracking vehicle's excursions are its controller's, not the planner's).
CheckerSettings flownCheckerSettings(const Body& body, const PlannerLimits& limits,
                                    const TrackingModel& tracking) {
  CheckerSettings settings = checkerSettings(body, limits);
  if (tracking.kind != TrackingKind::kPerfect) {
    settings.limits = DynamicLimits::uniform(INFINITY, INFINITY);
    settings.max_derivative = 1;
  }
  return settings;
}

}  // namespace

const ParameterSpecs& flightParameters() {
  static const ParameterSpecs specs =
      ParameterSpecs()
          .plugin("sensor", "sensor", "depth_camera",
                  "the range sensor (kinolab list sensors); set its parameters as sensor.NAME")
          .plugin("vehicle_map", "map", "probabilistic",
                  "the vehicle's map, its sensor model (kinolab list vehicle_maps); set its "
                  "parameters as map.NAME")
          .include(declareFields<MapModel>())
          .include(declareFields<FlightSettings>())
          .include(declareFields<TrackingModel>());
  return specs;
}

namespace {

/// A sensor whose every call is guarded (guardPluginCall): an exception from its code is a
/// PluginCodeError naming it, whatever it threw.
class GuardedSensor final : public Sensor {
 public:
  GuardedSensor(std::unique_ptr<Sensor> sensor, std::string name)
      : sensor_(std::move(sensor)), name_(std::move(name)) {}
  double maxRange() const override {
    return guardPluginCall(name_, "maxRange()", [&] { return sensor_->maxRange(); });
  }
  double frameRate() const override {
    return guardPluginCall(name_, "frameRate()", [&] { return sensor_->frameRate(); });
  }
  std::vector<Eigen::Vector3d> rayDirections() const override {
    return guardPluginCall(name_, "rayDirections()", [&] { return sensor_->rayDirections(); });
  }
  std::size_t rayCount() const override {
    return guardPluginCall(name_, "rayCount()", [&] { return sensor_->rayCount(); });
  }
  SensorNoise noise() const override {
    return guardPluginCall(name_, "noise()", [&] { return sensor_->noise(); });
  }
  std::optional<PixelGrid> pixelGrid() const override {
    return guardPluginCall(name_, "pixelGrid()", [&] { return sensor_->pixelGrid(); });
  }

 private:
  std::unique_ptr<Sensor> sensor_;
  std::string name_;
};

/// How errors from the code of the `kind` plugin a flight parameter `name` chose name it.
template <typename Interface>
std::string chosenPluginName(const ParameterSet& p, const std::string& name) {
  const PluginRegistry<Interface>& registry = pluginRegistry<Interface>();
  return describePlugin(registry.kind(), registry.info(p.text(name)));
}

}  // namespace

FlightSetup flightSetup(const ParameterSet& p) {
  FlightSetup setup;
  setup.sensor = std::make_shared<GuardedSensor>(pluginRegistry<Sensor>().createChosen(p, "sensor"),
                                                 chosenPluginName<Sensor>(p, "sensor"));
  const double range = setup.sensor->maxRange();
  const double rate = setup.sensor->frameRate();
  if (!(std::isfinite(range) && range > 0.0 && std::isfinite(rate) && rate > 0.0)) {
    throw PluginError("sensor '" + p.text("sensor") + "' reports a range of " +
                      formatNumber(range) + " m and a rate of " + formatNumber(rate) +
                      " Hz; both must be finite and positive");
  }
  setup.map = readFields<MapModel>(p);
  const std::size_t rays = setup.sensor->rayCount();
  const double steps = static_cast<double>(rays) * range / setup.map.resolution;
  if (rays > kMaxRaysPerFrame || steps > kMaxVoxelStepsPerFrame) {
    throw ConfigError(
        "flight: sensor '" + p.text("sensor") + "' casts " + std::to_string(rays) +
        " rays a frame of up to " + formatNumber(range) + " m, up to " + formatNumber(steps) +
        " voxel steps at map_resolution " + formatNumber(setup.map.resolution) + " m: about " +
        formatNumber(std::round(steps * 2.3e-6)) + " ms a frame to simulate; at most " +
        std::to_string(kMaxRaysPerFrame) + " rays and " + formatNumber(kMaxVoxelStepsPerFrame) +
        " steps (raise pixel_skip, lower the resolution, beams, channels or range, or coarsen "
        "map_resolution)");
  }
  // A new map for each flight, made as the parameters say (checked now, once).
  setup.make_map = [p, name = chosenPluginName<VehicleMap>(p, "map")] {
    std::unique_ptr<VehicleMap> map = pluginRegistry<VehicleMap>().createChosen(p, "map");
    map->nameAs(name);
    return map;
  };
  setup.make_map();
  setup.settings = readFields<FlightSettings>(p);
  setup.tracking = readFields<TrackingModel>(p);
  return setup;
}

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
    if (setup.tracking.kind == TrackingKind::kQuadrotor) {
      tracker_.emplace(setup.tracking, query.start.col(0), settings_.seed);
    }
    map_model_.reach = planning_body_.radius;  // the window sees what the body reaches
    map_model_.inset = settings_.planning_margin;     // room for tracking error at the map's end
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
    best_distance_ = (start - query_.goal).norm();
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
      if (checker_.collides(path.evaluate(std::min(s, path.duration())))) {
        t_ = s;
        collided_ = true;
        return false;
      }
    }
    const ChainState now = stateAt(path, t_);
    if (ended(now)) return false;
    ++result_.frames;
    if (settings_.snapshot_period > 0.0 &&
        (result_.snapshots.empty() ||
         t_ >= result_.snapshots.back().first + settings_.snapshot_period - 1e-9)) {
      snapshot();
    }
    const std::shared_ptr<const World> window = sense(now);
    committed_free_ = freeFrom(committed_, t_, truth_->bounds(), *window, planning_body_, limits_.limits);
    if (!committed_free_) {
      reason_ = "collision";
      next_replan_ = t_;
    }
    if (t_ + 1e-9 >= next_replan_) replan(*window, window);
    return true;
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
    if (distance < best_distance_ - 0.5) {
      best_distance_ = distance;
      best_time_ = t_;
    }
    if (t_ - best_time_ > settings_.stuck_time) {
      result_.status = "stuck";
      result_.message = "no progress towards the goal for " + formatNumber(settings_.stuck_time) +
                        " s" + takenSince(best_time_) + failuresSince(best_time_);
      return true;
    }
    return false;
  }

  /// The plans taken since `since` (a flight without progress whose plans are taken dithers
  /// between local goals): how many, the extent of their local goals and how near the goal
  /// the nearest came ("" when none was taken).
  std::string takenSince(double since) const {
    int taken = 0;
    Eigen::Vector3d low = Eigen::Vector3d::Constant(INFINITY);
    Eigen::Vector3d high = -low;
    double nearest = INFINITY;
    for (const FlightReplan& replan : result_.replans) {
      if (replan.time < since || !replan.accepted) continue;
      ++taken;
      low = low.cwiseMin(replan.local_goal);
      high = high.cwiseMax(replan.local_goal);
      nearest = std::min(nearest, (replan.local_goal - query_.goal).norm());
    }
    if (taken == 0) return "";
    return "; " + std::to_string(taken) + " plans taken meanwhile, their local goals within " +
           formatNumber((high - low).norm()) + " m of one another, the nearest " +
           formatNumber(nearest) + " m from the goal";
  }

  /// The failed replans since `since`, by status with the first reason of each, and the
  /// recoveries tried ("" when none failed).
  std::string failuresSince(double since) const {
    std::map<std::string, std::pair<int, std::string>> failures;  // status -> (count, why)
    std::map<std::string, int> recoveries;
    int total = 0;
    for (const FlightReplan& replan : result_.replans) {
      if (replan.time < since || replan.accepted || replan.kept) continue;
      ++total;
      auto& [count, why] = failures[replan.status];
      if (count++ == 0) why = replan.why;
      if (!replan.recovery.empty()) ++recoveries[replan.recovery];
    }
    if (total == 0) return "";
    std::string text = "; " + std::to_string(total) + " replans failed meanwhile:";
    for (const auto& [status, failure] : failures) {
      text += " " + std::to_string(failure.first) + " " + status + " (" + failure.second + ")";
    }
    for (const auto& [recovery, count] : recoveries) {
      text += "; " + recovery + " tried " + std::to_string(count) + " times";
    }
    return text;
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
    // Where the vehicle is, nothing is: its body is known free, with two voxels to spare for
    // the ESDF's conservative clearance (so that a cautious map still lets it start).
    map_->markFree(now.col(0), body_.radius + 2.0 * map_model_.resolution);
    result_.time_map_ms += millisecondsSince(begin);
    begin = std::chrono::steady_clock::now();
    std::shared_ptr<const World> window = map_->window(now.col(0));
    result_.time_window_ms += millisecondsSince(begin);
    return window;
  }

  /// A replan from the committed state `latency` ahead towards a local goal on the guide;
  /// an accepted plan is spliced in, and without one the vehicle brakes if its committed
  /// trajectory is no longer free.
  void replan(const World& window, const std::shared_ptr<const World>& shared_window) {
    FlightReplan replan;
    replan.time = t_;
    replan.reason = reason_;
    const double t_start = t_ + settings_.replanLatency();
    PlanningQuery local;
    local.start = stateAt(committed_, t_start);
    replan.start = local.start.col(0);
    const auto begin = std::chrono::steady_clock::now();
    const double z_low = std::min(local.start(2, 0), query_.goal.z()) - 0.5;
    const double z_high = std::max(local.start(2, 0), query_.goal.z()) + 0.5;
    // The guide starts at the vehicle but at a height within the query's, so that local goals
    // do not follow a vehicle that sank or rose away from the heights it was asked to fly.
    Eigen::Vector3d from = local.start.col(0);
    from.z() = std::clamp(from.z(), std::min(query_.start(2, 0), query_.goal.z()),
                          std::max(query_.start(2, 0), query_.goal.z()));
    const std::vector<Eigen::Vector3d> guide =
        map_->guide(from, query_.goal, planning_body_.radius, z_low, z_high);
    result_.time_guide_ms += millisecondsSince(begin);
    bool accepted = false;
    if (localGoal(local.start.col(0), query_.goal, guide, settings_.horizon, window,
                  planning_body_.radius, &local.goal)) {
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
    }
    reason_ = settled ? "period" : "retry";
    next_replan_ = std::max(next_replan_, t_ + (settled ? settings_.replan_period : dt_));
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
    if (settings_.keep_faster && arrivesFirst(plan.trajectory, t_start, goal)) {
      replan.kept = true;
      replan.trajectory = plan.trajectory;
      replan.why = "the committed trajectory comes as near the local goal no later";
      return false;
    }
    const double seen = seenUntil(plan.trajectory);
    for (double cut = std::min(plan.trajectory.duration(), seen); cut > 0.0; cut -= 0.1) {
      Trajectory spliced = splice(committed_, t_start, slice(plan.trajectory, cut), brake_rate_);
      if (freeFrom(spliced, t_start, truth_->bounds(), window, planning_body_, limits_.limits) &&
          seenUntil(spliced, t_start + cut) >= spliced.duration()) {
        replan.trajectory = plan.trajectory;
        intended_ = splice(committed_, t_start, plan.trajectory, brake_rate_);
        committed_ = std::move(spliced);
        return true;
      }
    }
    replan.why = settings_.commit == CommitSpace::kPlanned
                     ? "every braking tail after the plan leaves the map or meets a known obstacle"
                 : seen < 0.1 ? "the plan enters unseen space at once (commit: seen)"
                              : "every braking tail after the plan leaves the map, meets a known "
                                "obstacle or enters unseen space (commit: seen)";
    return false;
  }

  /// Whether the committed trajectory, from `t_start` on and still clear of what is known (this
  /// frame's verdict), comes as near `goal` as `plan` ends no later than the plan does: then the
  /// plan would trade a way for a slower one. A lattice search from a state between its primitives'
  /// ends need not find the rest of the plan it is on, so plans from one replan to the next
  /// disagreed, and a vehicle in the dense forest cycled through the same four plans (2.4,
  /// 3.0, 4.2 and 10.8 s long, two of them turning back) until it was stuck.
  bool arrivesFirst(const Trajectory& plan, double t_start, const Eigen::Vector3d& goal) const {
    if (!committed_free_ || plan.empty() || committed_.duration() <= t_start) return false;
    const double reach = (plan.endPosition() - goal).norm() + 1e-9;
    const double by = std::min(committed_.duration(), t_start + plan.duration());
    const auto far = [&](double s) { return (committed_.evaluate(s) - goal).norm() > reach; };
    return !everySample(t_start, by, 0.5 * map_model_.resolution, limits_.limits.bound[1].norm(),
                        far) ||
           !far(by);
  }

  /// How long `trajectory`, from `from` on, keeps the vehicle's centre in space the sensor
  /// has seen: its duration when it does throughout (and always with commit: planned), else
  /// the last sample before it leaves it. Samples every half voxel of path at the speed limit,
  /// each checking the ball of half that spacing, so that the path between samples is
  /// covered. The centre, not the body: a body-sized ball fits neither the camera's frustum
  /// near the camera nor the gaps the map's shared ray walks leave (tried: the vehicles stall).
  double seenUntil(const Trajectory& trajectory, double from = 0.0) const {
    if (settings_.commit == CommitSpace::kPlanned) return trajectory.duration();
    const double spacing = 0.5 * map_model_.resolution;
    const double radius = 0.5 * spacing;
    double last = from;
    const bool seen = everySample(from, trajectory.duration(), spacing,
                                  limits_.limits.bound[1].norm(), [&](double s) {
                                    if (!map_->seenAround(trajectory.evaluate(s), radius)) {
                                      return false;
                                    }
                                    last = s;
                                    return true;
                                  });
    if (!seen) return last;
    return map_->seenAround(trajectory.endPosition(), radius) ? trajectory.duration() : last;
  }

  /// Where the camera looks for a frame taken at t: towards where the intended trajectory (the
  /// last plan taken, whole, not cut where the vehicle would have to stop) will be a second
  /// later, so that a turn is seen before it is flown. When that second barely moves the
  /// vehicle (a plan that starts slowly, or at rest), towards the first point of the intended
  /// trajectory at least kNearestLook away horizontally (nearer, the frustum is too narrow to
  /// hold it) that the sensor has not seen (with commit: seen: what keeps the plan from being
  /// committed), else the first such point seen or not, else the goal. Looking at the goal
  /// there left a plan that started slowly and turned back outside the frustum: the vehicle
  /// crept on the few centimetres it could commit, replan after replan, 2 m from its goal.
  double heading(double t) const {
    constexpr double kNearestLook = 0.5;  // m
    const auto towards = [](const Eigen::Vector2d& v) { return std::atan2(v.y(), v.x()); };
    const Eigen::Vector3d here = intended_.evaluate(std::min(t, intended_.duration()));
    const Eigen::Vector2d ahead =
        (intended_.evaluate(std::min(t + 1.0, intended_.duration())) - here).head<2>();
    if (ahead.norm() > 0.3) return towards(ahead);
    const double spacing = 0.5 * map_model_.resolution;
    const bool seen_only = settings_.commit == CommitSpace::kSeen;
    std::optional<Eigen::Vector2d> first;
    std::optional<Eigen::Vector2d> unseen;
    everySample(t, intended_.duration(), spacing, limits_.limits.bound[1].norm(), [&](double s) {
      const Eigen::Vector3d p = intended_.evaluate(s);
      const Eigen::Vector2d away = (p - here).head<2>();
      if (away.norm() < kNearestLook) return true;
      if (!first) first = away;
      if (!seen_only) return false;  // the first point that far is all it looks for
      if (map_->seenAround(p, 0.5 * spacing)) return true;
      unseen = away;
      return false;
    });
    if (unseen) return towards(*unseen);
    if (first) return towards(*first);
    const Eigen::Vector2d goal = (query_.goal - here).head<2>();
    return goal.norm() > 1e-9 ? towards(goal) : 0.0;
  }

  /// After a failed replan with the vehicle at rest (or about to be): back off from the
  /// nearest known obstacle when the planner refused the start (a planner's margin, such as
  /// the TGK analogue's, can exceed the body's); move straight onto the local goal when the
  /// planner had nothing to fly (the vehicle within its goal region of the local goal, which
  /// near an obstructed goal stands in for it, but not within the flight's goal tolerance);
  /// else, from the second failure in a row, turn the camera 90 degrees to look for a way.
  void recover(FlightReplan& replan, const World& window) {
    ++failed_in_a_row_;
    const ChainState here = stateAt(committed_, t_);
    const bool at_rest =
        here.col(1).norm() < 0.05 && (committed_.endPosition() - here.col(0)).norm() < 0.05;
    if (!at_rest) return;
    if (replan.status == "invalid_start" && backOff(here.col(0), window)) {
      replan.recovery = "back_off";
      return;
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

  /// A straight 0.3 m move from `position` away from the nearest known obstacle (the window
  /// ESDF's gradient, horizontal), for the body alone: a vehicle inside its planning margin
  /// must be able to back out of it.
  bool backOff(const Eigen::Vector3d& position, const World& window) {
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    window.esdf().distanceWithGradient(position, &gradient);
    gradient.z() = 0.0;
    if (gradient.norm() < 1e-6) return false;
    return moveStraight(position, 0.3 * gradient.normalized(), window, body_);
  }

  /// A straight rest-to-rest move from `position` by `offset` (half the braking rate, half
  /// the speed limit), committed when it stays free for `body` in the window (and, with
  /// commit: seen, keeps the centre in seen space); the next replan waits for its end.
  bool moveStraight(const Eigen::Vector3d& position, const Eigen::Vector3d& offset,
                    const World& window, const Body& body) {
    const auto move =
        straightMove(position, offset, 0.5 * brake_rate_, 0.5 * limits_.limits.bound[1].minCoeff());
    Trajectory moved = slice(committed_, t_);
    for (const TrajectorySegment& segment : move) moved.append(segment);
    if (!freeFrom(moved, t_, truth_->bounds(), window, body, limits_.limits) ||
        seenUntil(moved, t_) < moved.duration()) {
      return false;
    }
    committed_ = std::move(moved);
    intended_ = committed_;
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
    // The tracking error: flown against committed, every centisecond.
    double squares = 0.0;
    int samples = 0;
    for (double s = 0.0; s <= result_.flown.duration(); s += 0.01, ++samples) {
      const double error = (result_.flown.evaluate(s) - committed_.evaluate(s)).norm();
      result_.tracking_error_max = std::max(result_.tracking_error_max, error);
      squares += error * error;
    }
    result_.tracking_error_rms = samples > 0 ? std::sqrt(squares / samples) : 0.0;
    if (settings_.snapshot_period > 0.0) {
      snapshot();
      for (const std::size_t voxel : map_->occupiedVoxels()) {
        result_.known_voxels.emplace_back(first_occupied_.at(voxel), map_->voxelCenter(voxel));
      }
      std::stable_sort(result_.known_voxels.begin(), result_.known_voxels.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
    }
    if (collided_) result_.status = "collision";
    CheckQuery check_query;
    check_query.start = query_.start;
    check_query.goal = query_.goal;
    check_query.require_goal = false;
    const CheckResult check = checker_.check(result_.flown, check_query);
    if (!check.valid && check.check == "collision") {
      result_.status = "collision";
      result_.message =
          "the flown trajectory hits the ground truth at t = " + std::to_string(check.time) +
          " s: " + check.detail;
      result_.flown = slice(result_.flown, check.time);
    } else if (!check.valid) {
      result_.message = "the checker: " + check.check + ": " + check.detail;
    }
    result_.evaluation = checker_.evaluate(result_.flown);
    result_.min_clearance = result_.evaluation.min_clearance;
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
  double best_distance_ = INFINITY;
  double best_time_ = 0.0;
  std::string reason_ = "start";
  bool collided_ = false;
  // This frame's verdict: the committed trajectory is clear of the window's known obstacles
  // for the planning margin (freeFrom; a replan on collision when not).
  bool committed_free_ = true;
  int failed_in_a_row_ = 0;   // failed replans since the last taken one
  double look_offset_ = 0.0;  // rad: the camera's turn from its heading, to look for a way
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
  return FlightLoop(truth, planner, seed, query, setup).run();
}

const MetricSpecs& flightStatistics() {
  static const MetricSpecs specs =
      MetricSpecs()
          .real("time_to_goal", "s", "simulated flight time to the goal (reached only)")
          .lower()
          .comparable()
          .real("mean_speed", "m/s", "flown length over flight time")
          .counter("replans", "replans made (planned, on collision, retries)")
          .counter("failed_replans",
                   "replans whose plan was not taken (kept replans are not failures)")
          .counter("kept_replans",
                   "replans whose plan was set aside for the committed trajectory, which comes "
                   "as near the local goal no later")
          .clock("replan_time_median_ms", "median planning time of the replans")
          .clock("replan_time_p95_ms", "95th percentile planning time of the replans")
          .clock("replan_time_max_ms", "largest planning time of a replan")
          .counter("inside_margin",
                   "1 when the body came nearer the ground truth than the planning margin "
                   "(tracking took it inside the clearance it was planned with), else 0: its "
                   "mean is the share of such flights")
          .real("plan_distance_median", "m", "median D of the replans' plans to their goals")
          .real("plan_distance_max", "m", "largest D of a replan's plan")
          .real("tracking_error_max", "m",
                "largest distance between the flown and the committed position (0: perfect "
                "tracking)")
          .real("tracking_error_rms", "m", "its root mean square over the flight")
          .counter("late_replans", "replans whose plan came past the latency (real time)")
          .real("guide_length", "m",
                "the query's difficulty, on the ground truth: the shortened guide's length")
          .real("traversability_obstruction", "",
                "FlightBench's TO along the guide: narrow passages make it large")
          .real("view_occlusion", "", "FlightBench's VO: obstacles close ahead along the guide")
          .real("angle_over_length", "1/m",
                "FlightBench's AOL: the guide's turns, sum exp(2 theta / pi) - 1, over its length")
          .real("obstacles_per_hectare", "1/ha",
                "obstacles cut by the horizontal slice at the start's height per hectare (trees "
                "in a forest)")
          .counter("frames", "sensor frames")
          .clock("frame_time_ms", "mean per frame: sensing, map insertion, window and ESDF")
          .clock("guide_time_ms", "mean per replan: the global guide on the known map");
  return specs;
}

namespace {

/// The `q` quantile (linear between order statistics) of `values`; none when empty.
MetricValue quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::monostate{};
  std::sort(values.begin(), values.end());
  const double position = q * static_cast<double>(values.size() - 1);
  const auto low = static_cast<std::size_t>(std::floor(position));
  const std::size_t high = std::min(values.size() - 1, low + 1);
  return values[low] + (position - static_cast<double>(low)) * (values[high] - values[low]);
}

/// The planning times of the replans that planned.
std::vector<double> replanTimes(const FlightResult& result) {
  std::vector<double> times;
  for (const FlightReplan& replan : result.replans) {
    if (replan.status != "no_local_goal") times.push_back(replan.planning_time_ms);
  }
  return times;
}

}  // namespace

const MetricList<FlightResult>& flightRunMetrics() {
  using F = FlightResult;
  static const MetricList<F> list =
      MetricList<F>()
          .add(MetricSpecs().text("status",
                                  "reached, collision (with the ground truth), stuck, timeout, "
                                  "invalid_start, invalid_goal"),
               [](const F& f) -> MetricValue { return f.status; })
          .add(MetricSpecs().text("message", "why, for statuses other than reached"),
               [](const F& f) -> MetricValue { return f.message; })
          .add(MetricSpecs()
                   .boolean("success", "reached the goal without a collision")
                   .higher()
                   .comparable(),
               [](const F& f) -> MetricValue { return f.status == "reached" ? 1.0 : 0.0; })
          .add(MetricSpecs()
                   .clock("planning_time_ms", "the replans' median planning time")
                   .lower()
                   .comparable(),
               [](const F& f) { return quantile(replanTimes(f), 0.5); })
          .add(MetricSpecs()
                   .real("distance_to_goal", "m", "from where the flight ended to the goal")
                   .lower()
                   .comparable(),
               [](const F& f) { return numberOrNone(f.distance_to_goal); })
          .include(evaluationMetrics(),
                   [](const F& f) { return f.flown.empty() ? nullptr : &f.evaluation; })
          .add(MetricSpecs()
                   .boolean("checker_valid", "the flown trajectory kept off the ground truth")
                   .higher()
                   .comparable(),
               [](const F& f) -> MetricValue { return f.status == "collision" ? 0.0 : 1.0; })
          .add(MetricSpecs().text("checker_check", "collision, when the flight hit"),
               [](const F& f) -> MetricValue {
                 return f.status == "collision" ? std::string("collision") : std::string();
               })
          .add(MetricSpecs().text("checker_detail", "where it hit"), [](const F& f) -> MetricValue {
            return f.status == "collision" ? f.message : std::string();
          });
  return list;
}

const MetricSpecs& flightMetrics() {
  static const MetricSpecs specs =
      MetricSpecs(flightRunMetrics().specs()).include(flightStatistics());
  return specs;
}

std::string knownVoxelsCsv(const FlightResult& result) {
  std::string csv = "t,x,y,z\n";
  for (const auto& [time, center] : result.known_voxels) {
    csv += formatNumber(time) + "," + formatNumber(center.x()) + "," + formatNumber(center.y()) +
           "," + formatNumber(center.z()) + "\n";
  }
  return csv;
}

namespace {

/// A CSV field: quoted (inner quotes doubled) when it holds a comma, a quote or a line break.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

}  // namespace

std::string replansCsv(const FlightResult& result) {
  const auto point = [](const Eigen::Vector3d& p) {
    return formatNumber(p.x()) + "," + formatNumber(p.y()) + "," + formatNumber(p.z());
  };
  std::string csv =
      "replan,time,reason,start_x,start_y,start_z,goal_x,goal_y,goal_z,status,planning_time_ms,"
      "distance_to_goal,accepted,kept,recovery,why\n";
  for (std::size_t i = 0; i < result.replans.size(); ++i) {
    const FlightReplan& r = result.replans[i];
    csv += std::to_string(i) + "," + formatNumber(r.time) + "," + r.reason + "," + point(r.start) +
           "," + point(r.local_goal) + "," + r.status + "," + formatNumber(r.planning_time_ms) +
           "," + formatNumber(r.distance_to_goal) + "," + (r.accepted ? "1" : "0") + "," +
           (r.kept ? "1" : "0") + "," + r.recovery + "," + csvField(r.why) + "\n";
  }
  return csv;
}

MetricValues flightStatisticValues(const FlightResult& result) {
  std::vector<double> distances;
  int failed = 0;
  for (const FlightReplan& replan : result.replans) {
    if (std::isfinite(replan.distance_to_goal)) distances.push_back(replan.distance_to_goal);
    failed += replan.accepted || replan.kept ? 0 : 1;
  }
  const std::vector<double> times = replanTimes(result);
  const double duration = result.flown.duration();
  const double length = result.flown.length();
  const double per_frame =
      result.frames > 0
          ? (result.time_sense_ms + result.time_map_ms + result.time_window_ms) / result.frames
          : NAN;
  return {
      {"time_to_goal", numberOrNone(result.time_to_goal)},
      {"mean_speed", numberOrNone(duration > 0.0 ? length / duration : NAN)},
      {"replans", static_cast<double>(result.replans.size())},
      {"failed_replans", static_cast<double>(failed)},
      {"kept_replans",
       static_cast<double>(std::count_if(result.replans.begin(), result.replans.end(),
                                         [](const FlightReplan& r) { return r.kept; }))},
      {"replan_time_median_ms", quantile(times, 0.5)},
      {"replan_time_p95_ms", quantile(times, 0.95)},
      {"replan_time_max_ms", quantile(times, 1.0)},
      {"inside_margin", result.inside_margin ? 1.0 : 0.0},
      {"plan_distance_median", quantile(distances, 0.5)},
      {"plan_distance_max", quantile(distances, 1.0)},
      {"tracking_error_max", numberOrNone(result.tracking_error_max)},
      {"tracking_error_rms", numberOrNone(result.tracking_error_rms)},
      {"guide_length", numberOrNone(result.difficulty.guide_length)},
      {"traversability_obstruction", numberOrNone(result.difficulty.traversability_obstruction)},
      {"view_occlusion", numberOrNone(result.difficulty.view_occlusion)},
      {"angle_over_length", numberOrNone(result.difficulty.angle_over_length)},
      {"obstacles_per_hectare", numberOrNone(result.difficulty.obstacles_per_hectare)},
      {"late_replans", static_cast<double>(std::count_if(
                           result.replans.begin(), result.replans.end(),
                           [](const FlightReplan& replan) { return replan.status == "late"; }))},
      {"frames", static_cast<double>(result.frames)},
      {"frame_time_ms", numberOrNone(per_frame)},
      {"guide_time_ms",
       numberOrNone(result.replans.empty() ? NAN : result.time_guide_ms / result.replans.size())}};
}

MetricValues flightValues(const FlightResult& result) {
  MetricValues values = flightRunMetrics().values(result);
  const MetricValues statistics = flightStatisticValues(result);
  values.insert(values.end(), statistics.begin(), statistics.end());
  return values;
}

}  // namespace kinolab
