// `lazy_mp_astar`: the paper's lazy motion-primitive A* (Wang, Shen, Chen, Lu, "Towards
// Efficient Motion Planning for UAVs: Lazy A* Search with Motion Primitives"): edges are
// queued with a lower bound and fully evaluated only when popped. With the `lwa` duplicate
// rule it returns the same cost as eager_mp_astar; `seed` is the paper's Algorithm 1 read
// literally.
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/lazy_sp.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace kinolab {
namespace {

/// Lookahead infinity: LazySP over the same lattice, controls, costs, heuristic and bound.
class LazySpPlanner final : public MotionPrimitivePlanner {
 public:
  LazySpPlanner(MotionPrimitiveConfig config, EdgeSelector selector)
      : MotionPrimitivePlanner(std::move(config)), selector_(selector) {}

 protected:
  void doSetup(const PlannerContext& context) override {
    MotionPrimitivePlanner::doSetup(context);
    lazy_ = std::make_unique<LazySpSearch>(context.world, search().controls(), config().settings,
                                           config().policies, selector_);
  }

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override {
    const auto outcome = lazy_->search(query.start, query.goal, stop);
    PlanResult result = resultOf(outcome, lazy_->trajectory(), lazy_->cost(),
                                 std::string(lazy_->memoryLimited() ? "memory budget" : "budget") +
                                     " spent: the evaluated start of the last lazy path");
    result.statistics = lazy_->statistics();
    result.statistics.emplace_back("controls", static_cast<double>(search().controls().size()));
    result.statistics.emplace_back("heuristic_weight", config().settings.heuristic_weight);
    return result;
  }

  SearchTree doTree(std::size_t) const override { return {}; }

 private:
  EdgeSelector selector_;
  std::unique_ptr<LazySpSearch> lazy_;
};

EdgeSelector selectorOf(const std::string& name) {
  if (name == "reverse") return EdgeSelector::kReverse;
  if (name == "alternate") return EdgeSelector::kAlternate;
  if (name == "failfast") return EdgeSelector::kFailFast;
  return EdgeSelector::kForward;
}

}  // namespace
}  // namespace kinolab

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
                  "certification of clear edges")
          .choice("lookahead", "1", {"1", "inf"},
                  "1: LWA* (an edge is evaluated when popped, the paper's lazy); inf: LazySP "
                  "(shortest lazy paths, evaluating the edges the selector picks on them)")
          .choice("selector", "forward", {"forward", "reverse", "alternate", "failfast"},
                  "LazySP's edge selector (lookahead inf): the first, the last, in turn, or the "
                  "edge likeliest to collide (least clearance at its end)"),
      [](const ParameterSet& parameters) {
        auto config = MotionPrimitiveConfig::fromParameters(parameters);
        config.policies.edges =
            pluginRegistry<EdgeEvaluationPolicy>().createChosen(parameters, "lower_bound");
        config.settings.duplicate_rule = parameters.text("duplicate_rule") == "seed"
                                             ? DuplicateRule::kSeed
                                             : DuplicateRule::kLwa;
        if (parameters.text("lookahead") == "inf") {
          if (parameters.text("search_space") != "lattice") {
            throw ParameterConflict("search_space",
                                    "LazySP (lookahead inf) reuses an edge's evaluations by its "
                                    "parent's key, which holds on the lattice only");
          }
          if (config.settings.duplicate_rule == DuplicateRule::kSeed) {
            throw ParameterConflict("duplicate_rule",
                                    "seed is Algorithm 1's rule for lookahead 1; LazySP "
                                    "(lookahead inf) keeps the cheapest path to each state");
          }
          return std::unique_ptr<Planner>(std::make_unique<LazySpPlanner>(
              std::move(config), selectorOf(parameters.text("selector"))));
        }
        return std::unique_ptr<Planner>(
            std::make_unique<MotionPrimitivePlanner>(std::move(config)));
      },
      motionPrimitiveStatistics().counter("lazy_searches",
                                          "LazySP's shortest-path searches (lookahead inf)"));
}
