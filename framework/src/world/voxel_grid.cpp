#include "kinolab/world/voxel_grid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "kinolab/core/error.hpp"

namespace kinolab {

Eigen::Vector3d VoxelGrid::voxelsAlong(const Box& bounds, double resolution) {
  // The small tolerance keeps 40 / 0.1 at 400 voxels despite rounding.
  return (bounds.size() / resolution).array().unaryExpr([](double n) {
    return std::max(1.0, std::ceil(n - 1e-9));
  });
}

VoxelGrid::VoxelGrid(const Box& bounds, double resolution, GridLayout layout)
    : resolution_(resolution), origin_(bounds.min), bricked_(layout == GridLayout::kBricked) {
  const double count = setDims(bounds);
  if (!bricked_) {
    if (count > 2e9) throw InvalidArgument("VoxelGrid: more than 2e9 voxels; raise the resolution");
    occupancy_ = std::vector<std::uint8_t>(size_, 0);
    return;
  }
  // The table holds 4 bytes per brick of 512 voxels.
  if (count > 1e12) throw InvalidArgument("VoxelGrid: more than 1e12 voxels; raise the resolution");
  bricks_ = (dims_.array() + kBrick - 1) / kBrick;
  brick_state_.assign(static_cast<std::size_t>(bricks_.cast<double>().prod()), kEmptyBrick);
}

VoxelGrid::VoxelGrid(const Box& bounds, double resolution, ValueArray<std::uint8_t> occupancy)
    : resolution_(resolution), origin_(bounds.min) {
  setDims(bounds);
  if (occupancy.size() != size_) {
    throw InvalidArgument("VoxelGrid: " + std::to_string(occupancy.size()) +
                          " occupancy values for " + std::to_string(size_) + " voxels");
  }
  occupancy_ = std::move(occupancy);
}

VoxelGrid::VoxelGrid(const Box& bounds, double resolution, std::vector<std::uint32_t> brick_states,
                     std::vector<std::uint64_t> brick_masks)
    : VoxelGrid(bounds, resolution, GridLayout::kBricked) {
  if (brick_states.size() != brick_state_.size()) {
    throw InvalidArgument("VoxelGrid: " + std::to_string(brick_states.size()) +
                          " brick states for " + std::to_string(brick_state_.size()) + " bricks");
  }
  if (brick_masks.size() % 8 != 0) {
    throw InvalidArgument("VoxelGrid: brick masks are not whole bricks of 8 words");
  }
  const std::size_t masks = brick_masks.size() / 8;
  for (const std::uint32_t state : brick_states) {
    if (state >= kMasked && state - kMasked >= masks) {
      throw InvalidArgument("VoxelGrid: a brick state names mask " +
                            std::to_string(state - kMasked) + " of " + std::to_string(masks));
    }
  }
  brick_state_ = std::move(brick_states);
  masks_ = std::move(brick_masks);
}

double VoxelGrid::setDims(const Box& bounds) {
  if (!(resolution_ > 0.0)) throw InvalidArgument("VoxelGrid: resolution must be positive");
  if (!(bounds.size().array() > 0.0).all()) {
    throw InvalidArgument("VoxelGrid: bounds must have max > min");
  }
  dims_ = voxelsAlong(bounds, resolution_).cast<int>();
  const double count = static_cast<double>(dims_.x()) * dims_.y() * dims_.z();
  size_ = static_cast<std::size_t>(count);
  return count;
}

std::size_t VoxelGrid::memoryBytes() const {
  return occupancy_.bytes() + brick_state_.capacity() * sizeof(std::uint32_t) +
         masks_.capacity() * sizeof(std::uint64_t);
}

std::size_t VoxelGrid::occupiedCount() const {
  if (!bricked_) {
    return static_cast<std::size_t>(std::count(occupancy_.begin(), occupancy_.end(), 1));
  }
  // Only bricks wholly inside the grid are ever full.
  std::size_t count = 0;
  for (const std::uint32_t state : brick_state_) {
    if (state == kFullBrick) count += kBrick * kBrick * kBrick;
    if (state < kMasked) continue;
    for (int word = 0; word < 8; ++word) {
      count += static_cast<std::size_t>(std::popcount(masks_[(state - kMasked) * 8 + word]));
    }
  }
  return count;
}

std::span<const std::uint8_t> VoxelGrid::occupancy() const {
  if (bricked_) denseOnly();
  return occupancy_.span();
}

std::span<std::uint8_t> VoxelGrid::mutableOccupancy() {
  if (bricked_) denseOnly();
  return occupancy_.mutableSpan();
}

void VoxelGrid::denseOnly() const {
  throw InvalidArgument(
      "VoxelGrid::occupancy: a bricked (sparse) grid has no dense occupancy array; query it by "
      "voxel");
}

void VoxelGrid::setBrickedOccupied(const VoxelIndex& v, bool value) {
  std::uint32_t& state = brick_state_[brickIndex(v.x() >> 3, v.y() >> 3, v.z() >> 3)];
  if (state == (value ? kFullBrick : kEmptyBrick)) return;
  if (state < kMasked) {
    const std::uint64_t fill = state == kFullBrick ? ~std::uint64_t{0} : 0;
    state = kMasked + static_cast<std::uint32_t>(masks_.size() / 8);
    masks_.insert(masks_.end(), 8, fill);
  }
  std::uint64_t& word = masks_[(state - kMasked) * 8 + (v.x() & 7)];
  const std::uint64_t bit = std::uint64_t{1} << (((v.y() & 7) << 3) | (v.z() & 7));
  word = value ? word | bit : word & ~bit;
}

void VoxelGrid::compactBricks() {
  if (!bricked_) return;
  std::vector<std::uint64_t> kept;
  for (std::uint32_t& state : brick_state_) {
    if (state < kMasked) continue;
    const std::uint64_t* mask = masks_.data() + (state - kMasked) * 8;
    bool all = true;
    bool none = true;
    for (int word = 0; word < 8; ++word) {
      all = all && mask[word] == ~std::uint64_t{0};
      none = none && mask[word] == 0;
    }
    if (all || none) {
      state = all ? kFullBrick : kEmptyBrick;
    } else {
      state = kMasked + static_cast<std::uint32_t>(kept.size() / 8);
      kept.insert(kept.end(), mask, mask + 8);
    }
  }
  masks_ = std::move(kept);
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

double VoxelGrid::fillCost(const Eigen::Vector3d& min, const Eigen::Vector3d& max) const {
  Eigen::Vector3i low;
  Eigen::Vector3i high;
  if (!voxelRange(min, max, low, high)) return 0.0;
  const Eigen::Array3d voxels = (high - low).array().cast<double>() + 1.0;
  if (!bricked_) return voxels.prod();
  // Per axis: the bricks the range touches and those it covers whole.
  Eigen::Array3d touched;
  Eigen::Array3d whole;
  for (int axis = 0; axis < 3; ++axis) {
    touched[axis] = (high[axis] >> 3) - (low[axis] >> 3) + 1;
    whole[axis] = std::max(0, ((high[axis] + 1) >> 3) - ((low[axis] + 7) >> 3));
  }
  return touched.prod() + voxels.prod() - whole.prod() * kBrick * kBrick * kBrick;
}

void VoxelGrid::fillBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  if (!bricked_) {
    std::uint8_t* cells = occupancy_.mutableData();
    forEachVoxelIn(min, max, [cells](std::size_t i) { cells[i] = 1; });
    return;
  }
  Eigen::Vector3i low;
  Eigen::Vector3i high;
  if (!voxelRange(min, max, low, high)) return;
  // Bricks the box covers whole become full; the others get the box's part voxel by voxel.
  for (int bx = low.x() >> 3; bx <= high.x() >> 3; ++bx) {
    for (int by = low.y() >> 3; by <= high.y() >> 3; ++by) {
      for (int bz = low.z() >> 3; bz <= high.z() >> 3; ++bz) {
        const VoxelIndex first = VoxelIndex(bx, by, bz) * kBrick;
        const VoxelIndex from = first.cwiseMax(low);
        const VoxelIndex to = (first.array() + kBrick - 1).matrix().cwiseMin(high);
        if (from == first && (to.array() == first.array() + kBrick - 1).all()) {
          brick_state_[brickIndex(bx, by, bz)] = kFullBrick;  // a mask it had is dropped later
          continue;
        }
        for (int x = from.x(); x <= to.x(); ++x) {
          for (int y = from.y(); y <= to.y(); ++y) {
            for (int z = from.z(); z <= to.z(); ++z) setBrickedOccupied({x, y, z}, true);
          }
        }
      }
    }
  }
}

}  // namespace kinolab
