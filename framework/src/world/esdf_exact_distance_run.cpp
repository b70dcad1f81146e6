// ExactDistanceRun: the exact distances of many nearby points (a trajectory's samples), the
// cubes that can be nearest gathered once per block of voxels from the bricks' occupancy.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "esdf_rows.hpp"
#include "kinolab/world/esdf.hpp"

namespace kinolab {
namespace {

using esdf_rows::BrickRows;
using esdf_rows::DenseRows;
using esdf_rows::floatSlack;

// ExactDistanceRun::kBlock: with the kept cubes pruned and empty bricks skipped, blocks of 4
// measured 1.06-1.46x faster than of 2, and of 8 between (BM_TrajectoryFigures): a larger
// block gathers less often over a thicker shell.

/// What a gather knows of an 8^3 brick: whether it holds a cube, and along which axes its
/// occupancy is uniform (the same at every coordinate along the axis, e.g. along x and y in a
/// floor's brick, along z in a pillar's).
namespace BrickOccupancy {
constexpr unsigned kHoldsCube = 1;
constexpr unsigned kUniformX = 2;  // kUniformX << axis for axis 0, 1, 2
constexpr unsigned kUniformY = 4;
constexpr unsigned kUniformZ = 8;
constexpr unsigned kAll = 15;
}  // namespace BrickOccupancy

/// A brick's occupancy as the gather reads it: the bits above and, with kHoldsCube, its
/// layers' masks (layer x - the brick's first x: bit 8 (y - first y) + (z - first z)).
struct BrickView {
  unsigned bits;
  const std::uint64_t* layers;
};

/// The bits of [from, to] (0-7, from <= to).
unsigned bitRange(std::int64_t from, std::int64_t to) {
  return (0xffu >> (7 - (to - from))) << from;
}

/// Floor and ceiling of a value well inside the integers, without a libm call.
std::int64_t floorInt(double v) {
  const auto t = static_cast<std::int64_t>(v);
  return t - (static_cast<double>(t) > v ? 1 : 0);
}
std::int64_t ceilInt(double v) {
  const auto t = static_cast<std::int64_t>(v);
  return t + (static_cast<double>(t) < v ? 1 : 0);
}

/// The gap in voxels along an axis between the slab [low, high) and voxel i's slab [i, i + 1].
double slabGap(std::int64_t low, std::int64_t high, std::int64_t i) {
  return i < low ? static_cast<double>(low - i - 1)
                 : (i >= high ? static_cast<double>(i - high) : 0.0);
}
/// Along an axis, the gap from voxel c's centre to voxel c + offset's slab.
double centreGap(std::int64_t offset) {
  return offset == 0 ? 0.0 : std::abs(static_cast<double>(offset)) - 0.5;
}

/// What a block's gather searches, in voxels: the block [low, high), every cube within
/// sqrt(reach2) of it, less those meeting the ball of radius sqrt(inner2) about the centre of
/// voxel `middle` (known free).
struct BlockShell {
  std::int64_t low[3];
  std::int64_t high[3];
  std::int64_t dims[3];
  double reach2;
  std::int64_t middle[3];
  double inner2;
};

/// Along an axis, the gap in voxels between the slab [low, high) and the voxels [first, last).
double rangeGap(std::int64_t low, std::int64_t high, std::int64_t first, std::int64_t last) {
  return last <= low ? static_cast<double>(low - last)
                     : (first >= high ? static_cast<double>(first - high) : 0.0);
}

/// The cubes of `shell` that can be nearest to a point of its block, over a field's z-rows
/// (`Rows`: DenseRows or BrickRows), appended to `cubes` (x, y, z each). Visits the 8^3 bricks
/// the shell meets, skipping those `occupancy(bx, by, bz)` says hold no occupied voxel, and in
/// the others every voxel within reach and outside the free ball, less the layers of a brick
/// uniform along an axis that a layer of the same brick dominates (keepUndominated(): in a
/// floor's brick only the columns under the block are read). An occupied cube is kept
/// unless its neighbour one voxel towards the block, along an axis on which it lies outside the
/// block's slab, is occupied too: along that axis the neighbour's gap to every point of the
/// block is at most the cube's (the other two gaps equal), so it is never farther, in exact or
/// rounded arithmetic, and it (or a cube never farther than it) is kept. Over a floor this
/// keeps the cubes under the block alone; of a solid column, its first cube each way.
template <typename Rows>
struct ShellGather {
  const Rows& rows;
  const BlockShell& shell;
  std::vector<std::int32_t>& cubes;

