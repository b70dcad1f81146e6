#include "kinolab/planner/back_end.hpp"

#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/trajectory_trace.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(BackEnd, "back_end", "back_ends",
                               "optimisation back ends run after a planner's front end (every "
                               "planner's `back_end`)",
                               9)

const MetricSpecs& backEndStatistics() {
  static const MetricSpecs specs =
      MetricSpecs()
          .real("front_end_cost", "",
                "the front end's own cost (its objective), before the back end")
          .clock("time_front_end_ms", "the front end's time (the planner before its back end)")
          .clock("time_back_end_ms", "the back end's time");
  return specs;
}

CheckResult backEndSelfCheck(const TrajectoryChecker& checker, const World& world,
                             const Trajectory& trajectory, const CheckQuery& query) {
  CheckResult result = checker.checkMotion(trajectory, query);
  if (!result.valid) return result;
  // Traced at the checker's own radius (the body's kept radius) plus a quarter of the
  // tolerance, exact to that quarter: a trajectory called free keeps the kept radius, so the
  // checker accepts it; one rejected comes within a quarter tolerance of it. (At the searches'
  // verdict radius, a whole tolerance stricter than the checker, corridor_minco lost 8 more of
  // the 300 runs of experiments/back_ends.yaml to its own check.)
  const Body& body = checker.settings().body;
  const double slack = 0.25 * body.tolerance;
  const TraceResult trace = traceTrajectory(world, trajectory, body.keptRadius() + slack, slack);
  if (trace.free) return result;
  result.valid = false;
  result.check = trace.left_domain ? "bounds" : "collision";
  result.time = trace.time;
  result.position = trace.position;
  result.detail = trace.left_domain ? "position " + formatPoint(trace.position) + " leaves the map"
                                    : "the body (kept radius " + formatNumber(body.keptRadius()) +
                                          " m) comes within " + formatNumber(slack) +
                                          " m of an occupied voxel cube (sphere tracing)";
  return result;
}

std::string backEndInputProblem(const BackEndProblem& problem) {
  if (!problem.start.allFinite()) return "the start state is not finite";
  if (!problem.goal.allFinite()) return "the goal is not finite";
  if (problem.path.empty()) return "the front end's path is empty";
  for (const Eigen::Vector3d& point : problem.path) {
    if (!point.allFinite()) return "the front end's path has a point that is not finite";
  }
  return "";
}

std::vector<Eigen::Vector3d> backEndPath(const std::vector<Eigen::Vector3d>& path,
                                         const Trajectory& trajectory) {
  if (!path.empty() || trajectory.empty()) return path;
  std::vector<Eigen::Vector3d> points;
  for (const TrajectorySample& sample : trajectory.sample(kBackEndPathStep)) {
    points.push_back(sample.position);
  }
  return points;  // sample() ends at the end time
}

}  // namespace kinolab
