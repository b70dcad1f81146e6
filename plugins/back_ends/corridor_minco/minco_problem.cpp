#include "minco_problem.hpp"

#include <lbfgs.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace kinolab::minco {

double durationOf(double tau) {
  if (tau > 0.0) return (0.5 * tau + 1.0) * tau + 1.0;
  return 1.0 / ((0.5 * tau - 1.0) * tau + 1.0);
}

double durationDerivative(double tau) {
  if (tau > 0.0) return tau + 1.0;
  const double denominator = (0.5 * tau - 1.0) * tau + 1.0;
  return (1.0 - tau) / (denominator * denominator);
}

double tauOf(double duration) {
  if (duration > 1.0) return std::sqrt(2.0 * duration - 1.0) - 1.0;
  return 1.0 - std::sqrt(2.0 / duration - 1.0);
}

namespace {

Eigen::Matrix3Xd headOf(int order, const ChainState& start) {
  Eigen::Matrix3Xd head = Eigen::Matrix3Xd::Zero(3, order);
  head.leftCols(std::min(order, 4)) = start.leftCols(std::min(order, 4));
  return head;
}

Eigen::Matrix3Xd tailOf(int order, const Eigen::Vector3d& end) {
  Eigen::Matrix3Xd tail = Eigen::Matrix3Xd::Zero(3, order);
  tail.col(0) = end;
  return tail;
}

/// The cubic penalty of an excess and its derivative.
std::pair<double, double> cubic(double excess) {
  if (excess <= 0.0) return {0.0, 0.0};
  return {excess * excess * excess, 3.0 * excess * excess};
}

}  // namespace

MincoProblem::MincoProblem(int order, const ChainState& start, const Eigen::Vector3d& end,
                           std::vector<Polytope> corridors, std::vector<int> corridor_of_piece,
                           ProblemWeights weights)
    : minco_(order, headOf(order, start), tailOf(order, end)),
      corridors_(std::move(corridors)),
      corridor_of_piece_(std::move(corridor_of_piece)),
      weights_(weights) {}

Eigen::VectorXd MincoProblem::variables(const Eigen::Matrix3Xd& waypoints,
                                        const Eigen::VectorXd& durations) const {
  const int m = pieces();
  Eigen::VectorXd x(m + 3 * (m - 1));
  for (int i = 0; i < m; ++i) x(i) = tauOf(durations(i));
  x.tail(3 * (m - 1)) = waypoints.reshaped();
  return x;
}

void MincoProblem::unpack(const Eigen::VectorXd& x) {
  const int m = pieces();
  durations_.resize(m);
  for (int i = 0; i < m; ++i) durations_(i) = durationOf(x(i));
  waypoints_ = x.tail(3 * (m - 1)).reshaped(3, m - 1);
  minco_.setParameters(waypoints_, durations_);
}

double MincoProblem::piecePenalty(int piece, Eigen::MatrixX3d& gradient_coefficients,
                                  Eigen::VectorXd& gradient_durations,
                                  Violations* violations) const {
  return minco_.s() == 3
             ? piecePenaltyOf<6>(piece, gradient_coefficients, gradient_durations, violations)
             : piecePenaltyOf<8>(piece, gradient_coefficients, gradient_durations, violations);
}

