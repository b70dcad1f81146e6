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
  const Body& body = checker.settings().body;
  const TraceResult trace =
      traceTrajectory(world, trajectory, body.verdictRadius(), body.tolerance);
  if (trace.free) return result;
  result.valid = false;
  result.check = trace.left_domain ? "bounds" : "collision";
  result.time = trace.time;
  result.position = trace.position;
  result.detail = trace.left_domain ? "position " + formatPoint(trace.position) + " leaves the map"
                                    : "the body (radius " + formatNumber(body.verdictRadius()) +
                                          " m) comes closer to an occupied voxel cube than the "
                                          "world's verdict allows (sphere tracing)";
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
