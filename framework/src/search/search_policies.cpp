#include "kinolab/search/search_policies.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(HeuristicBuilder, "heuristic", "heuristics",
                               "estimates of the cost to the goal, consistent with the edges' "
                               "lower bounds (a motion-primitive planner's `heuristic`)",
                               3)
KINOLAB_DEFINE_PLUGIN_REGISTRY(EdgeEvaluationPolicy, "lower_bound", "lower_bounds",
                               "how an edge is evaluated when its parent is expanded (a lazy "
                               "planner's `lower_bound`)",
                               4)
KINOLAB_DEFINE_PLUGIN_REGISTRY(SearchSpace, "search_space", "search_spaces",
                               "how a motion-primitive search tells states apart (its "
                               "`search_space`)",
                               7)

double ballDistance(const Eigen::Vector3d& position, const Eigen::Vector3d& goal, double radius) {
  return std::max((position - goal).norm() - radius, 0.0);
}

namespace {

/// A MaxHeuristic of `parts` each prepared by `prepare` (for a query, for a control set);
/// nullptr when no part changes.
template <typename Prepare>
std::shared_ptr<const SearchHeuristic> maxOfPrepared(
    const std::vector<std::shared_ptr<const SearchHeuristic>>& parts, const Prepare& prepare) {
  std::vector<std::shared_ptr<const SearchHeuristic>> prepared;
  bool changed = false;
  for (const auto& part : parts) {
    prepared.push_back(prepare(part));
    changed = changed || prepared.back() != part;
  }
  return changed ? std::make_shared<MaxHeuristic>(std::move(prepared)) : nullptr;
}

/// The least time to move `distance` >= 0 along an axis from speed `v` (positive towards the
/// target) with |v| <= v_max and |a| <= a_max: full acceleration, then cruise.
double axisMinimumTime(double distance, double v, double v_max, double a_max) {
  if (distance <= 0.0) return 0.0;
  v = std::clamp(v, -v_max, v_max);
  if (!std::isfinite(a_max)) return std::isfinite(v_max) ? distance / v_max : 0.0;
  // Distance covered while accelerating to v_max; INFINITY without a speed limit.
  const double ramp = std::isfinite(v_max) ? (v_max * v_max - v * v) / (2.0 * a_max) : INFINITY;
  if (distance <= ramp) {
    // v t + a t^2 / 2 = distance, in the form that does not cancel when v > 0.
    return 2.0 * distance / (v + std::sqrt(v * v + 2.0 * a_max * distance));
  }
  return (v_max - v) / a_max + (distance - ramp) / v_max;
}

/// The largest real root of m^3 + a m^2 + b m + c = 0 (Cardano, or the trigonometric form
/// when there are three real roots), polished by Newton's method.
double largestCubicRoot(double a, double b, double c) {
  const double shift = a / 3.0;
  const double p = b - a * shift;
  const double q = 2.0 * shift * shift * shift - b * shift + c;
  const double discriminant = 0.25 * q * q + p * p * p / 27.0;
  double y = 0.0;
  if (discriminant > 0.0) {
    const double root = std::sqrt(discriminant);
    y = std::cbrt(-0.5 * q + root) + std::cbrt(-0.5 * q - root);
  } else if (p < 0.0) {
    const double radius = std::sqrt(-p / 3.0);
    const double cosine = std::clamp(-0.5 * q / (radius * radius * radius), -1.0, 1.0);
    y = 2.0 * radius * std::cos(std::acos(cosine) / 3.0);
  }
  double m = y - shift;
  for (int i = 0; i < 2; ++i) {
    const double value = ((m + a) * m + b) * m + c;
    const double slope = (3.0 * m + 2.0 * a) * m + b;
    if (slope == 0.0) break;
    m -= value / slope;
  }
  return m;
}

/// The least time to move `distance` >= 0 along an axis from speed `v` and acceleration `a`
/// (positive towards the target) under |v| <= v_max, |a| <= a_max and |jerk| <= j_max: no
/// trajectory's speed exceeds w(t) = v + integral of min(a_max, a + j_max s), nor v_max, so
/// none covers more than X(t) = integral of min(v_max, w); the time is the first t with
/// X(t) = distance. (The exact optimum of a relaxation the jerk-limited edges satisfy, so it
/// is consistent.)
double axisMinimumTimeJerk(double distance, double v, double a, double v_max, double a_max,
                           double j_max) {
  if (distance <= 0.0) return 0.0;
  if (!std::isfinite(j_max)) return axisMinimumTime(distance, v, v_max, a_max);
  v = std::clamp(v, -v_max, v_max);
  a = std::clamp(a, -a_max, a_max);
  // Phase 1: the acceleration bound ramps from a to a_max until t1; phase 2: it stays.
  const double t1 = std::isfinite(a_max) ? (a_max - a) / j_max : INFINITY;
  const auto speed1 = [&](double t) { return v + a * t + 0.5 * j_max * t * t; };
  const auto covered1 = [&](double t) { return (v + (0.5 * a + j_max * t / 6.0) * t) * t; };
  // When the speed bound reaches v_max.
  double tv = 0.0;
  if (v < v_max) {
    // v + a t + j t^2 / 2 = v_max: the positive root, if within phase 1.
    const double root = (-a + std::sqrt(a * a + 2.0 * j_max * (v_max - v))) / j_max;
    tv = root <= t1 ? root : t1 + (v_max - speed1(t1)) / a_max;
  }
  // Within phase 1 before the cap: the cubic covered1(t) = distance, whose largest root is
  // the crossing (the covered distance only grows once the speed bound is positive).
  const double end1 = std::min(t1, tv);
  if (covered1(end1) >= distance) {
    double t = largestCubicRoot(3.0 * a / j_max, 6.0 * v / j_max, -6.0 * distance / j_max);
    return std::clamp(t, 0.0, end1);
  }
  double time = end1;
  double left = distance - covered1(end1);
  if (tv > t1) {
    // Phase 2 before the cap: w = w1 + a_max s.
    const double w1 = speed1(t1);
    const double span = tv - t1;
    const double phase = (w1 + 0.5 * a_max * span) * span;
    if (phase >= left) {
      return t1 + 2.0 * left / (w1 + std::sqrt(std::max(w1 * w1 + 2.0 * a_max * left, 0.0)));
    }
    time = tv;
    left -= phase;
  }
  return time + left / v_max;
}

/// The positive real roots of T^4 + p T^2 + q T + r (Ferrari's method), polished by Newton's
/// method; returns how many it wrote to `roots`.
int positiveQuarticRoots(double p, double q, double r, std::array<double, 4>& roots) {
  std::array<double, 4> found{};
  int count = 0;
  const auto quadratic = [&](double b, double c) {  // T^2 + b T + c = 0
    const double discriminant = b * b - 4.0 * c;
    if (discriminant < 0.0) return;
    const double root = std::sqrt(discriminant);
    found[count++] = 0.5 * (-b + root);
    found[count++] = 0.5 * (-b - root);
  };
  const double scale = std::max({std::abs(p), std::sqrt(std::abs(r)), 1e-300});
  const double m = largestCubicRoot(p, 0.25 * p * p - r, -0.125 * q * q);
  if (m > 1e-12 * scale) {
    const double s = std::sqrt(2.0 * m);
    quadratic(-s, 0.5 * p + m + 0.5 * q / s);
    quadratic(s, 0.5 * p + m - 0.5 * q / s);
  } else {
    // q is (numerically) zero: a quadratic in T^2.
    const double discriminant = p * p - 4.0 * r;
    if (discriminant >= 0.0) {
      for (const double z :
           {0.5 * (-p + std::sqrt(discriminant)), 0.5 * (-p - std::sqrt(discriminant))}) {
        if (z >= 0.0) found[count++] = std::sqrt(z);
      }
    }
  }
  int positive = 0;
  for (int i = 0; i < count; ++i) {
    double t = found[i];
    for (int step = 0; step < 2; ++step) {
      const double value = ((t * t + p) * t + q) * t + r;
      const double slope = (4.0 * t * t + 2.0 * p) * t + q;
      if (slope == 0.0) break;
      t -= value / slope;
    }
    if (t > 0.0 && std::isfinite(t)) roots[positive++] = t;
  }
  return positive;
}

}  // namespace

