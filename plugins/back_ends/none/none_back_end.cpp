// `none`: every planner's default back end. It keeps the front end's trajectory and cost
// (a geometric front end's is its path flown stop-and-go); the smallest back end to copy.
#include "kinolab/core/plugin.hpp"
#include "kinolab/planner/back_end.hpp"

namespace kinolab {
namespace {

class NoBackEnd final : public BackEnd {
 public:
  void setup(std::shared_ptr<const World> /*world*/, const Body& /*body*/,
             const PlannerLimits& /*limits*/) override {}

  BackEndResult refine(const BackEndProblem& problem, StopCondition& /*stop*/) const override {
    BackEndResult result;
    if (problem.front) {
      result.trajectory = *problem.front;
    } else {
      result.failure = "the front end made a path, not a trajectory: choose a back end";
    }
    return result;
  }

  bool keepsFrontEnd() const override { return true; }
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<BackEnd>("none", "no back end: the front end's trajectory as it is",
                         ParameterSpecs(),
                         [](const ParameterSet&) { return std::make_unique<NoBackEnd>(); });
}