template <int N>
double MincoProblem::piecePenaltyOf(int piece, Eigen::MatrixX3d& gradient_coefficients,
                                    Eigen::VectorXd& gradient_durations,
                                    Violations* violations) const {
  // k! / (k - d)!: the factor of t^(k - d) in the d-th derivative of t^k.
  static constexpr double kFalling[8][4] = {{1, 0, 0, 0},    {1, 1, 0, 0},   {1, 2, 2, 0},
                                            {1, 3, 6, 6},    {1, 4, 12, 24}, {1, 5, 20, 60},
                                            {1, 6, 30, 120}, {1, 7, 42, 210}};
  const Polytope& polytope = corridors_[static_cast<std::size_t>(corridor_of_piece_[piece])];
  const int samples = weights_.samples;
  const double duration = durations_(piece);
  const Eigen::Matrix<double, N, 3> coefficients = minco_.coefficients(piece);
  Eigen::Matrix<double, N, 3> gradient = Eigen::Matrix<double, N, 3>::Zero();
  Eigen::Matrix<double, N, 4> basis;  // (k, d): the d-th derivative of t^k
  double total = 0.0;
  for (int j = 0; j <= samples; ++j) {
    const double fraction = static_cast<double>(j) / samples;
    const double t = fraction * duration;
    double power[N];
    power[0] = 1.0;
    for (int k = 1; k < N; ++k) power[k] = power[k - 1] * t;
    for (int k = 0; k < N; ++k) {
      for (int d = 0; d < 4; ++d) basis(k, d) = k >= d ? kFalling[k][d] * power[k - d] : 0.0;
    }
    const Eigen::Matrix<double, 3, 4> state = coefficients.transpose() * basis;  // p, v, a, j
    const Penalty penalty = samplePenalty(polytope, state, violations);
    if (penalty.value == 0.0) continue;
    // The trapezoid rule's weight of this sample.
    const double share = (j == 0 || j == samples ? 0.5 : 1.0) / samples;
    total += share * duration * penalty.value;
    gradient.noalias() +=
        (share * duration) * basis.template leftCols<3>() * penalty.gradient.transpose();
    // The sample moves with T (t = fraction T) and so does its weight.
    const double along = penalty.gradient.cwiseProduct(state.rightCols<3>()).sum();
    gradient_durations(piece) += share * (penalty.value + duration * along * fraction);
  }
  gradient_coefficients.middleRows<N>(N * piece) += gradient;
  return total;
}

MincoProblem::Penalty MincoProblem::samplePenalty(const Polytope& polytope,
                                                  const Eigen::Matrix<double, 3, 4>& state,
                                                  Violations* violations) const {
  Penalty penalty;
  double worst = -INFINITY;
  for (int h = 0; h < polytope.size(); ++h) {
    const double excess = polytope.normals.col(h).dot(state.col(0)) - polytope.offsets(h);
    worst = std::max(worst, excess);
    const auto [cost, slope] = cubic(excess + weights_.corridor_margin);
    if (cost == 0.0) continue;
    penalty.value += weights_.corridor * cost;
    penalty.gradient.col(0) += weights_.corridor * slope * polytope.normals.col(h);
  }
  for (int axis = 0; axis < 3; ++axis) {
    const double v = state(axis, 1);
    const double a = state(axis, 2);
    const double v_max = weights_.max_velocity(axis);
    const double a_max = weights_.max_acceleration(axis);
    const auto [v_cost, v_slope] = cubic(v * v - v_max * v_max);
    const auto [a_cost, a_slope] = cubic(a * a - a_max * a_max);
    penalty.value += weights_.velocity * v_cost + weights_.acceleration * a_cost;
    penalty.gradient(axis, 1) += weights_.velocity * v_slope * 2.0 * v;
    penalty.gradient(axis, 2) += weights_.acceleration * a_slope * 2.0 * a;
  }
  if (violations != nullptr) {
    violations->corridor = std::max(violations->corridor, worst);
    violations->velocity = std::max(violations->velocity,
                                    (state.col(1).cwiseAbs() - weights_.max_velocity).maxCoeff());
    violations->acceleration = std::max(
        violations->acceleration, (state.col(2).cwiseAbs() - weights_.max_acceleration).maxCoeff());
  }
  return penalty;
}

double MincoProblem::cost(const Eigen::VectorXd& x, Eigen::VectorXd& gradient) {
  unpack(x);
  const int m = pieces();
  Eigen::MatrixX3d gradient_coefficients = Eigen::MatrixX3d::Zero(2 * minco_.s() * m, 3);
  Eigen::VectorXd partial_durations = Eigen::VectorXd::Constant(m, weights_.time);
  double total = minco_.energy(gradient_coefficients, partial_durations);
  total += weights_.time * durations_.sum();
  for (int i = 0; i < m; ++i) {
    total += piecePenalty(i, gradient_coefficients, partial_durations, nullptr);
  }
  Eigen::Matrix3Xd gradient_waypoints;
  Eigen::VectorXd gradient_durations;
  minco_.propagate(gradient_coefficients, partial_durations, gradient_waypoints,
                   gradient_durations);
  gradient.resize(x.size());
  for (int i = 0; i < m; ++i) gradient(i) = gradient_durations(i) * durationDerivative(x(i));
  gradient.tail(3 * (m - 1)) = gradient_waypoints.reshaped();
  return total;
}

Trajectory MincoProblem::trajectory(const Eigen::VectorXd& x) {
  unpack(x);
  return minco_.trajectory();
}

