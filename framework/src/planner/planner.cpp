#include "kinolab/planner/planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "kinolab/core/error.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/planner/back_end.hpp"

namespace kinolab {

std::string_view toString(PlanStatus status) {
  switch (status) {
    case PlanStatus::kExact:
      return "exact";
    case PlanStatus::kApproximate:
      return "approximate";
    case PlanStatus::kNoSolution:
      return "no_solution";
    case PlanStatus::kTimeout:
      return "timeout";
    case PlanStatus::kInvalidStart:
      return "invalid_start";
    case PlanStatus::kInvalidGoal:
      return "invalid_goal";
    case PlanStatus::kInvalidTrajectory:
      return "invalid_trajectory";
    case PlanStatus::kBackEndFailed:
      return "back_end_failed";
  }
  return "unknown";
}

std::string_view toString(SearchTreeEdge::State state) {
  switch (state) {
    case SearchTreeEdge::State::kPartial:
      return "partial";
    case SearchTreeEdge::State::kFull:
      return "full";
    case SearchTreeEdge::State::kCertified:
      return "certified";
    case SearchTreeEdge::State::kRejected:
      return "rejected";
  }
  return "unknown";
}

std::string positionProblem(const World& world, const Eigen::Vector3d& position, const Body& body) {
  if (!position.allFinite()) return "is not finite";
  if (!world.bounds().contains(position)) {
    const Box& b = world.bounds();
    return formatPoint(position) + " is outside the map " + formatPoint(b.min) + " .. " +
           formatPoint(b.max);
  }
  const double radius = body.keptRadius();
  // A body that keeps nothing (a point, or one thinner than its tolerance) collides inside a
  // closed occupied cube, as the checker's point does.
  if (radius == 0.0 && world.esdf().exactDistance(position, world.esdf().resolution()) <= 0.0) {
    return formatPoint(position) + " is inside an occupied voxel cube (robot radius " +
           formatNumber(body.radius) + " m, collision tolerance " + formatNumber(body.tolerance) +
           " m: the body keeps 0 m)";
  }
  const double clearance = world.clearanceFor(position, radius);
  if (clearance < radius) {
    return formatPoint(position) + " is in collision: an occupied voxel cube is " +
           formatNumber(std::max(clearance, 0.0)) + " m from it, less than the robot radius " +
           formatNumber(body.radius) + " m less the collision tolerance " +
           formatNumber(body.tolerance) + " m";
  }
  return "";
}

KINOLAB_DEFINE_PLUGIN_REGISTRY(Planner, "planner", "planners",
                               "planners: the contract of kinolab/planner/planner.hpp", 1)

Planner::Planner() = default;
Planner::~Planner() = default;

const World& Planner::world() const {
  if (!world_) throw InvalidArgument("planner: setup() was not called");
  return *world_;
}

std::string Planner::pluginName() const {
  // key_ is set by configurePlanner(), the way every caller makes a planner.
  return key_.empty() ? "planner" : describePlugin("planner", pluginRegistry<Planner>().info(key_));
}

void Planner::setup(const PlannerContext& context) {
  if (!context.world) throw InvalidArgument("planner: setup without a world");
  if (!(context.body_margin >= 0.0 && std::isfinite(context.body_margin))) {
    throw InvalidArgument("planner: a body margin must be finite and >= 0, got " +
                          formatNumber(context.body_margin));
  }
  body_ = configured_body_.grown(context.body_margin);
  // Not set up until every part is: a setup that throws leaves no half-old planner.
  world_.reset();
  checker_.reset();
  try {
    doSetup(context);
  } catch (...) {
    rethrowFromPlugin(pluginName(), "setup()");
  }
  if (back_end_) {
    try {
      back_end_->setup(context.world, body_, limits());
    } catch (...) {
      rethrowFromPlugin(describePlugin("back_end", pluginRegistry<BackEnd>().info(back_end_key_)),
                        "setup()");
    }
  }
  checker_ = std::make_unique<TrajectoryChecker>(context.world, checkerSettings(body_, limits()));
  world_ = context.world;
}

bool Planner::refinesFrontEnd() const { return back_end_ && !back_end_->keepsFrontEnd(); }

std::string Planner::objective() const {
  if (refinesFrontEnd()) return "trajectory length";
  std::string own = costObjective();
  if (!own.empty()) return own;
  return configuration_.empty() ? "planner-specific" : configuration_;
}

Budget Planner::budgetFor(const Budget& budget) const {
  const Budget own = ownBudget();
  return {std::min(budget.time_limit, own.time_limit),
          std::min(budget.max_iterations, own.max_iterations), budget.clock};
}

std::optional<PlanResult> Planner::refusal(const PlanningQuery& query) const {
  const World& map = world();
  const PlannerLimits own = limits();
  PlanResult result;
  const Eigen::Vector3d start = query.start.col(0);
  result.distance_to_goal = (start - query.goal).norm();
  if (!query.start.allFinite()) {  // a NaN passes every limit comparison below
    result.status = PlanStatus::kInvalidStart;
    result.message = "start state is not finite";
    return result;
  }
  if (std::string problem = positionProblem(map, start, body_); !problem.empty()) {
    result.status = PlanStatus::kInvalidStart;
    result.message = "start " + problem;
    return result;
  }
  if (std::string problem = stateProblem(start); !problem.empty()) {
    result.status = PlanStatus::kInvalidStart;
    result.message = "start " + formatPoint(start) + ": " + problem;
    return result;
  }
  for (int k = 1; k < own.limited_derivatives; ++k) {
    const Eigen::Vector3d excess = query.start.col(k).cwiseAbs() - own.limits.bound[k];
    if (excess.maxCoeff() > 0.0) {
      result.status = PlanStatus::kInvalidStart;
      result.message = "start derivative " + std::to_string(k) + " " +
                       formatPoint(query.start.col(k)) + " exceeds the limit " +
                       formatPoint(own.limits.bound[k]);
      return result;
    }
  }
  if (std::string problem = positionProblem(map, query.goal, body_); !problem.empty()) {
    result.status = PlanStatus::kInvalidGoal;
    result.message = "goal " + problem;
    return result;
  }
  if (std::string problem = goalRegionProblem(query.goal); !problem.empty()) {
    result.status = PlanStatus::kInvalidGoal;
    result.message = "goal region (within " + formatNumber(own.goal_radius) + " m of " +
                     formatPoint(query.goal) + ") has no room for a state: at the goal " + problem +
                     ", and at no voxel centre within it either";
    return result;
  }
  return std::nullopt;
}

std::string Planner::goalRegionProblem(const Eigen::Vector3d& goal) const {
  std::string at_goal = stateProblem(goal);
  if (at_goal.empty()) return at_goal;
  // A planner's goal is the ball of goal_radius: a state anywhere in it ends the search.
  // Decided at the voxel centres (each a few clearance lookups), so a region whose only room
  // is narrower than a voxel is refused too.
  const World& map = world();
  const VoxelGrid& grid = map.grid();
  const double radius = limits().goal_radius;
  const auto voxelOf = [&grid](const Eigen::Vector3d& point) -> VoxelIndex {
    return ((point - grid.origin()) / grid.resolution()).array().floor().cast<int>();
  };
  const Eigen::Vector3d offset = Eigen::Vector3d::Constant(radius);
  const VoxelIndex low = voxelOf(goal - offset).cwiseMax(VoxelIndex::Zero());
  const VoxelIndex high = voxelOf(goal + offset).cwiseMin(grid.dims() - VoxelIndex::Ones());
  for (int ix = low.x(); ix <= high.x(); ++ix) {
    for (int iy = low.y(); iy <= high.y(); ++iy) {
      for (int iz = low.z(); iz <= high.z(); ++iz) {
        const Eigen::Vector3d centre = grid.center(VoxelIndex(ix, iy, iz));
        if ((centre - goal).norm() > radius) continue;
        if (positionProblem(map, centre, body_).empty() && stateProblem(centre).empty()) return "";
      }
    }
  }
  return at_goal;
}

Budget Planner::frontEndBudget(const Budget& budget) const {
  Budget front = budget;
  if (refinesFrontEnd() && std::isfinite(budget.time_limit)) {
    front.time_limit = (1.0 - back_end_->budgetShare()) * budget.time_limit;
  }
  return front;
}

void Planner::runBackEnd(const PlanningQuery& query, PlanResult& result,
                         StopCondition& stop) const {
  const double front_end_ms = 1e3 * stop.elapsed();
  result.statistics.emplace_back("front_end_cost", result.cost);
  BackEndProblem problem;
  problem.start = query.start;
  problem.goal = query.goal;
  problem.path = backEndPath(result.path, result.trajectory);
  problem.front = result.trajectory.empty() ? nullptr : &result.trajectory;
  // The back end's stop: what is left of the call's time (iteration budgets count the front
  // end's work, expansions or tree iterations, not the back end's).
  const Budget whole = stop.budget();
  const double left = std::max(0.0, whole.time_limit - stop.elapsed());
  StopCondition back_stop(Budget{left, std::numeric_limits<long long>::max(), whole.clock});
  BackEndResult refined;
  try {
    refined = back_end_->refine(problem, back_stop);
  } catch (...) {
    rethrowFromPlugin(describePlugin("back_end", pluginRegistry<BackEnd>().info(back_end_key_)),
                      "refine()");
  }
  result.statistics.emplace_back("time_front_end_ms", front_end_ms);
  result.statistics.emplace_back("time_back_end_ms", 1e3 * stop.elapsed() - front_end_ms);
  result.statistics.insert(result.statistics.end(), refined.statistics.begin(),
                           refined.statistics.end());
  if (refined.trajectory.empty()) {
    result.status = PlanStatus::kBackEndFailed;
    // A back end cut short may name what it was doing, not the budget: say both.
    const bool spent = back_stop.elapsed() >= back_stop.budget().time_limit;
    result.message = "back end " + back_end_key_ + ": " +
                     (spent ? "the time budget ran out (" + formatNumber(1e3 * left) +
                                  " ms were left after the front end): "
                            : std::string()) +
                     (refined.failure.empty() ? "no trajectory" : refined.failure);
    result.trajectory = Trajectory();
    result.cost = INFINITY;
    return;
  }
  result.trajectory = std::move(refined.trajectory);
  result.cost = result.trajectory.length();
}

PlanResult Planner::plan(const PlanningQuery& query, const Budget& budget, SearchTree* tree) {
  if (std::optional<PlanResult> refused = refusal(query)) return *std::move(refused);
  return whileDoing("planning with " + pluginName(),
                    [&] { return planAccepted(query, budget, tree); });
}

PlanResult Planner::planAccepted(const PlanningQuery& query, const Budget& budget,
                                 SearchTree* tree) {
  const PlannerLimits own = limits();
  const Eigen::Vector3d start = query.start.col(0);
  PlanResult result;
  // The whole call's budget, and the front end's: its share of the time, the same start.
  StopCondition stop(budgetFor(budget));
  StopCondition front_stop(frontEndBudget(stop.budget()));
  try {
    result = doPlan(query, front_stop);
  } catch (...) {
    rethrowFromPlugin(pluginName(), "plan()");
  }
  const bool answered =
      result.status == PlanStatus::kExact || result.status == PlanStatus::kApproximate;
  // A back end that keeps the front end's trajectory (`none`, every planner's default) is not
  // run: its copy, the path sampled for it and its clock would cost every plan for nothing.
  if (refinesFrontEnd() && answered && (!result.trajectory.empty() || !result.path.empty())) {
    runBackEnd(query, result, stop);
  }
  result.planning_time_ms = 1e3 * stop.elapsed();
  result.objective = objective();
  if (tree) {
    try {
      *tree = doTree(kMaxTreeEdges);
    } catch (...) {
      rethrowFromPlugin(pluginName(), "its search tree");
    }
  }
  if (declared_statistics_) checkStatisticsDeclared(result, *declared_statistics_, key_);
  if (std::isnan(result.cost)) {
    // A NaN passes every comparison downstream: it is a failure, never a result.
    result.status = PlanStatus::kInvalidTrajectory;
    result.message = "the planner reported a cost that is not a number";
    result.check.check = "numeric";
    result.check.detail = result.message;
    return result;
  }

  if (result.trajectory.empty()) {
    result.distance_to_goal = (start - query.goal).norm();
    if (result.status == PlanStatus::kExact) {
      // Nothing to fly is a valid answer only when the start is already in the goal region.
      result.check.valid = result.distance_to_goal <= own.goal_radius;
      if (result.check.valid) result.cost = 0.0;  // nothing to fly costs nothing
      result.check.check = result.check.valid ? "" : "empty";
      result.check.detail = result.check.valid ? "the start is inside the goal region"
                                               : "exact status without a trajectory";
      if (!result.check.valid) result.status = PlanStatus::kInvalidTrajectory;
    }
    return result;
  }
  CheckQuery check_query;
  check_query.start = query.start;
  check_query.goal = query.goal;
  check_query.goal_radius = own.goal_radius;
  check_query.require_goal = result.status == PlanStatus::kExact;
  const auto check_begin = std::chrono::steady_clock::now();
  result.check = checker_->check(result.trajectory, check_query);
  result.evaluation = checker_->evaluate(result.trajectory);
  result.statistics.emplace_back(
      "time_check_ms",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - check_begin)
          .count());
  result.distance_to_goal = result.trajectory.closestDistance(query.goal, checker_->spacing());
  if (!result.check.valid && result.status != PlanStatus::kNoSolution) {
    result.message = std::string(toString(result.status)) + " trajectory rejected by the " +
                     result.check.check + " check at t = " + formatNumber(result.check.time) +
                     " s: " + result.check.detail;
    result.status = PlanStatus::kInvalidTrajectory;
  }
  return result;
}

