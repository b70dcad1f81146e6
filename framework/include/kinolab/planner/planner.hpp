#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kinolab/core/parameters.hpp"
#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/stop_condition.hpp"
#include "kinolab/dynamics/body.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/planner/metrics.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

struct ConfiguredPlanner;
class BackEnd;

/// How a planning call ended.
enum class PlanStatus {
  kExact,              ///< a trajectory into the goal region
  kApproximate,        ///< budget spent: the trajectory to the node closest to the goal
  kNoSolution,         ///< the search space is exhausted without reaching the goal
  kTimeout,            ///< budget spent with nothing better than the start
  kInvalidStart,       ///< the start is outside the map, in collision or beyond the limits
  kInvalidGoal,        ///< the goal is outside the map or in collision
  kInvalidTrajectory,  ///< the planner returned a trajectory the checker rejects
  kBackEndFailed,      ///< the front end found a path; its back end made no trajectory of it
};

/// "exact", "approximate", "no_solution", "timeout", "invalid_start", "invalid_goal",
/// "invalid_trajectory", "back_end_failed".
std::string_view toString(PlanStatus status);

/// One planning problem. The goal is a position; the region around it is the planner's
/// `goal_radius`.
struct PlanningQuery {
  ChainState start = ChainState::Zero();
  Eigen::Vector3d goal = Eigen::Vector3d::Zero();
};

/// The limits and goal region a planner plans for (with its body(): what the checker holds
/// its output to).
struct PlannerLimits {
  DynamicLimits limits;
  int limited_derivatives = 2;  ///< limits apply to derivatives 1..this
  double goal_radius = MotionDefaults::kGoalRadius;
};

/// Why `position` cannot be a start or goal for `body`, or "" when it can: not finite,
/// outside the map, or closer to the occupied cubes than the body's keptRadius() (the rule
/// every edge and the checker hold to).
std::string positionProblem(const World& world, const Eigen::Vector3d& position, const Body& body);

/// One edge of a planner's search tree or graph, for figures (the paper's Fig. 6).
struct SearchTreeEdge {
  enum class State { kPartial, kFull, kCertified, kRejected };
  std::vector<Eigen::Vector3d> points;  ///< from the parent to the child
  State state = State::kFull;
  bool closed = false;  ///< the child was expanded (or reached the goal)
};
using SearchTree = std::vector<SearchTreeEdge>;
/// The most edges a tree for figures holds (`kinolab plan --out`, the runner's store.trees):
/// a large search is decimated evenly to this, so its tree is megabytes, not gigabytes.
inline constexpr std::size_t kMaxTreeEdges = 20000;
/// The step that keeps every k-th of `total` edges so that at most `max_edges` remain (at
/// least one is kept).
inline std::size_t treeStride(std::size_t total, std::size_t max_edges) {
  const std::size_t limit = std::max<std::size_t>(max_edges, 1);
  return std::max<std::size_t>(1, (total + limit - 1) / limit);
}
std::string_view toString(SearchTreeEdge::State state);

/// A named statistic a planner reports (counters and times); the runner stores them all.
using Statistics = std::vector<std::pair<std::string, double>>;

struct PlanResult {
  PlanStatus status = PlanStatus::kNoSolution;
  Trajectory trajectory;  ///< empty when there is none
  /// A geometric front end's path (waypoints from the start, every straight piece free for
  /// its collision model), for its back end; empty for a front end that plans trajectories.
  std::vector<Eigen::Vector3d> path;
  double cost = INFINITY;  ///< the planner's own cost of the trajectory
  /// What `cost` measures (Planner::objective()): costs are comparable only between results
  /// of equal objectives.
  std::string objective;
  double distance_to_goal = INFINITY;  ///< D: from the trajectory's closest point (or start)
  double planning_time_ms = 0.0;  ///< the planner's work only (no checking), on the budget's clock
  Statistics statistics;
  /// Anytime progress: samples of the planner's declared series (MetricSpecs::series), each
  /// series in time order from the start of its work.
  Progress progress;
  CheckResult check;  ///< the independent checker's verdict on the trajectory
  /// The checker's figures of the trajectory (empty: none), the same for every planner.
  TrajectoryEvaluation evaluation;
  std::string message;  ///< why, for statuses other than exact
};

