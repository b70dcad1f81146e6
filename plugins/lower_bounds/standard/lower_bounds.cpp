// The lazy searches' lower bounds: full (eager), endpoint (the paper's), control_only and
// lipschitz.
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/search_policies.hpp"

namespace kinolab {
namespace {

template <typename Policy>
PluginFactory<EdgeEvaluationPolicy> plainPolicy() {
  return [](const ParameterSet&) { return std::make_unique<Policy>(); };
}

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;

  registrar.add<EdgeEvaluationPolicy>("full", "every edge fully evaluated at expansion (eager)",
                                      ParameterSpecs(), plainPolicy<FullEvaluationPolicy>());
  registrar.add<EdgeEvaluationPolicy>(
      "endpoint", "the end sample's collision test and obstacle share (the paper's)",
      ParameterSpecs(), plainPolicy<EndpointBoundPolicy>());
  registrar.add<EdgeEvaluationPolicy>("control_only",
                                      "time, length and control terms only (no map query)",
                                      ParameterSpecs(), plainPolicy<ControlOnlyBoundPolicy>());
  registrar.add<EdgeEvaluationPolicy>(
      "lipschitz", "endpoint, and exact when the ESDF's Lipschitz bound certifies the edge clear",
      ParameterSpecs(), plainPolicy<LipschitzBoundPolicy>());
}