  bool occupied(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return rows(x, y)[z] < 0.0f;
  }

  /// Keeps the occupied cube (x, y, z) unless a neighbour towards the block is occupied.
  void keep(std::int64_t x, std::int64_t y, std::int64_t z) {
    const std::int64_t* low = shell.low;
    const std::int64_t* high = shell.high;
    const std::int64_t tx = x < low[0] ? x + 1 : (x >= high[0] ? x - 1 : x);
    const std::int64_t ty = y < low[1] ? y + 1 : (y >= high[1] ? y - 1 : y);
    const std::int64_t tz = z < low[2] ? z + 1 : (z >= high[2] ? z - 1 : z);
    if ((tx != x && occupied(tx, y, z)) || (ty != y && occupied(x, ty, z)) ||
        (tz != z && occupied(x, y, tz))) {
      return;
    }
    cubes.insert(cubes.end(), {static_cast<std::int32_t>(x), static_cast<std::int32_t>(y),
                               static_cast<std::int32_t>(z)});
  }

  /// Column (x, y) over the heights [z0, z1) of one brick whose first height is `zb` and
  /// whose occupancy there is `column` (bit z - zb), `bxy2` its squared gap to the block.
  /// Within the block's heights every cube outside the free ball (below, above); beyond them
  /// the first occupied cube each way (those past it are never nearer), from the free ball's
  /// edge, if within reach.
  void column(std::int64_t x, std::int64_t y, std::int64_t zb, unsigned column, std::int64_t z0,
              std::int64_t z1, double bxy2) {
    const std::int64_t* low = shell.low;
    const std::int64_t* high = shell.high;
    const std::int64_t* middle = shell.middle;
    const double hxy2 = centreGap(x - middle[0]) * centreGap(x - middle[0]) +
                        centreGap(y - middle[1]) * centreGap(y - middle[1]);
    std::int64_t below = high[2];
    std::int64_t above = low[2] - 1;
    if (hxy2 < shell.inner2) {
      const double free_z = std::sqrt(shell.inner2 - hxy2);
      below = floorInt(static_cast<double>(middle[2]) - 0.5 - free_z);
      above = ceilInt(static_cast<double>(middle[2]) + 0.5 + free_z);
    }
    // The occupied heights of [from, to] (clamped to [z0, z1)), as bits from zb.
    const auto occupied = [&](std::int64_t from, std::int64_t to) {
      from = std::max(from, z0);
      to = std::min(to, z1 - 1);
      return from <= to ? column & bitRange(from - zb, to - zb) : 0u;
    };
    // Below the block: the highest cube, if within reach.
    if (const unsigned bits = occupied(z0, std::min(low[2] - 1, below))) {
      const std::int64_t z = zb + 31 - __builtin_clz(bits);
      const auto g = static_cast<double>(low[2] - 1 - z);
      if (bxy2 + g * g <= shell.reach2) keep(x, y, z);
    }
    // Within the block's heights: every cube outside the free ball.
    unsigned within = occupied(low[2], std::min(high[2] - 1, below)) |
                      occupied(std::max(low[2], above), high[2] - 1);
    while (within != 0) {
      keep(x, y, zb + __builtin_ctz(within));
      within &= within - 1;
    }
    // Above the block: the lowest cube, if within reach.
    if (const unsigned bits = occupied(std::max(high[2], above), z1 - 1)) {
      const std::int64_t z = zb + __builtin_ctz(bits);
      const auto g = static_cast<double>(z - high[2]);
      if (bxy2 + g * g <= shell.reach2) keep(x, y, z);
    }
  }

