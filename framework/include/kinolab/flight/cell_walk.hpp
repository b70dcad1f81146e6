// The voxel traversal that the simulated camera (flight/sensor.cpp) and the probabilistic
// vehicle map (plugins/vehicle_maps/probabilistic) step through most of a frame's time.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace kinolab {

/// Amanatides and Woo's traversal of the cells of a box (`dims`, x slowest, z fastest) on
/// fixed-point ray parameters, without branches on the axis: a ray's next axis is
/// unpredictable, and integer minima and compares make a shorter dependency chain per step
/// than floating-point ones (the map's walks 1.6x faster than on doubles). Ray parameters are
/// in cells (the direction is a unit vector in the same units) times kScale.
struct CellWalk {
  static constexpr double kScale = 16777216.0;                   // fixed-point units a cell (2^24)
  static constexpr std::int64_t kNever = std::int64_t{1} << 60;  // beyond every limit
  static std::int64_t fixed(double cells) {
    return cells < 1e9 ? static_cast<std::int64_t>(cells * kScale) : kNever;
  }

  CellWalk() = default;
  /// From `local` (in cells from the box's corner) along the unit `direction`.
  CellWalk(const Eigen::Vector3d& local, const Eigen::Vector3d& direction,
           const Eigen::Vector3i& dims) {
    const std::array<std::ptrdiff_t, 3> strides{static_cast<std::ptrdiff_t>(dims.y()) * dims.z(),
                                                dims.z(), 1};
    for (int axis = 0; axis < 3; ++axis) {
      const double corner = std::floor(local[axis]);
      cell[axis] = static_cast<int>(corner);
      index += static_cast<std::ptrdiff_t>(cell[axis]) * strides[axis];
      const double d = direction[axis];
      const double across = d != 0.0 ? 1.0 / std::abs(d) : INFINITY;
      delta[axis] = fixed(across);
      next[axis] = d > 0.0   ? fixed((corner + 1.0 - local[axis]) * across)
                   : d < 0.0 ? fixed((local[axis] - corner) * across)
                             : kNever;
      sign[axis] = d > 0.0 ? 1 : (d < 0.0 ? -1 : 0);
      stride[axis] = sign[axis] * strides[axis];
    }
  }
  /// The same ray's walk through cells of `factor`^3 of these (`coarse_dims` of them; this
  /// walk's cells from 0), on the same fixed-point parameters: a coarse cell's faces are the
  /// fine faces they lie on, so that the two walks agree exactly on where the ray crosses them
  /// (with each other; the parameters are truncated to 2^-24 of a cell, so where two faces are
  /// crossed closer together than that, a walk on doubles may order them otherwise).
  CellWalk coarser(int factor, const Eigen::Vector3i& coarse_dims) const {
    const std::array<std::ptrdiff_t, 3> strides{
        static_cast<std::ptrdiff_t>(coarse_dims.y()) * coarse_dims.z(), coarse_dims.z(), 1};
    CellWalk walk;
    for (int axis = 0; axis < 3; ++axis) {
      walk.cell[axis] = cell[axis] / factor;
      walk.index += static_cast<std::ptrdiff_t>(walk.cell[axis]) * strides[axis];
      walk.sign[axis] = sign[axis];
      walk.stride[axis] = sign[axis] * strides[axis];
      const int within = cell[axis] % factor;
      const int faces = sign[axis] > 0 ? factor - 1 - within : within;  // fine faces to cross
      walk.next[axis] = sign[axis] != 0 ? next[axis] + faces * delta[axis] : kNever;
      walk.delta[axis] = sign[axis] != 0 ? factor * delta[axis] : kNever;
    }
    return walk;
  }

  /// Where the ray leaves the current cell.
  std::int64_t leave() const { return std::min(next[0], std::min(next[1], next[2])); }
  /// Into the next cell; `leave` is leave().
  void step(std::int64_t leave) {
    const bool along_x = next[0] == leave;
    const bool along_y = !along_x && next[1] == leave;
    const bool along_z = !along_x && !along_y;
    index += (along_x ? stride[0] : 0) + (along_y ? stride[1] : 0) + (along_z ? stride[2] : 0);
    cell[0] += along_x ? sign[0] : 0;
    cell[1] += along_y ? sign[1] : 0;
    cell[2] += along_z ? sign[2] : 0;
    next[0] += along_x ? delta[0] : 0;
    next[1] += along_y ? delta[1] : 0;
    next[2] += along_z ? delta[2] : 0;
  }
  bool inside(const Eigen::Vector3i& dims) const {
    return static_cast<unsigned>(cell[0]) < static_cast<unsigned>(dims.x()) &&
           static_cast<unsigned>(cell[1]) < static_cast<unsigned>(dims.y()) &&
           static_cast<unsigned>(cell[2]) < static_cast<unsigned>(dims.z());
  }

  std::ptrdiff_t index = 0;             // the current cell's
  std::array<int, 3> cell{};            // its coordinates
  std::array<std::int64_t, 3> next{};   // where the ray leaves it along each axis
  std::array<std::int64_t, 3> delta{};  // the ray's length across a cell along each axis
  std::array<int, 3> sign{};
  std::array<std::ptrdiff_t, 3> stride{};  // the index's step along each axis
};

}  // namespace kinolab
