#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "kinolab/world/esdf.hpp"
#include "kinolab/world/voxel_grid.hpp"

namespace kinolab {

struct WorldSpec;

/// A built world: the occupancy grid and its exact signed distance field. Immutable once
/// built and shared read-only as std::shared_ptr<const World>. A robot or inflation radius
/// is applied at query time (compare distance() with it), never baked into the grid.
class World {
 public:
  World(std::string name, std::uint64_t spec_hash, VoxelGrid grid, Esdf esdf);
  /// A world whose planning domain `bounds` (where a state may be: bounds()) is a box inside
  /// the grid: the distances also see the obstacles of the grid around it (a flight's window
  /// sees the ground just below its floor). Throws InvalidArgument when it is not inside.
  World(std::string name, std::uint64_t spec_hash, VoxelGrid grid, Esdf esdf, const Box& bounds);

  /// Builds the grid from the spec's generators and computes the ESDF.
  static std::shared_ptr<const World> build(const WorldSpec& spec);
  /// Only the occupancy grid of a spec (no ESDF).
  static VoxelGrid buildGrid(const WorldSpec& spec);

  const std::string& name() const { return name_; }
  std::uint64_t specHash() const { return spec_hash_; }
  const VoxelGrid& grid() const { return grid_; }
  const Esdf& esdf() const { return esdf_; }
  /// Where a state may be: the grid's box, or the smaller domain it was built with.
  const Box& bounds() const { return bounds_; }

  /// Trilinear signed distance in metres (see Esdf for the rule outside the map).
  double distance(const Eigen::Vector3d& point) const { return esdf_.distance(point); }
  /// A proven lower bound of the distance to every occupied voxel cube (Esdf::clearance).
  double clearance(const Eigen::Vector3d& point) const { return esdf_.clearance(point); }
  /// The distance to the occupied cubes as a verdict at `threshold` needs it (Esdf::decided
  /// on clearance()): `clearanceFor(p, t) >= t` exactly when the true distance is at least t.
  double clearanceFor(const Eigen::Vector3d& point, double threshold) const {
    return esdf_.decided(point, esdf_.clearance(point), threshold, threshold);
  }
  /// True when `point` is inside the map and provably at least `radius` from every occupied
  /// cube (clearance() >= radius; a conservative test, for sampling queries).
  bool isFree(const Eigen::Vector3d& point, double radius) const {
    return bounds_.contains(point) && esdf_.clearance(point) >= radius;
  }
  /// True when every point of the segment from `a` to `b` is inside the map and provably at
  /// least `radius - tolerance` from every occupied cube (sphere tracing on clearance(), which
  /// is 1-Lipschitz): whether a query's straight line is open to a body of that radius.
  bool segmentFree(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius,
                   double tolerance = 0.01) const;

  /// Throws InvalidArgument (naming the world, `who` and both distances) when the field is
  /// truncated at or below `reach`, the distance out to which `who` reads it exactly.
  void requireExactDistancesTo(double reach, const std::string& who) const;
  /// The reach of an obstacle cost that reads the trilinear distance (and its gradient) out
  /// to `band`: every corner it reads lies within sqrt(3) voxels of the point, the point within
  /// sqrt(3) voxels of the corners' least (the distance is 1-Lipschitz), so band + 2 sqrt(3)
  /// voxels.
  double obstacleCostReach(double band) const {
    return band + 2.0 * std::sqrt(3.0) * esdf_.resolution();
  }

  /// Takes the grid and the field out of a World no one needs any more, so that their memory
  /// serves the next one (a flight's planning window, made anew every frame).
  std::pair<VoxelGrid, Esdf> release() && { return {std::move(grid_), std::move(esdf_)}; }

 private:
  std::string name_;
  std::uint64_t spec_hash_;
  VoxelGrid grid_;
  Esdf esdf_;
  Box bounds_;  // the domain (by default grid_.bounds()), kept for the per-query isFree()
};

}  // namespace kinolab