EuclideanHeuristic::EuclideanHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius)
    : weight_duration_(edges.weights.duration),
      weight_length_(edges.weights.length),
      goal_radius_(goal_radius) {
  const double speed = edges.limits.bound[1].norm();
  inverse_speed_ = std::isfinite(speed) ? 1.0 / speed : 0.0;  // no limit: no time bound
}

double EuclideanHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  const double distance = std::max((state.col(0) - goal).norm() - goal_radius_, 0.0);
  return weight_duration_ * distance * inverse_speed_ + weight_length_ * distance;
}

MinTimeHeuristic::MinTimeHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius)
    : weight_duration_(edges.weights.duration),
      weight_length_(edges.weights.length),
      goal_radius_(goal_radius),
      inverse_v_max_(edges.limits.bound[1].cwiseInverse()) {}  // infinite limits give 0

double MinTimeHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  const Eigen::Vector3d offset = (state.col(0) - goal).cwiseAbs();
  const double distance = std::max(offset.norm() - goal_radius_, 0.0);
  // The goal ball lies inside the cube of half-width R: per axis, the distance to that cube.
  const double time =
      ((offset.array() - goal_radius_).max(0.0) * inverse_v_max_.array()).maxCoeff();
  return weight_duration_ * time + weight_length_ * distance;
}

