#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/world/voxel_grid.hpp"

namespace kinolab {

class Rng;
class World;

/// How a sensor's readings err and when they arrive: the built-in sensors' parameters.
struct SensorNoise {
  double min_range = 0.0;        ///< m: nearer surfaces return nothing
  double sigma_base = 0.0;       ///< m: the range noise's standard deviation at range 0
  double sigma_quadratic = 0.0;  ///< 1/m: it grows by this times the range squared
  double dropout = 0.0;          ///< the probability that a ray returns nothing
  double latency = 0.0;          ///< s: a frame's age when the map receives it
  double latency_jitter = 0.0;   ///< s: the age varies uniformly by up to this either way

  /// The range noise's standard deviation at `range`, m.
  double sigma(double range) const { return sigma_base + sigma_quadratic * range * range; }

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("min_range", min_range, 0.0, 100.0, "nearer surfaces return nothing, m");
    f.real("sigma_base", sigma_base, 0.0, 10.0,
           "range noise (Gaussian) standard deviation at range 0, m");
    f.real("sigma_quadratic", sigma_quadratic, 0.0, 10.0,
           "range noise growth: sigma = sigma_base + sigma_quadratic * range^2, 1/m");
    f.real("dropout", dropout, 0.0, 1.0, "probability that a ray returns nothing");
    f.real("latency", latency, 0.0, 10.0, "a frame's age when the map receives it, s");
    f.real("latency_jitter", latency_jitter, 0.0, 10.0,
           "the age varies uniformly by up to this either way, s");
  }
};

/// Where a camera's used pixels lie: a direction (1, u, v) in the vehicle frame (x ahead, y
/// left, z up; u and v on the image plane at x = 1) is nearest the used pixel of column
/// round(column_scale u + column_offset) and row round(row_scale v + row_offset) (columns and
/// rows count used pixels only, as rayDirections() gives them: row by row).
struct PixelGrid {
  int columns = 0;
  int rows = 0;
  double column_scale = 0.0;
  double column_offset = 0.0;
  double row_scale = 0.0;
  double row_offset = 0.0;
  /// The used columns whose rays' u lie in [low, high], and the rows whose rays' v do: first
  /// and last index (first > last: none), a hundredth of a pixel to spare for rounding.
  std::pair<int, int> columnsIn(double low, double high) const {
    return indicesIn(low, high, column_scale, column_offset, columns);
  }
  std::pair<int, int> rowsIn(double low, double high) const {
    return indicesIn(low, high, row_scale, row_offset, rows);
  }
  static std::pair<int, int> indicesIn(double low, double high, double scale, double offset,
                                       int count) {
    const double a = scale * low + offset;
    const double b = scale * high + offset;
    return {std::max(0, static_cast<int>(std::ceil(std::min(a, b) - 0.01))),
            std::min(count - 1, static_cast<int>(std::floor(std::max(a, b) + 0.01)))};
  }
  /// The largest angle, rad, between a direction whose nearest used pixel is in the grid (a
  /// continuous index within half a pixel of it) and that pixel's ray.
  double maxOffset() const {
    return 0.5 * std::hypot(1.0 / std::abs(column_scale), 1.0 / std::abs(row_scale));
  }
};

/// A range sensor ray-cast into the ground-truth grid (kind "sensor", `kinolab list sensors`;
/// a flight's `sensor` parameter chooses one, `sensor.NAME` sets its parameters). Built-in:
/// `depth_camera` and `lidar` (plugins/sensors/); a plugin adds another by registering a
/// factory for this interface.
class Sensor {
 public:
  virtual ~Sensor() = default;
  /// Farthest distance a ray sees, m.
  virtual double maxRange() const = 0;
  /// Frames per second: the flight loop's step.
  virtual double frameRate() const = 0;
  /// Every ray's direction in the vehicle frame (x ahead, z up), unit length.
  virtual std::vector<Eigen::Vector3d> rayDirections() const = 0;
  /// How many rays rayDirections() gives, without making them (a flight refuses more than
  /// kMaxRaysPerFrame before it starts); by default it makes them and counts.
  virtual std::size_t rayCount() const { return rayDirections().size(); }
  /// Its errors and delay (senseFrame(), the flight loop); none by default.
  virtual SensorNoise noise() const { return {}; }
  /// A camera's pixel grid, when its rays are one (then a frame carries its ranges as an
  /// image, SensorFrame::image, and a map may integrate it by projection); none by default.
  virtual std::optional<PixelGrid> pixelGrid() const { return std::nullopt; }
};

template <>
PluginRegistry<Sensor>& pluginRegistry<Sensor>();