  /// Along `axis`, a brick's voxels [from, to) less those a neighbour in the brick dominates
  /// when the brick is uniform along the axis (its occupancy the same at every coordinate of
  /// it): outside the block's slab a cube's neighbour towards the block, in the brick, is then
  /// occupied too, so only the layer facing the block remains, and within the slab the slab.
  void keepUndominated(int axis, std::int64_t& from, std::int64_t& to) const {
    const std::int64_t low = shell.low[axis];
    const std::int64_t high = shell.high[axis];
    if (to <= low) {
      from = to - 1;
    } else if (from >= high) {
      to = from + 1;
    } else {
      from = std::max(from, low);
      to = std::min(to, high);
    }
  }

  /// The whole shell, brick by brick; `occupancy(bx, by, bz)` (a BrickView) says whether a
  /// brick holds a cube (BrickOccupancy::kHoldsCube; none skips it), along which axes it is
  /// uniform, and which of its voxels are occupied (the columns read from its masks).
  template <typename Occupancy>
  void run(const Occupancy& occupancy) {
    const std::int64_t* low = shell.low;
    const std::int64_t* high = shell.high;
    constexpr std::int64_t kSide = VoxelGrid::kBrick;
    const auto span = static_cast<std::int64_t>(std::sqrt(shell.reach2)) + 1;
    std::int64_t first[3];
    std::int64_t last[3];  // exclusive
    for (int axis = 0; axis < 3; ++axis) {
      first[axis] = std::max<std::int64_t>(0, low[axis] - span);
      last[axis] = std::min(shell.dims[axis], high[axis] + span);
    }
    // Brick b's voxels along `axis` within [first, last), and their gap to the block.
    const auto range = [&](int axis, std::int64_t b, std::int64_t& from, std::int64_t& to) {
      from = std::max(first[axis], b * kSide);
      to = std::min(last[axis], b * kSide + kSide);
      return rangeGap(low[axis], high[axis], from, to);
    };
    std::int64_t x0, x1, y0, y1, z0, z1;
    for (std::int64_t bx = first[0] / kSide; bx * kSide < last[0]; ++bx) {
      const double gx2 = range(0, bx, x0, x1) * range(0, bx, x0, x1);
      if (gx2 > shell.reach2) continue;
      for (std::int64_t by = first[1] / kSide; by * kSide < last[1]; ++by) {
        const double gxy2 = gx2 + range(1, by, y0, y1) * range(1, by, y0, y1);
        if (gxy2 > shell.reach2) continue;
        for (std::int64_t bz = first[2] / kSide; bz * kSide < last[2]; ++bz) {
          const double gz = range(2, bz, z0, z1);
          if (gxy2 + gz * gz > shell.reach2) continue;
          const BrickView brick = occupancy(bx, by, bz);
          const unsigned bits = brick.bits;
          if (!(bits & BrickOccupancy::kHoldsCube)) continue;
          std::int64_t from[3] = {x0, y0, z0};
          std::int64_t to[3] = {x1, y1, z1};
          for (int axis = 0; axis < 3; ++axis) {
            if (bits & (BrickOccupancy::kUniformX << axis))
              keepUndominated(axis, from[axis], to[axis]);
          }
          for (std::int64_t x = from[0]; x < to[0]; ++x) {
            const double bx2 = slabGap(low[0], high[0], x) * slabGap(low[0], high[0], x);
            const std::uint64_t layer = brick.layers[x - bx * kSide];
            for (std::int64_t y = from[1]; y < to[1]; ++y) {
              const auto bits_of_column =
                  static_cast<unsigned>((layer >> (kSide * (y - by * kSide))) & 0xff);
              if (bits_of_column == 0) continue;
              const double bxy2 = bx2 + slabGap(low[1], high[1], y) * slabGap(low[1], high[1], y);
              if (bxy2 + gz * gz <= shell.reach2) {
                column(x, y, bz * kSide, bits_of_column, from[2], to[2], bxy2);
              }
            }
          }
        }
      }
    }
  }
};

/// The occupancy bits (BrickOccupancy) of the 8^3 brick (bx, by, bz) of a field's z-rows
/// (`Rows`), and with a cube its layers' masks into `layers` (BrickView); `inverse_resolution`
/// the field's.
template <typename Rows>
unsigned readBrickOccupancy(const Rows& rows, const std::int64_t dims[3], double inverse_resolution,
                            std::int64_t bx, std::int64_t by, std::int64_t bz,
                            std::uint64_t* layers) {
  constexpr std::int64_t kSide = VoxelGrid::kBrick;
  static_assert(kSide == 8, "a brick's columns are bytes of its layers' 64-bit masks");
  const std::int64_t first[3] = {bx * kSide, by * kSide, bz * kSide};
  std::int64_t last[3];  // exclusive
  std::int64_t middle[3];
  double far2 = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    last[axis] = std::min(dims[axis], first[axis] + kSide);
    middle[axis] = (first[axis] + last[axis]) / 2;
    const double far = std::max(static_cast<double>(middle[axis] - first[axis]) + 0.5,
                                static_cast<double>(last[axis] - middle[axis]) - 0.5);
    far2 += far * far;
  }
  // The middle voxel's value bounds the distance from its centre to every cube: beyond the
  // brick's farthest corner, no cube lies in the brick.
  const float value = rows(middle[0], middle[1])[middle[2]];
  if (!(value < 0.0f)) {
    const double centre = static_cast<double>(value) * inverse_resolution;
    if (centre > std::sqrt(far2) + floatSlack(centre)) return 0;
  }
  // Layer x's occupancy: bit 8 (y - first y) + (z - first z).
  std::fill(layers, layers + kSide, 0);
  const std::int64_t sides[3] = {last[0] - first[0], last[1] - first[1], last[2] - first[2]};
  for (std::int64_t x = 0; x < sides[0]; ++x) {
    for (std::int64_t y = 0; y < sides[1]; ++y) {
      const auto row = rows(first[0] + x, first[1] + y);
      for (std::int64_t z = 0; z < sides[2]; ++z) {
        if (row[first[2] + z] < 0.0f) layers[x] |= std::uint64_t{1} << (8 * y + z);
      }
    }
  }
  // Voxels past the grid's end are free in every layer, column and height alike.
  unsigned bits = BrickOccupancy::kUniformX | BrickOccupancy::kUniformY | BrickOccupancy::kUniformZ;
  const std::uint64_t column_bits = (std::uint64_t{1} << sides[2]) - 1;
  std::uint64_t any = 0;
  for (std::int64_t x = 0; x < sides[0]; ++x) {
    any |= layers[x];
    if (layers[x] != layers[0]) bits &= ~BrickOccupancy::kUniformX;
    for (std::int64_t y = 0; y < sides[1]; ++y) {
      const std::uint64_t column = (layers[x] >> (8 * y)) & 0xff;
      if (column != (layers[x] & 0xff)) bits &= ~BrickOccupancy::kUniformY;
      if (column != 0 && column != column_bits) bits &= ~BrickOccupancy::kUniformZ;
    }
  }
  return any != 0 ? bits | BrickOccupancy::kHoldsCube : 0;
}

}  // namespace

