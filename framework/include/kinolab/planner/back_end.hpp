#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/stop_condition.hpp"
#include "kinolab/dynamics/body.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/planner/metrics.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/trajectory/trajectory.hpp"

namespace kinolab {

/// What a back end refines: the query and the front end's answer to it.
struct BackEndProblem {
  ChainState start = ChainState::Zero();  ///< the query's start state (within the limits)
  Eigen::Vector3d goal = Eigen::Vector3d::Zero();
  /// The front end's path from the start to its end (in the goal region for an exact front
  /// end): a geometric front end's waypoints (PlanResult::path; every straight piece free for
  /// its collision model), else its trajectory's positions every kBackEndPathStep seconds and
  /// its end (a polyline close to, not exactly on, a trajectory the checker accepts).
  std::vector<Eigen::Vector3d> path;
  /// The front end's own trajectory (valid for the checker when the front end's status is
  /// exact); a back end may start from it or ignore it.
  const Trajectory* front = nullptr;
};

/// A back end's answer: the trajectory to fly, or a named failure.
struct BackEndResult {
  Trajectory trajectory;  ///< empty when there is none
  /// Empty when `trajectory` is the answer; else why not, in words (the run's message).
  std::string failure;
  Statistics statistics;  ///< as declared at registration
};

/// An optimisation back end (kind "back_end", `kinolab list back_ends`): after a planner's
/// front end, it turns the path or trajectory found into the trajectory flown. Every planner
/// declares the parameter `back_end` (motionParameters(); `none` keeps the front end's
/// trajectory), and Planner::plan() runs the chosen one within the same budget, times it apart
/// (`time_front_end_ms`, `time_back_end_ms`) and sends its output to the independent checker.
class BackEnd {
 public:
  virtual ~BackEnd() = default;

  /// Prepares for a world (a planner's setup): the world, the body (with a flight's margin)
  /// and the planner's limits hold until the next setup.
  virtual void setup(std::shared_ptr<const World> world, const Body& body,
                     const PlannerLimits& limits) = 0;
  /// The trajectory from problem.start (its velocity and acceleration matched), within the
  /// limits, keeping the body's keptRadius() from the occupied cubes, ending at rest at the
  /// path's last point; or a failure in words. Stops at `stop` (what is left of the
  /// planner's time budget; its iterations are the back end's own to count);
  /// deterministic: the same problem gives the same answer.
  virtual BackEndResult refine(const BackEndProblem& problem, StopCondition& stop) const = 0;
  /// The share of a time budget kept for the back end: the front end stops at the rest.
  virtual double budgetShare() const { return 0.0; }
  /// True for a back end that returns the front end's trajectory as it is (`none`):
  /// Planner::plan() then does not run it (the front end's trajectory, cost and objective
  /// stand), and a front end that has only a path (a geometric one from a moving start)
  /// cannot be flown.
  virtual bool keepsFrontEnd() const { return false; }
};

template <>
PluginRegistry<BackEnd>& pluginRegistry<BackEnd>();

/// The statistics Planner::plan() reports for every planner with a back end:
/// `front_end_cost`, `time_front_end_ms`, `time_back_end_ms`.
const MetricSpecs& backEndStatistics();

/// Why a back end cannot refine `problem`, or "" when it can: a start state, goal or path
/// point that is not finite, or an empty path. Every back end checks its input with it.
std::string backEndInputProblem(const BackEndProblem& problem);

/// A back end's own check of its trajectory, before Planner::plan() hands it to the
/// independent checker: `checker`'s start, limits and goal checks (checkMotion), then the
/// world's sphere-traced verdict (traceTrajectory) on the checker's body in place of the
/// checker's FCL test at every sample, at a fraction of the cost: traced at the body's kept
/// radius plus a quarter of its tolerance, exact to that quarter, so that a trajectory it
/// passes keeps the kept radius (the checker accepts it) and one it rejects comes within a
/// quarter tolerance of it. A failure is named as the checker names it ("limits", "bounds",
/// "collision", ...).
CheckResult backEndSelfCheck(const TrajectoryChecker& checker, const World& world,
                             const Trajectory& trajectory, const CheckQuery& query);

/// The time step of BackEndProblem::path sampled from a front end's trajectory, s.
inline constexpr double kBackEndPathStep = 0.05;

/// The waypoints a back end refines from a front end's result: `path` when given, else the
/// trajectory's positions every kBackEndPathStep seconds and its end.
std::vector<Eigen::Vector3d> backEndPath(const std::vector<Eigen::Vector3d>& path,
                                         const Trajectory& trajectory);

}  // namespace kinolab
