// The closed-form heuristics: euclidean, min_time, time_optimal (the paper's), obvp and max
// (the larger of two others).
#include <optional>

#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/search_policies.hpp"

namespace kinolab {

namespace {

/// A factory for a heuristic that takes no parameters of its own and is made from the edges
/// and goal radius.
template <typename Heuristic>
PluginFactory<HeuristicBuilder> plainHeuristic() {
  return [](const ParameterSet&) {
    return std::make_unique<HeuristicBuilder>([](const HeuristicContext& context) {
      return std::make_shared<Heuristic>(context.edges, context.goal_radius);
    });
  };
}

void requireOrderTwo(const HeuristicContext& context) {
  if (context.edges.order != 2) {
    throw ParameterConflict("heuristic", "obvp needs order 2 (acceleration control), got order " +
                                             std::to_string(context.edges.order) +
                                             "; use time_optimal or max");
  }
}

/// The `max` heuristic's factory: its two parts, each left out where it does not serve the
/// planner's order.
std::unique_ptr<HeuristicBuilder> maxOfParts(const ParameterSet& p) {
  std::vector<std::shared_ptr<const HeuristicBuilder>> parts;
  for (const char* name : {"first", "second"}) {
    parts.push_back(pluginRegistry<HeuristicBuilder>().createChosen(p, name));
  }
  return std::make_unique<HeuristicBuilder>(
      [parts](const HeuristicContext& context) -> std::shared_ptr<const SearchHeuristic> {
        std::vector<std::shared_ptr<const SearchHeuristic>> made;
        std::optional<ParameterConflict> declined;
        for (const auto& part : parts) {
          try {
            made.push_back(part->build(context));
          } catch (const ParameterConflict& conflict) {
            if (!declined) declined = conflict;
          }
        }
        if (made.empty()) throw *declined;
        if (made.size() == 1) return made.front();
        return std::make_shared<MaxHeuristic>(std::move(made));
      });
}

void registerHeuristics(PluginRegistrar& registrar) {
  registrar.add<HeuristicBuilder>("euclidean", "w_T |d| / |v_max| + w_L |d| (straight line)",
                                  ParameterSpecs(), plainHeuristic<EuclideanHeuristic>());
  registrar.add<HeuristicBuilder>("min_time", "w_T max_i |d_i| / v_max_i + w_L |d| (MPL's)",
                                  ParameterSpecs(), plainHeuristic<MinTimeHeuristic>());
  registrar.add<HeuristicBuilder>(
      "time_optimal",
      "per-axis minimum time from the current velocity under v_max and a_max (the paper's)",
      ParameterSpecs().boolean("whole_primitives", false,
                               "round the time up to whole primitives (tau ceil(T / tau)): "
                               "tighter, for searches whose paths are whole primitives"),
      [](const ParameterSet& p) {
        const bool whole = p.boolean("whole_primitives");
        return std::make_unique<HeuristicBuilder>([whole](const HeuristicContext& context) {
          return std::make_shared<TimeOptimalHeuristic>(context.edges, context.goal_radius, whole);
        });
      });
  registrar.add<HeuristicBuilder>(
      "obvp",
      "least duration + control effort of the unconstrained chain (Fast-Planner's; order 2)",
      ParameterSpecs(), [](const ParameterSet&) {
        return std::make_unique<HeuristicBuilder>([](const HeuristicContext& context) {
          requireOrderTwo(context);
          return std::make_shared<ObvpHeuristic>(context.edges, context.goal_radius);
        });
      });
  registrar.add<HeuristicBuilder>(
      "max",
      "the larger of two heuristics, `first` and `second` (by default time_optimal and obvp); "
      "a part that does not serve the planner's order (obvp above 2) is left out",
      ParameterSpecs()
          .plugin("heuristic", "first", "time_optimal",
                  "one part (kinolab list heuristics); its parameters as first.NAME")
          .plugin("heuristic", "second", "obvp", "the other part; its parameters as second.NAME"),
      maxOfParts);
}

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) { kinolab::registerHeuristics(registrar); }