double ExactDistanceRun::operator()(const Eigen::Vector3d& point) {
  const Esdf& field = esdf_;
  double scaled[3];
  std::int64_t block[3];
  for (int axis = 0; axis < 3; ++axis) {
    scaled[axis] = (point[axis] - field.origin_[axis]) * field.inverse_resolution_;
    // Outside the grid (or not a number): the search itself.
    if (!(scaled[axis] >= 0.0 && scaled[axis] < static_cast<double>(field.dims_[axis]))) {
      return field.exactDistance(point, limit_);
    }
    block[axis] = static_cast<std::int64_t>(scaled[axis]) / kBlock * kBlock;
  }
  if (block[0] != block_[0] || block[1] != block_[1] || block[2] != block_[2]) gather(block);
  if (!usable_) return field.exactDistance(point, limit_);
  // The gaps and their sum as exactDistance() takes them, so the least is the same bit for bit.
  const auto gap = [&](int axis, std::int32_t i) {
    const double low = static_cast<double>(i);
    const double x = scaled[axis];
    return x < low ? low - x : (x > low + 1.0 ? x - low - 1.0 : 0.0);
  };
  double best2 = INFINITY;
  for (std::size_t i = 0; i < cubes_.size(); i += 3) {
    const double gx = gap(0, cubes_[i]);
    const double gy = gap(1, cubes_[i + 1]);
    const double gz = gap(2, cubes_[i + 2]);
    best2 = std::min(best2, (gx * gx + gy * gy) + gz * gz);
  }
  if (best2 == INFINITY) return limit_;
  if (best2 == 0.0) return -0.5 * field.resolution_;  // in (or on) a cube
  return std::min(std::sqrt(best2) * field.resolution_, limit_);
}

