#include "kinolab/flight/sensor.hpp"

#include <array>
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

namespace {

/// castRay() on the grid, without branches on the axis: the distance along the unit
/// `direction` from `origin` (inside the grid, or on its face) to the first occupied voxel
/// cube entered within `reach`, INFINITY when there is none or the ray leaves the grid.
/// `across` is the ray's length across a voxel along each axis (resolution / |direction|).
double firstOccupied(const VoxelGrid& grid, const Eigen::Vector3d& origin,
                     const Eigen::Vector3d& direction, const Eigen::Vector3d& across,
                     double reach) {
  const Eigen::Vector3d local = (origin - grid.origin()) / grid.resolution();  // in voxels
  const Eigen::Vector3i& n = grid.dims();
  const std::array<std::ptrdiff_t, 3> strides{static_cast<std::ptrdiff_t>(n.y()) * n.z(), n.z(), 1};
  std::array<int, 3> voxel{};
  std::array<int, 3> step{};
  std::array<double, 3> next{};   // ray parameter (m) where it leaves the voxel along each axis
  std::array<double, 3> delta{};  // ray parameter across a voxel along each axis
  std::ptrdiff_t index = 0;
  for (int axis = 0; axis < 3; ++axis) {
    voxel[axis] = static_cast<int>(std::floor(local[axis]));
    if (voxel[axis] < 0 || voxel[axis] >= n[axis]) return INFINITY;
    index += voxel[axis] * strides[axis];
    const double d = direction[axis];
    step[axis] = d > 0.0 ? 1 : (d < 0.0 ? -1 : 0);
    const double to_face = d > 0.0 ? voxel[axis] + 1 - local[axis] : local[axis] - voxel[axis];
    next[axis] = d != 0.0 ? to_face * across[axis] : INFINITY;
    delta[axis] = across[axis];
  }
  const std::uint8_t* occupancy = grid.occupancy().data();
  double t = 0.0;  // where the ray entered the voxel
  while (t <= reach) {
    if (occupancy[index] != 0) return t;
    const double out = std::min(next[0], std::min(next[1], next[2]));
    t = out;
    const bool along_x = next[0] == out;
    const bool along_y = !along_x && next[1] == out;
    const bool along_z = !along_x && !along_y;
    voxel[0] += along_x ? step[0] : 0;
    voxel[1] += along_y ? step[1] : 0;
    voxel[2] += along_z ? step[2] : 0;
    index += (along_x ? step[0] * strides[0] : 0) + (along_y ? step[1] * strides[1] : 0) +
             (along_z ? step[2] : 0);
    next[0] += along_x ? delta[0] : 0.0;
    next[1] += along_y ? delta[1] : 0.0;
    next[2] += along_z ? delta[2] : 0.0;
    if (static_cast<unsigned>(voxel[0]) >= static_cast<unsigned>(n.x()) ||
        static_cast<unsigned>(voxel[1]) >= static_cast<unsigned>(n.y()) ||
        static_cast<unsigned>(voxel[2]) >= static_cast<unsigned>(n.z())) {
      return INFINITY;
    }
  }
  return INFINITY;
}

}  // namespace

RayCaster::RayCaster(const World& world) : world_(&world) {
  const VoxelGrid& grid = world.grid();
  const Eigen::Vector3i& n = grid.dims();
  bricks_ = (n.array() + kBrick - 1) / kBrick;
  occupied_.assign(static_cast<std::size_t>(bricks_.prod()), 0);
  const std::uint8_t* occupancy = grid.occupancy().data();
  std::size_t i = 0;
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      const std::size_t row =
          (static_cast<std::size_t>(x / kBrick) * bricks_.y() + y / kBrick) * bricks_.z();
      for (int z = 0; z < n.z(); ++z, ++i) {
        if (occupancy[i] != 0) occupied_[row + z / kBrick] = 1;
      }
    }
  }
}

