#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/world/esdf.hpp"
#include "kinolab/world/voxel_grid.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// How the planning window treats space the sensor has not seen.
enum class UnknownSpace { kFree, kOccupied, kFreeBeyond };

/// The vehicle map's lattice and the planning window a flight takes from it.
struct MapModel {
  double resolution = 0.1;     ///< m; the map's voxels align with the ground truth's lattice
  double window = 8.0;         ///< m: the planning window's side in x and y
  double window_height = 2.0;  ///< m: its height (centred on the vehicle, within the map)
  double window_margin = 1.0;  ///< m: the kept window's extra side in x and y (window())
  UnknownSpace unknown = UnknownSpace::kFree;
  double free_beyond = 2.0;  ///< m (kFreeBeyond): unknown is occupied closer than this
  /// m: how far the window's distance field reaches beyond the planning domain on every side
  /// (not a parameter: the flight sets the planner's collision radius), so that an obstacle
  /// just outside the domain, the ground below its floor, is seen by a body inside it.
  double reach = 0.0;
  /// m: how far the planning domain keeps inside the map's box (not a parameter: the flight
  /// sets its planning margin), room for the tracking error where the map ends; the domain
  /// still holds the vehicle when it is closer to the map's end.
  double inset = 0.0;

  /// Its parameters, a flight's (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("map_resolution", resolution, 0.01, 10.0,
           "the vehicle's map voxel, m (the ground truth's lattice when equal)");
    f.real("window", window, 1.0, 1000.0, "planning window side in x and y, m");
    f.real("window_height", window_height, 0.2, 1000.0,
           "planning window height, m (centred on the vehicle, within the map; a camera looking "
           "ahead does not see far above or below, so a tall window lets a planner climb into "
           "unseen space)");
    f.real("window_margin", window_margin, 0.0, 1000.0,
           "the planning window is kept, and its ESDF updated only where the known map "
           "changed, while the vehicle stays within this of its centre in x and y (and a "
           "quarter of window_height in z); then it is built anew around the vehicle, m");
    f.choice("unknown", unknown,
             {{"free", UnknownSpace::kFree},
              {"occupied", UnknownSpace::kOccupied},
              {"free_beyond", UnknownSpace::kFreeBeyond}},
             "unseen space in the planning window: free, occupied, or occupied closer than "
             "free_beyond and free farther");
    f.real("free_beyond", free_beyond, 0.0, 1000.0, "see unknown, m");
  }
};

/// Marks the columns of a lattice's x-row `x` that hold an obstacle in the voxel layers
/// [z0, z1]: row[y] = 1 for those, 0 for the others (a row at a time: one call per row).
using ObstacleColumns = std::function<void(int x, int z0, int z1, std::uint8_t* row)>;

/// What the vehicle knows: the state of every voxel of the map's lattice (unknown, free or
/// occupied), grown frame by frame, and from it a planning window around the vehicle with its
/// exact ESDF, a global guide, views and the map as an OctoMap file.
///
/// A map kind (`kinolab list vehicle_maps`, the flight parameter `map`) is its sensor model:
/// how a frame changes what is known (doInsert()). Everything a flight asks of the map is
/// answered here from the known states, the same for every kind. Configured from its
/// parameters by its factory, then set up once per flight (setup()).
class VehicleMap {
 public:
  enum class Voxel : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

  virtual ~VehicleMap();

  /// Starts a map of `bounds` (the ground truth's box; positions outside are never mapped),
  /// everything unknown. A ConfigError when the lattice is too large to keep.
  void setup(const Box& bounds, const MapModel& model);
  bool isSetup() const { return !state_.empty(); }
  /// How errors from the kind's code (doSetup, doInsert, doMarkFree) name it, e.g. "plugin
  /// LIB (vehicle_map 'KEY')" (flightSetup() names the maps it makes; "vehicle_map" if unset).
  void nameAs(std::string plugin_name) { plugin_name_ = std::move(plugin_name); }

