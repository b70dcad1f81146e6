#include "flight_motion.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "kinolab/core/text.hpp"
#include "kinolab/trajectory/segment_bounds.hpp"

namespace kinolab::flight_motion {

double millisecondsSince(std::chrono::steady_clock::time_point begin) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin)
      .count();
}

ChainState stateAt(const Trajectory& trajectory, double t) {
  ChainState state = ChainState::Zero();
  const double clamped = std::clamp(t, 0.0, trajectory.duration());
  for (int k = 0; k < 3; ++k) state.col(k) = trajectory.evaluate(clamped, k);
  return state;
}

TrajectorySegment hold(const Eigen::Vector3d& position, double duration) {
  TrajectorySegment segment;
  segment.duration = duration;
  segment.coefficients = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 1);
  segment.coefficients.col(0) = position;
  return segment;
}

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

namespace {
constexpr int kSpeedSamples = 256;  // intervals of each segment where slowedTo() reads its speed
}  // namespace

Trajectory slowedTo(const Trajectory& trajectory, double speed) {
  double fastest = 0.0;
  for (const TrajectorySegment& segment : trajectory.segments()) {
    for (int i = 0; i <= kSpeedSamples; ++i) {
      const double t = segment.duration * static_cast<double>(i) / kSpeedSamples;
      fastest = std::max(fastest, segment.evaluate(t, 1).norm());
    }
  }
  if (!(fastest > speed)) return trajectory;
  // p(k t) over duration / k: coefficient j times k^j.
  const double k = speed / fastest;
  Trajectory slowed;
  for (TrajectorySegment segment : trajectory.segments()) {
    double power = 1.0;
    for (Eigen::Index j = 0; j < segment.coefficients.cols(); ++j, power *= k) {
      segment.coefficients.col(j) *= power;
    }
    segment.duration /= k;
    slowed.append(std::move(segment));
  }
  return slowed;
}

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

Trajectory splice(const Trajectory& committed, double t, const Trajectory& plan,
                  double acceleration) {
  Trajectory out = slice(committed, t);
  for (const TrajectorySegment& segment : plan.segments()) out.append(segment);
  const TrajectorySegment stop = brake(stateAt(out, out.duration()), acceleration);
  if (stop.duration > 0.0) out.append(stop);
  return out;
}

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

TraceResult vouchedTrace(const VehicleMap& map, const Trajectory& trajectory, double from,
                         const Body& body, double inset) {
  constexpr double kReach = 0.2;  // m a traced step may take beyond the radius
  const Box& box = map.bounds();
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(inset);
  const Eigen::Vector3d first = trajectory.evaluate(std::clamp(from, 0.0, trajectory.duration()));
  const Box domain{(box.min + margin).cwiseMin(box.max).cwiseMin(first),
                   (box.max - margin).cwiseMax(box.min).cwiseMax(first)};
  return traceTrajectory([&](const Eigen::Vector3d& p,
                             double radius) { return map.unvouchedDistance(p, radius + kReach); },
                         domain, trajectory, body.keptRadius(), body.tolerance, from);
}

double exactMinClearance(const World& truth, const Trajectory& flown, double radius, double reach) {
  if (flown.empty()) return NAN;
  const Esdf& esdf = truth.esdf();
  const double cap = std::min(esdf.maxDistance(), std::max(esdf.truncation(), radius + reach));
  const auto distance = [&](double s) { return esdf.exactDistance(flown.evaluate(s), cap); };
  double speed = 0.0;
  for (const TrajectorySegment& segment : flown.segments()) {
    speed = std::max(speed, speedBound(segment));
  }
  constexpr double kStep = 0.01;
  const double duration = flown.duration();
  std::vector<double> times;
  for (double s = 0.0; s < duration; s += kStep) times.push_back(s);
  times.push_back(duration);
  std::vector<double> distances(times.size());
  for (std::size_t i = 0; i < times.size(); ++i) distances[i] = distance(times[i]);
  double least = *std::min_element(distances.begin(), distances.end());
  for (std::size_t i = 0; i + 1 < times.size(); ++i) {
    const double span = times[i + 1] - times[i];
    if (std::min(distances[i], distances[i + 1]) - 0.5 * speed * span >= least) continue;
    // Golden-section search for the interval's least distance.
    constexpr double kRatio = 0.6180339887498949;
    double a = times[i];
    double b = times[i + 1];
    while (b - a > 1e-6) {
      const double left = b - kRatio * (b - a);
      const double right = a + kRatio * (b - a);
      if (distance(left) < distance(right)) {
        b = right;
      } else {
        a = left;
      }
    }
    least = std::min(least, distance(0.5 * (a + b)));
  }
  return least - radius;
}