double RayCaster::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                       double max_range) const {
  // Amanatides and Woo's traversal over the bricks, without branches on the axis (a ray's
  // next axis is unpredictable); through a brick that holds an obstacle, the voxels' own
  // traversal from where the ray enters it to where it leaves (from a point on the brick's
  // face rounding may start it in the empty brick before: a free voxel).
  const VoxelGrid& grid = world_->grid();
  if (!grid.inside(
          ((origin - grid.origin()) / grid.resolution()).array().floor().cast<int>().matrix())) {
    return INFINITY;  // as the voxels' traversal: nothing from outside the grid
  }
  const double side = kBrick * grid.resolution();
  const Eigen::Vector3d local = (origin - grid.origin()) / side;  // in bricks
  Eigen::Vector3d across;  // the ray's length across a voxel along each axis
  for (int axis = 0; axis < 3; ++axis) {
    across[axis] =
        direction[axis] != 0.0 ? grid.resolution() / std::abs(direction[axis]) : INFINITY;
  }
  const std::array<std::ptrdiff_t, 3> strides{
      static_cast<std::ptrdiff_t>(bricks_.y()) * bricks_.z(), bricks_.z(), 1};
  std::array<int, 3> brick{};     // the brick's coordinates
  std::array<int, 3> step{};      // +-1 or 0 along each axis
  std::array<double, 3> next{};   // ray parameter (m) where it leaves the brick along each axis
  std::array<double, 3> delta{};  // ray parameter across a brick along each axis
  std::ptrdiff_t index = 0;
  for (int axis = 0; axis < 3; ++axis) {
    brick[axis] = std::min(static_cast<int>(std::floor(local[axis])), bricks_[axis] - 1);
    index += brick[axis] * strides[axis];
    const double d = direction[axis];
    step[axis] = d > 0.0 ? 1 : (d < 0.0 ? -1 : 0);
    const double to_face = d > 0.0 ? brick[axis] + 1 - local[axis] : local[axis] - brick[axis];
    next[axis] = d != 0.0 ? to_face * kBrick * across[axis] : INFINITY;
    delta[axis] = kBrick * across[axis];
  }
  double t = 0.0;  // where the ray entered the brick
  while (t <= max_range) {
    const double out = std::min(next[0], std::min(next[1], next[2]));
    if (occupied_[static_cast<std::size_t>(index)] != 0) {
      const double reach = std::min(out, max_range) - t;
      const double hit = firstOccupied(grid, origin + t * direction, direction, across, reach);
      if (hit <= reach) return t + hit;
    }
    t = out;
    const bool along_x = next[0] == out;
    const bool along_y = !along_x && next[1] == out;
    const bool along_z = !along_x && !along_y;
    brick[0] += along_x ? step[0] : 0;
    brick[1] += along_y ? step[1] : 0;
    brick[2] += along_z ? step[2] : 0;
    index += (along_x ? step[0] * strides[0] : 0) + (along_y ? step[1] * strides[1] : 0) +
             (along_z ? step[2] : 0);
    next[0] += along_x ? delta[0] : 0.0;
    next[1] += along_y ? delta[1] : 0.0;
    next[2] += along_z ? delta[2] : 0.0;
    if (static_cast<unsigned>(brick[0]) >= static_cast<unsigned>(bricks_.x()) ||
        static_cast<unsigned>(brick[1]) >= static_cast<unsigned>(bricks_.y()) ||
        static_cast<unsigned>(brick[2]) >= static_cast<unsigned>(bricks_.z())) {
      return INFINITY;
    }
  }
  return INFINITY;
}

SensorFrame senseFrame(const World& truth, const Sensor& sensor, const Eigen::Vector3d& origin,
                       double yaw, Rng& noise) {
  return senseFrame(RayCaster(truth), sensor, sensor.rayDirections(), origin, yaw, noise);
}

SensorFrame senseFrame(const RayCaster& truth, const Sensor& sensor,
                       const std::vector<Eigen::Vector3d>& rays, const Eigen::Vector3d& origin,
                       double yaw, Rng& noise) {
  const double range = sensor.maxRange();
  const SensorNoise errors = sensor.noise();
  const double voxel = truth.world().grid().resolution();
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
    const double distance = truth.cast(origin, direction, range);
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
