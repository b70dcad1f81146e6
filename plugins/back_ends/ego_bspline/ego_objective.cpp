#include "ego_objective.hpp"

#include <lbfgs.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace kinolab::ego {
namespace {

/// The first and last three control points are fixed (start state, rest at the end).
constexpr int kFixed = 3;

/// The squared excess of |value| over `limit` and its derivative by `value`.
std::pair<double, double> excess(double value, double limit) {
  const double over = std::abs(value) - limit;
  if (over <= 0.0) return {0.0, 0.0};
  return {over * over, 2.0 * over * (value > 0.0 ? 1.0 : -1.0)};
}

struct Minimisation {
  const EgoObjective& objective;
  Eigen::Matrix3Xd& control;
  double interval;
  const StopCondition& stop;
  int iterations = 0;
};

lbfgsfloatval_t evaluateFree(void* instance, const lbfgsfloatval_t* x, lbfgsfloatval_t* g,
                             const int n, const lbfgsfloatval_t /*step*/) {
  auto& m = *static_cast<Minimisation*>(instance);
  const int free = n / 3;
  m.control.middleCols(kFixed, free) = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, free);
  Eigen::Matrix3Xd gradient;
  const double cost = m.objective.evaluate(m.control, m.interval, &gradient);
  Eigen::Map<Eigen::Matrix3Xd>(g, 3, free) = gradient.middleCols(kFixed, free);
  return cost;
}

int progress(void* instance, const lbfgsfloatval_t*, const lbfgsfloatval_t*, lbfgsfloatval_t,
             lbfgsfloatval_t, lbfgsfloatval_t, lbfgsfloatval_t, int, int k, int) {
  auto& m = *static_cast<Minimisation*>(instance);
  m.iterations = k;
  return m.stop.elapsed() >= m.stop.budget().time_limit ? 1 : 0;
}

}  // namespace

EgoObjective::EgoObjective(const ObjectiveWeights& weights, const DynamicLimits& limits,
                           double safe_distance)
    : weights_(weights), limits_(limits), safe_distance_(safe_distance) {}

double EgoObjective::evaluate(const Eigen::Matrix3Xd& control, double interval,
                              Eigen::Matrix3Xd* gradient) const {
  Eigen::Matrix3Xd part;
  Eigen::Matrix3Xd* want = gradient ? &part : nullptr;
  if (gradient) gradient->setZero(3, control.cols());
  double cost = 0.0;
  const auto add = [&](double weight, double value) {
    cost += weight * value;
    if (gradient) *gradient += weight * part;
  };
  add(weights_.smoothness, smoothness(control, want));
  add(weights_.collision, collision(control, want));
  add(weights_.feasibility, feasibility(control, interval, want));
  if (reference_.cols() > 0) add(weights_.fitness, fitness(control, want));
  return cost;
}

double EgoObjective::collision(const Eigen::Matrix3Xd& control, Eigen::Matrix3Xd* gradient) const {
  if (gradient) gradient->setZero(3, control.cols());
  const double s = safe_distance_;
  // Beyond a shortfall of s the cubic continues as its second-order expansion at s.
  const double a = 3.0 * s;
  const double b = -3.0 * s * s;
  const double c = s * s * s;
  double cost = 0.0;
  const int end = std::min<int>(static_cast<int>(control.cols()), static_cast<int>(pairs_.size()));
  for (int i = 0; i < end; ++i) {
    for (const RepulsionPair& pair : pairs_[i]) {
      const double shortfall = s - (control.col(i) - pair.anchor).dot(pair.direction);
      if (shortfall <= 0.0) continue;
      double slope = 0.0;
      if (shortfall < s) {
        cost += shortfall * shortfall * shortfall;
        slope = 3.0 * shortfall * shortfall;
      } else {
        cost += a * shortfall * shortfall + b * shortfall + c;
        slope = 2.0 * a * shortfall + b;
      }
      if (gradient) gradient->col(i) -= slope * pair.direction;
    }
  }
  return cost;
}

double EgoObjective::smoothness(const Eigen::Matrix3Xd& control, Eigen::Matrix3Xd* gradient) {
  if (gradient) gradient->setZero(3, control.cols());
  double cost = 0.0;
  for (int i = 0; i + 3 < control.cols(); ++i) {
    const Eigen::Vector3d jerk =
        control.col(i + 3) - 3.0 * control.col(i + 2) + 3.0 * control.col(i + 1) - control.col(i);
    cost += jerk.squaredNorm();
    if (!gradient) continue;
    gradient->col(i) -= 2.0 * jerk;
    gradient->col(i + 1) += 6.0 * jerk;
    gradient->col(i + 2) -= 6.0 * jerk;
    gradient->col(i + 3) += 2.0 * jerk;
  }
  return cost;
}

