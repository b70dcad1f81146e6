#include "kinolab/primitives/edge_evaluator.hpp"

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"

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
  require(settings_.robot_radius >= 0.0, "robot_radius must be >= 0");
  require(settings_.safety_distance > 0.0, "safety_distance must be positive");
  const CostWeights& w = settings_.weights;
  require(w.duration >= 0 && w.length >= 0 && w.control_effort >= 0 && w.obstacle >= 0,
          "cost weights must be non-negative");
  const double voxel = world_->esdf().resolution();
  end_powers_ = powersOver(settings_.duration, settings_.order);
  if (settings_.sampling.mode == EdgeSampling::Mode::kCount) {
    require(settings_.sampling.samples >= 1, "samples (K) must be >= 1");
    const int samples = settings_.sampling.samples;
    for (int k = 1; k < samples; ++k) {
      sample_powers_.push_back(powersOver(settings_.duration * k / samples, settings_.order));
    }
    sample_powers_.push_back(end_powers_);
  } else {
    require(settings_.sampling.spacing > 0.0 && settings_.sampling.spacing <= 0.5 * voxel,
            "spacing must be in (0, half a voxel = " + formatNumber(0.5 * voxel) + " m], got " +
                formatNumber(settings_.sampling.spacing));
  }
  // Per axis, neighbouring voxel values differ by at most one voxel (both free) or two (at a
  // surface); the interpolant's gradient is bounded by sqrt(3) times that. Cells touching an
  // obstacle never exceed sqrt(3) voxels in value, so a radius at least that large keeps the
  // test inside all-free cells, where the smaller constant holds.
  lipschitz_ = std::sqrt(3.0) * (settings_.robot_radius >= std::sqrt(3.0) * voxel ? 1.0 : 2.0);
  // The trilinear value mixes the eight voxels around a point, all within a voxel diagonal of
  // the nearest one, and neighbouring values differ by at most two voxels per voxel step.
  far_slack_ = 2.0 * std::sqrt(3.0) * voxel;
  inverse_safety_distance_ = 1.0 / settings_.safety_distance;
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

EdgeEvaluation EdgeEvaluator::partial(const ChainState& start,
                                      const Eigen::Vector3d& control) const {
  EdgeEvaluation result = controlOnly(start, control);
  if (!result.collision_free) return result;  // breaks a limit or leaves the map
  // The end state's position is the last sample of full evaluation, bit for bit.
  const double distance = world_->esdf().distance(result.end.col(0));
  result.esdf_queries = 1;
  result.end_distance = distance;
  if (distance < settings_.robot_radius) {
    result.collision_free = false;
    result.collision_time = settings_.duration;
    result.cost = INFINITY;
    return result;
  }
  result.obstacle_cost =
      settings_.weights.obstacle * penalty(distance) * settings_.duration / result.samples;
  result.cost += result.obstacle_cost;
  return result;
}

double EdgeEvaluator::sampleMargin(double path_bound, int samples) const {
  // Samples are at most path_bound / K apart along the path: a Lipschitz margin over half that.
  return settings_.certify ? 0.5 * lipschitz_ * path_bound / samples : 0.0;
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
  EdgeEvaluation result;
  result.end = endState(start, control);
  result.within_limits = chain_.withinLimits(start, control, settings_.duration, settings_.limits);
  if (!result.within_limits) return result;
  const double path_bound = pathBound(start, control);
  const int samples = sampleCountFor(path_bound);
  result.samples = samples;
  const double margin = sampleMargin(path_bound, samples);
  const World& world = *world_;
  const Esdf& esdf = world.esdf();
  const Box& bounds = world.bounds();
  const double step = settings_.duration / samples;
  // Far from every obstacle the penalty is zero and no collision is possible, and the cheap
  // nearest-voxel value tells so: it is within far_slack_ of the trilinear value.
  const double far = std::max(settings_.robot_radius + 2.0 * margin,
                              settings_.robot_radius + settings_.safety_distance) +
                     far_slack_;
  const Eigen::Vector3d end = result.end.col(0);
  Eigen::Vector3d previous = start.col(0);
  double penalty_sum = 0.0;
  // The first sample alone covers the stretch from the start (whose clearance is only known
  // to be above the radius): twice the margin.
  double threshold = settings_.robot_radius + 2.0 * margin;
  for (int k = 1; k <= samples; ++k) {
    const Eigen::Vector3d position = samplePosition(start, control, end, k, samples);
    ++result.esdf_queries;
    result.length += (position - previous).norm();
    previous = position;
    if (!bounds.contains(position)) {
      result.collision_time = step * k;
      return result;
    }
    if (esdf.nearestDistance(position) >= far) {
      threshold = settings_.robot_radius + margin;
      continue;
    }
    const double distance = esdf.distance(position);
    if (distance < threshold) {
      result.collision_time = step * k;
      return result;
    }
    threshold = settings_.robot_radius + margin;
    penalty_sum += penalty(distance);
  }
  result.collision_free = true;
  result.obstacle_cost = settings_.weights.obstacle * penalty_sum * step;
  result.cost =
      mapFreeCost(control) + settings_.weights.length * result.length + result.obstacle_cost;
  return result;
}

EdgeEvaluation EdgeEvaluator::controlOnly(const ChainState& start,
                                          const Eigen::Vector3d& control) const {
  EdgeEvaluation result;
  result.end = endState(start, control);
  result.within_limits = chain_.withinLimits(start, control, settings_.duration, settings_.limits);
  if (!result.within_limits) return result;
  result.samples = sampleCount(start, control);
  const Eigen::Vector3d end = result.end.col(0);
  result.length = (end - start.col(0)).norm();
  if (!world_->bounds().contains(end)) {
    result.collision_time = settings_.duration;
    return result;
  }
  result.collision_free = true;
  result.cost = mapFreeCost(control) + settings_.weights.length * result.length;
  return result;
}

bool EdgeEvaluator::certify(const ChainState& start, double start_distance,
                            const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const {
  if (!evaluation.valid() || !std::isfinite(evaluation.end_distance)) return false;
  const double path_bound = pathBound(start, control);
  const int samples = sampleCountFor(path_bound);
  const double needed = std::max(settings_.robot_radius + 2.0 * sampleMargin(path_bound, samples),
                                 settings_.robot_radius + settings_.safety_distance);
  const double lower = 0.5 * (start_distance + evaluation.end_distance - lipschitz_ * path_bound);
  if (lower < needed) return false;
  // Every sample within half the path bound of an endpoint: both endpoints that far inside.
  const Box& bounds = world_->bounds();
  const Eigen::Vector3d inset = Eigen::Vector3d::Constant(0.5 * path_bound);
  const Box inner{bounds.min + inset, bounds.max - inset};
  const Eigen::Vector3d end = evaluation.end.col(0);
  if (!inner.contains(start.col(0)) || !inner.contains(end)) return false;
  evaluation.samples = samples;
  evaluation.obstacle_cost = 0.0;
  evaluation.length = 0.0;
  if (settings_.weights.length > 0.0) {
    // The polyline full evaluation measures, through the same sample positions.
    Eigen::Vector3d previous = start.col(0);
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
