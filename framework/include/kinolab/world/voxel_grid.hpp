#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "kinolab/core/value_array.hpp"

namespace kinolab {

/// Integer voxel coordinates.
using VoxelIndex = Eigen::Vector3i;

/// An axis-aligned box in metres.
struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();

  bool contains(const Eigen::Vector3d& point) const {
    return (point.array() >= min.array()).all() && (point.array() <= max.array()).all();
  }
  Eigen::Vector3d size() const { return max - min; }

  /// As a mapping `{min: [x, y, z], max: [x, y, z]}` (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.point("min", min, "lowest corner, m", {.required = true});
    f.point("max", max, "highest corner, m", {.required = true});
  }
};

/// How a VoxelGrid stores its occupancy.
enum class GridLayout {
  /// One byte a voxel (occupancy()), for grids that fit in memory whole.
  kDense,
  /// Bricks of 8 x 8 x 8 voxels, each empty, full, or a 512-bit mask: memory for the bricks
  /// an obstacle's surface crosses, so a city of 10^10 voxels fits (a "sparse" world).
  kBricked,
};

/// An occupancy voxel grid with metric bounds. Voxel (ix, iy, iz) covers
/// [origin + i * resolution, origin + (i + 1) * resolution) per axis; its centre is at
/// origin + (i + 0.5) * resolution. Voxels are numbered row-major over (ix, iy, iz), z
/// fastest, so index(ix, iy, iz) = (ix * ny + iy) * nz + iz ("axis_order: xyz" in exported
/// files); a dense grid stores them in that order, a bricked one in bricks (the same queries,
/// without occupancy()).
class VoxelGrid {
 public:
  /// A brick's side in voxels (kBricked).
  static constexpr int kBrick = 8;

  VoxelGrid() = default;
  /// A free grid covering `bounds` (rounded up to whole voxels) at `resolution` metres.
  VoxelGrid(const Box& bounds, double resolution, GridLayout layout = GridLayout::kDense);
  /// A dense grid covering `bounds` at `resolution` whose occupancy is `occupancy` (0 free,
  /// 1 occupied, one byte a voxel in storage order; a view of a world cache file is not
  /// copied). Throws InvalidArgument when the sizes differ.
  VoxelGrid(const Box& bounds, double resolution, ValueArray<std::uint8_t> occupancy);
  /// A bricked grid covering `bounds` at `resolution` from its bricks as brickStates() and
  /// brickMasks() give them (a world cache file's). Throws InvalidArgument when they do not
  /// fit the grid or each other.
  VoxelGrid(const Box& bounds, double resolution, std::vector<std::uint32_t> brick_states,
            std::vector<std::uint64_t> brick_masks);
  /// The voxels along each axis a grid of `bounds` at `resolution` has (as a double, for size
  /// checks before anything is allocated).
  static Eigen::Vector3d voxelsAlong(const Box& bounds, double resolution);

  GridLayout layout() const { return bricked_ ? GridLayout::kBricked : GridLayout::kDense; }

  const Eigen::Vector3i& dims() const { return dims_; }
  double resolution() const { return resolution_; }
  /// The minimum corner of voxel (0, 0, 0).
  const Eigen::Vector3d& origin() const { return origin_; }
  /// The metric box the voxels cover (may exceed the requested bounds by < 1 voxel).
  Box bounds() const { return {origin_, origin_ + dims_.cast<double>() * resolution_}; }
  /// The number of voxels (dims' product).
  std::size_t size() const { return size_; }
  /// Bytes the occupancy takes (the byte array, or the bricks' table and masks).
  std::size_t memoryBytes() const;

  std::size_t index(int ix, int iy, int iz) const {
    return (static_cast<std::size_t>(ix) * dims_.y() + iy) * dims_.z() + iz;
  }
  std::size_t index(const VoxelIndex& voxel) const {
    return index(voxel.x(), voxel.y(), voxel.z());
  }
  bool inside(const VoxelIndex& voxel) const {
    return (voxel.array() >= 0).all() && (voxel.array() < dims_.array()).all();
  }
  Eigen::Vector3d center(const VoxelIndex& voxel) const {
    return origin_ + (voxel.cast<double>().array() + 0.5).matrix() * resolution_;
  }

  /// The voxel of an index (index()'s inverse).
  VoxelIndex voxel(std::size_t index) const {
    const auto nz = static_cast<std::size_t>(dims_.z());
    const std::size_t column = index / nz;
    return {static_cast<int>(column / static_cast<std::size_t>(dims_.y())),
            static_cast<int>(column % static_cast<std::size_t>(dims_.y())),
            static_cast<int>(index % nz)};
  }

