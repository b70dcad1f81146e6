#include "kinolab/flight/sensor.hpp"

#include <cmath>
#include <limits>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/world/world.hpp"

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
  // A pinhole: pixel centres on the image plane at x = 1, every pixel_skip-th one.
  std::vector<Eigen::Vector3d> directions;
  const double half_w = std::tan(0.5 * fov_horizontal);
  const double half_h = std::tan(0.5 * fov_vertical);
  directions.reserve(rayCount());
  for (int row = 0; row < height; row += pixel_skip) {
    const double v = half_h * (1.0 - 2.0 * (row + 0.5) / height);
    for (int column = 0; column < width; column += pixel_skip) {
      const double u = half_w * (1.0 - 2.0 * (column + 0.5) / width);
      directions.push_back(Eigen::Vector3d(1.0, u, v).normalized());
    }
  }
  return directions;
}

std::size_t DepthCamera::rayCount() const {
  const auto used = [&](int pixels) {
    return static_cast<std::size_t>((pixels + pixel_skip - 1) / pixel_skip);
  };
  return used(width) * used(height);
}

std::size_t Lidar::rayCount() const { return static_cast<std::size_t>(beams) * channels; }

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
  double hit = INFINITY;
  grid.walkRay(origin, direction, max_range, [&](const VoxelIndex& voxel, double t) {
    if (!grid.occupied(voxel)) return true;
    hit = t;
    return false;
  });
  return hit;
}

double castRay(const World& world, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
               double max_range) {
  // Sphere tracing on the ESDF: inside the map the nearest voxel centre c is at most half a
  // voxel's diagonal from p, and the stored distance is exact at c and 1-Lipschitz, so
  // D(c) - sqrt(3) / 2 voxel is a proven lower bound of the distance from p to the cubes: a
  // leap never passes a cube. Where the leaps get short (beside a surface), the exact
  // traversal takes over for a few voxels (it checks every voxel it enters, the one holding
  // its end too), then the leaps resume.
  const double r = world.grid().resolution();
  const double half_diagonal = (0.5 * std::sqrt(3.0) + 1e-3) * r;  // and float rounding
  const double stretch = 4.0 * r;
  const Box& box = world.bounds();
  double t = 0.0;
  while (t <= max_range) {
    const Eigen::Vector3d p = origin + t * direction;
    if ((p.array() < box.min.array()).any() || (p.array() >= box.max.array()).any()) break;
    const double leap = world.esdf().nearestDistance(p) - half_diagonal;
    if (leap >= r) {
      t += leap;
      continue;
    }
    const double reach = std::min(stretch, max_range - t);
    const double hit = castRay(world.grid(), p, direction, reach);
    if (hit <= reach) return t + hit;
    if (reach < stretch) return INFINITY;  // the range ends within the stretch
    t += stretch;
  }
  return INFINITY;
}

SensorFrame senseFrame(const World& truth, const Sensor& sensor, const Eigen::Vector3d& origin,
                       double yaw, Rng& noise) {
  return senseFrame(truth, sensor, sensor.rayDirections(), origin, yaw, noise);
}

SensorFrame senseFrame(const World& truth, const Sensor& sensor,
                       const std::vector<Eigen::Vector3d>& rays, const Eigen::Vector3d& origin,
                       double yaw, Rng& noise) {
  const double range = sensor.maxRange();
  const SensorNoise errors = sensor.noise();
  const double voxel = truth.grid().resolution();
  SensorFrame frame;
  frame.origin = origin;
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  // Hits are nudged a hundredth of a voxel into the struck cube so that the map marks that
  // voxel (before the noise moves them); misses end a voxel beyond the range, so that the map
  // inserts free space only.
  const double nudge = 0.01 * voxel;
  for (const Eigen::Vector3d& ray : rays) {
    if (errors.dropout > 0.0 && noise.uniform01() < errors.dropout) continue;
    const Eigen::Vector3d direction(c * ray.x() - s * ray.y(), s * ray.x() + c * ray.y(), ray.z());
    const double distance = castRay(truth, origin, direction, range);
    if (distance > range) {
      frame.misses.push_back(origin + (range + voxel) * direction);
      continue;
    }
    const double sigma = errors.sigma(distance);
    const double measured = distance + nudge + (sigma > 0.0 ? sigma * noise.normal() : 0.0);
    if (distance < errors.min_range || measured < errors.min_range) continue;
    if (measured > range) {
      frame.misses.push_back(origin + (range + voxel) * direction);
    } else {
      frame.hits.push_back(origin + measured * direction);
    }
  }
  return frame;
}

}  // namespace kinolab