TimeOptimalHeuristic::TimeOptimalHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius,
                                           bool whole_primitives)
    : whole_primitives_(whole_primitives),
      tau_(edges.duration),
      weight_duration_(edges.weights.duration),
      weight_length_(edges.weights.length),
      goal_radius_(goal_radius),
      v_max_(edges.limits.bound[1]),
      a_max_(edges.limits.bound[2]),
      j_max_(edges.order >= 3 ? edges.limits.bound[3] : Eigen::Vector3d::Constant(INFINITY)) {}

double TimeOptimalHeuristic::minimumTime(const ChainState& state,
                                         const Eigen::Vector3d& goal) const {
  double time = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    const double offset = goal[axis] - state(axis, 0);
    const double sign = offset >= 0.0 ? 1.0 : -1.0;
    time = std::max(
        time, axisMinimumTimeJerk(std::abs(offset) - goal_radius_, sign * state(axis, 1),
                                  sign * state(axis, 2), v_max_[axis], a_max_[axis], j_max_[axis]));
  }
  return time;
}

double TimeOptimalHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  double time = minimumTime(state, goal);
  // ceil(T / tau) primitives; a hair above a whole number counts as it (rounding).
  if (whole_primitives_) time = tau_ * std::ceil(time / tau_ - 1e-9);
  return weight_duration_ * time + weight_length_ * ballDistance(state.col(0), goal, goal_radius_);
}

ObvpHeuristic::ObvpHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius)
    : weight_duration_(edges.weights.duration),
      weight_control_(edges.weights.control_effort),
      weight_length_(edges.weights.length),
      goal_radius_(goal_radius) {
  if (edges.order != 2) {
    throw InvalidArgument("the obvp heuristic needs order 2 (acceleration control), got order " +
                          std::to_string(edges.order));
  }
}

double ObvpHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  const double length = weight_length_ * ballDistance(state.col(0), goal, goal_radius_);
  const Eigen::Vector3d offset = goal - state.col(0);
  const Eigen::Vector3d velocity = state.col(1);
  const double radius = goal_radius_;
  // e_i(T) = max(|offset_i - v_i T| - R, 0): zero between the times the axis enters and
  // leaves the cube's extent. Those times split T > 0 into stretches with one active set.
  std::array<double, 8> breaks{};
  int count = 0;
  breaks[count++] = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    if (velocity[axis] == 0.0) continue;
    for (const double edge : {offset[axis] - radius, offset[axis] + radius}) {
      const double t = edge / velocity[axis];
      if (t > 0.0 && std::isfinite(t)) breaks[count++] = t;
    }
  }
  for (int i = 1; i < count; ++i) {  // insertion sort of at most seven times
    for (int j = i; j > 0 && breaks[j - 1] > breaks[j]; --j) std::swap(breaks[j - 1], breaks[j]);
  }
  const auto cost = [&](double t) {
    double effort = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const double e = std::max(std::abs(offset[axis] - velocity[axis] * t) - radius, 0.0);
      effort += e * e;
    }
    return weight_duration_ * t + weight_control_ * 3.0 * effort / (t * t * t);
  };
  if (weight_control_ == 0.0 || weight_duration_ == 0.0) {
    // Only one term: with no effort weight the duration is free to shrink to 0 (and with no
    // duration weight the effort vanishes as T grows), so the infimum is 0 once outside the
    // goal.
    return length;
  }
  double best = INFINITY;
  const double ratio = weight_control_ / weight_duration_;
  for (int i = 0; i < count; ++i) {
    const double begin = breaks[i];
    const double end = i + 1 < count ? breaks[i + 1] : INFINITY;
    if (begin > 0.0) best = std::min(best, cost(begin));
    // On this stretch e_i = alpha_i - beta_i T for the active axes; f'(T) T^4 / w_T is
    // T^4 - 3 k C T^2 + 12 k B T - 9 k A with k = w_U / w_T.
    const double probe = std::isfinite(end) ? 0.5 * (begin + end) : begin + 1.0;
    double a_sum = 0.0;
    double b_sum = 0.0;
    double c_sum = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const double residual = offset[axis] - velocity[axis] * probe;
      if (std::abs(residual) <= radius) continue;
      const double sign = residual > 0.0 ? 1.0 : -1.0;
      const double alpha = sign * offset[axis] - radius;
      const double beta = sign * velocity[axis];
      a_sum += alpha * alpha;
      b_sum += alpha * beta;
      c_sum += beta * beta;
    }
    if (a_sum == 0.0 && c_sum == 0.0) {
      // Inside the cube's extent on every axis throughout: w_T T, least at the start.
      best = std::min(best, weight_duration_ * begin);
      continue;
    }
    std::array<double, 4> roots{};
    const int found = positiveQuarticRoots(-3.0 * ratio * c_sum, 12.0 * ratio * b_sum,
                                           -9.0 * ratio * a_sum, roots);
    for (int k = 0; k < found; ++k) {
      if (roots[k] >= begin && roots[k] <= end) best = std::min(best, cost(roots[k]));
    }
  }
  return (std::isfinite(best) ? best : 0.0) + length;
}

namespace {

/// Round half up: floor(x + 0.5) by truncation and a correction (no libm call), clamped to
/// the key's 32 bits.
std::int32_t roundedKey(double value) {
  const double shifted = std::clamp(value, -2.0e9, 2.0e9) + 0.5;
  auto rounded = static_cast<std::int32_t>(shifted);
  if (rounded > shifted) --rounded;
  return rounded;
}

}  // namespace

LatticeSpace::LatticeSpace(const Resolution& r) {
  const std::array<double, 3> resolution{r.position, r.velocity, r.acceleration};
  for (int k = 0; k < 3; ++k) {
    if (!(resolution[k] > 0.0)) {
      throw InvalidArgument("lattice search space: resolutions must be positive");
    }
    inverse_[k] = 1.0 / resolution[k];
  }
}

SearchSpace::Key LatticeSpace::key(const ChainState& state, const ChainState& start,
                                   int order) const {
  Key key{};
  for (int k = 0; k < order; ++k) {
    const double inverse = inverse_[std::min(k, 2)];
    for (int axis = 0; axis < 3; ++axis) {
      key[3 * k + axis] = roundedKey((state(axis, k) - start(axis, k)) * inverse);
    }
  }
  return key;
}