/// The most rays a flight's sensor may cast a frame: 3.3 x a 640 x 480 camera at every pixel
/// (which simulates at about 70 ms a frame here, docs/flights.md).
inline constexpr std::size_t kMaxRaysPerFrame = 1000000;
/// The most voxels a frame's rays may walk, rays x range / map_resolution (the map inserts
/// every ray up to its hit or its range): about 2.3 ns a voxel here (the every-pixel camera's
/// 3e7 in 70 ms; a 1e6-ray lidar at 100 m in an open field took 4.5 s a frame on a loaded
/// machine), so about a second a frame. A 128-channel lidar of 1,024 beams at 100 m on a 0.1 m
/// map is 1.3e8. Beyond either cap a flight is refused with the estimate, before it starts.
inline constexpr double kMaxVoxelStepsPerFrame = 4e8;

/// One frame: where it was taken, the hit points (on the struck cube's face, nudged inside it,
/// then moved along the ray by the range noise) and the ends of rays that struck nothing
/// within range (placed just beyond it). Lost rays (dropout, nearer than min_range) are in
/// neither.
struct SensorFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> hits;
  std::vector<Eigen::Vector3d> misses;
  /// A camera's frame (Sensor::pixelGrid()) as an image too: every used pixel's measured
  /// range, row by row (NaN where the ray was lost, +infinity where it struck nothing within
  /// range), with the pixel grid and the heading it was taken at (rad about z); no ranges for
  /// other sensors.
  struct Image {
    PixelGrid grid;
    double yaw = 0.0;
    std::vector<float> ranges;
  } image;
};

/// Distance along the unit `direction` from `origin` to the first occupied voxel cube of
/// `grid` (0 when origin is inside one), exact (the cube's entry point, Amanatides-Woo
/// traversal); INFINITY when the ray leaves the grid or passes `max_range` first.
double castRay(const VoxelGrid& grid, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction, double max_range);

/// A ground-truth world made ready for casting rays: its voxels grouped in bricks of 4^3, each
/// brick's occupancy a 64-bit mask (and a byte telling whether it is empty), so that a ray crosses
/// an empty brick in one step and walks voxels only through bricks that hold an obstacle, on the
/// mask in a register (both traversals on fixed-point parameters without branches on the axis).
/// Built once per world (a pass over its occupancy; a flight makes one); keeps a reference to
/// `world`.
class RayCaster {
 public:
  explicit RayCaster(const World& world);

  /// castRay() into the world's grid: the same distance (to rounding), and the same voxels
  /// entered at edges and corners, except where the ray passes within 2^-24 of a voxel of an
  /// edge or a corner, whose faces the two traversals' roundings may cross in another order.
  double cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
              double max_range) const {
    return cast(origin, direction, max_range, 0.0);
  }
  /// The same, the traversal started `from` metres along the ray: the same answer when no
  /// occupied voxel's cube is nearer than `from` along it (the distance is still measured
  /// from `origin`).
  double cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double max_range,
              double from) const;
  /// For a camera (`pixels`, heading `yaw` about z) at `origin`: per used pixel a distance
  /// along its ray before which it meets no occupied voxel, so that cast() may start there.
  /// Every brick with an obstacle within `max_range` is projected into the image (the box of
  /// its occupied voxels), that box's nearest point's distance written into the pixels its
  /// projection covers (a lower bound of where a ray through it meets an obstacle there).
  /// `starts` is left empty when the camera is within a few centimetres of an obstacle (the
  /// bound is not made there).
  void startDistances(const Eigen::Vector3d& origin, double yaw, const PixelGrid& pixels,
                      double max_range, std::vector<float>& starts) const;
  const World& world() const { return *world_; }

 private:
  /// The distance from the ray's start (`local`, in voxels) to where it enters `voxel`, m.
  double entry(const Eigen::Vector3d& local, const Eigen::Vector3d& direction,
               const std::array<int, 3>& voxel) const;

  static constexpr int kBrick = 4;  ///< voxels a brick's side
  const World* world_;
  Eigen::Vector3i bricks_;              // bricks per axis
  std::vector<std::uint64_t> masks_;    // per brick (x slowest, z fastest): bit (x * 4 + y) * 4 + z
                                        // of its voxel (x, y, z) set when that voxel is occupied
  std::vector<std::uint8_t> occupied_;  // per brick: its mask is not 0 (an eighth of the memory
                                        // the bricks' walk reads)
};

/// A frame of `sensor` from `origin`, the vehicle heading `yaw` (rad about z), world frame,
/// with the sensor's range noise and dropouts drawn from `noise`.
SensorFrame senseFrame(const World& truth, const Sensor& sensor, const Eigen::Vector3d& origin,
                       double yaw, Rng& noise);
/// The same with the truth's caster and the sensor's rayDirections() made once by the caller
/// (a flight's every frame casts the same rays into the same world).
SensorFrame senseFrame(const RayCaster& truth, const Sensor& sensor,
                       const std::vector<Eigen::Vector3d>& rays, const Eigen::Vector3d& origin,
                       double yaw, Rng& noise);

}  // namespace kinolab
