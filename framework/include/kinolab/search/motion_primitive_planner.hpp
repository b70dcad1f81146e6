#pragma once

#include <memory>
#include <string>

#include "kinolab/core/parameters.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/search/motion_primitive_search.hpp"

namespace kinolab {

/// The parameters every motion-primitive planner declares: sampler, dynamics, limits, cost
/// weights, edge sampling, body (motionParameters()), heuristic, state keys, goal region and
/// budgets. A plugin adds its own (e.g. the lazy options) after these.
ParameterSpecs motionPrimitiveParameters();
/// The statistics every MotionPrimitivePlanner reports (the search's counters and times);
/// a plugin that reports more includes these in its own declaration.
MetricSpecs motionPrimitiveStatistics();

/// The registered heuristic `key` (kinolab list heuristics), at its default parameters, for
/// these edges; a heuristic that cannot serve them throws ParameterConflict.
std::shared_ptr<const SearchHeuristic> heuristicFor(const std::string& key,
                                                    const EdgeEvaluatorSettings& edges,
                                                    double goal_radius);

/// Everything a MotionPrimitivePlanner is built from. fromParameters() reads the parameters
/// of motionPrimitiveParameters() (and no others) and sets eager defaults: full evaluation,
/// the heuristic the `heuristic` parameter chose (with its own parameters), the lwa duplicate
/// rule, cost weight 1. A plugin then sets what its own parameters choose: a lazy edge policy
/// (e.g. from a `lower_bound` plugin parameter), another duplicate rule or cost weight.
struct MotionPrimitiveConfig {
  /// The search's settings; the edges' body is the planner's body(), set at setup.
  SearchSettings settings;
  /// The edge policy, search space and shot; the heuristic is built at setup (below).
  SearchPolicies policies;
  /// Builds the heuristic for the edges of the body set up with.
  std::shared_ptr<const HeuristicBuilder> heuristic;
  Budget budget;
  /// The control sampler (the `sampler` plugin parameter) the control set is drawn from at
  /// setup, with the setup's seed.
  std::shared_ptr<const ControlSampler> sampler;
  /// A fixed control set: when not empty, used instead of the sampler's (a planner whose
  /// controls are its own parameters).
  std::vector<Eigen::Vector3d> controls;

  static MotionPrimitiveConfig fromParameters(const ParameterSet& parameters);
};

/// A planner on the motion-primitive search core: draws its control set from the sampler at
/// setup, searches each query, and returns the path (or, on a budget stop, the path to the
/// state nearest the goal). Plugins register it with their config; see
/// docs/adding_a_planner.md.
class MotionPrimitivePlanner : public Planner {
 public:
  explicit MotionPrimitivePlanner(MotionPrimitiveConfig config);

  /// The search of the last setup (for tests and benchmarks).
  const MotionPrimitiveSearch& search() const;
  const MotionPrimitiveConfig& config() const { return config_; }

 protected:
  /// A plan result of a search outcome: its status (exact, no_solution, or approximate /
  /// timeout at a budget stop, with `budget_spent` as the message), trajectory and cost.
  static PlanResult resultOf(MotionPrimitiveSearch::Outcome outcome, Trajectory trajectory,
                             double cost, const std::string& budget_spent);

  /// What a search of this planner is made of at setup: the control set (the sampler's for
  /// the setup's seed, or the fixed one), the settings for the planner's body() and the
  /// policies with the heuristic built for them. A planner with another search on the same
  /// graph (the lazy family) makes it from these.
  struct SearchParts {
    std::vector<Eigen::Vector3d> controls;
    SearchSettings settings;
    SearchPolicies policies;
  };
  SearchParts searchParts(const PlannerContext& context) const;

  void doSetup(const PlannerContext& context) override;
  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override;
  SearchTree doTree(std::size_t max_edges) const override;
  void doReset() override;
  PlannerLimits plannerLimits() const override;
  Budget ownBudget() const override { return config_.budget; }
  /// The edge cost's function: the chain's order, the weights, and where they count, the
  /// body, the safety band and the quadrature (the heuristic, keys and rules do not change it).
  std::string costObjective() const override;
  /// A lattice that cannot move is refused: with the sampler's set for seed 1 here, and with
  /// the set of the run's own seed at setup.
  void doCheck() const override;

 private:
  /// The configured settings with the edges' body `body`.
  SearchSettings settingsFor(const Body& body) const;
  /// The control set for `seed`: the fixed one, or the sampler's.
  std::vector<Eigen::Vector3d> controlsFor(std::uint64_t seed) const;

  MotionPrimitiveConfig config_;
  std::unique_ptr<MotionPrimitiveSearch> search_;
};

}  // namespace kinolab