  /// Inserts a frame seen from frame.origin, rays cut at `max_range`: free space along every
  /// ray, an obstacle at every hit, as the map kind's sensor model decides.
  void insert(const SensorFrame& frame, double max_range);
  /// Marks the unseen voxels within `radius` of `center` known (where the vehicle is, nothing
  /// can be: free); voxels the sensor has seen keep their state. With `only`, just the voxels
  /// whose centre it accepts.
  void markFree(const Eigen::Vector3d& center, double radius,
                const std::function<bool(const Eigen::Vector3d&)>& only = {});
  /// True when every voxel of the map's lattice whose cube comes within `radius` of `p` is
  /// known free (unknown counts as occupied): a body of that radius at `p` is in space the
  /// known map vouches for. Voxels outside the map do not count (nothing is there).
  bool knownFreeAround(const Eigen::Vector3d& p, double radius) const {
    return unvouchedDistance(p, radius) >= radius;
  }
  /// The exact distance from `p` to the nearest cube of a voxel that is not known free
  /// (unknown or occupied) when it is below `limit`, else `limit`; 0 inside one. Voxels
  /// outside the map do not count. What a flight traces a plan against before committing it
  /// (traceTrajectory): the space the known map vouches for.
  double unvouchedDistance(const Eigen::Vector3d& p, double limit) const {
    return unvouchedDistance(p, limit, nullptr);
  }
  /// unvouchedDistance(), and in `nearest` (when one is below `limit`) the point of that
  /// voxel's cube nearest `p`: what keeps a body at `p` from being vouched for.
  double unvouchedDistance(const Eigen::Vector3d& p, double limit, Eigen::Vector3d* nearest) const;
  /// The planning world around `center`: known occupied voxels and unknown ones as `unknown`
  /// says (kFreeBeyond: measured from `center`), with its exact ESDF. The window is kept
  /// between calls: its domain (World::bounds()) is a box of side window + 2 window_margin in
  /// x and y and window_height in z (clamped to the map's box less `inset`), built around the
  /// vehicle and kept while it holds the square of side `window` around `center` and `center` is
  /// within a quarter of its height of its middle; its grid and ESDF reach `reach` farther on every
  /// side. Meanwhile only the voxels whose occupancy changed are updated (IncrementalEsdf),
  /// and the same World is returned while none did. With `rebuild` it is built anew around
  /// `center` whatever it held (the flight's way out when the kept window leaves a local goal
  /// no room beyond the planner's goal region).
  std::shared_ptr<const World> window(const Eigen::Vector3d& center, bool rebuild = false);
  /// A shortest 8-connected path over the map's x-y cells from `from` to `to`, through cells
  /// with no known occupied voxel within `radius` in the heights [z_low, z_high] (unknown is
  /// free): the global guide a local goal is taken from. Cell centres at heights
  /// interpolated from `from` to `to`; empty when the known map leaves no way.
  std::vector<Eigen::Vector3d> guide(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                     double radius, double z_low, double z_high) const;
  /// guide() from each of `froms` (one path each, empty where there is none), the map's
  /// columns read once: a flight's guide and the way from where it last made progress. The
  /// cells within `room` of each of `froms` and of `to` are open whatever the band holds (a
  /// vehicle stands there; see columnGuides()), and those of `trail` (where it flew); the cells
  /// within the model's `inset` of the
  /// map's sides are closed.
  std::vector<std::vector<Eigen::Vector3d>> guides(
      std::span<const Eigen::Vector3d> froms, const Eigen::Vector3d& to, double radius,
      double z_low, double z_high, double room = 0.0,
      std::span<const Eigen::Vector3d> trail = {}) const;
  /// Which x-y columns of the lattice hold a known occupied voxel in given layers: what the
  /// guides read (guides(), levelColumnGuides()).
  ObstacleColumns obstacleColumns() const;
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
  /// Writes the known voxels as an OctoMap .bt file (world frame).
  void write(const std::string& path) const;

  /// The map's box (setup()'s) and its lattice, which covers it.
  const Box& bounds() const { return bounds_; }
  const VoxelGrid& lattice() const { return lattice_; }
  const MapModel& model() const { return model_; }
  Voxel state(std::size_t index) const { return static_cast<Voxel>(state_[index]); }

 protected:
  /// After setup() made the lattice (all unknown): start the kind's own state.
  virtual void doSetup() {}
  /// The kind's sensor model: updates its state from the frame and calls setState() for
  /// every lattice voxel whose known state it changes.
  virtual void doInsert(const SensorFrame& frame, double max_range) = 0;
  /// The unseen voxel `index` (centre `center`) is inside the vehicle's body: make it known
  /// free in the kind's state and call setState(). By default, only the latter.
  virtual void doMarkFree(std::size_t index, const Eigen::Vector3d& center);

  void setState(std::size_t index, Voxel state) {
    state_[index] = static_cast<std::uint8_t>(state);
  }
  /// Asks for voxel `index`'s state ahead of state() or setState() (a kind updating voxels
  /// scattered over the lattice hides the loads' latency so).
  void prefetchState(std::size_t index) const { __builtin_prefetch(&state_[index], 1); }