  bool occupied(std::size_t index) const {
    return bricked_ ? brickedOccupied(voxel(index)) : occupancy_[index] != 0;
  }
  bool occupied(const VoxelIndex& voxel) const {
    return bricked_ ? brickedOccupied(voxel) : occupancy_[index(voxel)] != 0;
  }
  void setOccupied(std::size_t index, bool value) {
    if (bricked_) {
      setBrickedOccupied(voxel(index), value);
    } else {
      occupancy_.mutableData()[index] = value ? 1 : 0;
    }
  }
  void setOccupied(const VoxelIndex& voxel, bool value) {
    if (bricked_) {
      setBrickedOccupied(voxel, value);
    } else {
      occupancy_.mutableData()[index(voxel)] = value ? 1 : 0;
    }
  }
  std::size_t occupiedCount() const;

  /// 0 (free) or 1 (occupied) per voxel, in storage order; a dense grid's only (throws
  /// InvalidArgument on a bricked one: use occupied() or forEachOccupied()).
  std::span<const std::uint8_t> occupancy() const;
  /// The same for writing (a grid viewing a world cache file copies it first).
  std::span<std::uint8_t> mutableOccupancy();

  /// Calls `visit(voxel)` for every occupied voxel (a dense grid's x-major, a bricked grid's
  /// brick by brick); a bricked grid skips its empty bricks, so the cost is its obstacles', not
  /// its volume's.
  template <typename Visit>
  void forEachOccupied(Visit&& visit) const {
    if (!bricked_) {
      std::size_t i = 0;
      for (int x = 0; x < dims_.x(); ++x) {
        for (int y = 0; y < dims_.y(); ++y) {
          for (int z = 0; z < dims_.z(); ++z, ++i) {
            if (occupancy_[i] != 0) visit(VoxelIndex(x, y, z));
          }
        }
      }
      return;
    }
    for (int bx = 0; bx < bricks_.x(); ++bx) {
      for (int by = 0; by < bricks_.y(); ++by) {
        for (int bz = 0; bz < bricks_.z(); ++bz) {
          if (brick_state_[brickIndex(bx, by, bz)] == kEmptyBrick) continue;
          const VoxelIndex low(bx * kBrick, by * kBrick, bz * kBrick);
          const VoxelIndex high = (low.array() + kBrick).min(dims_.array());
          for (int x = low.x(); x < high.x(); ++x) {
            for (int y = low.y(); y < high.y(); ++y) {
              for (int z = low.z(); z < high.z(); ++z) {
                if (brickedOccupied({x, y, z})) visit(VoxelIndex(x, y, z));
              }
            }
          }
        }
      }
    }
  }

  /// Bricks per axis (kBricked; zero on a dense grid).
  const Eigen::Vector3i& brickDims() const { return bricks_; }
  /// Whether brick (bx, by, bz) has an occupied voxel (kBricked).
  bool brickHasObstacle(int bx, int by, int bz) const {
    return brick_state_[brickIndex(bx, by, bz)] != kEmptyBrick;
  }
  /// Whether brick (bx, by, bz) is stored as wholly occupied (kBricked; a brick filled voxel by
  /// voxel is, after compactBricks()).
  bool brickFull(int bx, int by, int bz) const {
    return brick_state_[brickIndex(bx, by, bz)] == kFullBrick;
  }
  /// The occupancy of the eight voxels (x, y, 8 bz + k) of brick layer bz, bit k (kBricked; a
  /// full brick past the grid's end has bits set beyond it).
  std::uint8_t brickRow(int x, int y, int bz) const {
    const std::uint32_t state = brick_state_[brickIndex(x >> 3, y >> 3, bz)];
    if (state < kMasked) return state == kFullBrick ? 0xFF : 0;
    return static_cast<std::uint8_t>(masks_[(state - kMasked) * 8 + (x & 7)] >> ((y & 7) << 3));
  }
  /// A bricked grid's storage: per brick (x-major, z fastest) 0 empty, 1 full, else 2 + the
  /// index of its mask of 8 words in brickMasks() (bit (y % 8) * 8 + z % 8 of word x % 8).
  std::span<const std::uint32_t> brickStates() const { return brick_state_; }
  std::span<const std::uint64_t> brickMasks() const { return masks_; }
  /// Frees the masks of bricks that became wholly full or empty (a bricked grid after edits).
  void compactBricks();

