// `hybrid_astar` and `hybrid_astar_bspline`: Fast-Planner's kinodynamic front end (Zhou et al.,
// "Robust and Efficient Quadrotor Trajectory Generation for Fast Autonomous Flight", RA-L 2019)
// on kinolab's motion-primitive core: acceleration controls on a grid (-a_max .. a_max per
// axis) applied for one duration, states kept one per position cell (the first to close a
// cell closes it), the OBVP heuristic weighted by lambda, and an analytic expansion (the
// least-effort cubic to rest at the goal) from closed states near the goal, accepted when the
// independent checker accepts it. `hybrid_astar_bspline` is the same planner with the
// `bspline` back end by default (Fast-Planner's pairing: the Ceres uniform B-spline of
// rrtstar_ceres; plugins/back_ends/bspline). Neither is optimal. docs/hybrid_astar.md.
#include <cmath>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace kinolab {
namespace {

/// The front end's own parameters; the body, limits, goal region and time limit are
/// motionParameters().
struct HybridSettings {
  double tau = 0.6;
  long long acceleration_steps = 5;
  double cell_size = 0.1;
  double velocity_resolution = 0.0;
  double heuristic_weight = 5.0;
  double shot_distance = 1.5;
  CostWeights weights{1.0, 0.0, 0.1, 0.0};  // no obstacle term, as Fast-Planner's search
  long long max_expansions = 0;
  double memory_limit_mb = 2048.0;

  template <typename Fields>
  void fields(Fields& f) {
    f.real("tau", tau, 0.01, 5.0, "primitive duration, s (Fast-Planner's max_tau)");
    f.integer("acceleration_steps", acceleration_steps, 2, 21,
              "accelerations per axis, evenly from -max_acceleration to max_acceleration "
              "(Fast-Planner: 5, steps of a_max / 2: 125 controls)");
    f.real("cell_size", cell_size, 0.01, 10.0,
           "position cell of the closed set, m (Fast-Planner's resolution_astar)");
    f.real("velocity_resolution", velocity_resolution, 0.0, 100.0,
           "velocity bin of the closed set, m/s (0: position cells only, as Fast-Planner)");
    f.real("heuristic_weight", heuristic_weight, 1.0, 100.0,
           "lambda: f = g + lambda h with the OBVP heuristic (Fast-Planner's lambda_heu)");
    f.real("shot_distance", shot_distance, 0.01, 1000.0,
           "the analytic expansion is tried from closed states this close to the goal, m");
    f.real("weight_duration", weights.duration, 0.0, 1e6, "cost per second of flight");
    f.real("weight_length", weights.length, 0.0, 1e6, "cost per metre travelled");
    f.real("weight_control", weights.control_effort, 0.0, 1e6,
           "cost per |a|^2 s of control effort (Fast-Planner: w_time = 10 to 1)");
    f.integer("max_expansions", max_expansions, 0, 1000000000, "expansion budget (0: none)");
    f.real("memory_limit_mb", memory_limit_mb, 1.0, 1e6, "memory budget of the search, MB");
  }
};

ParameterSpecs hybridParameters(const std::string& back_end) {
  return declareFields<HybridSettings>().include(motionParameters(10.0, back_end));
}

MetricSpecs hybridStatistics() {
  return motionPrimitiveStatistics()
      .counter("shots", "analytic expansions tried")
      .counter("shots_rejected", "analytic expansions the checker refused");
}

/// The motion-primitive configuration of the hybrid front end.
MotionPrimitiveConfig hybridConfig(const ParameterSet& parameters) {
  const HybridSettings hybrid = readFields<HybridSettings>(parameters);
  const PlannerLimits limits = plannerLimitsFrom(parameters);
  MotionPrimitiveConfig config;
  SearchSettings& settings = config.settings;
  EdgeEvaluatorSettings& edges = settings.edges;
  edges.order = 2;
  edges.duration = hybrid.tau;
  edges.limits = limits.limits;
  edges.weights = hybrid.weights;
  settings.heuristic_weight = hybrid.heuristic_weight;
  settings.goal_radius = limits.goal_radius;
  settings.memory_limit_mb = hybrid.memory_limit_mb;
  config.policies.edges = std::make_shared<FullEvaluationPolicy>();
  config.heuristic = std::make_shared<HeuristicBuilder>([](const HeuristicContext& context) {
    return std::make_shared<ObvpHeuristic>(context.edges, context.goal_radius);
  });
  config.policies.space =
      std::make_shared<CellSpace>(CellSpace::Cells{hybrid.cell_size, hybrid.velocity_resolution});
  config.policies.shot = std::make_shared<ObvpShot>(edges, hybrid.shot_distance);
  std::vector<double> steps;
  for (long long i = 0; i < hybrid.acceleration_steps; ++i) {
    steps.push_back(-1.0 + 2.0 * static_cast<double>(i) /
                               static_cast<double>(hybrid.acceleration_steps - 1));
  }
  config.controls = controlGrid(steps, edges.limits.bound[2]);
  config.budget = timeBudgetFrom(parameters);
  if (hybrid.max_expansions > 0) config.budget.max_iterations = hybrid.max_expansions;
  return config;
}

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  const auto make = [](const ParameterSet& parameters) {
    return std::make_unique<MotionPrimitivePlanner>(hybridConfig(parameters));
  };
  registrar.add<Planner>(
      "hybrid_astar",
      "Fast-Planner's kinodynamic A*: position cells, OBVP heuristic, analytic shot to the goal "
      "(not optimal)",
      hybridParameters("none"), make, hybridStatistics());
  registrar.add<Planner>(
      "hybrid_astar_bspline",
      "hybrid_astar with the bspline back end by default (Fast-Planner's front and back end)",
      hybridParameters("bspline"), make, hybridStatistics());
}
