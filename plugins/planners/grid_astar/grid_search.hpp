#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "kinolab/core/stop_condition.hpp"
#include "kinolab/world/world.hpp"

/// The voxel search shared by the `grid_astar` planner and the `ego_bspline` back end's guide
/// paths: A* or Jump Point Search (Harabor and Grastien, AAAI 2011; in 3-D as Liu et al.,
/// "Planning Dynamically Feasible Trajectories for Quadrotors Using Safe Flight Corridors in
/// 3-D Complex Environments", RA-L 2017, JPS3D) over the 26-connected voxels of a world.
namespace kinolab::grid {

/// Which search runs.
enum class GridAlgorithm { kAStar, kJps };

/// Which voxels a search may enter: inside the world's domain and the optional window, with
/// the ESDF's proven clearance at the centre at least `radius`. A move between neighbours
/// needs every voxel of the cube they span free (no corner cutting): the straight segment
/// between the two centres is then free at `radius` too (along it each axis's distance to a
/// voxel-aligned cube is monotone, so no point is nearer an obstacle than the nearest of
/// those centres).
class FreeVoxels {
 public:
  FreeVoxels(const World& world, double radius);
  /// Only the voxels from `low` to `high` (inclusive, clamped to the grid).
  FreeVoxels(const World& world, double radius, const VoxelIndex& low, const VoxelIndex& high);

  bool free(const VoxelIndex& voxel) const;
  /// Whether the move from `voxel` by `step` (components in {-1, 0, 1}) is allowed.
  bool canMove(const VoxelIndex& voxel, const VoxelIndex& step) const;
  const VoxelGrid& grid() const { return world_.grid(); }
  const World& world() const { return world_; }
  /// Voxels whose clearance was computed (each once).
  long long evaluations() const { return evaluations_; }

 private:
  std::size_t local(const VoxelIndex& voxel) const;

  const World& world_;
  double radius_;
  VoxelIndex low_;
  VoxelIndex high_;
  /// Per voxel of the window: 0 not yet known, 1 free, 2 blocked; in a hash map instead when
  /// the window is too large for a byte a voxel (a city's grid).
  mutable std::vector<std::uint8_t> known_;
  mutable std::unordered_map<std::size_t, std::uint8_t> sparse_known_;
  mutable long long evaluations_ = 0;
};

struct GridSearchResult {
  bool found = false;
  bool stopped = false;  ///< the stop condition ended the search
  /// Start .. goal voxels: every voxel for A*, the jump points for JPS (consecutive ones on a
  /// straight or diagonal line of free moves).
  std::vector<VoxelIndex> voxels;
  double length = 0.0;       ///< m, along `voxels`' centres
  long long expansions = 0;  ///< nodes taken from the open list
  long long generated = 0;   ///< nodes put on the open list (a better cost counts again)
  long long jump_steps = 0;  ///< voxels stepped over by JPS's jumps
};

/// The shortest 26-connected path of voxel moves from `start` to `goal` (both free), with the
/// octile distance as heuristic; JPS returns a path of the same length as A*. Stops at
/// `stop` (expansions are its iterations).
GridSearchResult searchGrid(const FreeVoxels& voxels, const VoxelIndex& start,
                            const VoxelIndex& goal, GridAlgorithm algorithm, StopCondition& stop);

/// The octile distance between two voxels (the cost of the shortest move sequence without
/// obstacles), in voxels.
double octileDistance(const VoxelIndex& a, const VoxelIndex& b);

/// The polyline through the centres of `voxels`, collinear points merged.
std::vector<Eigen::Vector3d> voxelCentres(const VoxelGrid& grid,
                                          const std::vector<VoxelIndex>& voxels);

}  // namespace kinolab::grid
