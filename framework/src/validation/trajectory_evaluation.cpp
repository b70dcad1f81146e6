// TrajectoryChecker::evaluate(): the figures every run reports of its trajectory, measured at
// the checker's samples and from the polynomials, and their declarations (evaluationMetrics()).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/core/text.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "trajectory_samples.hpp"

namespace kinolab {
namespace {

using checker_detail::kDerivatives;
using checker_detail::sampleTimes;

/// "NAME: REASON" for each name, a line each (what the report reads per metric).
void markUndefined(std::vector<std::string>& lines, std::initializer_list<const char*> names,
                   const std::string& reason) {
  for (const char* name : names) lines.push_back(std::string(name) + ": " + reason);
}

/// True when every segment is finite; else false, with every real figure marked undefined.
bool finiteOrMarked(const Trajectory& trajectory, std::vector<std::string>& undefined) {
  for (const TrajectorySegment& segment : trajectory.segments()) {
    if (!std::isfinite(segment.duration) || !segment.coefficients.allFinite()) {
      for (const MetricSpec& spec : evaluationMetrics().specs().all()) {
        if (spec.type == MetricType::kReal) {
          undefined.push_back(spec.name + ": the trajectory is not finite");
        }
      }
      return false;
    }
  }
  return true;
}

/// The squared integrals of the acceleration and the jerk and the acceleration's jumps into
/// `result`, or why they are not defined into `undefined`.
void evaluateIntegrals(const Trajectory& trajectory, TrajectoryEvaluation& result,
                       std::vector<std::string>& undefined) {
  // A jump of any derivative below k at a joint makes derivative k impulsive there (a jump of
  // the position, a teleport, makes every derivative so): its squared integral is not finite,
  // whatever the polynomials' own figure says.
  const auto firstJump = [&](int below) -> std::pair<int, Trajectory::Jumps> {
    for (int d = 0; d < below; ++d) {
      if (const Trajectory::Jumps jumps = trajectory.jumps(d); jumps.count > 0) return {d, jumps};
    }
    return {-1, {}};
  };
  const auto jumpReason = [](int d, const Trajectory::Jumps& jumps) {
    return std::string("the ") + kDerivatives[d] + " jumps at " + std::to_string(jumps.count) +
           " joint" + (jumps.count > 1 ? "s" : "") + ", so what is above it is impulsive there";
  };
  const auto integral = [&](int derivative, const char* name, const char* per_metre) {
    const auto [d, jumps] = firstJump(derivative);
    if (d < 0) return trajectory.squaredIntegral(derivative);
    markUndefined(undefined, {name, per_metre}, jumpReason(d, jumps));
    return static_cast<double>(NAN);
  };
  result.acceleration_integral = integral(2, "acceleration_integral", "acceleration_per_metre");
  result.jerk_integral = integral(3, "jerk_integral", "jerk_per_metre");
  if (const auto [d, jumps] = firstJump(2); d < 0) {
    result.acceleration_jumps = trajectory.jumps(2).squared_sum;
  } else {
    markUndefined(undefined, {"acceleration_jumps"}, jumpReason(d, jumps));
  }
}

/// The figures of the position samples, gathered in time order: clearance, peaks, ratios to
/// the limits, curvature.
class SampleFigures {
 public:
  explicit SampleFigures(const DynamicLimits& limits) : limits_(limits) {}

  /// A segment begins: its first moving sample's direction is compared across the joint.
  void startSegment() { across_ = true; }

  /// A sample `distance` from the obstacles, moving at `velocity` with `acceleration`, with a
  /// `share` of the segment's time (half of each neighbouring interval).
  void add(double distance, const Eigen::Vector3d& velocity, const Eigen::Vector3d& acceleration,
           double share) {
    least_ = std::min(least_, distance);
    clearance_sum_ += distance;
    ++samples_;
    const double speed = velocity.norm();
    peak_speed_ = std::max(peak_speed_, speed);
    peak_acceleration_ = std::max(peak_acceleration_, acceleration.norm());
    for (int axis = 0; axis < 3; ++axis) {
      speed_ratio_ = std::max(speed_ratio_, std::abs(velocity[axis]) / limits_.bound[1][axis]);
      acceleration_ratio_ =
          std::max(acceleration_ratio_, std::abs(acceleration[axis]) / limits_.bound[2][axis]);
    }
    if (speed < TrajectoryEvaluation::kCurvatureMinSpeed) {
      across_ = true;
      return;
    }
    const Eigen::Vector3d direction = velocity / speed;
    if (across_ && last_direction_.squaredNorm() > 0.0) {
      const double angle = std::acos(std::clamp(direction.dot(last_direction_), -1.0, 1.0));
      if (angle > 1e-3) {  // a milliradian: rounding at a smooth joint stays far below
        turning_ += angle;
        ++corners_;
      }
    }
    last_direction_ = direction;
    across_ = false;
    const double curvature = velocity.cross(acceleration).norm() / (speed * speed * speed);
    max_curvature_ = std::max(max_curvature_, curvature);
    const double arc = share * speed;
    turning_ += curvature * arc;
    moving_length_ += arc;
  }