Eigen::Vector3d windowCentre(const Eigen::Vector3d& position, double way_height,
                             double window_height) {
  const double quarter = 0.25 * window_height;
  Eigen::Vector3d centre = position;
  centre.z() += std::clamp(way_height - position.z(), -quarter, quarter);
  return centre;
}

double wayHeight(const std::vector<Eigen::Vector3d>& guide, double horizon,
                 const Eigen::Vector3d& goal) {
  if (guide.size() < 2) return goal.z();
  double height = guide.front().z();
  double along = 0.0;
  for (std::size_t i = 1; i < guide.size() && along <= horizon; ++i) {
    along += (guide[i] - guide[i - 1]).norm();
    const double z = along > horizon ? pointAlong(guide, horizon).z() : guide[i].z();
    if (std::abs(z - guide.front().z()) > std::abs(height - guide.front().z())) height = z;
  }
  return height;
}

std::string takenSince(const std::vector<FlightReplan>& replans, double since,
                       const Eigen::Vector3d& goal) {
  int taken = 0;
  Eigen::Vector3d low = Eigen::Vector3d::Constant(INFINITY);
  Eigen::Vector3d high = -low;
  double nearest = INFINITY;
  for (const FlightReplan& replan : replans) {
    if (replan.time < since || !replan.accepted) continue;
    ++taken;
    low = low.cwiseMin(replan.local_goal);
    high = high.cwiseMax(replan.local_goal);
    nearest = std::min(nearest, (replan.local_goal - goal).norm());
  }
  if (taken == 0) return "";
  return "; " + std::to_string(taken) + " plans taken meanwhile, their local goals within " +
         formatNumber((high - low).norm()) + " m of one another, the nearest " +
         formatNumber(nearest) + " m from the goal";
}

std::string failuresSince(const std::vector<FlightReplan>& replans, double since) {
  std::map<std::string, std::pair<int, std::string>> failures;  // status -> (count, why)
  std::map<std::string, int> recoveries;
  int total = 0;
  for (const FlightReplan& replan : replans) {
    if (replan.time < since || replan.accepted || replan.kept) continue;
    ++total;
    auto& [count, why] = failures[replan.status];
    if (count++ == 0) why = replan.why;
    if (!replan.recovery.empty()) ++recoveries[replan.recovery];
  }
  if (total == 0) return "";
  // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "literal" +
  // std::to_string() here.
  std::string text = "; ";
  text.append(std::to_string(total)).append(" replans failed meanwhile:");
  for (const auto& [status, failure] : failures) {
    text.append(" ").append(std::to_string(failure.first)).append(" ").append(status);
    text.append(" (").append(failure.second).append(")");
  }
  for (const auto& [recovery, count] : recoveries) {
    text.append("; ").append(recovery).append(" tried ").append(std::to_string(count));
    text.append(" times");
  }
  return text;
}

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

Eigen::Vector3d pointAlong(const std::vector<Eigen::Vector3d>& way, double s) {
  double along = 0.0;
  for (std::size_t i = 1; i < way.size(); ++i) {
    const double step = (way[i] - way[i - 1]).norm();
    if (along + step > s) return way[i - 1] + (way[i] - way[i - 1]) * ((s - along) / step);
    along += step;
  }
  return way.back();
}

std::string notCommittedWhy(CommitSpace commit, double vouched) {
  if (commit == CommitSpace::kPlanned) {
    return "every braking tail after the plan leaves the map or meets a known obstacle";
  }
  return vouched < 0.1
             ? "the plan leaves the space the known map vouches for at once (commit: seen)"
             : "every braking tail after the plan leaves the space the known map vouches for "
               "(commit: seen)";
}

