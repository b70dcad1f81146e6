// Every registered sampler (built-in, and any library named in $KINOLAB_TEST_PLUGINS) keeps
// the ControlSampler contract.
#include <gtest/gtest.h>

#include <cctype>

#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

std::vector<std::string> registeredSamplers() {
  test::loadTestPlugins();
  return pluginRegistry<ControlSampler>().keys();
}

class SamplerConformance : public ::testing::TestWithParam<std::string> {};

/// Parameter sets to try: the defaults, then each numeric parameter at both ends of its range
/// and each choice, one at a time.
std::vector<std::vector<ParameterAssignment>> parameterCases(const PluginInfo& info) {
  std::vector<std::vector<ParameterAssignment>> cases{{}};
  for (const auto& spec : info.parameters.all()) {
    const auto add = [&](const std::string& value) {
      cases.push_back({{spec.name, value, "test"}});
    };
    if (spec.type == ParameterType::kInteger || spec.type == ParameterType::kReal) {
      // Integer ranges up to 64 per axis would mean 262144 controls: cap what we try.
      add(formatNumber(spec.minimum));
      if (spec.maximum <= 16 || spec.type == ParameterType::kReal) add(formatNumber(spec.maximum));
    } else if (spec.type == ParameterType::kChoice) {
      for (const auto& choice : spec.choices) add(choice);
    }
  }
  return cases;
}

TEST_P(SamplerConformance, ControlsAreFiniteInBoundsAndReproducible) {
  const auto& registry = pluginRegistry<ControlSampler>();
  const PluginInfo& info = registry.info(GetParam());
  EXPECT_FALSE(info.description.empty());
  for (const auto& spec : info.parameters.all()) EXPECT_FALSE(spec.doc.empty()) << spec.name;
  const std::vector<Eigen::Vector3d> bounds{{1.0, 1.0, 1.0}, {3.0, 2.0, 0.5}};
  for (const auto& assignments : parameterCases(info)) {
    const auto sampler = registry.create(GetParam(), assignments);
    for (const auto& u_max : bounds) {
      for (const std::uint64_t seed : {1ULL, 99ULL}) {
        const auto controls = sampler->sample(u_max, seed);
        ASSERT_FALSE(controls.empty());
        for (const auto& control : controls) {
          ASSERT_TRUE(control.allFinite());
          ASSERT_TRUE((control.array().abs() <= u_max.array()).all());
        }
        // Same parameters and seed, same set, bit for bit (also from a fresh instance).
        const auto again = registry.create(GetParam(), assignments)->sample(u_max, seed);
        ASSERT_EQ(again.size(), controls.size());
        for (std::size_t i = 0; i < controls.size(); ++i) ASSERT_EQ(again[i], controls[i]);
      }
    }
  }
}

TEST_P(SamplerConformance, RejectsUnknownParametersAndBadBounds) {
  const auto& registry = pluginRegistry<ControlSampler>();
  EXPECT_THROW(registry.create(GetParam(), {{"no_such_parameter", "1", "test"}}), ConfigError);
  const auto sampler = registry.create(GetParam(), {});
  EXPECT_THROW(sampler->sample(Eigen::Vector3d(1.0, 0.0, 1.0), 1), InvalidArgument);
  EXPECT_THROW(sampler->sample(Eigen::Vector3d(1.0, INFINITY, 1.0), 1), InvalidArgument);
}

INSTANTIATE_TEST_SUITE_P(Registered, SamplerConformance, ::testing::ValuesIn(registeredSamplers()),
                         [](const ::testing::TestParamInfo<std::string>& key) {
                           std::string name = key.param;  // test names allow [A-Za-z0-9_]
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

}  // namespace
}  // namespace kinolab
