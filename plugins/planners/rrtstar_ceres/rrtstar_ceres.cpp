// `rrtstar_ceres`: the TGK analogue. OMPL's RRT* plans a geometric path on the ESDF
// (states need the robot radius plus a margin of clearance), OMPL's simplifier shortens it,
// and Ceres turns it into a uniform cubic B-spline trajectory: smoothness (jerk), an ESDF
// obstacle penalty with its analytic gradient, velocity and acceleration penalties, then
// time re-allocation until the limits hold. `rrtstar` is the front end alone, flown
// stop-and-go along the path (for ablations).
#include <cmath>

#include "bspline_smoother.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "rrt_front_end.hpp"

namespace kinolab::rrt {
namespace {

ParameterSpecs frontEndParameters() {
  return ParameterSpecs()
      .real("range", 1.5, 0.0, 1000.0,
            "longest RRT* edge, m (0: OMPL's default, 20 % of the map's extent)")
      .real("goal_bias", 0.05, 0.0, 1.0, "probability of sampling the goal")
      .real("rewire_factor", 1.1, 1.0, 10.0, "scales RRT*'s rewiring neighbourhood")
      .boolean("k_nearest", true, "rewire over the k nearest vertices (else within a radius)")
      .boolean("delay_collision_checking", true, "check a neighbour's edge only when it would win")
      .include(motionParameters(5.0))
      .real("clearance_margin", 0.1, 0.0, 10.0,
            "RRT* states need the radius plus this much clearance, m")
      .real("motion_resolution", 0.5, 0.05, 10.0, "RRT* motions are checked every this many voxels")
      .boolean("simplify", true, "OMPL's vertex reduction and shortcutting of the path")
      .integer("refine_iterations", 1000, 0, 1000000000,
               "RRT* iterations after the first solution (0: stop at the first)")
      .integer("max_iterations", 0, 0, 1000000000, "RRT* iteration budget (0: none)")
      .integer("max_vertices", 500000, 100, 100000000,
               "RRT* tree size budget: the search stops there (bounds its memory)");
}

ParameterSpecs smoothingParameters() {
  return frontEndParameters()
      .real("knot_spacing", 0.5, 0.02, 10.0, "B-spline control points along the path, m")
      .real("initial_speed", 0.7, 0.05, 1.0, "first time allocation: this share of max_velocity")
      .real("safety_distance", 0.25, 0.0, 10.0,
            "the obstacle penalty acts below the radius plus this, m")
      .real("weight_smoothness", 1.0, 0.0, 1e6, "weight of the jerk (third difference) term")
      .real("weight_guide", 0.01, 0.0, 1e6,
            "weight keeping control points near the time-allocated path (0: free)")
      .real("weight_obstacle", 10.0, 0.0, 1e6, "weight of the ESDF obstacle penalty")
      .real("weight_feasibility", 10.0, 0.0, 1e6, "weight of the velocity/acceleration penalty")
      .integer("obstacle_samples", 4, 1, 100, "ESDF samples per B-spline span")
      .integer("max_solver_iterations", 100, 1, 100000, "Ceres iterations per solve")
      .integer("max_rounds", 4, 1, 20,
               "solves: after a collision, again with half the knot spacing, 4x obstacle weight");
}

MetricSpecs frontEndStatistics() {
  MetricSpecs specs;
  specs.clock("time_simplify_ms", "OMPL path simplification")
      .counter("path_vertices_raw", "RRT* path vertices before simplification")
      .real("path_length_raw", "m", "RRT* path length before simplification")
      .counter("path_vertices", "path vertices after simplification")
      .real("path_length", "m", "path length after simplification")
      .counter("iterations", "RRT* iterations")
      .counter("tree_size", "RRT* tree vertices")
      .counter("collision_checks", "state validity checks (ESDF clearance)")
      .counter("motion_checks", "motion validity checks")
      .counter("motion_checks_invalid", "motion checks that found a collision")
      .counter("first_solution_iteration", "iteration of the first exact solution")
      .clock("first_solution_ms", "time to the first exact solution")
      .real("first_solution_cost", "m", "path length of the first exact solution")
      .real("best_cost", "m", "RRT*'s best path length")
      .clock("time_rrt_ms", "RRT* (front end) time");
  specs.series("anytime_cost", "m",
               "RRT*'s best path length over its planning time (a sample at every "
               "improvement)");
  return specs;
}

MetricSpecs smoothingStatistics() {
  return frontEndStatistics()
      .counter("smoothing_rounds", "Ceres solves")
      .counter("ceres_iterations", "Ceres iterations over all solves")
      .real("ceres_initial_cost", "", "objective before the first solve")
      .real("ceres_final_cost", "", "objective after the last solve")
      .counter("time_reallocations", "time re-allocations until the limits hold")
      .counter("control_points", "B-spline control points")
      .real("knot_interval", "s", "B-spline knot interval")
      .clock("time_smooth_ms", "Ceres smoothing (back end) time")
      .boolean("smoothing_valid", "the smoothed trajectory passed the smoother's own check");
}

class RrtStarPlanner final : public Planner {
 public:
  RrtStarPlanner(const ParameterSet& parameters, bool smooth)
      : parameters_(parameters),
        model_(planningModelFrom(parameters)),
        budget_(timeBudgetFrom(parameters)) {
    if (const long long limit = parameters.integer("max_iterations"); limit > 0) {
      budget_.max_iterations = limit;
    }
    if (smooth) {
      SmootherSettings& s = smoother_settings_.emplace();
      s.knot_spacing = parameters.real("knot_spacing");
      s.initial_speed = parameters.real("initial_speed");
      s.robot_radius = model_.robot_radius;
      s.safety_distance = parameters.real("safety_distance");
      s.limits = model_.limits;
      s.weight_smoothness = parameters.real("weight_smoothness");
      s.weight_guide = parameters.real("weight_guide");
      s.weight_obstacle = parameters.real("weight_obstacle");
      s.weight_feasibility = parameters.real("weight_feasibility");
      s.obstacle_samples = static_cast<int>(parameters.integer("obstacle_samples"));
      s.max_solver_iterations = static_cast<int>(parameters.integer("max_solver_iterations"));
      s.max_rounds = static_cast<int>(parameters.integer("max_rounds"));
    }
  }

