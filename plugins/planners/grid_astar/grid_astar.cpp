// `grid_astar`: the geometric front end of kr_mp_design (Liu et al., RA-L 2017, JPS3D): A* or
// Jump Point Search over the world's 26-connected voxels (a voxel is free when the ESDF's
// proven clearance at its centre is at least the body's keptRadius()), the path shortcut by
// line of sight and flown stop-and-go at the limits, as `rrtstar` flies its path.
#include <cmath>

#include "grid_path.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/trajectory/uniform_bspline.hpp"

namespace kinolab::grid {
namespace {

ParameterSpecs gridParameters() {
  return ParameterSpecs()
      .include(motionParameters(1.0))
      .choice("algorithm", "jps", {"astar", "jps"},
              "astar: every voxel's 26 neighbours; jps: Jump Point Search (the same path "
              "length, fewer expansions)")
      .integer("max_expansions", 10000000, 1, 1000000000,
               "search budget: nodes taken from the open list");
}

MetricSpecs gridStatistics() {
  MetricSpecs specs;
  specs.counter("expansions", "nodes taken from the open list")
      .counter("generated", "nodes put on the open list (again when improved)")
      .counter("jump_steps", "voxels stepped over by JPS's jumps (0 for A*)")
      .counter("voxel_evaluations", "voxels whose clearance the search read")
      .real("path_length_grid", "m", "path length through the voxel centres")
      .counter("path_vertices_grid", "vertices of the voxel path (straight runs merged)")
      .real("path_length", "m", "path length after the line-of-sight shortcut")
      .counter("path_vertices", "vertices of the shortcut path")
      .counter("line_of_sight_checks", "straight segments checked by the shortcut");
  return specs;
}

/// A search that found nothing: timeout when it spent the budget; an end without a free
/// voxel next to it is refused as plan() refuses one in collision, before any search.
PlanStatus statusOf(GridPath::Outcome outcome) {
  switch (outcome) {
    case GridPath::Outcome::kStopped:
      return PlanStatus::kTimeout;
    case GridPath::Outcome::kStartUnconnected:
      return PlanStatus::kInvalidStart;
    case GridPath::Outcome::kGoalUnconnected:
      return PlanStatus::kInvalidGoal;
    default:
      return PlanStatus::kNoSolution;
  }
}

class GridAstarPlanner final : public Planner {
 public:
  explicit GridAstarPlanner(const ParameterSet& parameters)
      : algorithm_(parameters.text("algorithm") == "astar" ? GridAlgorithm::kAStar
                                                           : GridAlgorithm::kJps),
        limits_(plannerLimitsFrom(parameters)),
        budget_(timeBudgetFrom(parameters)) {
    budget_.max_iterations = parameters.integer("max_expansions");
  }

 protected:
  void doSetup(const PlannerContext& /*context*/) override {}

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override {
    PlanResult result;
    const bool at_rest = query.start.col(1).isZero() && query.start.col(2).isZero();
    if (!refinesFrontEnd() && !at_rest) {
      result.status = PlanStatus::kInvalidStart;
      result.message =
          "with back_end none grid_astar flies its path stop-and-go, so it starts at rest "
          "(choose a back end, e.g. back_end=corridor_minco, for a moving start)";
      return result;
    }
    const GridPath found =
        findGridPath(world(), body(), query.start.col(0), query.goal, algorithm_, stop);
    result.statistics = {{"expansions", static_cast<double>(found.search.expansions)},
                         {"generated", static_cast<double>(found.search.generated)},
                         {"jump_steps", static_cast<double>(found.search.jump_steps)},
                         {"voxel_evaluations", static_cast<double>(found.voxel_evaluations)},
                         {"line_of_sight_checks", static_cast<double>(found.line_of_sight_checks)}};
    if (found.outcome != GridPath::Outcome::kFound) {
      result.status = statusOf(found.outcome);
      result.message = found.message;
      return result;
    }
    result.statistics.insert(result.statistics.end(),
                             {{"path_length_grid", found.grid_length},
                              {"path_vertices_grid", static_cast<double>(found.grid_path.size())},
                              {"path_length", found.length},
                              {"path_vertices", static_cast<double>(found.path.size())}});
    result.status = PlanStatus::kExact;
    // From a moving start there is only the path: the back end makes the trajectory.
    if (found.length > 0.0) {
      result.path = found.path;
      if (at_rest) result.trajectory = stopAndGo(result.path, limits_.limits);
    }
    result.cost = result.trajectory.empty() ? found.length : result.trajectory.length();
    return result;
  }

  PlannerLimits plannerLimits() const override { return limits_; }
  Budget ownBudget() const override { return budget_; }
  std::string costObjective() const override { return "trajectory length"; }

 private:
  GridAlgorithm algorithm_;
  PlannerLimits limits_;
  Budget budget_;
};

}  // namespace
}  // namespace kinolab::grid

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<Planner>(
      "grid_astar",
      "kr_mp_design's front end: A* or JPS over the 26-connected free voxels, the path "
      "shortcut by line of sight and flown stop-and-go",
      grid::gridParameters(),
      [](const ParameterSet& parameters) {
        return std::make_unique<grid::GridAstarPlanner>(parameters);
      },
      grid::gridStatistics());
}