double EgoObjective::feasibility(const Eigen::Matrix3Xd& control, double interval,
                                 Eigen::Matrix3Xd* gradient) const {
  if (gradient) gradient->setZero(3, control.cols());
  double cost = 0.0;
  const int count = static_cast<int>(control.cols());
  for (int i = 0; i + 1 < count; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      const double velocity = (control(axis, i + 1) - control(axis, i)) / interval;
      const auto [value, slope] = excess(velocity, limits_.bound[1][axis]);
      cost += value;
      if (gradient && slope != 0.0) {
        (*gradient)(axis, i) -= slope / interval;
        (*gradient)(axis, i + 1) += slope / interval;
      }
    }
  }
  const double inverse_square = 1.0 / (interval * interval);
  for (int i = 0; i + 2 < count; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      const double acceleration =
          (control(axis, i + 2) - 2.0 * control(axis, i + 1) + control(axis, i)) * inverse_square;
      const auto [value, slope] = excess(acceleration, limits_.bound[2][axis]);
      cost += value;
      if (gradient && slope != 0.0) {
        (*gradient)(axis, i) += slope * inverse_square;
        (*gradient)(axis, i + 1) -= 2.0 * slope * inverse_square;
        (*gradient)(axis, i + 2) += slope * inverse_square;
      }
    }
  }
  return cost;
}

double EgoObjective::fitness(const Eigen::Matrix3Xd& control, Eigen::Matrix3Xd* gradient) const {
  if (gradient) gradient->setZero(3, control.cols());
  constexpr double kAlong = 25.0;  // EGO's a^2: deviation along the curve is cheap
  constexpr double kAcross = 1.0;  // b^2
  double cost = 0.0;
  const int knots =
      std::min<int>(static_cast<int>(reference_.cols()), static_cast<int>(control.cols()) - 2);
  for (int k = 0; k < knots; ++k) {
    const Eigen::Vector3d x =
        (control.col(k) + 4.0 * control.col(k + 1) + control.col(k + 2)) / 6.0 - reference_.col(k);
    const int before = std::max(k - 1, 0);
    const int after = std::min(k + 1, knots - 1);
    Eigen::Vector3d v = reference_.col(after) - reference_.col(before);
    if (v.norm() < 1e-12) continue;  // no tangent (the curve rests): no anisotropy to define
    v.normalize();
    const double along = x.dot(v);
    const Eigen::Vector3d across = x.cross(v);
    cost += along * along / kAlong + across.squaredNorm() / kAcross;
    if (!gradient) continue;
    const Eigen::Vector3d slope = 2.0 * along / kAlong * v + 2.0 / kAcross * v.cross(across);
    gradient->col(k) += slope / 6.0;
    gradient->col(k + 1) += 4.0 * slope / 6.0;
    gradient->col(k + 2) += slope / 6.0;
  }
  return cost;
}

int minimise(const EgoObjective& objective, Eigen::Matrix3Xd& control, double interval,
             int iterations, const StopCondition& stop) {
  const int free = static_cast<int>(control.cols()) - 2 * kFixed;
  if (free <= 0) return 0;
  const int n = 3 * free;
  lbfgsfloatval_t* x = lbfgs_malloc(n);
  Eigen::Map<Eigen::Matrix3Xd>(x, 3, free) = control.middleCols(kFixed, free);
  lbfgs_parameter_t parameters;
  lbfgs_parameter_init(&parameters);
  parameters.m = 16;
  parameters.max_iterations = iterations;
  parameters.epsilon = 1e-5;
  parameters.max_linesearch = 60;
  Minimisation m{objective, control, interval, stop};
  lbfgsfloatval_t cost = 0.0;
  lbfgs(n, x, &cost, &evaluateFree, &progress, &m, &parameters);
  // Whatever the status (converged, iteration cap, a line search that could not improve),
  // lbfgs leaves in x the best point it accepted.
  control.middleCols(kFixed, free) = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, free);
  lbfgs_free(x);
  return m.iterations;
}

}  // namespace kinolab::ego
