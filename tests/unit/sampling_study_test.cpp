#include "kinolab/experiment/sampling_study.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"

namespace kinolab {
namespace {

std::string writeStudy(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("kinolab_" + name + ".yaml");
  std::ofstream(path) << text;
  return path.string();
}

const char* kStudy =
    "kind: sampling_study\nname: t\nseed: 5\nthreshold: 0.1\n"
    "dynamics: {order: 2, duration: 0.4, limits: {velocity: 2.0, acceleration: 3.0}}\n"
    "states: {rest: true, moving: 4, speed: [0.5, 2.0]}\n"
    "samplers:\n"
    "  - {id: coarse, type: uniform, params: {samples_per_axis: 5}}\n"
    "  - {id: fine, type: uniform, params: {samples_per_axis: 7}}\n";

TEST(SamplingStudy, NearestDistancesMatchAScanWithDuplicatesAndEveryDimension) {
  // The k-d tree against every pair: random clouds, lattices (ties on every axis) and
  // duplicates (distance 0), in 3 and 6 dimensions, from a single point to a few thousand.
  Rng rng(11);
  for (const int dims : {3, 6}) {
    for (const std::size_t n :
         {std::size_t{1}, std::size_t{2}, std::size_t{9}, std::size_t{40}, std::size_t{2000}}) {
      for (int shape = 0; shape < 3; ++shape) {
        std::vector<Eigen::Matrix<double, 6, 1>> points(n);
        for (std::size_t i = 0; i < n; ++i) {
          for (int k = 0; k < 6; ++k) {
            const double u = rng.uniform(-1.0, 1.0);
            points[i][k] = shape == 0 ? u : std::round(2.0 * u);  // shape 1, 2: a lattice
          }
          if (shape == 2 && i % 3 == 1) points[i] = points[i - 1];  // exact duplicates
        }
        const std::vector<double> nearest = nearestDistances(points, dims);
        ASSERT_EQ(nearest.size(), n);
        for (std::size_t i = 0; i < n; ++i) {
          double expected = INFINITY;
          for (std::size_t j = 0; j < n; ++j) {
            if (j != i) expected = std::min(expected, (points[i] - points[j]).head(dims).norm());
          }
          ASSERT_EQ(nearest[i], expected) << "dims " << dims << " n " << n << " shape " << shape;
        }
      }
    }
  }
}

TEST(SamplingStudy, EndpointSpreadByHand) {
  // Three points on a line at 0, 0.05 and 0.3: the first two are within 0.1 of each other.
  int useful = 0;
  double mean = 0.0;
  endpointSpread({{0, 0, 0}, {0.05, 0, 0}, {0.3, 0, 0}}, 0.1, &useful, &mean);
  EXPECT_EQ(useful, 1);
  EXPECT_NEAR(mean, (0.05 + 0.05 + 0.25) / 3.0, 1e-12);
  endpointSpread({{0, 0, 0}}, 0.1, &useful, &mean);
  EXPECT_EQ(useful, 1);
  EXPECT_TRUE(std::isnan(mean));
}

TEST(SamplingStudy, UniformGridsMatchTheirClosedForm) {
  registerBuiltinPlugins();
  const auto config = SamplingStudyConfig::fromFile(writeStudy("study", kStudy));
  const auto rows = runSamplingStudy(config);
  ASSERT_EQ(rows.size(), 2u * 5u);
  for (const auto& row : rows) {
    // Endpoints are p + v tau + u tau^2 / 2: the control grid scaled by tau^2 / 2, whatever
    // the state. 5 per axis over +-3: spacing 1.5 * 0.08 = 0.12 m > 0.1, all useful;
    // 7 per axis: 1.0 * 0.08 = 0.08 m, none.
    const bool coarse = row.sampler == "coarse";
    EXPECT_EQ(row.controls, coarse ? 125 : 343);
    EXPECT_EQ(row.useful, coarse ? 125 : 0);
    EXPECT_NEAR(row.mean_nearest, coarse ? 0.12 : 0.08, 1e-9);
    if (row.state == 0) {
      EXPECT_EQ(row.limit_breaking, 0);  // at rest: |a| tau <= 1.2 < 2
    }
  }
  // Moving states break limits with the controls that push along their velocity.
  int breaking = 0;
  for (const auto& row : rows) breaking += row.limit_breaking;
  EXPECT_GT(breaking, 0);
  const auto summaries = summarizeSamplingStudy(config, rows);
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_DOUBLE_EQ(summaries[0].alpha, 1.0);
  EXPECT_DOUBLE_EQ(summaries[0].alpha_sd, 0.0);
  // Seeded: the same file gives the same states.
  EXPECT_EQ(samplingStudyStates(config)[3], samplingStudyStates(config)[3]);
  EXPECT_GT(samplingStudyStates(config)[3].col(1).norm(), 0.5 - 1e-12);
}

std::string errorOf(const std::string& text) {
  try {
    SamplingStudyConfig::fromFile(writeStudy("bad", text));
  } catch (const Error& error) {
    return error.what();
  }
  return "no error";
}

TEST(SamplingStudy, BadFilesNameTheKey) {
  registerBuiltinPlugins();
  std::string text = kStudy;
  EXPECT_NE(errorOf(text + "treshold: 0.2\n")
                .find("unknown key 'treshold' (did you mean "
                      "'threshold'?)"),
            std::string::npos);
  std::string unknown_type = text;
  unknown_type.replace(unknown_type.find("type: uniform"), 13, "type: uniformm");
  EXPECT_NE(errorOf(unknown_type).find("samplers[0].type: unknown sampler 'uniformm'"),
            std::string::npos)
      << errorOf(unknown_type);
  std::string bad_param = text;
  bad_param.replace(bad_param.find("samples_per_axis: 5"), 19, "samples_per_axis: 0");
  EXPECT_NE(errorOf(bad_param).find("samplers[0].params.samples_per_axis: sampler 'uniform': "
                                    "parameter 'samples_per_axis': expected an integer in [1, 64]"),
            std::string::npos)
      << errorOf(bad_param);
  std::string no_limit = text;
  no_limit.replace(no_limit.find("acceleration: 3.0"), 17, "jerk: 3.0");
  EXPECT_NE(errorOf(no_limit).find("missing required key 'acceleration'"), std::string::npos);
}

TEST(SamplingStudy, ReadingsAgreeWithTheStudyAndWithClosedForms) {
  registerBuiltinPlugins();
  const std::string readings =
      "readings: {thresholds: [0.05, 0.1], distance: [position, position_velocity], "
      "propagation: [exact, euler], pooling: [per_state, pooled], samples_per_axis: [5, 7]}\n";
  const auto config = SamplingStudyConfig::fromFile(writeStudy("readings", kStudy + readings));
  const auto rows = runSamplingReadings(config);
  // 2 samplers x 2 M x 2 propagations x 2 distances x 2 poolings x 2 thresholds.
  ASSERT_EQ(rows.size(), 64u);
  for (const auto& row : rows) {
    // The readings' M overrides the sampler's own.
    const int per_axis = row.controls == 125 ? 5 : 7;
    ASSERT_EQ(row.controls, per_axis * per_axis * per_axis);
    const double spacing = (per_axis == 5 ? 1.5 : 1.0) * 0.08;  // du tau^2 / 2
    if (!row.with_velocity && row.propagation == Propagation::kExact && !row.pooled) {
      // The study's own reading: the uniform grid's closed form (see above).
      EXPECT_NEAR(row.mean_nearest, spacing, 1e-9);
      EXPECT_EQ(row.alpha, spacing > row.threshold ? 1.0 : 0.0);
    }
    if (!row.with_velocity && row.propagation == Propagation::kEuler) {
      // One Euler step moves the position by v tau whatever the control: all coincide.
      EXPECT_EQ(row.mean_nearest, 0.0);
      EXPECT_EQ(row.alpha, 0.0);
    }
    if (row.with_velocity && row.propagation == Propagation::kExact && !row.pooled) {
      // (p, v) of a grid: spacing du (tau^2 / 2, tau) per axis, 0.08 and 0.4 per 1 m/s^2.
      const double du = per_axis == 5 ? 1.5 : 1.0;
      EXPECT_NEAR(row.mean_nearest, du * std::hypot(0.08, 0.4), 1e-9);
    }
  }
  const std::string bad =
      kStudy + std::string(readings).replace(readings.find("position_velocity"), 17, "velocity");
  EXPECT_NE(errorOf(bad).find("readings.distance[1]: expected position or position_velocity, "
                              "got 'velocity'"),
            std::string::npos)
      << errorOf(bad);
  const std::string empty =
      kStudy + std::string(readings).replace(readings.find("[0.05, 0.1]"), 11, "[]");
  EXPECT_NE(errorOf(empty).find("readings.thresholds: expected at least one value"),
            std::string::npos)
      << errorOf(empty);
}

}  // namespace
}  // namespace kinolab
