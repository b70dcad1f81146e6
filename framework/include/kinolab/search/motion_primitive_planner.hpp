#pragma once

#include <memory>
#include <optional>

#include "kinolab/core/parameters.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/search/motion_primitive_search.hpp"

namespace kinolab {

/// The parameters every motion-primitive planner declares: sampler, dynamics, limits, cost
/// weights, edge sampling, body, heuristic, state keys, goal region and budgets. A plugin adds
/// its own (e.g. the lazy options) after these.
ParameterSpecs motionPrimitiveParameters();

/// Search settings from parameters declared by motionPrimitiveParameters() (and, when
/// declared, `duplicate_rule`, `lower_bound` and `cost_weight`).
SearchSettings searchSettingsFrom(const ParameterSet& parameters, EvaluationMode mode);

/// A planner on the motion-primitive search core: draws its control set from the sampler at
/// setup, searches each query, and returns the path (or, on a budget stop, the path to the
/// state nearest the goal). Plugins register it with their settings; see
/// docs/adding_a_planner.md.
class MotionPrimitivePlanner : public Planner {
 public:
  /// From parameters declared by motionPrimitiveParameters() (plus the plugin's own).
  MotionPrimitivePlanner(const ParameterSet& parameters, EvaluationMode mode);

  /// The search of the last setup (for tests and benchmarks).
  const MotionPrimitiveSearch& search() const;

 protected:
  void doSetup(const PlannerContext& context) override;
  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop, SearchTree* tree) override;
  void doReset() override;
  PlanningModel planningModel() const override;
  Budget ownBudget() const override { return budget_; }

 private:
  SearchSettings settings_;
  Budget budget_;
  std::unique_ptr<MotionPrimitiveSearch> search_;
};

}  // namespace kinolab
