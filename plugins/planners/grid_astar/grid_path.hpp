#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "grid_search.hpp"
#include "kinolab/dynamics/body.hpp"

namespace kinolab::grid {

/// A geometric path from a position to a position through the voxel search.
struct GridPath {
  /// kStartUnconnected, kGoalUnconnected: no free voxel next to that end (decided before
  /// the search).
  enum class Outcome { kFound, kNoPath, kStopped, kStartUnconnected, kGoalUnconnected };
  Outcome outcome = Outcome::kNoPath;
  /// The start, the voxel centres (straight runs merged) and the goal.
  std::vector<Eigen::Vector3d> grid_path;
  /// `grid_path` shortcut by line of sight: every straight piece free for the body.
  std::vector<Eigen::Vector3d> path;
  double grid_length = 0.0;  ///< m, of grid_path
  double length = 0.0;       ///< m, of path
  long long line_of_sight_checks = 0;
  long long voxel_evaluations = 0;  ///< voxels whose clearance the search read
  GridSearchResult search;
  std::string message;  ///< why there is no path
};

/// The voxel of `voxels` nearest `position` (its own or one of its 26 neighbours) that is free
/// and joined to it by a straight segment free for `body`, or none.
std::optional<VoxelIndex> connectedVoxel(const FreeVoxels& voxels, const Eigen::Vector3d& position,
                                         const Body& body);

/// Whether the segment keeps the body's keptRadius() from the occupied cubes (proven, sphere
/// tracing on the ESDF's lower bound) inside the world's domain.
bool segmentFree(const World& world, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 const Body& body);

/// Start and goal snapped to connected voxels, the search between them, the path through the
/// voxel centres from the exact start to the exact goal, then shortcut greedily: from each
/// kept point, the farthest later point of the path in a straight free line.
GridPath findGridPath(const World& world, const Body& body, const Eigen::Vector3d& start,
                      const Eigen::Vector3d& goal, GridAlgorithm algorithm, StopCondition& stop);

/// The length of a polyline, m.
double polylineLength(const std::vector<Eigen::Vector3d>& points);

}  // namespace kinolab::grid