  /// The figures into `result` (the clearance less the body's radius), and why any is not
  /// defined into `undefined`.
  void write(double body_radius, TrajectoryEvaluation& result,
             std::vector<std::string>& undefined) const {
    result.min_clearance = least_ - body_radius;
    result.mean_clearance = clearance_sum_ / samples_ - body_radius;
    result.peak_speed = peak_speed_;
    result.peak_acceleration = peak_acceleration_;
    result.speed_limit_ratio = speed_ratio_;
    result.acceleration_limit_ratio = acceleration_ratio_;
    if (moving_length_ <= 0.0) {
      markUndefined(undefined, {"max_curvature", "mean_curvature"},
                    "the trajectory never moves faster than " +
                        formatNumber(TrajectoryEvaluation::kCurvatureMinSpeed) +
                        " m/s, so its direction is not defined");
      return;
    }
    result.mean_curvature = turning_ / moving_length_;
    if (corners_ == 0) {
      result.max_curvature = max_curvature_;
    } else {
      markUndefined(undefined, {"max_curvature"},
                    "the path turns " + std::to_string(corners_) + " corner" +
                        (corners_ > 1 ? "s" : "") +
                        " in place (at rest, or where the velocity jumps), where its curvature "
                        "is unbounded; mean_curvature counts their angles");
    }
  }

