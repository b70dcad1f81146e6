#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// How hard a flight's query is before anyone flies it: FlightBench's task difficulty metrics
/// (Yu et al., "FlightBench", 2024, and its cal_difficulty.py), computed on the ground truth
/// along a guide path, plus the obstacle density. Deterministic: where FlightBench samples
/// its corridor spheres' centres, this takes the best of a fixed grid of them.
struct ScenarioDifficulty {
  /// The guide: a shortest 8-connected path over the truth's x-y cells whose centres keep
  /// the body's radius from every obstacle in the query's heights (+- 0.5 m; columnGuide()),
  /// shortened by cutting every corner whose shortcut the body clears; empty when there is
  /// none.
  std::vector<Eigen::Vector3d> guide;
  double guide_length = NAN;  ///< m
  /// TO: every 0.3 m along the guide the radius r_i of a corridor sphere, the largest
  /// clearance less the body's radius (at most 4 m) of centres on a 5 x 5 grid across the
  /// path up to 0.5 m either way; of the smaller half of them (N), R / (2 N) sum 1 / r_i
  /// (R = 4 m, FlightBench's sensing range): narrow passages make it large.
  double traversability_obstruction = NAN;
  /// VO: every R / 10 along the guide, looking along it, the nearest occupied voxel within R
  /// in four cones about the direction (up to 36, 30, 22.5 and 15 degrees off it, weighted
  /// 0.05, 0.1, 0.3, 0.55 in that order), sum weight R / distance; the mean over the guide.
  double view_occlusion = NAN;
  /// AOL: sum over the shortened guide's corners of exp(2 theta / pi) - 1 (theta its turn),
  /// over its length, 1/m.
  double angle_over_length = NAN;
  /// Obstacles (8-connected occupied areas) that the horizontal slice at the start's height
  /// cuts, per hectare of the map: trees per hectare in a forest.
  double obstacles_per_hectare = NAN;
};

ScenarioDifficulty scenarioDifficulty(const World& truth, const PlanningQuery& query,
                                      double robot_radius);

}  // namespace kinolab
