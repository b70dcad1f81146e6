#pragma once

#include <Eigen/Core>
#include <vector>

#include "kinolab/dynamics/body.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab::minco {

/// A convex polytope in H-representation: the points x with normal_i . x <= offset_i for every
/// row i (unit normals), so that a half-space's excess n . x - b is a distance in metres.
struct Polytope {
  Eigen::Matrix3Xd normals;
  Eigen::VectorXd offsets;

  void add(const Eigen::Vector3d& normal, double offset);
  int size() const { return static_cast<int>(offsets.size()); }
  /// The largest excess of `point` over the half-spaces: <= 0 inside, m.
  double excess(const Eigen::Vector3d& point) const;
  bool contains(const Eigen::Vector3d& point, double slack = 1e-9) const {
    return excess(point) <= slack;
  }
};

/// The path with its points skipped wherever the straight line between two kept ones keeps
/// the body's keptRadius() from the occupied cubes (greedy, from the start): a search's dense
/// polyline becomes a few segments, each the seed of one corridor.
std::vector<Eigen::Vector3d> shortcutPath(const World& world,
                                          const std::vector<Eigen::Vector3d>& path,
                                          const Body& body);

/// What corridorAround() did, for the statistics.
struct CorridorTally {
  int obstacles = 0;   ///< surface cubes near the segment considered
  int halfspaces = 0;  ///< planes cut for obstacles (beside the box's six)
};

/// A convex polytope around the segment from `a` to `b` whose every point keeps `radius` from
/// every occupied voxel cube, inside the box of the segment grown by `box_half_size` and the
/// world's bounds. Obstacles are the occupied cubes with a free face neighbour (the others lie
/// behind them); nearest to the segment first, each cube not yet cut off adds the plane through
/// its point closest to the segment, normal to the line between the two, moved towards the
/// segment by `radius` (Liu et al.'s ellipsoid decomposition with the segment as a degenerate
/// ellipsoid; a simpler, sound stand-in for FIRI's inflation). The segment stays inside
/// whenever it keeps `radius` from the cubes.
Polytope corridorAround(const World& world, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        double box_half_size, double radius, CorridorTally* tally = nullptr);

}  // namespace kinolab::minco