ParameterSpecs motionParameters(double default_time_limit, const std::string& default_back_end) {
  return ParameterSpecs()
      .real("robot_radius", MotionDefaults::kRobotRadius, 0.0, 10.0,
            "body radius (0: a point); the obstacles are the occupied voxel cubes, and a "
            "position whose proven clearance to them (the ESDF's lower bound) is below this "
            "collides, m")
      .real("collision_tolerance", MotionDefaults::kCollisionTolerance, 1e-4, 1.0,
            "the collision verdict is exact to this: an edge called free keeps robot_radius "
            "less this from every occupied cube, m")
      .real("max_velocity", MotionDefaults::kMaxVelocity, 0.01, 100.0,
            "per-axis velocity limit, m/s")
      .real("max_acceleration", MotionDefaults::kMaxAcceleration, 0.01, 1000.0,
            "per-axis acceleration limit, m/s^2")
      .real("goal_radius", MotionDefaults::kGoalRadius, 0.001, 100.0,
            "goal region: positions this close to the goal, m")
      .real("time_limit", default_time_limit, 0.0, 1e6, "planning time budget, s (0: none)")
      .plugin("back_end", "back_end", default_back_end,
              "the optimisation back end run on the front end's path within the same budget "
              "(kinolab list back_ends; none: the front end's trajectory); its parameters "
              "back_end.NAME");
}

