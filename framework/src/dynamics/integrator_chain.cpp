#include "kinolab/dynamics/integrator_chain.hpp"

#include <cmath>

#include "kinolab/core/error.hpp"

namespace kinolab {
namespace {

constexpr double kInverseFactorial[] = {1.0, 1.0, 1.0 / 2.0, 1.0 / 6.0, 1.0 / 24.0};

/// Coefficients, lowest power first, of the k-th derivative of one axis as a polynomial in
/// time under a constant control; returns the degree (order - k).
int derivativePolynomial(const ChainState& state, const Eigen::Vector3d& control, int order,
                         int derivative, int axis, double coefficients[5]) {
  const int degree = order - derivative;
  for (int m = 0; m < degree; ++m) {
    coefficients[m] = state(axis, derivative + m) * kInverseFactorial[m];
  }
  coefficients[degree] = control[axis] * kInverseFactorial[degree];
  return degree;
}

double evaluatePolynomial(const double coefficients[5], int degree, double t) {
  double value = coefficients[degree];
  for (int m = degree - 1; m >= 0; --m) value = value * t + coefficients[m];
  return value;
}

/// Times in (0, duration) where the polynomial's derivative vanishes (its degree is <= 2
/// for every derivative we bound), plus the two ends.
int extremumCandidates(const double coefficients[5], int degree, double duration, double times[4]) {
  int count = 0;
  times[count++] = 0.0;
  times[count++] = duration;
  auto add = [&](double t) {
    if (t > 0.0 && t < duration) times[count++] = t;
  };
  if (degree == 2) {
    // p' = c1 + 2 c2 t
    if (coefficients[2] != 0.0) add(-coefficients[1] / (2.0 * coefficients[2]));
  } else if (degree == 3) {
    // p' = c1 + 2 c2 t + 3 c3 t^2
    const double a = 3.0 * coefficients[3];
    const double b = 2.0 * coefficients[2];
    const double c = coefficients[1];
    if (a == 0.0) {
      if (b != 0.0) add(-c / b);
    } else {
      const double discriminant = b * b - 4.0 * a * c;
      if (discriminant >= 0.0) {
        // The numerically stable form of the quadratic roots.
        const double q = -0.5 * (b + std::copysign(std::sqrt(discriminant), b));
        if (q != 0.0) {
          add(q / a);
          add(c / q);
        } else {
          add(0.0);
        }
      }
    }
  } else if (degree > 3) {
    throw InvalidArgument("integrator chain: limit check on a polynomial of degree > 3");
  }
  return count;
}

}  // namespace

DynamicLimits::DynamicLimits() { bound.fill(Eigen::Vector3d::Constant(INFINITY)); }

DynamicLimits DynamicLimits::uniform(double velocity, double acceleration, double jerk,
                                     double snap) {
  DynamicLimits limits;
  limits.bound[1].setConstant(velocity);
  limits.bound[2].setConstant(acceleration);
  limits.bound[3].setConstant(jerk);
  limits.bound[4].setConstant(snap);
  return limits;
}

IntegratorChain::IntegratorChain(int order, Propagation propagation, int euler_steps)
    : order_(order), propagation_(propagation), euler_steps_(euler_steps) {
  if (order < 2 || order > 4) {
    throw InvalidArgument("integrator chain order must be 2, 3 or 4, got " + std::to_string(order));
  }
  if (euler_steps < 1) throw InvalidArgument("integrator chain: euler_steps must be >= 1");
}

ChainState IntegratorChain::stateAt(const ChainState& state, const Eigen::Vector3d& control,
                                    double t) const {
  double power[5];
  power[0] = 1.0;
  for (int j = 1; j <= order_; ++j) power[j] = power[j - 1] * t * (1.0 / j);  // t^j / j!
  ChainState result = ChainState::Zero();
  for (int k = 0; k < order_; ++k) {
    Eigen::Vector3d value = control * power[order_ - k];
    for (int m = order_ - 1; m >= k; --m) value += state.col(m) * power[m - k];
    result.col(k) = value;
  }
  return result;
}

ChainState IntegratorChain::propagate(const ChainState& state, const Eigen::Vector3d& control,
                                      double duration) const {
  if (propagation_ == Propagation::kExact) return stateAt(state, control, duration);
  ChainState result = state;
  const double step = duration / euler_steps_;
  for (int s = 0; s < euler_steps_; ++s) {
    // Lowest derivative first, so each update uses the previous step's higher derivative.
    for (int k = 0; k + 1 < order_; ++k) result.col(k) += step * result.col(k + 1);
    result.col(order_ - 1) += step * control;
  }
  return result;
}

Eigen::Vector3d IntegratorChain::maxAbsDerivative(const ChainState& state,
                                                  const Eigen::Vector3d& control, double duration,
                                                  int derivative) const {
  if (derivative < 1 || derivative >= order_) {
    throw InvalidArgument("maxAbsDerivative: derivative must be in [1, order)");
  }
  Eigen::Vector3d result;
  for (int axis = 0; axis < 3; ++axis) {
    double coefficients[5];
    const int degree = derivativePolynomial(state, control, order_, derivative, axis, coefficients);
    double times[4];
    const int count = extremumCandidates(coefficients, degree, duration, times);
    double best = 0.0;
    for (int i = 0; i < count; ++i) {
      best = std::max(best, std::abs(evaluatePolynomial(coefficients, degree, times[i])));
    }
    result[axis] = best;
  }
  return result;
}

std::optional<LimitViolation> IntegratorChain::checkLimits(const ChainState& state,
                                                           const Eigen::Vector3d& control,
                                                           double duration,
                                                           const DynamicLimits& limits) const {
  std::optional<LimitViolation> first;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(control[axis]) > limits.bound[order_][axis]) {
      return LimitViolation{order_, axis, 0.0, control[axis]};
    }
  }
  for (int derivative = 1; derivative < order_; ++derivative) {
    for (int axis = 0; axis < 3; ++axis) {
      const double bound = limits.bound[derivative][axis];
      if (std::isinf(bound)) continue;
      double coefficients[5];
      const int degree =
          derivativePolynomial(state, control, order_, derivative, axis, coefficients);
      double times[4];
      const int count = extremumCandidates(coefficients, degree, duration, times);
      for (int i = 0; i < count; ++i) {
        const double value = evaluatePolynomial(coefficients, degree, times[i]);
        if (std::abs(value) > bound && (!first || times[i] < first->time)) {
          first = LimitViolation{derivative, axis, times[i], value};
        }
      }
    }
  }
  return first;
}

