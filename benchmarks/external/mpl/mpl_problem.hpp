// MPL's planner set up for a double-integrator problem of kinolab's kind, shared by
// mpl_vs_kinolab (parameters from the experiment file) and mpl_plan_query (the benchmark's):
// the uniform control grid of kinolab's `uniform` sampler, and the start and goal waypoints of
// MPL's examples. MPL headers only (mpl_plan_query links no kinolab).
#pragma once

#include <mpl_planner/planner/map_planner.h>

#include <memory>

struct MplProblem {
  int samples_per_axis = 3;  // controls per axis, evenly over [-a_max, a_max]
  double max_velocity = 2;
  double max_acceleration = 1;
  double tau = 1;
  double time_weight = 10;  // MPL's w: cost J + w T
  double epsilon = 1;
  double goal_tolerance = 0.01;
};

// A planner on `map` for `problem`.
inline std::unique_ptr<MPL::VoxelMapPlanner> makeMplPlanner(std::shared_ptr<MPL::VoxelMapUtil> map,
                                                            const MplProblem& problem) {
  const int n = problem.samples_per_axis;
  const auto u = [&](int i) {
    return n == 1 ? 0.0 : problem.max_acceleration * (2.0 * i / (n - 1) - 1.0);
  };
  vec_E<VecDf> controls;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) controls.push_back(Vec3f(u(i), u(j), u(k)));
  auto planner = std::make_unique<MPL::VoxelMapPlanner>(false);
  planner->setMapUtil(map);
  planner->setVmax(problem.max_velocity);
  planner->setAmax(problem.max_acceleration);
  planner->setDt(problem.tau);
  planner->setU(controls);
  planner->setW(problem.time_weight);
  planner->setEpsilon(problem.epsilon);
  planner->setTol(problem.goal_tolerance);
  return planner;
}

// As in MPL's examples: at rest at `position`, acceleration control (with setTol alone, MPL's
// goal test ignores a goal's velocity).
inline Waypoint3D restingWaypoint(const Vec3f& position) {
  Waypoint3D waypoint;
  waypoint.pos = position;
  waypoint.vel = Vec3f::Zero();
  waypoint.acc = Vec3f::Zero();
  waypoint.jrk = Vec3f::Zero();
  waypoint.yaw = 0;
  waypoint.use_pos = true;
  waypoint.use_vel = true;
  waypoint.use_acc = false;
  waypoint.use_jrk = false;
  waypoint.use_yaw = false;
  return waypoint;
}