std::vector<std::pair<double, Eigen::Vector3d>> knownVoxelsInOrder(
    const VehicleMap& map, const std::unordered_map<std::size_t, double>& first) {
  std::vector<std::pair<double, Eigen::Vector3d>> voxels;
  for (const std::size_t voxel : map.occupiedVoxels()) {
    voxels.emplace_back(first.at(voxel), map.voxelCenter(voxel));
  }
  std::stable_sort(voxels.begin(), voxels.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  return voxels;
}

double wayLength(const std::vector<Eigen::Vector3d>& guide, const Eigen::Vector3d& from,
                 const Eigen::Vector3d& goal) {
  if (guide.size() < 2) return (goal - from).norm();
  double length = 0.0;
  for (std::size_t i = 1; i < guide.size(); ++i) length += (guide[i] - guide[i - 1]).norm();
  return length;
}

std::pair<double, double> trackingError(const Trajectory& flown, const Trajectory& committed) {
  double largest = 0.0;
  double squares = 0.0;
  int samples = 0;
  for (double s = 0.0; s <= flown.duration(); s += 0.01, ++samples) {
    const double error = (flown.evaluate(s) - committed.evaluate(s)).norm();
    largest = std::max(largest, error);
    squares += error * error;
  }
  return {largest, samples > 0 ? std::sqrt(squares / samples) : 0.0};
}

bool localGoal(const Eigen::Vector3d& from, const Eigen::Vector3d& goal,
               const std::vector<Eigen::Vector3d>& guide, double horizon, const World& window,
               double radius, const Box& map, Eigen::Vector3d* out) {
  const Box box = window.bounds();
  Eigen::Vector3d margin_min = Eigen::Vector3d::Constant(0.5);
  Eigen::Vector3d margin_max = Eigen::Vector3d::Constant(0.5);
  for (int axis = 0; axis < 2; ++axis) {  // x and y: z keeps its margin (localGoal's heights)
    if (box.min[axis] <= map.min[axis] + 1e-6) margin_min[axis] = 0.0;
    if (box.max[axis] >= map.max[axis] - 1e-6) margin_max[axis] = 0.0;
  }
  const Eigen::Vector3d inner_min = (box.min + margin_min).cwiseMin(box.max);
  const Eigen::Vector3d inner_max = (box.max - margin_max).cwiseMax(box.min);
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
  // Within the horizon along the way, not in a straight line: a goal behind a wall that the
  // guide goes round was taken as the local goal, and the vehicle dithered at the wall.
  const bool at_goal = wayLength(guide, from, goal) <= horizon && (goal_inside - goal).norm() < 0.5;
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

CheckerSettings flownCheckerSettings(const Body& body, const PlannerLimits& limits,
                                     const TrackingModel& tracking) {
  CheckerSettings settings = checkerSettings(body, limits);
  if (tracking.kind != TrackingKind::kPerfect) {
    settings.limits = DynamicLimits::uniform(INFINITY, INFINITY);
    settings.max_derivative = 1;
  }
  return settings;
}

void judgeFlown(const CheckResult& check, bool collided,
                const std::optional<Eigen::Vector3d>& left_map, double t, FlightResult& result) {
  if (collided) result.status = "collision";
  if (left_map) {
    result.status = "left_map";
    result.message = "the vehicle left the map at " + formatPoint(*left_map) +
                     ", t = " + formatNumber(t) + " s (the tracking error: wind, a late plan)";
    return;
  }
  if (!check.valid && check.check == "collision") {
    result.status = "collision";
    result.message =
        "the flown trajectory hits the ground truth at t = " + std::to_string(check.time) +
        " s: " + check.detail;
    result.flown = slice(result.flown, check.time);
  } else if (!check.valid) {
    result.message = "the checker: " + check.check + ": " + check.detail;
  }
}

double vouchedUntil(const VehicleMap& map, const Trajectory& trajectory, const Body& body,
                    double inset) {
  const TraceResult trace = vouchedTrace(map, trajectory, 0.0, body, inset);
  return trace.free ? trajectory.duration() : trace.time;
}

}  // namespace kinolab::flight_motion
