// `eager_mp_astar`: motion-primitive A* that fully evaluates every edge when its parent is
// expanded (the paper's MP-A* baseline; Liu et al., RA-L 2018).
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<Planner>(
      "eager_mp_astar", "motion-primitive A*, every edge fully evaluated at expansion",
      motionPrimitiveParameters(),
      [](const ParameterSet& parameters) {
        return std::make_unique<MotionPrimitivePlanner>(
            MotionPrimitiveConfig::fromParameters(parameters));
      },
      motionPrimitiveStatistics());
}
