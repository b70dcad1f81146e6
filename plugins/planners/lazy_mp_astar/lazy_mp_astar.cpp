// `lazy_mp_astar`: the paper's lazy motion-primitive A* (Wang, Shen, Chen, Lu, "Towards
// Efficient Motion Planning for UAVs: Lazy A* Search with Motion Primitives"): edges are
// queued with a lower bound and fully evaluated only when popped. With the `lwa` duplicate
// rule it returns the same cost as eager_mp_astar; `seed` is the paper's Algorithm 1 read
// literally.
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<Planner>(
      "lazy_mp_astar", "lazy motion-primitive A*: lower bound at expansion, full check at pop",
      motionPrimitiveParameters()
          .choice("duplicate_rule", "lwa", {"lwa", "seed"},
                  "lwa: keep every cheaper candidate of a state (optimal); seed: the paper's "
                  "literal rule, first candidate only")
          .plugin("lower_bound", "lower_bound", "endpoint",
                  "how an edge is queued (kinolab list lower_bounds): endpoint, the paper's "
                  "end-sample bound; control_only, no map term; lipschitz, endpoint plus "
                  "certification of clear edges"),
      [](const ParameterSet& parameters) {
        auto config = MotionPrimitiveConfig::fromParameters(parameters);
        config.policies.edges =
            pluginRegistry<EdgeEvaluationPolicy>().createChosen(parameters, "lower_bound");
        config.settings.duplicate_rule = parameters.text("duplicate_rule") == "seed"
                                             ? DuplicateRule::kSeed
                                             : DuplicateRule::kLwa;
        return std::make_unique<MotionPrimitivePlanner>(std::move(config));
      },
      motionPrimitiveStatistics());
}
