#include "kinolab/flight/sensor.hpp"

#include <cmath>
#include <limits>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(Sensor, "sensor", "sensors",
                               "range sensors of closed-loop flights (the flight's `sensor`)", 6)

namespace {

void registerBuiltins() {
  PluginRegistrar registrar("built-in (framework)");
  registrar.add<Sensor>("depth_camera", "a pinhole depth camera looking along the heading",
                        declareFields<DepthCamera>(), [](const ParameterSet& p) {
                          return std::make_unique<DepthCamera>(readFields<DepthCamera>(p));
                        });
  registrar.add<Sensor>(
      "lidar", "a 360-degree lidar: beams around, channels up and down", declareFields<Lidar>(),
      [](const ParameterSet& p) { return std::make_unique<Lidar>(readFields<Lidar>(p)); });
  registrar.commit();
}

[[maybe_unused]] const bool builtins_registered = (registerBuiltins(), true);

}  // namespace

std::vector<Eigen::Vector3d> DepthCamera::rayDirections() const {
  // A pinhole: pixel centres on the image plane at x = 1.
  std::vector<Eigen::Vector3d> directions;
  const double half_w = std::tan(0.5 * fov_horizontal);
  const double half_h = std::tan(0.5 * fov_vertical);
  directions.reserve(static_cast<std::size_t>(width) * height);
  for (int row = 0; row < height; ++row) {
    const double v = half_h * (1.0 - 2.0 * (row + 0.5) / height);
    for (int column = 0; column < width; ++column) {
      const double u = half_w * (1.0 - 2.0 * (column + 0.5) / width);
      directions.push_back(Eigen::Vector3d(1.0, u, v).normalized());
    }
  }
  return directions;
}

std::vector<Eigen::Vector3d> Lidar::rayDirections() const {
  std::vector<Eigen::Vector3d> directions;
  directions.reserve(static_cast<std::size_t>(beams) * channels);
  for (int channel = 0; channel < channels; ++channel) {
    const double elevation = channels > 1 ? fov_vertical * (channel / (channels - 1.0) - 0.5) : 0.0;
    for (int beam = 0; beam < beams; ++beam) {
      const double azimuth = 2.0 * M_PI * beam / beams;
      directions.emplace_back(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    }
  }
  return directions;
}

double castRay(const VoxelGrid& grid, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction, double max_range) {
  const double r = grid.resolution();
  const Eigen::Vector3d local = (origin - grid.origin()) / r;  // in voxels
  const Eigen::Vector3i& dims = grid.dims();
  VoxelIndex voxel;
  Eigen::Vector3i step;
  Eigen::Vector3d next;   // ray parameter (m) at the next face crossing per axis
  Eigen::Vector3d delta;  // ray parameter between faces per axis
  for (int axis = 0; axis < 3; ++axis) {
    voxel[axis] = static_cast<int>(std::floor(local[axis]));
    const double d = direction[axis];
    if (d > 0.0) {
      step[axis] = 1;
      next[axis] = (voxel[axis] + 1 - local[axis]) * r / d;
      delta[axis] = r / d;
    } else if (d < 0.0) {
      step[axis] = -1;
      next[axis] = (local[axis] - voxel[axis]) * r / -d;
      delta[axis] = r / -d;
    } else {
      step[axis] = 0;
      next[axis] = INFINITY;
      delta[axis] = INFINITY;
    }
  }
  if (!grid.inside(voxel)) return INFINITY;
  double t = 0.0;  // where the ray entered the current voxel
  while (t <= max_range) {
    if (grid.occupied(voxel)) return t;
    int axis = 0;
    if (next[1] < next[axis]) axis = 1;
    if (next[2] < next[axis]) axis = 2;
    t = next[axis];
    next[axis] += delta[axis];
    voxel[axis] += step[axis];
    if (voxel[axis] < 0 || voxel[axis] >= dims[axis]) return INFINITY;
  }
  return INFINITY;
}

SensorFrame senseFrame(const VoxelGrid& truth, const Sensor& sensor, const Eigen::Vector3d& origin,
                       double yaw) {
  const double range = sensor.maxRange();
  SensorFrame frame;
  frame.origin = origin;
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  // Hits are nudged a hundredth of a voxel into the struck cube so that the map marks that
  // voxel; misses end a voxel beyond the range, so that the map inserts free space only.
  const double nudge = 0.01 * truth.resolution();
  for (const Eigen::Vector3d& ray : sensor.rayDirections()) {
    const Eigen::Vector3d direction(c * ray.x() - s * ray.y(), s * ray.x() + c * ray.y(), ray.z());
    const double distance = castRay(truth, origin, direction, range);
    if (distance <= range) {
      frame.hits.push_back(origin + (distance + nudge) * direction);
    } else {
      frame.misses.push_back(origin + (range + truth.resolution()) * direction);
    }
  }
  return frame;
}

}  // namespace kinolab
