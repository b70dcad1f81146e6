// `lazy_mp_astar`: the paper's lazy motion-primitive A* (Wang, Shen, Chen, Lu, "Towards
// Efficient Motion Planning for UAVs: Lazy A* Search with Motion Primitives"): edges are
// queued with a lower bound and fully evaluated only when popped. With the `lwa` duplicate
// rule it returns the same cost as eager_mp_astar; `seed` is the paper's Algorithm 1 read
// literally.
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace {

using namespace kinolab;

std::shared_ptr<const EdgeEvaluationPolicy> lowerBound(const std::string& name) {
  if (name == "control_only") return std::make_shared<ControlOnlyBoundPolicy>();
  if (name == "lipschitz") return std::make_shared<LipschitzBoundPolicy>();
  return std::make_shared<EndpointBoundPolicy>();  // the declared choices leave "endpoint"
}

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<Planner>(
      "lazy_mp_astar", "lazy motion-primitive A*: lower bound at expansion, full check at pop",
      motionPrimitiveParameters()
          .choice("duplicate_rule", "lwa", {"lwa", "seed"},
                  "lwa: keep every cheaper candidate of a state (optimal); seed: the paper's "
                  "literal rule, first candidate only")
          .choice("lower_bound", "endpoint", {"endpoint", "control_only", "lipschitz"},
                  "queued cost: end-sample obstacle term; no map term; or endpoint plus "
                  "Lipschitz certification of clear edges"),
      [](const ParameterSet& parameters) {
        auto config = MotionPrimitiveConfig::fromParameters(parameters);
        config.policies.edges = lowerBound(parameters.text("lower_bound"));
        config.settings.duplicate_rule = parameters.text("duplicate_rule") == "seed"
                                             ? DuplicateRule::kSeed
                                             : DuplicateRule::kLwa;
        return std::make_unique<MotionPrimitivePlanner>(std::move(config));
      },
      motionPrimitiveStatistics());
}