PlannerLimits plannerLimitsFrom(const ParameterSet& parameters) {
  PlannerLimits limits;
  limits.limits =
      DynamicLimits::uniform(parameters.real("max_velocity"), parameters.real("max_acceleration"));
  limits.limited_derivatives = 2;
  limits.goal_radius = parameters.real("goal_radius");
  return limits;
}

Body bodyFrom(const ParameterSet& parameters) {
  Body body;
  body.radius = parameters.has("robot_radius") ? parameters.real("robot_radius") : 0.0;
  if (parameters.has("collision_tolerance")) {
    body.tolerance = parameters.real("collision_tolerance");
  }
  if (parameters.has("safety_distance")) body.safety_band = parameters.real("safety_distance");
  return body;
}

CheckerSettings checkerSettings(const Body& body, const PlannerLimits& limits) {
  CheckerSettings settings;
  settings.body = body;
  settings.limits = limits.limits;
  settings.max_derivative = limits.limited_derivatives;
  return settings;
}

Budget timeBudgetFrom(const ParameterSet& parameters) {
  Budget budget;
  if (const double limit = parameters.real("time_limit"); limit > 0.0) budget.time_limit = limit;
  return budget;
}

MetricSpecs declaredStatistics(const PluginInfo& planner) {
  MetricSpecs specs = MetricSpecs(commonStatistics()).include(planner.statistics);
  const ParameterSpec* back_end = planner.parameters.find("back_end");
  if (!back_end || back_end->type != ParameterType::kPlugin) return specs;
  specs.include(backEndStatistics());
  for (const PluginInfo* info : pluginRegistry<BackEnd>().list()) specs.include(info->statistics);
  return specs;
}

