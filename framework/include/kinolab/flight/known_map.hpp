#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/flight/sensor.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// How the planning window treats space the sensor has not seen.
enum class UnknownSpace { kFree, kOccupied, kFreeBeyond };

struct MapModel {
  double resolution = 0.1;     ///< m; the map's voxels align with the ground truth's lattice
  double window = 8.0;         ///< m: the planning window's side in x and y
  double window_height = 2.0;  ///< m: its height (centred on the vehicle, within the map)
  UnknownSpace unknown = UnknownSpace::kFree;
  double free_beyond = 2.0;      ///< m (kFreeBeyond): unknown is occupied closer than this
  double probability_hit = 0.7;  ///< OctoMap sensor model
  double probability_miss = 0.4;
};

/// What the vehicle knows: an OctoMap OcTree updated with every frame (log-odds, max range),
/// and from it a planning window around the vehicle with its exact ESDF.
class KnownMap {
 public:
  /// A map of `bounds` (the ground truth's box; positions outside are never mapped).
  KnownMap(const Box& bounds, const MapModel& model);
  ~KnownMap();
  KnownMap(KnownMap&&) noexcept;
  KnownMap& operator=(KnownMap&&) noexcept;

  /// Inserts a frame: free space along every ray, an occupied voxel at every hit.
  void insert(const SensorFrame& frame, double max_range);
  /// Marks the unseen voxels within `radius` of `center` free (where the vehicle is, nothing
  /// can be), in the tree and the mirror; voxels the sensor has seen keep their state.
  void markFree(const Eigen::Vector3d& center, double radius);
  /// The planning world: the window of side `window` around `center` (clamped to the map),
  /// known occupied voxels and unknown ones as `unknown` says (kFreeBeyond: measured from
  /// `center`), with its exact ESDF.
  std::shared_ptr<const World> window(const Eigen::Vector3d& center) const;
  /// A shortest 8-connected path over the map's x-y cells from `from` to `to`, through cells
  /// with no known occupied voxel within `radius` in the heights [z_low, z_high] (unknown is
  /// free): the global guide a local goal is taken from. Cell centres at heights
  /// interpolated from `from` to `to`; empty when the known map leaves no way.
  std::vector<Eigen::Vector3d> guide(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                     double radius, double z_low, double z_high) const;
  /// The known map from above over heights [z_low, z_high], as text: a line
  /// "nx,ny,origin_x,origin_y,resolution", then per x one line of ny digits, per column 2 (a
  /// known obstacle in the band), 1 (known free there) or 0 (unknown).
  std::string topView(double z_low, double z_high) const;
  /// Voxels known free and known occupied.
  std::size_t knownFree() const;
  std::size_t knownOccupied() const;
  /// The known occupied voxels, as indices of the map's lattice (x slowest, z fastest).
  std::vector<std::size_t> occupiedVoxels() const;
  /// The centre of the lattice voxel `index` (world frame).
  Eigen::Vector3d voxelCenter(std::size_t index) const;
  /// Writes the OcTree as a .bt file (world frame: the tree is kept relative to the map's
  /// origin, so the file is shifted back on writing).
  void write(const std::string& path) const;

 private:
  struct Tree;
  std::unique_ptr<Tree> tree_;
  Box bounds_;
  MapModel model_;
};

}  // namespace kinolab