  /// Calls `visit(index)` for every voxel whose centre lies in the closed box [min, max].
  template <typename Visit>
  void forEachVoxelIn(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Visit&& visit) const {
    Eigen::Vector3i low;
    Eigen::Vector3i high;
    if (voxelRange(min, max, low, high)) forEachVoxelOf(low, high, visit);
  }
  /// Calls `visit(index)` for every voxel whose cube overlaps the box (min, max) by more than
  /// a thousandth of a voxel on every axis: the conservative test for obstacles, so that
  /// resampling never loses one (a box aligned with the grid covers exactly its voxels).
  template <typename Visit>
  void forEachVoxelOverlapping(const Eigen::Vector3d& min, const Eigen::Vector3d& max,
                               Visit&& visit) const {
    Eigen::Vector3i low;
    Eigen::Vector3i high;
    if (overlapRange(min, max, low, high)) forEachVoxelOf(low, high, visit);
  }
  /// Walks the voxels a ray passes through (Amanatides and Woo's traversal), from the voxel
  /// holding `origin` along the unit `direction`: visit(voxel, t) with t the ray parameter (m)
  /// where the ray enters the voxel (0 for the first), in order, until visit returns false,
  /// the ray leaves the grid or t exceeds `max_range`. Nothing is visited when `origin` lies
  /// outside the grid.
  template <typename Visit>
  void walkRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double max_range,
               Visit&& visit) const {
    const Eigen::Vector3d local = (origin - origin_) / resolution_;  // in voxels
    VoxelIndex voxel;
    Eigen::Vector3i step;
    Eigen::Vector3d next;   // ray parameter (m) at the next face crossing per axis
    Eigen::Vector3d delta;  // ray parameter between faces per axis
    for (int axis = 0; axis < 3; ++axis) {
      voxel[axis] = static_cast<int>(std::floor(local[axis]));
      const double d = direction[axis];
      step[axis] = d > 0.0 ? 1 : (d < 0.0 ? -1 : 0);
      const double to_face = d > 0.0 ? voxel[axis] + 1 - local[axis] : local[axis] - voxel[axis];
      next[axis] = d != 0.0 ? to_face * resolution_ / std::abs(d) : INFINITY;
      delta[axis] = d != 0.0 ? resolution_ / std::abs(d) : INFINITY;
    }
    if (!inside(voxel)) return;
    double t = 0.0;  // where the ray entered the current voxel
    while (t <= max_range) {
      if (!visit(voxel, t)) return;
      int axis = 0;
      if (next[1] < next[axis]) axis = 1;
      if (next[2] < next[axis]) axis = 2;
      t = next[axis];
      next[axis] += delta[axis];
      voxel[axis] += step[axis];
      if (voxel[axis] < 0 || voxel[axis] >= dims_[axis]) return;
    }
  }

  /// Marks every voxel whose centre lies in the closed box [min, max] as occupied.
  void fillBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max);
  /// The writes fillBox(min, max) makes, without making them: its voxels on a dense grid; on a
  /// bricked one a write per brick it touches and its voxels in bricks it covers in part. For
  /// generators that refuse unbounded work before doing any.
  double fillCost(const Eigen::Vector3d& min, const Eigen::Vector3d& max) const;

  /// The voxel range whose centres lie in [min, max]; false when it is empty.
  bool voxelRange(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Eigen::Vector3i& low,
                  Eigen::Vector3i& high) const;
  /// The voxel range whose cubes overlap (min, max) (see forEachVoxelOverlapping).
  bool overlapRange(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Eigen::Vector3i& low,
                    Eigen::Vector3i& high) const;

 private:
  /// Calls `visit(index)` for every voxel of the inclusive index range [low, high].
  template <typename Visit>
  void forEachVoxelOf(const Eigen::Vector3i& low, const Eigen::Vector3i& high, Visit& visit) const {
    for (int ix = low.x(); ix <= high.x(); ++ix) {
      for (int iy = low.y(); iy <= high.y(); ++iy) {
        const std::size_t row = index(ix, iy, 0);
        for (int iz = low.z(); iz <= high.z(); ++iz) visit(row + iz);
      }
    }
  }

  // A brick's state: empty, full, or kMasked + the index of its mask (8 words, bit
  // (y % 8) * 8 + z % 8 of word x % 8).
  static constexpr std::uint32_t kEmptyBrick = 0;
  static constexpr std::uint32_t kFullBrick = 1;
  static constexpr std::uint32_t kMasked = 2;

  std::size_t brickIndex(int bx, int by, int bz) const {
    return (static_cast<std::size_t>(bx) * bricks_.y() + by) * bricks_.z() + bz;
  }
  bool brickedOccupied(const VoxelIndex& v) const {
    const std::uint32_t state = brick_state_[brickIndex(v.x() >> 3, v.y() >> 3, v.z() >> 3)];
    if (state < kMasked) return state == kFullBrick;
    const std::uint64_t word = masks_[(state - kMasked) * 8 + (v.x() & 7)];
    return (word >> (((v.y() & 7) << 3) | (v.z() & 7))) & 1;
  }
  void setBrickedOccupied(const VoxelIndex& v, bool value);
  /// Sets dims_ and size_ from `bounds` and resolution_; returns the voxel count (as a double,
  /// which does not overflow). Throws InvalidArgument on a bad resolution or an empty box.
  double setDims(const Box& bounds);
  [[noreturn]] void denseOnly() const;

  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double resolution_ = 0.0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  std::size_t size_ = 0;
  ValueArray<std::uint8_t> occupancy_;  // kDense
  bool bricked_ = false;
  Eigen::Vector3i bricks_ = Eigen::Vector3i::Zero();  // kBricked: bricks per axis
  std::vector<std::uint32_t> brick_state_;
  std::vector<std::uint64_t> masks_;
};

}  // namespace kinolab
