// The built-in samplers' own promises, beyond the conformance suite.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {
namespace {

std::vector<Eigen::Vector3d> sampleWith(const std::string& key,
                                        const std::vector<std::string>& settings,
                                        std::uint64_t seed = 7,
                                        Eigen::Vector3d u_max = Eigen::Vector3d::Ones()) {
  registerBuiltinPlugins();
  return pluginRegistry<ControlSampler>()
      .create(key, parseAssignments(settings, "test"))
      ->sample(u_max, seed);
}

/// The distinct x values of a set, sorted.
std::vector<double> xValues(const std::vector<Eigen::Vector3d>& controls) {
  std::set<double> values;
  for (const auto& control : controls) values.insert(control.x());
  return {values.begin(), values.end()};
}

TEST(UniformSampler, IsTheEvenGridWithEnds) {
  const auto controls = sampleWith("uniform", {"samples_per_axis=3"}, 1, {2.0, 1.0, 0.5});
  ASSERT_EQ(controls.size(), 27u);
  EXPECT_EQ(controls.front(), Eigen::Vector3d(-2.0, -1.0, -0.5));
  EXPECT_EQ(controls[13], Eigen::Vector3d::Zero());
  EXPECT_EQ(controls.back(), Eigen::Vector3d(2.0, 1.0, 0.5));
  EXPECT_EQ(xValues(sampleWith("uniform", {"samples_per_axis=5"})),
            (std::vector<double>{-1.0, -0.5, 0.0, 0.5, 1.0}));
  EXPECT_EQ(sampleWith("uniform", {"samples_per_axis=1"}),
            std::vector<Eigen::Vector3d>{Eigen::Vector3d::Zero()});
}

TEST(NormalSampler, QuantilesAreSymmetricIncludeTheEndsAndCrowdZero) {
  const auto values = xValues(sampleWith("normal", {"samples_per_axis=7", "sigma=0.4"}));
  ASSERT_EQ(values.size(), 7u);
  EXPECT_EQ(values.front(), -1.0);
  EXPECT_EQ(values.back(), 1.0);
  EXPECT_EQ(values[3], 0.0);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(values[i], -values[6 - i], 1e-12);
  // Gaps grow away from zero (the density falls), unlike the uniform grid's equal gaps.
  for (int i = 3; i < 5; ++i) EXPECT_LT(values[i + 1] - values[i], values[i + 2] - values[i + 1]);
  EXPECT_LT(values[4], 1.0 / 3.0);  // the uniform grid's first positive value
  // P(X < q_k) = k / (n - 1) for the truncated normal: check one quantile by hand.
  // sigma 0.4: Phi(-2.5) = 0.0062097, Phi(2.5) = 0.9937903; q_4 has mass 4/6 of the interval.
  const double p = 0.0062096653 + (4.0 / 6.0) * (0.9937903347 - 0.0062096653);
  EXPECT_NEAR(0.5 * std::erfc(-values[4] / 0.4 / std::sqrt(2.0)), p, 1e-8);
  // A very wide normal is nearly uniform.
  const auto wide = xValues(sampleWith("normal", {"samples_per_axis=5", "sigma=10"}));
  EXPECT_NEAR(wide[3], 0.5, 0.01);
}

TEST(NormalSampler, RandomDrawsFollowTheTruncatedNormal) {
  const auto controls =
      sampleWith("normal", {"samples_per_axis=30", "variant=random", "sigma=0.5"}, 3);
  ASSERT_EQ(controls.size(), 27000u);
  double sum = 0.0;
  double squares = 0.0;
  for (const auto& control : controls) {
    sum += control.x();
    squares += control.x() * control.x();
  }
  const double n = static_cast<double>(controls.size());
  // Variance of N(0, s^2) truncated to [-1, 1]: s^2 (1 - 2 phi(a) a / (2 Phi(a) - 1)), a = 1/s.
  const double s = 0.5;
  const double a = 1.0 / s;
  const double phi = std::exp(-0.5 * a * a) / std::sqrt(2.0 * M_PI);
  const double mass = std::erf(a / std::sqrt(2.0));
  const double variance = s * s * (1.0 - 2.0 * a * phi / mass);
  EXPECT_NEAR(sum / n, 0.0, 5.0 * std::sqrt(variance / n));
  EXPECT_NEAR(squares / n, variance, 0.02 * variance);
  // Another seed, another set.
  EXPECT_NE(sampleWith("normal", {"variant=random"}, 3),
            sampleWith("normal", {"variant=random"}, 4));
}

TEST(RandomSampler, DrawsUniformlyAndDependsOnTheSeed) {
  const auto controls = sampleWith("random", {"samples_per_axis=30"}, 11, {2.0, 2.0, 2.0});
  ASSERT_EQ(controls.size(), 27000u);
  double sum = 0.0;
  double squares = 0.0;
  for (const auto& control : controls) {
    sum += control.z();
    squares += control.z() * control.z();
  }
  const double n = static_cast<double>(controls.size());
  EXPECT_NEAR(sum / n, 0.0, 0.05);
  EXPECT_NEAR(squares / n, 4.0 / 3.0, 0.03);  // variance of U(-2, 2)
  EXPECT_NE(sampleWith("random", {}, 1), sampleWith("random", {}, 2));
}

}  // namespace
}  // namespace kinolab
