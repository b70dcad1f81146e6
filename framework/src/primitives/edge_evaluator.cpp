#include "kinolab/primitives/edge_evaluator.hpp"

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"

namespace kinolab {
namespace {

/// t^m / m! for m = 0..order.
std::array<double, 5> powersOver(double t, int order) {
  std::array<double, 5> powers{1.0, 0.0, 0.0, 0.0, 0.0};
  for (int m = 1; m <= order; ++m) powers[m] = powers[m - 1] * t / m;
  return powers;
}

Eigen::Vector3d positionFromPowers(const ChainState& start, const Eigen::Vector3d& control,
                                   int order, const std::array<double, 5>& powers) {
  Eigen::Vector3d position = start.col(0) + control * powers[order];
  for (int m = 1; m < order; ++m) position += start.col(m) * powers[m];
  return position;
}

/// The state after t from the powers t^m / m!: column k is the (k)-th derivative. Column 0
/// is computed exactly as positionFromPowers does, so end state and last sample agree.
ChainState stateFromPowers(const ChainState& start, const Eigen::Vector3d& control, int order,
                           const std::array<double, 5>& powers) {
  ChainState state = ChainState::Zero();
  state.col(0) = positionFromPowers(start, control, order, powers);
  for (int k = 1; k < order; ++k) {
    Eigen::Vector3d value = start.col(k) + control * powers[order - k];
    for (int m = k + 1; m < order; ++m) value += start.col(m) * powers[m - k];
    state.col(k) = value;
  }
  return state;
}

void require(bool condition, const std::string& what) {
  if (!condition) throw InvalidArgument("edge evaluator: " + what);
}

}  // namespace

EdgeEvaluator::EdgeEvaluator(std::shared_ptr<const World> world, EdgeEvaluatorSettings settings)
    : world_(std::move(world)), settings_(settings), chain_(settings.order) {
  require(world_ != nullptr, "no world");
  require(std::isfinite(settings_.duration) && settings_.duration > 0.0,
          "duration (tau) must be positive");
  require(settings_.body.radius >= 0.0, "the body's radius must be >= 0");
  require(settings_.body.safety_band > 0.0, "the body's safety band must be positive");
  require(settings_.body.tolerance > 0.0, "the body's collision tolerance must be positive");
  const CostWeights& w = settings_.weights;
  require(w.duration >= 0 && w.length >= 0 && w.control_effort >= 0 && w.obstacle >= 0,
          "cost weights must be non-negative");
  end_powers_ = powersOver(settings_.duration, settings_.order);
  if (settings_.sampling.mode == EdgeSampling::Mode::kCount) {
    require(settings_.sampling.samples >= 1, "samples (K) must be >= 1");
    const int samples = settings_.sampling.samples;
    for (int k = 1; k < samples; ++k) {
      sample_powers_.push_back(powersOver(settings_.duration * k / samples, settings_.order));
    }
    sample_powers_.push_back(end_powers_);
  } else {
    require(settings_.sampling.spacing > 0.0, "spacing must be positive");
  }
  inverse_safety_band_ = 1.0 / settings_.body.safety_band;
  // A sparse world's distances are exact up to its truncation T. The verdicts read them up to
  // the radius; the obstacle cost's trilinear values below the band's edge B read voxel
  // centres up to B + 2 sqrt(3) voxels away (each centre within sqrt(3) voxels of the point,
  // the distance 1-Lipschitz), so with T beyond that a valid edge costs what it costs on the
  // dense world. Verdicts are exact to the tolerance on either layout; where the truth lies
  // within the tolerance band the two may differ (tracing steps follow the clamped clearance).
  world_->requireExactDistancesTo(
      w.obstacle > 0.0
          ? world_->obstacleCostReach(settings_.body.costReach())
          : verdictRadius(),
      w.obstacle > 0.0 ? "edge evaluator (obstacle cost)" : "edge evaluator (collision verdict)");
  const auto choose = [](int n, int k) {
    double value = 1.0;
    for (int i = 1; i <= k; ++i) value = value * (n - k + i) / i;
    return value;
  };
  const int n = settings_.order;
  for (int k = 0; k <= n; ++k) {
    for (int m = 0; m <= k; ++m) bernstein_[k][m] = choose(k, m) / choose(n, m);
  }
}

ChainState EdgeEvaluator::endState(const ChainState& start, const Eigen::Vector3d& control) const {
  return stateFromPowers(start, control, settings_.order, end_powers_);
}

double EdgeEvaluator::pathBound(const ChainState& start, const Eigen::Vector3d& control) const {
  // Per axis |v(t)| <= sum of |coefficient| t^m / m! at t = tau; times tau for the path.
  const int order = settings_.order;
  Eigen::Array3d bound = control.array().abs() * end_powers_[order - 1];
  for (int m = 1; m < order; ++m) bound += start.col(m).array().abs() * end_powers_[m - 1];
  return bound.matrix().norm() * settings_.duration;
}

int EdgeEvaluator::sampleCountFor(double path_bound) const {
  if (settings_.sampling.mode == EdgeSampling::Mode::kCount) return settings_.sampling.samples;
  constexpr double kMaxSamples = 100000.0;
  return static_cast<int>(
      std::clamp(std::ceil(path_bound / settings_.sampling.spacing), 1.0, kMaxSamples));
}

double EdgeEvaluator::mapFreeCost(const Eigen::Vector3d& control) const {
  const CostWeights& w = settings_.weights;
  return (w.duration + w.control_effort * control.squaredNorm()) * settings_.duration;
}

bool EdgeEvaluator::insideMap(const ChainState& start, const Eigen::Vector3d& control) const {
  // Per axis the position is sum_m b_m s^m over s = t / tau in [0, 1], b_m = a_m tau^m; it
  // stays in the convex hull of its Bernstein coefficients sum_{m<=k} C(k,m)/C(n,m) b_m.
  const int n = settings_.order;
  std::array<Eigen::Vector3d, 5> b;
  for (int m = 0; m < n; ++m) b[m] = start.col(m) * end_powers_[m];
  b[n] = control * end_powers_[n];
  const Box& box = world_->bounds();
  for (int k = 0; k <= n; ++k) {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    for (int m = 0; m <= k; ++m) point += bernstein_[k][m] * b[m];
    if (!box.contains(point)) return false;
  }
  return true;
}

EdgeEvaluation EdgeEvaluator::controlOnly(const ChainState& start,
                                          const Eigen::Vector3d& control) const {
  EdgeEvaluation result;
  result.end = endState(start, control);
  result.within_limits = chain_.withinLimits(start, control, settings_.duration, settings_.limits);
  if (!result.within_limits) return result;
  result.samples = sampleCount(start, control);
  if (!insideMap(start, control)) {
    result.collision_time = settings_.duration;
    return result;
  }
  result.length = (result.end.col(0) - start.col(0)).norm();
  result.collision_free = true;
  result.cost = mapFreeCost(control) + settings_.weights.length * result.length;
  return result;
}

EdgeEvaluation EdgeEvaluator::partial(const ChainState& start,
                                      const Eigen::Vector3d& control) const {
  EdgeEvaluation result = controlOnly(start, control);
  if (!result.collision_free) return result;  // breaks a limit or leaves the map
  // The end state's position is the last sample of full evaluation, bit for bit.
  const Eigen::Vector3d end = result.end.col(0);
  const Esdf& esdf = world_->esdf();
  result.esdf_queries = 1;
  result.end_clearance = esdf.clearance(end, &result.end_distance);
  const double radius = verdictRadius();
  if (result.end_clearance < radius) {
    // The bound undershoots near obstacles: decide with the exact distance (full does too).
    result.end_clearance = esdf.decided(end, result.end_clearance, radius, radius);
  }
  if (result.end_clearance < radius) {
    result.collision_free = false;
    result.collision_time = settings_.duration;
    result.cost = INFINITY;
    return result;
  }
  if (settings_.weights.obstacle > 0.0) {
    result.obstacle_cost = settings_.weights.obstacle * penalty(result.end_distance) *
                           settings_.duration / result.samples;
    result.cost += result.obstacle_cost;
  }
  return result;
}

Eigen::Vector3d EdgeEvaluator::samplePosition(const ChainState& start,
                                              const Eigen::Vector3d& control,
                                              const Eigen::Vector3d& end, int k,
                                              int samples) const {
  const int order = settings_.order;
  if (settings_.sampling.mode == EdgeSampling::Mode::kCount) {
    return positionFromPowers(start, control, order, sample_powers_[k - 1]);
  }
  if (k == samples) return end;
  return positionFromPowers(start, control, order,
                            powersOver(settings_.duration * k / samples, order));
}

EdgeEvaluation EdgeEvaluator::full(const ChainState& start, const Eigen::Vector3d& control) const {
  EdgeEvaluation result = full(start, control, world_->esdf().clearance(start.col(0)));
  ++result.esdf_queries;
  return result;
}

EdgeEvaluation EdgeEvaluator::full(const ChainState& start, const Eigen::Vector3d& control,
                                   double start_clearance) const {
  EdgeEvaluation result;
  result.end = endState(start, control);
  result.within_limits = chain_.withinLimits(start, control, settings_.duration, settings_.limits);
  if (!result.within_limits) return result;
  const double path_bound = pathBound(start, control);
  const int samples = sampleCountFor(path_bound);
  result.samples = samples;
  if (!insideMap(start, control)) {
    result.collision_time = settings_.duration;
    return result;
  }
  const double seconds_per_metre = secondsPerMetre(path_bound);
  Traced traced;
  if (!traceFree(start, control, start_clearance, seconds_per_metre, traced, result)) {
    return result;
  }
  result.collision_free = true;
  integrate(start, control, samples, seconds_per_metre, traced, result);
  return result;
}

bool EdgeEvaluator::traceFree(const ChainState& start, const Eigen::Vector3d& control,
                              double start_clearance, double seconds_per_metre, Traced& traced,
                              EdgeEvaluation& result) const {
  const Esdf& esdf = world_->esdf();
  const double tau = settings_.duration;
  const double radius = verdictRadius();
  const int order = settings_.order;
  traced.time[0] = 0.0;
  traced.distance[0] = start_clearance;
  traced.count = 1;
  // Where the bound says "collision", the exact distance to the cubes decides (and, when
  // free, is what the next step covers): an edge is refused only when a traced point is
  // really closer than the radius.
  const auto decided = [&](double clearance, const Eigen::Vector3d& position) {
    if (clearance >= radius) return clearance;
    ++result.esdf_queries;
    // Searched one voxel beyond the radius: a longer next step.
    return esdf.decided(position, clearance, radius, radius + esdf.resolution());
  };
  const auto record = [&](double t, double distance) {
    if (traced.count < static_cast<int>(traced.time.size())) {
      traced.time[traced.count] = t;
      traced.distance[traced.count++] = distance;
    }
  };
  // The end first: a primitive that ends too close is refused without tracing its way there
  // (near a surface the steps are short).
  ++result.esdf_queries;
  double end_distance = 0.0;
  const Eigen::Vector3d end = result.end.col(0);
  if (decided(esdf.clearance(end, &end_distance), end) < radius) {
    result.collision_time = tau;
    return false;
  }
  double t = 0.0;
  double clearance = decided(start_clearance, start.col(0));
  for (;;) {
    if (clearance < radius) {
      result.collision_time = t;
      return false;
    }
    t += tracingReach(clearance) * seconds_per_metre;
    if (!(t < tau)) break;
    const Eigen::Vector3d position =
        positionFromPowers(start, control, order, powersOver(t, order));
    ++result.esdf_queries;
    double distance = 0.0;
    clearance = decided(esdf.clearance(position, &distance), position);
    record(t, distance);
  }
  record(tau, end_distance);
  return true;
}

void EdgeEvaluator::integrate(const ChainState& start, const Eigen::Vector3d& control, int samples,
                              double seconds_per_metre, const Traced& traced,
                              EdgeEvaluation& result) const {
  // A sample is outside the penalty band when a traced point's lower bound, less sqrt(3)
  // times the path between them (the trilinear ESDF is sqrt(3)-Lipschitz), is beyond it.
  const Esdf& esdf = world_->esdf();
  const double tau = settings_.duration;
  const Eigen::Vector3d end = result.end.col(0);
  const bool obstacle_term = settings_.weights.obstacle > 0.0;
  const bool length_term = settings_.weights.length > 0.0;
  double penalty_sum = 0.0;
  if (obstacle_term || length_term) {
    const double band = settings_.body.costReach();
    const double lipschitz_per_second = std::sqrt(3.0) / seconds_per_metre;
    Eigen::Vector3d previous = start.col(0);
    int next_traced = 0;
    for (int k = 1; k <= samples; ++k) {
      const Eigen::Vector3d position = samplePosition(start, control, end, k, samples);
      result.length += (position - previous).norm();
      previous = position;
      if (!obstacle_term) continue;
      const double time = tau * k / samples;
      while (next_traced < traced.count && traced.time[next_traced] <= time) ++next_traced;
      bool outside_band = false;
      for (const int i : {next_traced - 1, next_traced}) {
        if (i < 0 || i >= traced.count) continue;
        const double bound =
            traced.distance[i] - lipschitz_per_second * std::abs(time - traced.time[i]);
        outside_band = outside_band || bound >= band;
      }
      if (outside_band) continue;
      ++result.esdf_queries;
      penalty_sum += penalty(esdf.distance(position));
    }
  }
  if (!length_term) result.length = (end - start.col(0)).norm();
  result.obstacle_cost = settings_.weights.obstacle * penalty_sum * tau / samples;
  result.cost =
      mapFreeCost(control) + settings_.weights.length * result.length + result.obstacle_cost;
}

bool EdgeEvaluator::certify(const ChainState& start, double start_clearance,
                            const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const {
  if (!evaluation.valid()) return false;
  const double path_bound = pathBound(start, control);
  const double tau = settings_.duration;
  // Full evaluation traces the start and then the end only when one step covers the path
  // (the same arithmetic as full()); the end's clearance was tested by the partial one.
  if (!(start_clearance >= verdictRadius()) ||
      tracingReach(start_clearance) * secondsPerMetre(path_bound) < tau) {
    return false;
  }
  if (settings_.weights.obstacle > 0.0) {
    // Every point is within half the path bound of an endpoint: the trilinear value is at
    // least (d_start + d_end - sqrt(3) l) / 2 (the clearance bounds d_start from below).
    if (!std::isfinite(evaluation.end_distance)) return false;
    const double lower =
        0.5 * (start_clearance + evaluation.end_distance - std::sqrt(3.0) * path_bound);
    if (lower < settings_.body.costReach()) return false;
  }
  evaluation.obstacle_cost = 0.0;
  if (settings_.weights.length > 0.0) {
    // The polyline full evaluation measures, through the same sample positions (the partial
    // evaluation has the chord, which is what full evaluation reports without a length term).
    const Eigen::Vector3d end = evaluation.end.col(0);
    const int samples = evaluation.samples;
    Eigen::Vector3d previous = start.col(0);
    evaluation.length = 0.0;
    for (int k = 1; k <= samples; ++k) {
      const Eigen::Vector3d position = samplePosition(start, control, end, k, samples);
      evaluation.length += (position - previous).norm();
      previous = position;
    }
  }
  evaluation.cost = mapFreeCost(control) + settings_.weights.length * evaluation.length;
  return true;
}

}  // namespace kinolab
