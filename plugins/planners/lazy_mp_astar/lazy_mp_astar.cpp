// `lazy_mp_astar`: the paper's lazy motion-primitive A* (Wang, Shen, Chen, Lu, "Towards
// Efficient Motion Planning for UAVs: Lazy A* Search with Motion Primitives"): edges are
// queued with a lower bound and fully evaluated only when popped. With the `lwa` duplicate
// rule it returns the same cost as eager_mp_astar; `seed` is the paper's Algorithm 1 read
// literally.
#include <charconv>

#include "kinolab/core/plugin.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"
#include "lazy_family.hpp"

namespace kinolab {
namespace {

/// A lookahead above 1 over the same lattice, controls, costs, heuristic and bound: LRA*
/// (finite) or LazySP (infinite, `lookahead` 0).
class LazyFamilyPlanner final : public MotionPrimitivePlanner {
 public:
  LazyFamilyPlanner(MotionPrimitiveConfig config, EdgeSelector selector, int lookahead)
      : MotionPrimitivePlanner(std::move(config)), selector_(selector), lookahead_(lookahead) {}

 protected:
  void doSetup(const PlannerContext& context) override {
    SearchParts parts = searchParts(context);
    if (lookahead_ == 0) {
      lazy_ = std::make_unique<LazySpSearch>(context.world, std::move(parts.controls),
                                             std::move(parts.settings), std::move(parts.policies),
                                             selector_);
    } else {
      lazy_ = std::make_unique<LraStarSearch>(context.world, std::move(parts.controls),
                                              std::move(parts.settings), std::move(parts.policies),
                                              lookahead_, selector_);
    }
  }

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override {
    const auto outcome = lazy_->search(query.start, query.goal, stop);
    PlanResult result = resultOf(
        outcome, lazy_->trajectory(), lazy_->cost(),
        std::string(lazy_->memoryLimited() ? "memory budget" : "budget") +
            " spent: the path to the state nearest the goal reached through evaluated edges");
    result.statistics = lazy_->statistics();
    result.statistics.emplace_back("controls",
                                   static_cast<double>(lazy_->graph().controls().size()));
    result.statistics.emplace_back("heuristic_weight", config().settings.heuristic_weight);
    return result;
  }

  SearchTree doTree(std::size_t) const override { return {}; }

 private:
  EdgeSelector selector_;
  int lookahead_;
  std::unique_ptr<LazyFamilySearch> lazy_;
};

EdgeSelector selectorOf(const std::string& name) {
  if (name == "reverse") return EdgeSelector::kReverse;
  if (name == "alternate") return EdgeSelector::kAlternate;
  if (name == "failfast") return EdgeSelector::kFailFast;
  return EdgeSelector::kForward;
}

/// The lookahead parameter: a whole number from 1, or "inf" (returned as 0).
int lookaheadOf(const std::string& text) {
  if (text == "inf") return 0;
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 1 || value > 1000000) {
    throw ParameterConflict(
        "lookahead", "expected a whole number from 1 to 1000000 or 'inf', got '" + text + "'");
  }
  return value;
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
          .text("lookahead", "1",
                "unevaluated edges a lazy path may hold: 1, LWA* (an edge is evaluated when "
                "popped, the paper's lazy); k > 1, LRA* (the best path k edges ahead is "
                "evaluated); inf, LazySP (shortest lazy paths to the goal)")
          .choice("selector", "forward", {"forward", "reverse", "alternate", "failfast"},
                  "the order in which a lazy path's edges are evaluated (lookahead above 1): "
                  "the first, the last, in turn, or the likeliest to collide (least clearance "
                  "at its end) first"),
      [](const ParameterSet& parameters) {
        auto config = MotionPrimitiveConfig::fromParameters(parameters);
        config.policies.edges =
            pluginRegistry<EdgeEvaluationPolicy>().createChosen(parameters, "lower_bound");
        config.settings.duplicate_rule = parameters.text("duplicate_rule") == "seed"
                                             ? DuplicateRule::kSeed
                                             : DuplicateRule::kLwa;
        const int lookahead = lookaheadOf(parameters.text("lookahead"));
        if (lookahead == 1) {
          return std::unique_ptr<Planner>(
              std::make_unique<MotionPrimitivePlanner>(std::move(config)));
        }
        if (parameters.text("search_space") != "lattice") {
          throw ParameterConflict("search_space",
                                  "a lookahead above 1 (LRA*, LazySP) reuses an edge's "
                                  "evaluations by its parent's key, which holds on the lattice "
                                  "only");
        }
        if (config.settings.duplicate_rule == DuplicateRule::kSeed) {
          throw ParameterConflict("duplicate_rule",
                                  "seed is Algorithm 1's rule for lookahead 1; a larger "
                                  "lookahead keeps the cheapest path to each state");
        }
        return std::unique_ptr<Planner>(std::make_unique<LazyFamilyPlanner>(
            std::move(config), selectorOf(parameters.text("selector")), lookahead));
      },
      motionPrimitiveStatistics()
          .counter("lazy_searches", "LazySP's shortest-path searches (lookahead inf)")
          .counter("rewired_vertices",
                   "LRA*'s vertices taken out of the tree below an invalid or dearer edge "
                   "(lookahead above 1, finite)"));
}
