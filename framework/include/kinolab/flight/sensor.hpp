#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/world/voxel_grid.hpp"

namespace kinolab {

/// A range sensor ray-cast into the ground-truth grid (kind "sensor", `kinolab list sensors`;
/// a flight's `sensor` parameter chooses one, `sensor.NAME` sets its parameters). Built-in:
/// `depth_camera` and `lidar`; a plugin adds another by registering a factory for this
/// interface.
class Sensor {
 public:
  virtual ~Sensor() = default;
  /// Farthest distance a ray sees, m.
  virtual double maxRange() const = 0;
  /// Frames per second: the flight loop's step.
  virtual double frameRate() const = 0;
  /// Every ray's direction in the vehicle frame (x ahead, z up), unit length.
  virtual std::vector<Eigen::Vector3d> rayDirections() const = 0;
};

template <>
PluginRegistry<Sensor>& pluginRegistry<Sensor>();

/// A pinhole depth camera looking along the vehicle's heading.
struct DepthCamera final : Sensor {
  double range = 5.0;
  double rate = 10.0;
  double fov_horizontal = M_PI / 2;  ///< rad (declared in degrees)
  double fov_vertical = M_PI / 3;    ///< rad
  int width = 32;
  int height = 24;

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("range", range, 0.1, 100.0, "sensor range, m");
    f.real("rate", rate, 0.5, 100.0, "frames per second (the flight loop's step)");
    f.real("fov_horizontal", fov_horizontal, 1.0, 170.0, "horizontal field of view, degrees",
           M_PI / 180.0);
    f.real("fov_vertical", fov_vertical, 1.0, 170.0, "vertical field of view, degrees",
           M_PI / 180.0);
    f.integer("width", width, 1, 4096, "pixels across");
    f.integer("height", height, 1, 4096, "pixels down");
  }

  double maxRange() const override { return range; }
  double frameRate() const override { return rate; }
  std::vector<Eigen::Vector3d> rayDirections() const override;
};

/// A 360-degree lidar: `beams` around, `channels` spread over the vertical field of view.
struct Lidar final : Sensor {
  double range = 5.0;
  double rate = 10.0;
  double fov_vertical = M_PI / 3;  ///< rad (declared in degrees)
  int beams = 360;
  int channels = 16;

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("range", range, 0.1, 100.0, "sensor range, m");
    f.real("rate", rate, 0.5, 100.0, "revolutions per second (the flight loop's step)");
    f.real("fov_vertical", fov_vertical, 1.0, 170.0,
           "vertical field of view of the channels, degrees", M_PI / 180.0);
    f.integer("beams", beams, 1, 100000, "beams per revolution");
    f.integer("channels", channels, 1, 1024, "channels");
  }

  double maxRange() const override { return range; }
  double frameRate() const override { return rate; }
  std::vector<Eigen::Vector3d> rayDirections() const override;
};

/// One frame: where it was taken, the hit points (on the struck cube's face, nudged inside it)
/// and the ends of rays that struck nothing within range (placed just beyond it).
struct SensorFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> hits;
  std::vector<Eigen::Vector3d> misses;
};

/// Distance along the unit `direction` from `origin` to the first occupied voxel cube of
/// `grid` (0 when origin is inside one), exact (the cube's entry point, Amanatides-Woo
/// traversal); INFINITY when the ray leaves the grid or passes `max_range` first.
double castRay(const VoxelGrid& grid, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction, double max_range);

/// A frame of `sensor` from `origin`, the vehicle heading `yaw` (rad about z), world frame.
SensorFrame senseFrame(const VoxelGrid& truth, const Sensor& sensor, const Eigen::Vector3d& origin,
                       double yaw);

}  // namespace kinolab