namespace {

/// A brick's words in ExactDistanceRun's brick cache: (its index + 1) << 4 plus its
/// BrickOccupancy bits (0: an empty slot), then its layers' masks (BrickView).
constexpr std::size_t kSlotWords = 1 + VoxelGrid::kBrick;

}  // namespace

template <typename Scan>
const std::uint64_t* ExactDistanceRun::brickOccupancy(std::int64_t bx, std::int64_t by,
                                                      std::int64_t bz, const Scan& scan) {
  constexpr std::int64_t kSide = VoxelGrid::kBrick;
  const auto bricks = [&](int axis) { return (esdf_.dims_[axis] + kSide - 1) / kSide; };
  const auto index = static_cast<std::uint64_t>((bx * bricks(1) + by) * bricks(2) + bz);
  // Direct-mapped.
  if (brick_cache_.empty()) brick_cache_.assign(kBrickCacheSlots * kSlotWords, 0);
  std::uint64_t* slot = &brick_cache_[(index % kBrickCacheSlots) * kSlotWords];
  if (slot[0] >> 4 == index + 1) return slot;
  ++bricks_read_;
  // A truncated field's shared brick is all +T (no cube) or all -T (all cubes).
  int shared = 0;
  const bool own = !esdf_.brick_table_ ||
                   esdf_.brickCodes(static_cast<std::size_t>(bx) * esdf_.brick_strides_[0] +
                                        static_cast<std::size_t>(by) * esdf_.brick_strides_[1] +
                                        static_cast<std::size_t>(bz),
                                    shared) != nullptr;
  unsigned bits = 0;
  if (own) {
    bits = scan(slot + 1);
  } else if (shared < 0) {
    bits = BrickOccupancy::kAll;
    // Every voxel of the brick inside the grid.
    const auto side = [&](int axis, std::int64_t b) {
      return std::min<std::int64_t>(kSide,
                                    static_cast<std::int64_t>(esdf_.dims_[axis]) - b * kSide);
    };
    const std::uint64_t column = (std::uint64_t{1} << side(2, bz)) - 1;
    std::uint64_t layer = 0;
    for (std::int64_t y = 0; y < side(1, by); ++y) layer |= column << (kSide * y);
    for (std::int64_t x = 0; x < kSide; ++x) slot[1 + x] = x < side(0, bx) ? layer : 0;
  }
  slot[0] = ((index + 1) << 4) | bits;
  return slot;
}