 private:
  const DynamicLimits& limits_;
  double least_ = INFINITY;
  double clearance_sum_ = 0.0;
  int samples_ = 0;
  double peak_speed_ = 0.0;
  double peak_acceleration_ = 0.0;
  double speed_ratio_ = 0.0;
  double acceleration_ratio_ = 0.0;
  double max_curvature_ = 0.0;
  double turning_ = 0.0;  // curvature over arc length of the moving samples, plus the corners
  double moving_length_ = 0.0;
  // The direction of travel at the last moving sample; a change of it across a stretch too
  // slow to have a direction, or across a joint, is a corner: turned in place.
  Eigen::Vector3d last_direction_ = Eigen::Vector3d::Zero();
  bool across_ = false;  // a slow stretch or a joint lies since the last moving sample
  int corners_ = 0;
};

}  // namespace

TrajectoryEvaluation TrajectoryChecker::evaluate(const Trajectory& trajectory) const {
  TrajectoryEvaluation result;
  if (trajectory.empty()) return result;
  std::vector<std::string> undefined;
  if (!finiteOrMarked(trajectory, undefined)) {
    result.undefined = join(undefined, "\n");
    return result;
  }
  result.duration = trajectory.duration();
  result.length = trajectory.length();
  evaluateIntegrals(trajectory, result, undefined);
  const Esdf& esdf = world_->esdf();
  // The exact distance, up to the map's diagonal or a truncated field's truncation (a sparse
  // world's clearance figures are capped there: exact below it).
  ExactDistanceRun exactDistance(esdf, std::min(esdf.maxDistance(), esdf.truncation()));
  SampleFigures figures(settings_.limits);
  double segment_start = 0.0;
  std::vector<std::pair<double, double>> times;
  for (const auto& segment : trajectory.segments()) {
    sampleTimes(segment, segment_start, speedBound(segment), spacing_, times);
    figures.startSegment();
    for (std::size_t i = 0; i < times.size(); ++i) {
      const double local = times[i].second;
      const double distance = std::max(exactDistance(segment.evaluate(local)), 0.0);
      const double before = i > 0 ? local - times[i - 1].second : 0.0;
      const double after = i + 1 < times.size() ? times[i + 1].second - local : 0.0;
      figures.add(distance, segment.evaluate(local, 1), segment.evaluate(local, 2),
                  0.5 * (before + after));
    }
    segment_start += segment.duration;
  }
  figures.write(settings_.body.radius, result, undefined);
  result.undefined = join(undefined, "\n");
  return result;
}

namespace {

using E = TrajectoryEvaluation;

/// A metric's getter: the field, or none where it is NaN.
auto of(double E::*field) {
  return [field](const E& e) { return numberOrNone(e.*field); };
}

/// Per metre of path: a long detour and a short direct flight compared on one scale
/// (FlightBench's energy measures).
auto perMetre(double E::*field) {
  return [field](const E& e) { return numberOrNone(e.length > 0.0 ? e.*field / e.length : NAN); };
}

/// The figures of the path's size, smoothness and shape.
void addPathMetrics(MetricList<E>& list) {
  list.add(MetricSpecs().real("duration", "s", "trajectory duration").lower().comparable(),
           of(&E::duration))
      .add(MetricSpecs().real("length", "m", "trajectory length").lower().comparable(),
           of(&E::length))
      .add(MetricSpecs()
               .real("acceleration_integral", "m^2/s^3",
                     "integral of |a|^2 over the trajectory (undefined where the velocity "
                     "jumps)")
               .lower()
               .comparable(),
           of(&E::acceleration_integral))
      .add(MetricSpecs()
               .real("acceleration_per_metre", "m/s^3", "acceleration_integral per metre")
               .lower()
               .comparable(),
           perMetre(&E::acceleration_integral))
      .add(MetricSpecs()
               .real("jerk_integral", "m^2/s^5",
                     "integral of |j|^2 over the trajectory; undefined (never 0) where the "
                     "acceleration jumps: see acceleration_jumps")
               .lower()
               .comparable(),
           of(&E::jerk_integral))
      .add(MetricSpecs()
               .real("jerk_per_metre", "m/s^5", "jerk_integral per metre")
               .lower()
               .comparable(),
           perMetre(&E::jerk_integral))
      .add(MetricSpecs()
               .real("acceleration_jumps", "m^2/s^4",
                     "sum of the squared acceleration jumps at the joints (0: continuous "
                     "acceleration)")
               .lower()
               .comparable(),
           of(&E::acceleration_jumps))
      .add(MetricSpecs()
               .real("max_curvature", "1/m",
                     "largest curvature |v x a| / |v|^3 where the speed is at least 0.1 m/s; "
                     "undefined where the path turns a corner in place")
               .lower()
               .comparable(),
           of(&E::max_curvature))
      .add(MetricSpecs()
               .real("mean_curvature", "1/m",
                     "turning per metre: curvature integrated over arc length (where the "
                     "speed is at least 0.1 m/s) plus the corners turned in place, over the "
                     "length")
               .lower()
               .comparable(),
           of(&E::mean_curvature));
}

/// The figures of the motion: clearance, speed and acceleration against the limits, and why
/// any figure is not defined.
void addMotionMetrics(MetricList<E>& list) {
  list.add(MetricSpecs()
               .real("min_clearance", "m",
                     "least exact distance from the trajectory's checked positions to the "
                     "occupied voxel cubes, less the robot radius")
               .higher()
               .comparable(),
           of(&E::min_clearance))
      .add(MetricSpecs()
               .real("mean_clearance", "m",
                     "mean exact distance from the trajectory's checked positions to the "
                     "occupied voxel cubes, less the robot radius")
               .higher()
               .comparable(),
           of(&E::mean_clearance))
      .add(MetricSpecs().real("peak_speed", "m/s", "largest speed |v|").comparable(),
           of(&E::peak_speed))
      .add(
          MetricSpecs().real("peak_acceleration", "m/s^2", "largest acceleration |a|").comparable(),
          of(&E::peak_acceleration))
      .add(MetricSpecs()
               .real("speed_limit_ratio", "",
                     "largest per-axis speed over its limit (above 1: beyond the limit)")
               .comparable(),
           of(&E::speed_limit_ratio))
      .add(MetricSpecs()
               .real("acceleration_limit_ratio", "",
                     "largest per-axis acceleration over its limit (above 1: beyond the "
                     "limit)")
               .comparable(),
           of(&E::acceleration_limit_ratio))
      .add(MetricSpecs().text("undefined",
                              "the figures not defined for this trajectory, NAME: REASON a "
                              "line (never stored as 0)"),
           [](const E& e) -> MetricValue { return e.undefined; });
}

}  // namespace

const MetricList<TrajectoryEvaluation>& evaluationMetrics() {
  static const MetricList<E> list = [] {
    MetricList<E> metrics;
    addPathMetrics(metrics);
    addMotionMetrics(metrics);
    return metrics;
  }();
  return list;
}

}  // namespace kinolab
