#include "kinolab/world/voxel_grid.hpp"

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"

namespace kinolab {

VoxelGrid::VoxelGrid(const Box& bounds, double resolution)
    : resolution_(resolution), origin_(bounds.min) {
  if (!(resolution > 0.0)) throw InvalidArgument("VoxelGrid: resolution must be positive");
  const Eigen::Vector3d extent = bounds.size();
  for (int axis = 0; axis < 3; ++axis) {
    if (!(extent[axis] > 0.0)) throw InvalidArgument("VoxelGrid: bounds must have max > min");
    // The small tolerance keeps 40 / 0.1 at 400 voxels despite rounding.
    dims_[axis] = std::max(1, static_cast<int>(std::ceil(extent[axis] / resolution - 1e-9)));
  }
  const double count = static_cast<double>(dims_.x()) * dims_.y() * dims_.z();
  if (count > 2e9) throw InvalidArgument("VoxelGrid: more than 2e9 voxels; raise the resolution");
  occupancy_.assign(static_cast<std::size_t>(count), 0);
}

std::size_t VoxelGrid::occupiedCount() const {
  return static_cast<std::size_t>(std::count(occupancy_.begin(), occupancy_.end(), 1));
}

bool VoxelGrid::voxelRange(const Eigen::Vector3d& min, const Eigen::Vector3d& max,
                           Eigen::Vector3i& low, Eigen::Vector3i& high) const {
  for (int axis = 0; axis < 3; ++axis) {
    // Centre i is at origin + (i + 0.5) * resolution.
    const double first = std::ceil((min[axis] - origin_[axis]) / resolution_ - 0.5);
    const double last = std::floor((max[axis] - origin_[axis]) / resolution_ - 0.5);
    const double clamped_first = std::max(first, 0.0);
    const double clamped_last = std::min(last, static_cast<double>(dims_[axis] - 1));
    if (clamped_first > clamped_last) return false;
    low[axis] = static_cast<int>(clamped_first);
    high[axis] = static_cast<int>(clamped_last);
  }
  return true;
}

bool VoxelGrid::overlapRange(const Eigen::Vector3d& min, const Eigen::Vector3d& max,
                             Eigen::Vector3i& low, Eigen::Vector3i& high) const {
  // Of a voxel: touching faces and rounding (OctoMap keeps coordinates as floats) do not count.
  constexpr double kSlack = 1e-3;
  for (int axis = 0; axis < 3; ++axis) {
    // Voxel i spans [origin + i r, origin + (i + 1) r].
    const double first = std::floor((min[axis] - origin_[axis]) / resolution_ + kSlack);
    const double last = std::ceil((max[axis] - origin_[axis]) / resolution_ - kSlack) - 1.0;
    const double clamped_first = std::max(first, 0.0);
    const double clamped_last = std::min(last, static_cast<double>(dims_[axis] - 1));
    if (!(clamped_first <= clamped_last)) return false;
    low[axis] = static_cast<int>(clamped_first);
    high[axis] = static_cast<int>(clamped_last);
  }
  return true;
}

void VoxelGrid::fillBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  forEachVoxelIn(min, max, [this](std::size_t i) { occupancy_[i] = 1; });
}

}  // namespace kinolab
