#include "kinolab/flight/sensor.hpp"

#include <cmath>
#include <limits>

#include "kinolab/core/plugin.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(Sensor, "sensor", "sensors",
                               "range sensors of closed-loop flights (the flight's `sensor`)", 6)

namespace {

constexpr double kDegree = M_PI / 180.0;

/// The declared parameters of each built-in sensor, their defaults the models' own.
ParameterSpecs rangeAndRate(double range, double rate) {
  return ParameterSpecs()
      .real("range", range, 0.1, 100.0, "sensor range, m")
      .real("rate", rate, 0.5, 100.0, "frames per second (the flight loop's step)");
}

void registerBuiltins() {
  PluginRegistrar registrar("built-in (framework)");
  const DepthCamera camera;
  registrar.add<Sensor>("depth_camera", "a pinhole depth camera looking along the heading",
                        rangeAndRate(camera.range, camera.rate)
                            .real("fov_horizontal", camera.fov_horizontal / kDegree, 1.0, 170.0,
                                  "horizontal field of view, degrees")
                            .real("fov_vertical", camera.fov_vertical / kDegree, 1.0, 170.0,
                                  "vertical field of view, degrees")
                            .integer("width", camera.width, 1, 4096, "pixels across")
                            .integer("height", camera.height, 1, 4096, "pixels down"),
                        [](const ParameterSet& p) {
                          auto sensor = std::make_unique<DepthCamera>();
                          sensor->range = p.real("range");
                          sensor->rate = p.real("rate");
                          sensor->fov_horizontal = p.real("fov_horizontal") * kDegree;
                          sensor->fov_vertical = p.real("fov_vertical") * kDegree;
                          sensor->width = static_cast<int>(p.integer("width"));
                          sensor->height = static_cast<int>(p.integer("height"));
                          return sensor;
                        });
  const Lidar lidar;
  registrar.add<Sensor>("lidar", "a 360-degree lidar: beams around, channels up and down",
                        rangeAndRate(lidar.range, lidar.rate)
                            .real("fov_vertical", lidar.fov_vertical / kDegree, 1.0, 170.0,
                                  "vertical field of view of the channels, degrees")
                            .integer("beams", lidar.beams, 1, 100000, "beams per revolution")
                            .integer("channels", lidar.channels, 1, 1024, "channels"),
                        [](const ParameterSet& p) {
                          auto sensor = std::make_unique<Lidar>();
                          sensor->range = p.real("range");
                          sensor->rate = p.real("rate");
                          sensor->fov_vertical = p.real("fov_vertical") * kDegree;
                          sensor->beams = static_cast<int>(p.integer("beams"));
                          sensor->channels = static_cast<int>(p.integer("channels"));
                          return sensor;
                        });
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
