#include "kinolab/dynamics/integrator_chain.hpp"

#include <gtest/gtest.h>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"

namespace kinolab {
namespace {

ChainState randomState(Rng& rng, int order, double scale = 2.0) {
  ChainState state = ChainState::Zero();
  for (int k = 0; k < order; ++k) {
    for (int axis = 0; axis < 3; ++axis) state(axis, k) = rng.uniform(-scale, scale);
  }
  return state;
}

Eigen::Vector3d randomControl(Rng& rng, double scale = 3.0) {
  return {rng.uniform(-scale, scale), rng.uniform(-scale, scale), rng.uniform(-scale, scale)};
}

/// Classical Runge-Kutta on the chain's ODE, independent of the closed form.
ChainState integrateRk4(const ChainState& start, const Eigen::Vector3d& control, int order,
                        double duration, int steps) {
  auto derivative = [&](const ChainState& x) {
    ChainState dx = ChainState::Zero();
    for (int k = 0; k + 1 < order; ++k) dx.col(k) = x.col(k + 1);
    dx.col(order - 1) = control;
    return dx;
  };
  ChainState x = start;
  const double h = duration / steps;
  for (int s = 0; s < steps; ++s) {
    const ChainState k1 = derivative(x);
    const ChainState k2 = derivative(x + 0.5 * h * k1);
    const ChainState k3 = derivative(x + 0.5 * h * k2);
    const ChainState k4 = derivative(x + h * k3);
    x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  return x;
}

class IntegratorChainOrderTest : public ::testing::TestWithParam<int> {};

TEST_P(IntegratorChainOrderTest, ClosedFormMatchesFineNumericalIntegration) {
  const int order = GetParam();
  const IntegratorChain chain(order);
  Rng rng(100 + order);
  for (int trial = 0; trial < 200; ++trial) {
    const ChainState start = randomState(rng, order);
    const Eigen::Vector3d control = randomControl(rng);
    const double duration = rng.uniform(0.05, 2.0);
    const ChainState exact = chain.propagate(start, control, duration);
    const ChainState numeric = integrateRk4(start, control, order, duration, 1000);
    EXPECT_LT((exact - numeric).cwiseAbs().maxCoeff(), 1e-9);
    // Unused columns stay zero.
    EXPECT_TRUE(exact.rightCols(4 - order).isZero());
  }
}

TEST_P(IntegratorChainOrderTest, EulerStepsConvergeToTheClosedForm) {
  const int order = GetParam();
  Rng rng(7);
  const ChainState start = randomState(rng, order);
  const Eigen::Vector3d control = randomControl(rng);
  const ChainState exact = IntegratorChain(order).propagate(start, control, 1.0);
  const double coarse =
      (IntegratorChain(order, Propagation::kEuler, 10).propagate(start, control, 1.0) - exact)
          .cwiseAbs()
          .maxCoeff();
  const double fine =
      (IntegratorChain(order, Propagation::kEuler, 10000).propagate(start, control, 1.0) - exact)
          .cwiseAbs()
          .maxCoeff();
  EXPECT_GT(coarse, 1e-3);  // Euler is a real approximation ...
  EXPECT_LT(fine, 2e-3);    // ... that converges (first order) ...
  EXPECT_LT(fine, coarse / 100.0);
}

TEST_P(IntegratorChainOrderTest, ExactMaximaBoundDenseSamplingTightly) {
  const int order = GetParam();
  const IntegratorChain chain(order);
  Rng rng(200 + order);
  for (int trial = 0; trial < 300; ++trial) {
    const ChainState start = randomState(rng, order);
    const Eigen::Vector3d control = randomControl(rng);
    const double duration = rng.uniform(0.1, 2.0);
    for (int derivative = 1; derivative < order; ++derivative) {
      const Eigen::Vector3d exact = chain.maxAbsDerivative(start, control, duration, derivative);
      Eigen::Vector3d sampled = Eigen::Vector3d::Zero();
      const int samples = 4000;
      for (int i = 0; i <= samples; ++i) {
        const ChainState at = chain.stateAt(start, control, duration * i / samples);
        sampled = sampled.cwiseMax(at.col(derivative).cwiseAbs());
      }
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_GE(exact[axis], sampled[axis] - 1e-12);
        EXPECT_LE(exact[axis], sampled[axis] + 1e-4);
      }
    }
  }
}

TEST_P(IntegratorChainOrderTest, LimitVerdictAgreesWithDenseSampling) {
  const int order = GetParam();
  const IntegratorChain chain(order);
  const DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0, 6.0, 12.0);
  Rng rng(300 + order);
  int feasible = 0;
  int infeasible = 0;
  int interior_only = 0;  // broken between the end points only: an end-point check misses it
  for (int trial = 0; trial < 2000; ++trial) {
    // Start inside the limits, so that every violation happens during the primitive.
    ChainState start = ChainState::Zero();
    for (int k = 1; k < order; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        start(axis, k) = rng.uniform(-limits.bound[k][axis], limits.bound[k][axis]);
      }
    }
    const Eigen::Vector3d control = randomControl(rng, limits.bound[order].x());
    const double duration = rng.uniform(0.1, 2.0);
    bool dense_ok = true;
    const int samples = 2000;
    for (int i = 0; i <= samples && dense_ok; ++i) {
      const ChainState at = chain.stateAt(start, control, duration * i / samples);
      for (int k = 1; k < order; ++k) {
        if ((at.col(k).cwiseAbs().array() > limits.bound[k].array()).any()) dense_ok = false;
      }
    }
    const auto violation = chain.checkLimits(start, control, duration, limits);
    if (dense_ok) {
      // Dense sampling can miss a violation that the exact check finds, but only a tiny one.
      if (violation) {
        EXPECT_LT(std::abs(violation->value) - limits.bound[violation->derivative][violation->axis],
                  1e-3);
      }
      ++feasible;
    } else {
      ASSERT_TRUE(violation.has_value()) << "dense sampling found a violation the check missed";
      ++infeasible;
      const ChainState end = chain.stateAt(start, control, duration);
      bool ends_ok = true;
      for (int k = 1; k < order; ++k) {
        ends_ok = ends_ok && (start.col(k).cwiseAbs().array() <= limits.bound[k].array()).all() &&
                  (end.col(k).cwiseAbs().array() <= limits.bound[k].array()).all();
      }
      if (ends_ok) ++interior_only;
    }
  }
  EXPECT_GT(feasible, 50);
  EXPECT_GT(infeasible, 50);
  if (order > 2) {
    EXPECT_GT(interior_only, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Orders, IntegratorChainOrderTest, ::testing::Values(2, 3, 4));

TEST(IntegratorChainTest, ReportsTheControlLimitAndTheViolationTime) {
  const IntegratorChain chain(2);
  const DynamicLimits limits = DynamicLimits::uniform(1.0, 2.0);
  ChainState start = ChainState::Zero();
  EXPECT_EQ(chain.checkLimits(start, {3.0, 0.0, 0.0}, 1.0, limits)->derivative, 2);
  // From rest with a = 2 along y, the velocity passes 1 m/s at t = 0.5 and peaks at t = 1.
  const auto violation = chain.checkLimits(start, {0.0, 2.0, 0.0}, 1.0, limits);
  ASSERT_TRUE(violation.has_value());
  EXPECT_EQ(violation->derivative, 1);
  EXPECT_EQ(violation->axis, 1);
  EXPECT_DOUBLE_EQ(violation->value, 2.0);
  EXPECT_TRUE(chain.withinLimits(start, {0.0, 2.0, 0.0}, 0.5, limits));
}

TEST(IntegratorChainTest, FastLimitVerdictAgreesWithTheDetailedCheck) {
  Rng rng(2024);
  const DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0, 4.0, 6.0);
  for (int order = 2; order <= 4; ++order) {
    const IntegratorChain chain(order);
    int rejected = 0;
    for (int trial = 0; trial < 20000; ++trial) {
      // States mostly inside the limits, controls up to their bound, so both verdicts occur.
      ChainState start = randomState(rng, order, 1.0);
      start.col(1) *= 2.0;
      const Eigen::Vector3d control = randomControl(rng, limits.bound[order].x());
      const double duration = rng.uniform(0.05, 1.5);
      const bool fast = chain.withinLimits(start, control, duration, limits);
      ASSERT_EQ(fast, !chain.checkLimits(start, control, duration, limits))
          << "order " << order << " trial " << trial;
      rejected += fast ? 0 : 1;
    }
    EXPECT_GT(rejected, 2000) << order;
    EXPECT_LT(rejected, 18000) << order;
  }
}

TEST(IntegratorChainTest, RejectsUnsupportedOrders) {
  EXPECT_THROW(IntegratorChain(1), InvalidArgument);
  EXPECT_THROW(IntegratorChain(5), InvalidArgument);
}

}  // namespace
}  // namespace kinolab