CellSpace::CellSpace(const Cells& cells)
    : inverse_cell_(1.0 / cells.cell_size),
      inverse_velocity_(cells.velocity_resolution > 0.0 ? 1.0 / cells.velocity_resolution : 0.0) {
  if (!(cells.cell_size > 0.0) || !(cells.velocity_resolution >= 0.0)) {
    throw InvalidArgument(
        "cell search space: the cell size must be positive and the velocity resolution at "
        "least 0");
  }
}

SearchSpace::Key CellSpace::key(const ChainState& state, const ChainState& start, int) const {
  Key key{};
  for (int axis = 0; axis < 3; ++axis) {
    key[axis] = roundedKey((state(axis, 0) - start(axis, 0)) * inverse_cell_);
    key[3 + axis] = roundedKey((state(axis, 1) - start(axis, 1)) * inverse_velocity_);
  }
  return key;
}

ObvpShot::ObvpShot(const EdgeEvaluatorSettings& edges, double reach)
    : weights_(edges.weights), limits_(edges.limits), reach_(reach) {
  if (edges.order != 2) {
    throw InvalidArgument("the obvp shot needs order 2 (acceleration control), got order " +
                          std::to_string(edges.order));
  }
  if (!(reach > 0.0)) throw InvalidArgument("the obvp shot's reach must be positive");
}

TrajectorySegment ObvpShot::cubic(const ChainState& state, const Eigen::Vector3d& goal,
                                  double duration) {
  const double t = duration;
  const Eigen::Vector3d d = goal - state.col(0) - state.col(1) * t;
  const Eigen::Vector3d e = -state.col(1);
  TrajectorySegment segment;
  segment.duration = t;
  segment.coefficients.resize(3, 4);
  segment.coefficients.col(0) = state.col(0);
  segment.coefficients.col(1) = state.col(1);
  segment.coefficients.col(2) = (3.0 * d - e * t) / (t * t);
  segment.coefficients.col(3) = (e * t - 2.0 * d) / (t * t * t);
  return segment;
}

double ObvpShot::objective(const ChainState& state, const Eigen::Vector3d& goal, double t) const {
  const Eigen::Vector3d d = goal - state.col(0) - state.col(1) * t;
  const Eigen::Vector3d e = -state.col(1);
  const double effort =
      12.0 * d.squaredNorm() / (t * t * t) - 12.0 * d.dot(e) / (t * t) + 4.0 * e.squaredNorm() / t;
  return weights_.duration * t + weights_.control_effort * effort;
}

Trajectory ObvpShot::shoot(const ChainState& state, const Eigen::Vector3d& goal) const {
  const double distance = (goal - state.col(0)).norm();
  if (distance > reach_) return {};
  // The objective over T: a log-spaced scan, then golden-section refinement around the best.
  const double speed = limits_.bound[1].minCoeff();
  const double low = std::max(1e-3, 0.25 * distance / speed);
  const double high =
      4.0 * (distance / speed + state.col(1).norm() / limits_.bound[2].minCoeff()) + 1.0;
  constexpr int kScan = 48;
  double best = low;
  double best_value = objective(state, goal, low);
  for (int i = 1; i <= kScan; ++i) {
    const double t = low * std::pow(high / low, static_cast<double>(i) / kScan);
    if (const double value = objective(state, goal, t); value < best_value) {
      best = t;
      best_value = value;
    }
  }
  // Golden section on the bracket around it, one new evaluation per step.
  const double step = std::pow(high / low, 1.0 / kScan);
  double a = best / step;
  double b = best * step;
  constexpr double kGolden = 0.6180339887498949;
  double x1 = b - kGolden * (b - a);
  double x2 = a + kGolden * (b - a);
  double f1 = objective(state, goal, x1);
  double f2 = objective(state, goal, x2);
  for (int i = 0; i < 40; ++i) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - kGolden * (b - a);
      f1 = objective(state, goal, x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + kGolden * (b - a);
      f2 = objective(state, goal, x2);
    }
  }
  double duration = 0.5 * (a + b);
  // Stretch while a limit breaks: the acceleration is linear in time (extremes at the ends),
  // the velocity quadratic (extremes at the ends or its vertex).
  const auto within = [&](const TrajectorySegment& c) {
    const Eigen::Vector3d b2 = c.coefficients.col(2);
    const Eigen::Vector3d c3 = c.coefficients.col(3);
    for (int axis = 0; axis < 3; ++axis) {
      const double vertex = c3[axis] != 0.0 ? -b2[axis] / (3.0 * c3[axis]) : 0.0;
      for (const double t : {0.0, c.duration, std::clamp(vertex, 0.0, c.duration)}) {
        if (std::abs(c.evaluate(t, 1)[axis]) > limits_.bound[1][axis]) return false;
      }
      for (const double t : {0.0, c.duration}) {
        if (std::abs(c.evaluate(t, 2)[axis]) > limits_.bound[2][axis]) return false;
      }
    }
    return true;
  };
  TrajectorySegment segment = cubic(state, goal, duration);
  for (int i = 0; i < 8 && !within(segment); ++i) {
    duration *= 1.25;
    segment = cubic(state, goal, duration);
  }
  Trajectory shot;
  shot.append(std::move(segment));
  return shot;
}