/// What a planner is set up with: the world, the seed of its random streams, and how much
/// more than its body it keeps from the obstacles (a flight's planning margin: the body it
/// plans for is its configured body grown by this).
struct PlannerContext {
  std::shared_ptr<const World> world;
  std::uint64_t seed = 0;
  double body_margin = 0.0;  ///< m
};

/// The planner contract. A planner is configured from its parameters (by its factory), set
/// up once per world, then asked to plan queries. plan() is the same for every planner: it
/// rejects invalid starts and goals, times the planner's own work, runs its back end (the
/// `back_end` parameter of motionParameters(); kinolab/planner/back_end.hpp) on the front
/// end's answer, and runs the independent checker on what comes out; a plugin implements the
/// protected steps (the front end).
class Planner {
 public:
  Planner();
  virtual ~Planner();

  void setup(const PlannerContext& context);
  /// Plans one query within `budget`. With `tree`, the planner's search tree is written there,
  /// built after the clock stopped (planning_time_ms is the same with or without it) and at
  /// most kMaxTreeEdges edges.
  PlanResult plan(const PlanningQuery& query, const Budget& budget, SearchTree* tree = nullptr);
  /// Forgets everything from earlier queries (setup stays).
  void reset() { doReset(); }

  /// The budget plan(query, budget) works within: per limit, the tighter of `budget` (the
  /// caller's: an experiment's `budget:`, `kinolab plan --time-limit`) and the planner's own
  /// (its `time_limit` and expansion parameters), on the caller's clock. The one rule every
  /// caller times against.
  Budget budgetFor(const Budget& budget) const;

  /// What the planner's `cost` measures, as text: two planners' costs mean the same only
  /// when their objectives are equal (eager and lazy MP-A* at equal weights). A planner that
  /// does not say (costObjective() empty) has its type and every parameter as its objective:
  /// its cost compares only with its own configuration's. After a back end (other than
  /// `none`) the cost is the trajectory's length, whatever the front end: "trajectory length".
  std::string objective() const;

  bool isSetup() const { return world_ != nullptr; }
  const World& world() const;
  /// The body the planner plans for: the one configurePlanner() read from its parameters
  /// (bodyFrom(); the default Body for a planner made otherwise), grown by the last setup's
  /// body_margin. Its edges, heuristic and the independent checker all take it.
  const Body& body() const { return body_; }
  /// The body as configured, before any margin.
  const Body& configuredBody() const { return configured_body_; }
  /// Its limits and goal region.
  PlannerLimits limits() const { return plannerLimits(); }