 protected:
  void doSetup(const PlannerContext& context) override {
    FrontEndSettings settings;
    settings.range = parameters_.real("range");
    settings.goal_bias = parameters_.real("goal_bias");
    settings.rewire_factor = parameters_.real("rewire_factor");
    settings.k_nearest = parameters_.boolean("k_nearest");
    settings.delay_collision_checking = parameters_.boolean("delay_collision_checking");
    settings.clearance = model_.robot_radius + parameters_.real("clearance_margin");
    settings.motion_resolution =
        parameters_.real("motion_resolution") * context.world->esdf().resolution();
    settings.simplify = parameters_.boolean("simplify");
    settings.refine_iterations = parameters_.integer("refine_iterations");
    settings.max_vertices = parameters_.integer("max_vertices");
    settings.goal_radius = model_.goal_radius;
    front_end_ = std::make_unique<RrtFrontEnd>(context.world, settings);
    clearance_ = settings.clearance;
    seed_ = context.seed;
    if (smoother_settings_) smoother_.emplace(context.world, *smoother_settings_);
  }

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override {
    PlanResult result;
    const Eigen::Vector3d start = query.start.col(0);
    const bool at_rest = query.start.col(1).isZero() && query.start.col(2).isZero();
    if (!smoother_ && !at_rest) {
      result.status = PlanStatus::kInvalidStart;
      result.message =
          "rrtstar flies its path stop-and-go, so it starts at rest (use "
          "rrtstar_ceres for a moving start)";
      return result;
    }
    if (const double clearance = world().clearance(start); clearance < clearance_) {
      result.status = PlanStatus::kInvalidStart;
      result.message = "start clearance " + formatNumber(clearance) +
                       " m is below robot_radius + clearance_margin = " + formatNumber(clearance_) +
                       " m, which every RRT* state needs";
      return result;
    }
    // The run's seed and the query decide OMPL's random streams: the same case repeats.
    std::uint64_t seed = hashBytes(query.goal.data(), 3 * sizeof(double), seed_);
    seed = hashBytes(query.start.data(), sizeof(ChainState), seed);
    FrontEndResult path =
        front_end_->plan(start, query.goal, static_cast<std::uint32_t>(seed), stop);
    result.statistics = std::move(path.statistics);
    result.progress = std::move(path.progress);
    if (path.outcome == FrontEndResult::Outcome::kNone) {
      result.status = PlanStatus::kTimeout;
      result.message = "no RRT* path after " + std::to_string(path.iterations) + " iterations";
      return result;
    }
    result.status = path.outcome == FrontEndResult::Outcome::kExact ? PlanStatus::kExact
                                                                    : PlanStatus::kApproximate;
    if (result.status == PlanStatus::kApproximate) {
      result.message = "budget spent after " + std::to_string(path.iterations) +
                       " iterations: the path to the vertex closest to the goal";
    }
    // A path of length 0 (the start is in the goal region) leaves nothing to fly.
    if (smoother_ && path.path_length > 0.0) {
      SmootherResult smoothed = smoother_->smooth(query.start, path.path, stop);
      result.statistics.insert(result.statistics.end(), smoothed.statistics.begin(),
                               smoothed.statistics.end());
      result.statistics.emplace_back("smoothing_valid", smoothed.valid ? 1.0 : 0.0);
      if (!smoothed.valid) result.message = "smoothing failed: " + smoothed.problem;
      result.trajectory = std::move(smoothed.trajectory);
    } else if (path.path_length > 0.0) {
      result.trajectory = stopAndGo(path.path, model_.limits);
    }
    result.cost = result.trajectory.empty() ? INFINITY : result.trajectory.length();
    return result;
  }

  SearchTree doTree(std::size_t max_edges) const override {
    return front_end_ ? front_end_->tree(max_edges) : SearchTree{};
  }

  PlanningModel planningModel() const override { return model_; }

  Budget ownBudget() const override { return budget_; }

 private:
  ParameterSet parameters_;
  PlanningModel model_;
  Budget budget_;
  std::optional<SmootherSettings> smoother_settings_;
  std::uint64_t seed_ = 0;
  double clearance_ = 0.0;
  std::unique_ptr<RrtFrontEnd> front_end_;
  std::optional<BsplineSmoother> smoother_;
};

}  // namespace
}  // namespace kinolab::rrt

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.library("ompl", rrt::omplVersion());
  registrar.library("ceres", rrt::ceresVersion());
  registrar.add<Planner>(
      "rrtstar_ceres",
      "TGK analogue: OMPL RRT* path, Ceres-smoothed uniform cubic B-spline (jerk, ESDF, limits)",
      rrt::smoothingParameters(),
      [](const ParameterSet& parameters) {
        return std::make_unique<rrt::RrtStarPlanner>(parameters, true);
      },
      rrt::smoothingStatistics());
  registrar.add<Planner>(
      "rrtstar", "OMPL RRT* path alone, flown stop-and-go at the limits (ablation of the smoother)",
      rrt::frontEndParameters(),
      [](const ParameterSet& parameters) {
        return std::make_unique<rrt::RrtStarPlanner>(parameters, false);
      },
      rrt::frontEndStatistics());
}