void ExactDistanceRun::gather(const std::int64_t block[3]) {
  const Esdf& field = esdf_;
  BlockShell shell{};
  for (int axis = 0; axis < 3; ++axis) {
    block_[axis] = block[axis];
    shell.low[axis] = block[axis];
    shell.high[axis] = std::min<std::int64_t>(block[axis] + kBlock, field.dims_[axis]);
    shell.dims[axis] = field.dims_[axis];
  }
  cubes_.clear();
  // In voxels. A voxel v of the block whose centre value d_v bounds its nearest cube has a cube
  // within d_v of its centre, so within d_v + (the block's farthest corner from v's centre) of
  // every point of the block: the least of these is the reach. The voxel of largest value is
  // the middle of a ball free of cubes. Both with float rounding's slack; a cube gathered
  // beyond need is harmless.
  double reach = INFINITY;
  float largest = -INFINITY;
  const std::int64_t* low = shell.low;
  const std::int64_t* high = shell.high;
  for (std::int64_t x = low[0]; x < high[0]; ++x) {
    for (std::int64_t y = low[1]; y < high[1]; ++y) {
      for (std::int64_t z = low[2]; z < high[2]; ++z) {
        const float raw = field.valueAt(static_cast<std::size_t>(x), static_cast<std::size_t>(y),
                                        static_cast<std::size_t>(z));
        // At the cap no voxel of the grid is occupied: nothing to gather.
        if (!(raw < static_cast<float>(field.max_distance_))) continue;
        if (raw > largest) {
          largest = raw;
          shell.middle[0] = x;
          shell.middle[1] = y;
          shell.middle[2] = z;
        }
        // A truncated value at the truncation bounds nothing above.
        if (!(raw < static_cast<float>(field.truncation_))) continue;
        const double d = std::max(0.0, static_cast<double>(raw) * field.inverse_resolution_);
        const double far_x =
            std::max(static_cast<double>(x - low[0]) + 0.5, static_cast<double>(high[0] - x) - 0.5);
        const double far_y =
            std::max(static_cast<double>(y - low[1]) + 0.5, static_cast<double>(high[1] - y) - 0.5);
        const double far_z =
            std::max(static_cast<double>(z - low[2]) + 0.5, static_cast<double>(high[2] - z) - 0.5);
        reach = std::min(
            reach, d + floatSlack(d) + std::sqrt(far_x * far_x + far_y * far_y + far_z * far_z));
      }
    }
  }
  usable_ = reach < INFINITY;
  if (!usable_) return;
  ++gathers_;
  const double limit = limit_ * field.inverse_resolution_;
  reach = std::min(reach, limit + floatSlack(limit));
  shell.reach2 = reach * reach;
  const double d = static_cast<double>(largest) * field.inverse_resolution_;
  const double inner = std::max(0.0, d - floatSlack(d));
  shell.inner2 = inner * inner;
  const auto gatherOver = [&](const auto& rows) {
    ShellGather<std::decay_t<decltype(rows)>>{rows, shell, cubes_}.run(
        [&](std::int64_t bx, std::int64_t by, std::int64_t bz) {
          const std::uint64_t* slot = brickOccupancy(bx, by, bz, [&](std::uint64_t* layers) {
            return readBrickOccupancy(rows, shell.dims, field.inverse_resolution_, bx, by, bz,
                                      layers);
          });
          return BrickView{static_cast<unsigned>(slot[0] & BrickOccupancy::kAll), slot + 1};
        });
  };
  if (field.brick_table_) {
    gatherOver(BrickRows{field.brick_table_,
                         {field.brick_strides_[0], field.brick_strides_[1]},
                         field.code_values_});
  } else {
    gatherOver(DenseRows{field.values_.data(),
                         {static_cast<std::int64_t>(field.strides_[0]),
                          static_cast<std::int64_t>(field.strides_[1])}});
  }
  cubes_gathered_ += cubes_.size() / 3;
}

}  // namespace kinolab