 protected:
  virtual void doSetup(const PlannerContext& context) = 0;
  /// Plans from a valid start to a valid goal. The status, trajectory, cost and statistics
  /// are the planner's; plan() adds the time, D and the checker's verdict.
  virtual PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) = 0;
  /// The search tree (or graph) of the last doPlan(), for figures: at most `max_edges`
  /// edges, decimated evenly beyond that. Called after the clock stopped; none by default.
  virtual SearchTree doTree(std::size_t /*max_edges*/) const { return {}; }
  virtual void doReset() {}
  virtual PlannerLimits plannerLimits() const = 0;
  /// The planner's own budget (from its parameters); plan() uses the tighter of this and
  /// the caller's.
  virtual Budget ownBudget() const { return {}; }
  /// Refuses, when configured (before any world: `run --dry-run` and an experiment's
  /// validation see it), a configuration that cannot work (a control set that cannot move),
  /// as a ParameterConflict naming the parameter to change; nothing by default.
  virtual void doCheck() const {}
  /// What the cost measures (objective()); "" by default.
  virtual std::string costObjective() const { return ""; }
  /// Why a state of this planner cannot stand at `position` (already inside the map and clear
  /// for body()), or "": a planner whose states keep more than the body (RRT*'s
  /// clearance_margin, ompl_control's step margin) says what. plan() refuses a start where
  /// none can stand (invalid_start) and a goal whose region has no such point (invalid_goal)
  /// before the budget is spent; nothing more by default.
  virtual std::string stateProblem(const Eigen::Vector3d& /*position*/) const { return ""; }
  /// True when its back end makes the trajectory flown from the front end's answer (any but
  /// `none`): a geometric front end may then plan from a moving start, with only a path.
  bool refinesFrontEnd() const;

 private:
  friend ConfiguredPlanner configurePlanner(std::string_view,
                                            const std::vector<ParameterAssignment>&);

  /// How errors from its own code name it: "plugin LIB (planner 'KEY')" (from key_).
  std::string pluginName() const;
  /// The result of a query the planner must refuse (a start or goal outside the map or in
  /// collision, a start beyond the limits or where no state stands, a goal region without
  /// room for a state), or none.
  std::optional<PlanResult> refusal(const PlanningQuery& query) const;
  /// plan()'s work once the query is accepted; plan() names it when memory runs out.
  PlanResult planAccepted(const PlanningQuery& query, const Budget& budget, SearchTree* tree);
  /// "" when a state of this planner stands somewhere in the goal region: at the goal or at a
  /// voxel centre within goal_radius of it; else why not at the goal.
  std::string goalRegionProblem(const Eigen::Vector3d& goal) const;
  /// The front end's budget within the call's: the time less the back end's share.
  Budget frontEndBudget(const Budget& budget) const;
  /// Runs the back end on the front end's answer within `stop` (the whole call's budget):
  /// its trajectory and length replace the front end's, or the status is back_end_failed.
  void runBackEnd(const PlanningQuery& query, PlanResult& result, StopCondition& stop) const;

  std::shared_ptr<const World> world_;
  Body configured_body_;
  Body body_;
  std::unique_ptr<TrajectoryChecker> checker_;
  /// Set for planners made by configurePlanner(): plan() holds their statistics to the
  /// registration's declaration (declaredStatistics()), and errors name the plugin.
  std::string key_;
  std::optional<MetricSpecs> declared_statistics_;
  /// The objective of a planner that does not declare one: its type and parameters.
  std::string configuration_;
  std::unique_ptr<BackEnd> back_end_;  ///< the chosen back end (none without the parameter)
  std::string back_end_key_;
};

template <>
PluginRegistry<Planner>& pluginRegistry<Planner>();

/// The motion parameters most planners share, declared once: `robot_radius`,
/// `collision_tolerance`, `max_velocity`, `max_acceleration` (per axis), `goal_radius`,
/// `time_limit` (with the planner's own default) and `back_end` (the back end run after the
/// planner, `none` by default; its parameters `back_end.NAME`). Include them with
/// ParameterSpecs::include().
ParameterSpecs motionParameters(double default_time_limit,
                                const std::string& default_back_end = "none");
/// The velocity and acceleration limits and goal region of motionParameters().
PlannerLimits plannerLimitsFrom(const ParameterSet& parameters);
/// The body a planner's parameters declare: `robot_radius` (0, a point, when it has none),
/// `collision_tolerance` and `safety_distance` (Body's defaults when it has none).
/// configurePlanner() reads it once.
Body bodyFrom(const ParameterSet& parameters);
/// What the independent checker holds a planner of this body and these limits to.
CheckerSettings checkerSettings(const Body& body, const PlannerLimits& limits);
/// The `time_limit` of motionParameters() as a budget (0: none).
Budget timeBudgetFrom(const ParameterSet& parameters);

/// Every statistic a registered planner may report: its registration's, commonStatistics(),
/// and, when it has the `back_end` parameter, every registered back end's.
MetricSpecs declaredStatistics(const PluginInfo& planner);

/// A planner created from its registered key and assignments (every one validated before
/// anything is created), its body read from them (bodyFrom()).
struct ConfiguredPlanner {
  std::unique_ptr<Planner> planner;
  const PluginInfo* info = nullptr;  ///< its registration: key, parameters, statistics
  ParameterSet parameters;
};
ConfiguredPlanner configurePlanner(std::string_view key,
                                   const std::vector<ParameterAssignment>& assignments);

}  // namespace kinolab
