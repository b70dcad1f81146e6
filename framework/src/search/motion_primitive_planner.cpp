#include "kinolab/search/motion_primitive_planner.hpp"

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {

ParameterSpecs motionPrimitiveParameters() {
  return ParameterSpecs()
      .text("sampler", "uniform",
            "control sampler (kinolab list samplers); set its parameters as sampler.NAME")
      .integer("order", 2, 2, 4, "integrator chain order: 2 acceleration, 3 jerk, 4 snap control")
      .real("tau", 0.4, 0.01, 5.0, "primitive duration, s")
      .real("max_velocity", 2.0, 0.01, 100.0, "per-axis velocity limit, m/s")
      .real("max_acceleration", 3.0, 0.01, 1000.0, "per-axis acceleration limit, m/s^2")
      .real("max_jerk", 10.0, 0.01, 10000.0, "per-axis jerk limit (order >= 3), m/s^3")
      .real("max_snap", 50.0, 0.01, 100000.0, "per-axis snap limit (order 4), m/s^4")
      .real("weight_duration", 1.0, 0.0, 1e6, "cost per second of flight")
      .real("weight_length", 0.0, 0.0, 1e6, "cost per metre travelled")
      .real("weight_control", 0.1, 0.0, 1e6, "cost per |u|^2 s of control effort")
      .real("weight_obstacle", 1.0, 0.0, 1e6, "cost per second inside the safety band (squared)")
      .integer("edge_samples", 10, 1, 10000, "K: ESDF samples per edge in full evaluation")
      .real("edge_spacing", 0.0, 0.0, 10.0,
            "> 0: sample edges this far apart (at most half a voxel) instead of K samples, m")
      .real("robot_radius", 0.25, 0.0, 10.0, "body radius: clearance below this collides, m")
      .real("safety_distance", 0.5, 0.001, 100.0, "obstacle penalty band beyond the radius, m")
      .choice("heuristic", "min_time", {"euclidean", "min_time"},
              "euclidean: |d| / |v_max|; min_time: max_i |d_i| / v_max_i (MPL)")
      .real("heuristic_weight", 1.0, 1.0, 100.0,
            "epsilon: f = g + epsilon h; > 1 is bounded suboptimal (cost <= epsilon optimum)")
      .real("key_position_resolution", 0.01, 1e-6, 10.0, "state key: position rounding, m")
      .real("key_velocity_resolution", 0.01, 1e-6, 10.0, "state key: velocity rounding, m/s")
      .real("key_acceleration_resolution", 0.01, 1e-6, 100.0,
            "state key: acceleration (and jerk) rounding")
      .real("goal_radius", 0.5, 0.001, 100.0, "goal region: positions this close to the goal, m")
      .real("time_limit", 10.0, 0.0, 1e6, "planning time budget, s (0: none)")
      .integer("max_expansions", 0, 0, 1000000000, "expansion budget (0: none)");
}

SearchSettings searchSettingsFrom(const ParameterSet& parameters, EvaluationMode mode) {
  SearchSettings settings;
  settings.mode = mode;
  EdgeEvaluatorSettings& edges = settings.edges;
  edges.order = static_cast<int>(parameters.integer("order"));
  edges.duration = parameters.real("tau");
  edges.limits =
      DynamicLimits::uniform(parameters.real("max_velocity"), parameters.real("max_acceleration"),
                             parameters.real("max_jerk"), parameters.real("max_snap"));
  edges.weights.duration = parameters.real("weight_duration");
  edges.weights.length = parameters.real("weight_length");
  edges.weights.control_effort = parameters.real("weight_control");
  edges.weights.obstacle = parameters.real("weight_obstacle");
  edges.robot_radius = parameters.real("robot_radius");
  edges.safety_distance = parameters.real("safety_distance");
  const double spacing = parameters.real("edge_spacing");
  edges.sampling.mode = spacing > 0.0 ? EdgeSampling::Mode::kSpacing : EdgeSampling::Mode::kCount;
  edges.sampling.samples = static_cast<int>(parameters.integer("edge_samples"));
  if (spacing > 0.0) edges.sampling.spacing = spacing;
  settings.heuristic =
      parameters.text("heuristic") == "euclidean" ? Heuristic::kEuclidean : Heuristic::kMinTime;
  settings.heuristic_weight = parameters.real("heuristic_weight");
  settings.key_resolution = {parameters.real("key_position_resolution"),
                             parameters.real("key_velocity_resolution"),
                             parameters.real("key_acceleration_resolution")};
  settings.goal_radius = parameters.real("goal_radius");
  if (parameters.has("duplicate_rule")) {
    settings.duplicate_rule =
        parameters.text("duplicate_rule") == "seed" ? DuplicateRule::kSeed : DuplicateRule::kLwa;
  }
  if (parameters.has("lower_bound")) {
    const std::string& bound = parameters.text("lower_bound");
    settings.lower_bound = bound == "control_only" ? LowerBound::kControlOnly
                           : bound == "lipschitz"  ? LowerBound::kLipschitz
                                                   : LowerBound::kEndpoint;
  }
  if (parameters.has("cost_weight")) settings.cost_weight = parameters.real("cost_weight");
  return settings;
}

MotionPrimitivePlanner::MotionPrimitivePlanner(const ParameterSet& parameters, EvaluationMode mode)
    : settings_(searchSettingsFrom(parameters, mode)) {
  if (const double limit = parameters.real("time_limit"); limit > 0.0) budget_.time_limit = limit;
  if (const long long limit = parameters.integer("max_expansions"); limit > 0) {
    budget_.max_iterations = limit;
  }
}

const MotionPrimitiveSearch& MotionPrimitivePlanner::search() const {
  if (!search_) throw InvalidArgument("motion-primitive planner: setup() was not called");
  return *search_;
}

void MotionPrimitivePlanner::doSetup(const PlannerContext& context) {
  if (!context.sampler) {
    throw InvalidArgument("motion-primitive planner: set up without a control sampler");
  }
  const Eigen::Vector3d u_max = settings_.edges.limits.bound[settings_.edges.order];
  auto controls = context.sampler->sample(u_max, context.seed);
  if (settings_.edges.sampling.mode == EdgeSampling::Mode::kSpacing) {
    const double half_voxel = 0.5 * context.world->esdf().resolution();
    if (settings_.edges.sampling.spacing > half_voxel) {
      throw ConfigError("edge_spacing " + formatNumber(settings_.edges.sampling.spacing) +
                        " m is coarser than half a voxel of world '" + context.world->name() +
                        "' (" + formatNumber(half_voxel) + " m)");
    }
  }
  search_ = std::make_unique<MotionPrimitiveSearch>(context.world, std::move(controls), settings_);
}

void MotionPrimitivePlanner::doReset() {
  if (search_) search_->clear();
}

PlanningModel MotionPrimitivePlanner::planningModel() const {
  PlanningModel model;
  model.robot_radius = settings_.edges.robot_radius;
  model.limits = settings_.edges.limits;
  model.limited_derivatives = settings_.edges.order;
  model.goal_radius = settings_.goal_radius;
  return model;
}

PlanResult MotionPrimitivePlanner::doPlan(const PlanningQuery& query, StopCondition& stop,
                                          SearchTree* tree) {
  MotionPrimitiveSearch& search = *search_;
  const auto outcome = search.search(query.start, query.goal, stop);
  PlanResult result;
  result.trajectory = search.trajectory();
  result.cost = result.trajectory.empty() ? INFINITY : search.cost();
  switch (outcome) {
    case MotionPrimitiveSearch::Outcome::kGoal:
      result.status = PlanStatus::kExact;
      break;
    case MotionPrimitiveSearch::Outcome::kExhausted:
      result.status = PlanStatus::kNoSolution;
      result.message = "every reachable state was expanded without reaching the goal region";
      break;
    case MotionPrimitiveSearch::Outcome::kBudget:
      result.status = result.trajectory.empty() ? PlanStatus::kTimeout : PlanStatus::kApproximate;
      result.message =
          "budget spent after " + std::to_string(search.counters().expansions) + " expansions";
      break;
  }
  result.statistics = search.statistics();
  result.statistics.emplace_back("controls", static_cast<double>(search.controls().size()));
  result.statistics.emplace_back("heuristic_weight", settings_.heuristic_weight);
  if (tree) *tree = search.tree();
  return result;
}

}  // namespace kinolab