 private:
  MapModel model_;
  Box bounds_;
  std::string plugin_name_ = "vehicle_map";
  /// The box on the map's lattice of half-sides `half` around `center`, clamped to the map.
  Box latticeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& half) const;
  /// The window's occupancy on `grid` (a box of the lattice) seen from `center`, into
  /// `occupancy` (one byte a voxel of `grid`).
  void windowOccupancy(const VoxelGrid& grid, const Eigen::Vector3d& center,
                       std::span<std::uint8_t> occupancy) const;

  VoxelGrid lattice_;  // the map's geometry (its occupancy unused)
  std::vector<std::uint8_t> state_;
  // The kept planning window (window()): its field, the World last made of it, its middle.
  std::unique_ptr<IncrementalEsdf> window_field_;
  std::shared_ptr<World> window_world_;
  Eigen::Vector3d window_middle_ = Eigen::Vector3d::Zero();
  std::vector<std::uint8_t> window_occupancy_;  // the kept window's, this frame (a buffer)
};

template <>
PluginRegistry<VehicleMap>& pluginRegistry<VehicleMap>();

/// A shortest 8-connected path over the x-y cells of `lattice` from `from` to `to`, through
/// cells with no column within `radius` that holds an obstacle (`obstacles`) in the heights
/// [z_low, z_high] (VehicleMap::guide on a map's states; on a ground truth's grid of either
/// layout, the way a flight could take knowing everything). Cell centres at heights
/// interpolated from `from` to `to`, the first and last at `from` and `to`; empty when there is
/// none.
std::vector<Eigen::Vector3d> columnGuide(const VoxelGrid& lattice, const ObstacleColumns& obstacles,
                                         const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                         double radius, double z_low, double z_high);
/// columnGuide() from each of `froms` (one path each, empty where there is none), the
/// obstacle columns read once. The cells whose centres lie within `room` of a start (and of
/// `to`) are open whatever the band holds: a vehicle that stands within the radius of
/// something in the band (a wall 0.39 m away, a desk below it) has every cell round it
/// blocked, and without them no way leaves its cell (on geb079 most flights whose every
/// replan failed had no guide so, their local goals on the straight line through a wall).
/// Cells whose centres lie within `inset` of the lattice's sides in x and y are closed: plans
/// keep that far inside the map (a flight's planning margin), and a guide along the map's end
/// outside it left the local goal nowhere to go. The cells of the points of `trail` in the band
/// (where a flight's vehicle has flown: its body fits there) are open too: a door the vehicle
/// flew through, narrower for the band's columns than for its body (a column is closed by
/// anything within `radius` in the whole band, on 8 cm cells), closed behind it, and a
/// vehicle that had seen the room beyond was left without a guide (geb079).
std::vector<std::vector<Eigen::Vector3d>> columnGuides(const VoxelGrid& lattice,
                                                       const ObstacleColumns& obstacles,
                                                       std::span<const Eigen::Vector3d> froms,
                                                       const Eigen::Vector3d& to, double radius,
                                                       double z_low, double z_high,
                                                       double room = 0.0, double inset = 0.0,
                                                       std::span<const Eigen::Vector3d> trail = {});
/// columnGuides() over `levels` (heights, ascending) joined into one graph: at each level the
/// band one `radius` above and below it, its cells closed as columnGuides() closes them (and
/// `room` about `to` opened), and a way moves between cells of a level (8-connected) or up or
/// down one level at a cell open in both, at the cost of the height changed. From each of
/// `froms` (at the level nearest its height, `room` about it opened there) to `to`'s cell at
/// any level; points at their level's height, the first and last `from` and `to`; empty where
/// there is none. A way over a desk and under a shelf needs two levels: searched one level at
/// a time, a guide that closed at one level moved to another level's way, elsewhere, turn by
/// turn as the map grew (geb079's flights that ended moving without progress). The points of
/// `trail` open their cells at each level within `radius` of their height (columnGuides()).
std::vector<std::vector<Eigen::Vector3d>> levelColumnGuides(
    const VoxelGrid& lattice, const ObstacleColumns& obstacles,
    std::span<const Eigen::Vector3d> froms, const Eigen::Vector3d& to, double radius,
    std::span<const double> levels, double room = 0.0, double inset = 0.0,
    std::span<const Eigen::Vector3d> trail = {});

}  // namespace kinolab
