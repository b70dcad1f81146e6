// `hybrid_astar` and `hybrid_astar_bspline`: Fast-Planner's kinodynamic front end (Zhou et al.,
// "Robust and Efficient Quadrotor Trajectory Generation for Fast Autonomous Flight", RA-L 2019)
// on kinolab's motion-primitive core: acceleration controls on a grid (-a_max .. a_max per
// axis) applied for one duration, states kept one per position cell (the first to close a
// cell closes it), the OBVP heuristic weighted by lambda, and an analytic expansion (the
// least-effort cubic to rest at the goal) from closed states near the goal, accepted when the
// independent checker accepts it. `hybrid_astar_bspline` then smooths the result with the
// Ceres uniform B-spline back end (smoothness, ESDF clearance, feasibility, time
// re-allocation) shared with rrtstar_ceres. Neither is optimal. docs/hybrid_astar.md.
#include <cmath>
#include <optional>

#include "bspline_smoother.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace kinolab {
namespace {

using smoothing::BsplineSmoother;
using smoothing::SmootherSettings;

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

ParameterSpecs hybridParameters() {
  return declareFields<HybridSettings>().include(motionParameters(10.0));
}

ParameterSpecs hybridBsplineParameters() {
  return hybridParameters().include(declareFields<SmootherSettings>());
}

MetricSpecs hybridStatistics() {
  return motionPrimitiveStatistics()
      .counter("shots", "analytic expansions tried")
      .counter("shots_rejected", "analytic expansions the checker refused");
}

MetricSpecs hybridBsplineStatistics() {
  return hybridStatistics()
      .real("front_end_cost", "", "the front end's cost (the search's, before smoothing)")
      .clock("time_front_end_ms", "front end (hybrid A*) time")
      .include(smoothing::smootherStatistics())
      .boolean("smoothing_valid",
               "the smoothed trajectory passed the smoother's own check (else the front end's "
               "trajectory is returned)");
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

/// The front end, then the B-spline back end on its path; the front end's trajectory when
/// the smoother fails its own check.
class HybridBsplinePlanner final : public MotionPrimitivePlanner {
 public:
  explicit HybridBsplinePlanner(const ParameterSet& parameters)
      : HybridBsplinePlanner(hybridConfig(parameters), parameters) {}

 protected:
  void doSetup(const PlannerContext& context) override {
    MotionPrimitivePlanner::doSetup(context);
    SmootherSettings settings = smoother_settings_;
    settings.body = body();
    smoother_.emplace(context.world, settings);
  }

  /// The smoothed trajectory's cost is the shot's (duration and control effort, exact): the
  /// front end's objective where that has no length or obstacle term, another one elsewhere.
  std::string costObjective() const override {
    const CostWeights& w = config().settings.edges.weights;
    const std::string front_end = MotionPrimitivePlanner::costObjective();
    return w.length == 0.0 && w.obstacle == 0.0 ? front_end
                                                : "shot cost without obstacles, " + front_end;
  }

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override {
    PlanResult result = MotionPrimitivePlanner::doPlan(query, stop);
    result.statistics.emplace_back("front_end_cost", result.cost);
    result.statistics.emplace_back("time_front_end_ms", 1e3 * stop.elapsed());
    if (result.status != PlanStatus::kExact) return result;
    // The path: the front end's positions every 0.05 s.
    std::vector<Eigen::Vector3d> path;
    for (const TrajectorySample& sample : result.trajectory.sample(0.05)) {
      path.push_back(sample.position);
    }
    smoothing::SmootherResult smoothed = smoother_->smooth(query.start, path, stop);
    result.statistics.insert(result.statistics.end(), smoothed.statistics.begin(),
                             smoothed.statistics.end());
    result.statistics.emplace_back("smoothing_valid", smoothed.valid ? 1.0 : 0.0);
    if (smoothed.valid) {
      result.trajectory = std::move(smoothed.trajectory);
      result.cost = shot_.cost(result.trajectory);
    }
    return result;
  }

 private:
  HybridBsplinePlanner(const MotionPrimitiveConfig& config, const ParameterSet& parameters)
      : MotionPrimitivePlanner(config),
        smoother_settings_(readFields<SmootherSettings>(parameters)),
        shot_(config.settings.edges, 1.0) {
    smoother_settings_.limits = config.settings.edges.limits;
  }

  SmootherSettings smoother_settings_;
  ObvpShot shot_;  // its cost functional: w_T T + w_U |a|^2 + w_L length
  std::optional<BsplineSmoother> smoother_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.library("ceres", smoothing::ceresVersion());
  registrar.add<Planner>(
      "hybrid_astar",
      "Fast-Planner's kinodynamic A*: position cells, OBVP heuristic, analytic shot to the goal "
      "(not optimal)",
      hybridParameters(),
      [](const ParameterSet& parameters) {
        return std::make_unique<MotionPrimitivePlanner>(hybridConfig(parameters));
      },
      hybridStatistics());
  registrar.add<Planner>(
      "hybrid_astar_bspline",
      "hybrid_astar, then the Ceres uniform B-spline back end (smoothness, ESDF, limits)",
      hybridBsplineParameters(),
      [](const ParameterSet& parameters) {
        return std::make_unique<HybridBsplinePlanner>(parameters);
      },
      hybridBsplineStatistics());
}