double ObvpShot::cost(const Trajectory& shot) const {
  double effort = 0.0;
  for (const TrajectorySegment& segment : shot.segments()) {
    // |a(t)|^2 with a linear: (a0^2 + a0 a1 + a1^2) T / 3 per axis, exact.
    const Eigen::Vector3d a0 = segment.evaluate(0.0, 2);
    const Eigen::Vector3d a1 = segment.evaluate(segment.duration, 2);
    effort += (a0.squaredNorm() + a0.dot(a1) + a1.squaredNorm()) * segment.duration / 3.0;
  }
  return weights_.duration * shot.duration() + weights_.control_effort * effort +
         weights_.length * shot.length();
}

MaxHeuristic::MaxHeuristic(std::vector<std::shared_ptr<const SearchHeuristic>> parts)
    : parts_(std::move(parts)) {
  if (parts_.empty()) throw InvalidArgument("max heuristic: no heuristics to combine");
}

double MaxHeuristic::estimate(const ChainState& state, const Eigen::Vector3d& goal) const {
  double best = 0.0;
  for (const auto& part : parts_) best = std::max(best, part->estimate(state, goal));
  return best;
}

std::shared_ptr<const SearchHeuristic> MaxHeuristic::forQuery(const World& world,
                                                              const Eigen::Vector3d& goal,
                                                              StopCondition& stop) const {
  return maxOfPrepared(
      parts_, [&](const auto& part) { return heuristicForQuery(part, world, goal, stop); });
}

std::shared_ptr<const SearchHeuristic> MaxHeuristic::forControls(
    const std::vector<Eigen::Vector3d>& controls) const {
  return maxOfPrepared(parts_,
                       [&](const auto& part) { return heuristicForControls(part, controls); });
}

std::shared_ptr<const SearchHeuristic> SearchHeuristic::forControls(
    const std::vector<Eigen::Vector3d>& /*controls*/) const {
  return nullptr;
}

std::shared_ptr<const SearchHeuristic> SearchHeuristic::forQuery(const World& /*world*/,
                                                                 const Eigen::Vector3d& /*goal*/,
                                                                 StopCondition& /*stop*/) const {
  return nullptr;
}

std::shared_ptr<const SearchHeuristic> heuristicForQuery(
    const std::shared_ptr<const SearchHeuristic>& heuristic, const World& world,
    const Eigen::Vector3d& goal, StopCondition& stop) {
  auto prepared = heuristic->forQuery(world, goal, stop);
  return prepared ? prepared : heuristic;
}

std::shared_ptr<const SearchHeuristic> heuristicForControls(
    const std::shared_ptr<const SearchHeuristic>& heuristic,
    const std::vector<Eigen::Vector3d>& controls) {
  auto prepared = heuristic->forControls(controls);
  return prepared ? prepared : heuristic;
}

}  // namespace kinolab
