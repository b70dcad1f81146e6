// A researcher's own lazy lower bound, built outside the kinolab tree against an installed
// kinolab (docs/adding_a_planner.md walks through it): the paper's endpoint bound scaled by
// `bound_scale` in [0, 1]. Any scale keeps it a lower bound of the full cost (the endpoint
// bound is one, and every cost term is non-negative), so the search stays optimal and returns
// eager's cost; a smaller scale defers more work to pop time. No file under framework/ knows
// this policy or its parameter.
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace {

using namespace kinolab;

class ScaledEndpointBound final : public EdgeEvaluationPolicy {
 public:
  explicit ScaledEndpointBound(double scale) : scale_(scale) {}

  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    if (evaluation.valid()) evaluation.cost *= scale_;
    return EdgeEstimate::kLowerBound;
  }

 private:
  double scale_;
};

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<Planner>(
      "lazy_scaled_bound", "lazy MP-A* queueing edges on a scaled endpoint bound",
      motionPrimitiveParameters().real("bound_scale", 0.5, 0.0, 1.0,
                                       "share of the endpoint bound the edge is queued with"),
      [](const ParameterSet& parameters) {
        auto config = MotionPrimitiveConfig::fromParameters(parameters);
        config.policies.edges =
            std::make_shared<ScaledEndpointBound>(parameters.real("bound_scale"));
        return std::make_unique<MotionPrimitivePlanner>(std::move(config));
      },
      motionPrimitiveStatistics());
}