ConfiguredPlanner configurePlanner(std::string_view key,
                                   const std::vector<ParameterAssignment>& assignments) {
  const PluginRegistry<Planner>& planners = pluginRegistry<Planner>();
  ConfiguredPlanner configured;
  configured.parameters = planners.resolve(key, assignments);
  try {
    configured.planner = planners.createResolved(key, configured.parameters);
    configured.planner->configured_body_ = bodyFrom(configured.parameters);
    configured.planner->body_ = configured.planner->configured_body_;
    configured.planner->doCheck();
  } catch (const ParameterConflict& conflict) {
    // Where the blamed parameter was set (the last assignment wins), else where the first of
    // the others taking part was, else the blamed one's default.
    const auto setAt = [&](const std::string& name) {
      std::string at;
      for (const auto& assignment : assignments) {
        if (assignment.name == name) at = assignment.where;
      }
      return at;
    };
    std::string where = setAt(conflict.parameter());
    for (const std::string& other : conflict.others()) {
      if (where.empty()) where = setAt(other);
    }
    if (where.empty()) where = "the default of '" + conflict.parameter() + "'";
    throw ConfigError(where + ": planner '" + std::string(key) + "': " + conflict.what());
  }
  if (configured.parameters.has("back_end")) {
    configured.planner->back_end_key_ = configured.parameters.text("back_end");
    configured.planner->back_end_ =
        pluginRegistry<BackEnd>().createChosen(configured.parameters, "back_end");
  }
  configured.info = &planners.info(key);
  configured.planner->key_ = configured.info->key;
  configured.planner->declared_statistics_ = declaredStatistics(*configured.info);
  configured.planner->configuration_ =
      configured.info->key + "{" + configured.parameters.canonical() + "}";
  return configured;
}

}  // namespace kinolab
