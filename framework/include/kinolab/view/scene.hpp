#pragma once

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/planner/planner.hpp"

namespace kinolab::view {

/// An axis-aligned block of voxels, [lo, hi) in voxel indices of the grid.
struct VoxelBox {
  std::array<int, 3> lo{};
  std::array<int, 3> hi{};
};

/// Boxes covering exactly the occupied voxels of `grid` coarsened by `stride` (a coarse voxel
/// is occupied when any of its fine voxels is; the boxes are in fine-voxel indices, clipped to
/// the grid), disjoint: each grown greedily from the first uncovered voxel along z, then y,
/// then x, so a floor is one box and a forest of trunks a few thousand, not a million voxels.
std::vector<VoxelBox> obstacleBoxes(const VoxelGrid& grid, int stride = 1);

/// The obstacle boxes of a world for the 3D viewer: at the finest stride (1, 2, 4, ...) that
/// gives at most `max_boxes` boxes, and whose coarse grid has at most kMostViewerCells cells
/// (a byte each: a city of 7.5 x 10^9 voxels starts at stride 4). Returns the boxes and the
/// stride used.
constexpr std::size_t kMostViewerCells = std::size_t{1} << 27;
std::pair<std::vector<VoxelBox>, int> viewerBoxes(const VoxelGrid& grid,
                                                  std::size_t max_boxes = 60000);

/// A 3D scene for the viewer (viewer/viewer.js; the format is in docs/viewer.md): a world's
/// obstacles, then per query the trajectories, search trees and flights of any planners.
class Scene {
 public:
  explicit Scene(const std::string& title);
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;
  void setWorld(const World& world);
  /// Adds a query; returns its index for the add* calls.
  int addQuery(const std::string& name, const Eigen::Vector3d& start, const Eigen::Vector3d& goal);
  /// The trajectory sampled every `step` seconds.
  void addTrajectory(int query, const std::string& planner, const Trajectory& trajectory,
                     double step = 0.05);
  void addTree(int query, const std::string& planner, const SearchTree& tree);
  /// A flight: the flown trajectory sampled every `step` seconds, and its known map as
  /// voxels (cubes of `voxel_size` at their centres) with the time each was first known
  /// occupied (FlightResult::known_voxels), so that a replay shows the map growing.
  void addFlight(int query, const std::string& planner, const Trajectory& flown,
                 const std::vector<std::pair<double, Eigen::Vector3d>>& known_voxels,
                 double voxel_size, double step = 0.1);
  /// The scene as JSON.
  std::string json() const;

 private:
  struct Impl;  // the JSON document
  std::unique_ptr<Impl> impl_;
};

/// The viewer page template (one self-contained HTML file with three.js inlined, built by
/// CMake): $KINOLAB_VIEWER, else share/kinolab/viewer.html beside the installed framework
/// library, else the build tree's. Throws FileError when none exists.
std::string viewerTemplatePath();

/// The viewer page with `scene_json` inlined.
std::string viewHtml(const std::string& scene_json);

/// Writes `path` (atomically): viewHtml(scene_json).
void writeViewHtml(const std::string& path, const std::string& scene_json);

}  // namespace kinolab::view