bool IntegratorChain::withinLimits(const ChainState& state, const Eigen::Vector3d& control,
                                   double duration, const DynamicLimits& limits) const {
  using Eigen::Array3d;
  const auto within = [](const Array3d& value, const Eigen::Vector3d& bound) {
    return (value.abs() <= bound.array()).all();
  };
  if (!within(control.array(), limits.bound[order_])) return false;
  if (order_ == 2) {
    // Velocity is linear in time: its extremes are at the ends.
    const Array3d v0 = state.col(1).array();
    return within(v0, limits.bound[1]) && within(v0 + control.array() * duration, limits.bound[1]);
  }
  if (order_ == 3) {
    const Array3d v0 = state.col(1).array();
    const Array3d a0 = state.col(2).array();
    const Array3d u = control.array();
    if (!within(a0, limits.bound[2]) || !within(a0 + u * duration, limits.bound[2])) return false;
    const Array3d v_end = v0 + a0 * duration + 0.5 * u * duration * duration;
    if (!within(v0, limits.bound[1]) || !within(v_end, limits.bound[1])) return false;
    // Velocity is quadratic: its vertex, where acceleration a0 + u t vanishes, if inside.
    for (int axis = 0; axis < 3; ++axis) {
      if (u[axis] == 0.0) continue;
      const double vertex_time = -a0[axis] / u[axis];
      if (vertex_time > 0.0 && vertex_time < duration &&
          std::abs(v0[axis] - 0.5 * a0[axis] * a0[axis] / u[axis]) > limits.bound[1][axis]) {
        return false;
      }
    }
    return true;
  }
  return !checkLimits(state, control, duration, limits);
}

}  // namespace kinolab