Violations MincoProblem::violations(const Eigen::VectorXd& x) {
  unpack(x);
  const int m = pieces();
  Eigen::MatrixX3d gradient_coefficients = Eigen::MatrixX3d::Zero(2 * minco_.s() * m, 3);
  Eigen::VectorXd gradient_durations = Eigen::VectorXd::Zero(m);
  Violations violations{-INFINITY, -INFINITY, -INFINITY};
  for (int i = 0; i < m; ++i) {
    piecePenalty(i, gradient_coefficients, gradient_durations, &violations);
  }
  violations.corridor = std::max(violations.corridor, 0.0);
  violations.velocity = std::max(violations.velocity, 0.0);
  violations.acceleration = std::max(violations.acceleration, 0.0);
  return violations;
}

double MincoProblem::stretchNeeded(const Eigen::VectorXd& x, const DynamicLimits& limits) {
  unpack(x);
  double factor = 1.0;
  for (int i = 0; i < pieces(); ++i) {
    for (int j = 0; j <= kStretchSamples; ++j) {
      const double t = durations_(i) * j / kStretchSamples;
      const Eigen::Array3d v = minco_.evaluate(i, t, 1).array().abs() / limits.bound[1].array();
      const Eigen::Array3d a = minco_.evaluate(i, t, 2).array().abs() / limits.bound[2].array();
      factor = std::max({factor, v.maxCoeff(), std::sqrt(a.maxCoeff())});
    }
  }
  return factor;
}

Eigen::VectorXd MincoProblem::stretched(const Eigen::VectorXd& x, double factor) const {
  Eigen::VectorXd result = x;
  for (int i = 0; i < pieces(); ++i) result(i) = tauOf(durationOf(x(i)) * factor);
  return result;
}

namespace {

/// What liblbfgs's callbacks reach: the problem, the stop condition and the count.
struct Solve {
  MincoProblem* problem;
  StopCondition* stop;
  long long iterations_before;
  int size;  ///< variables of the problem (liblbfgs's array is padded beyond them)
  int iterations = 0;
};

lbfgsfloatval_t evaluate(void* instance, const lbfgsfloatval_t* x, lbfgsfloatval_t* g, int n,
                         lbfgsfloatval_t /*step*/) {
  Solve& solve = *static_cast<Solve*>(instance);
  const Eigen::VectorXd variables = Eigen::Map<const Eigen::VectorXd>(x, solve.size);
  Eigen::VectorXd gradient;
  const double value = solve.problem->cost(variables, gradient);
  Eigen::Map<Eigen::VectorXd>(g, n).setZero();
  Eigen::Map<Eigen::VectorXd>(g, solve.size) = gradient;
  return value;
}

int progress(void* instance, const lbfgsfloatval_t*, const lbfgsfloatval_t*, lbfgsfloatval_t,
             lbfgsfloatval_t, lbfgsfloatval_t, lbfgsfloatval_t, int, int k, int) {
  Solve& solve = *static_cast<Solve*>(instance);
  solve.iterations = k;
  return solve.stop->expired(solve.iterations_before + k) ? 1 : 0;
}

}  // namespace

MincoProblem::Outcome MincoProblem::optimise(Eigen::VectorXd& x, int max_iterations,
                                             double relative_tolerance, StopCondition& stop,
                                             long long iterations_before) {
  const int size = static_cast<int>(x.size());
  // A build of liblbfgs with SSE wants a multiple of 16 variables in aligned memory: the
  // padding variables have zero gradient and never move.
  const int padded = (size + 15) / 16 * 16;
  lbfgsfloatval_t* memory = lbfgs_malloc(padded);
  Eigen::Map<Eigen::VectorXd> variables(memory, padded);
  variables.setZero();
  variables.head(size) = x;
  lbfgs_parameter_t parameters;
  lbfgs_parameter_init(&parameters);
  parameters.max_iterations = max_iterations;
  parameters.epsilon = 1e-6;
  parameters.past = 3;
  parameters.delta = relative_tolerance;
  Solve solve{this, &stop, iterations_before, size};
  Outcome outcome;
  lbfgsfloatval_t value = 0.0;
  outcome.status = lbfgs(padded, memory, &value, evaluate, progress, &solve, &parameters);
  outcome.iterations = solve.iterations;
  outcome.cost = value;
  x = variables.head(size);
  lbfgs_free(memory);
  return outcome;
}

}  // namespace kinolab::minco
