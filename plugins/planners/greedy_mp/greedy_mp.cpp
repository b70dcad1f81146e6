// `greedy_mp`: weighted greedy best-first search on the motion-primitive core, the example
// of docs/adding_a_planner.md. It orders the open list by cost_weight * g + h: 0 is pure
// greedy best-first (fast, no cost guarantee).
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<Planner>(
      "greedy_mp", "weighted greedy best-first on the motion-primitive core (example plugin)",
      motionPrimitiveParameters().real("cost_weight", 0.0, 0.0, 1.0,
                                       "weight of the cost so far in the priority (0: greedy)"),
      [](const ParameterSet& parameters) {
        auto config = MotionPrimitiveConfig::fromParameters(parameters);
        config.settings.cost_weight = parameters.real("cost_weight");
        return std::make_unique<MotionPrimitivePlanner>(std::move(config));
      },
      motionPrimitiveStatistics());
}
