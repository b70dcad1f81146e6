// Esdf::exactDistance(): the exact distance from a point to the nearest occupied voxel cube,
// searched over the shell between a proven lower bound and the nearest centre's value.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "kinolab/world/esdf.hpp"

namespace kinolab {
namespace {

/// The slack, in voxels, on a bound made from a stored float distance of `voxels` voxels:
/// float rounding of the stored values (about 6e-8 relative) and of the sums made of them,
/// with room to spare; a fixed slack alone falls short beyond about 500 voxels.
double floatSlack(double voxels) { return 1e-4 + 4e-7 * std::abs(voxels); }

/// A dense field's z-rows (x and y strides; z is contiguous).
struct DenseRows {
  const float* values;
  std::int64_t strides[2];
  const float* operator()(std::int64_t x, std::int64_t y) const {
    return values + x * strides[0] + y * strides[1];
  }
};

/// A truncated field's z-rows, through its brick table.
struct BrickRows {
  struct Row {
    const std::int16_t* const* bricks;  // the column of bricks holding the row
    std::size_t inner;                  // the row within a brick
    const float* values;                // of the codes
    float operator[](std::int64_t z) const {
      return values[static_cast<std::uint16_t>(
          bricks[static_cast<std::size_t>(z) >> 3][inner | (static_cast<std::size_t>(z) & 7)])];
    }
  };
  const std::int16_t* const* table;
  std::size_t strides[2];  // bricks per x and per y step
  const float* values;
  Row operator()(std::int64_t x, std::int64_t y) const {
    const auto ux = static_cast<std::size_t>(x);
    const auto uy = static_cast<std::size_t>(y);
    return {table + (ux >> 3) * strides[0] + (uy >> 3) * strides[1],
            ((ux & 7) << 6) | ((uy & 7) << 3), values};
  }
};

/// The search of Esdf::exactDistance() (voxel units), over a field's z-rows (`Rows`: DenseRows
/// or BrickRows): the occupied voxel (negative value) whose cube is nearest to the point, among
/// the voxels [from, to] within sqrt(best2) of it, skipping the ball of radius sqrt(inner2)
/// about the point, known free. From the point's voxel outwards along x, then y, then z, both
/// ways: the gaps grow, so each way stops at the first voxel beyond the best (and along z at
/// the first occupied one), and everything stops at a cube nearer than sqrt(enough2).
template <typename Rows>
struct NearestCubeSearch {
  Rows rows;
  double scaled[3] = {0, 0, 0};      // the point
  std::int64_t cell[3] = {0, 0, 0};  // its voxel (clamped into the grid)
  std::int64_t from[3] = {0, 0, 0};
  std::int64_t to[3] = {0, 0, 0};
  double inner2 = 0.0;
  double best2 = 0.0;
  double enough2 = -1.0;
  bool found = false;

  /// Distance along an axis from the point to the slab of voxel i: [i, i + 1].
  double gap(int axis, std::int64_t i) const {
    const double low = static_cast<double>(i);
    const double x = scaled[axis];
    return x < low ? low - x : (x > low + 1.0 ? x - low - 1.0 : 0.0);
  }
  /// Beyond the best so far (a cube exactly at the first upper bound still counts).
  bool beyond(double d2) const { return found ? d2 >= best2 : d2 > best2; }

  /// One way along z: false at the first voxel beyond the best or the first occupied one.
  template <typename Row>
  bool visit(const Row& row, double gxy2, std::int64_t z) {
    const double gz = gap(2, z);
    const double d2 = gxy2 + gz * gz;
    if (beyond(d2)) return false;
    if (!(row[z] < 0.0f)) return true;
    best2 = d2;
    found = true;
    return false;
  }

  /// The column (x, y) from the first voxel outside the free ball, both ways: below, z <= cell
  /// with a gap scaled - z - 1 of at least free_z; above, z > cell with a gap z - scaled of at
  /// least free_z. False when the search is done.
  bool column(std::int64_t x, std::int64_t y, double gxy2) {
    const auto row = rows(x, y);
    const double free_z = gxy2 < inner2 ? std::sqrt(inner2 - gxy2) : 0.0;
    const std::int64_t below =
        free_z > 0.0
            ? std::min(cell[2], static_cast<std::int64_t>(std::floor(scaled[2] - 1.0 - free_z)))
            : cell[2];
    for (std::int64_t z = below; z >= from[2] && visit(row, gxy2, z); --z) {
    }
    const std::int64_t above =
        std::max(cell[2] + 1, static_cast<std::int64_t>(std::ceil(scaled[2] + free_z)));
    for (std::int64_t z = above; z <= to[2] && visit(row, gxy2, z); ++z) {
    }
    return !(found && best2 < enough2);
  }

  /// Along `axis` from the point's voxel, both ways; `step(i)` is 1 to go on, 0 when this way
  /// is done, -1 when the search is. False when the search is done.
  template <typename Step>
  bool sweep(int axis, const Step& step) {
    for (std::int64_t i = cell[axis]; i >= from[axis]; --i) {
      const int next = step(i);
      if (next < 0) return false;
      if (next == 0) break;
    }
    for (std::int64_t i = cell[axis] + 1; i <= to[axis]; ++i) {
      const int next = step(i);
      if (next <= 0) return next == 0;
    }
    return true;
  }

  void run() {
    sweep(0, [&](std::int64_t x) {
      const double gx2 = gap(0, x) * gap(0, x);
      if (beyond(gx2)) return 0;
      return sweep(1,
                   [&](std::int64_t y) {
                     const double gxy2 = gx2 + gap(1, y) * gap(1, y);
                     if (beyond(gxy2)) return 0;
                     return column(x, y, gxy2) ? 1 : -1;
                   })
                 ? 1
                 : -1;
    });
  }
};

}  // namespace

double Esdf::exactDistanceAbove(const Eigen::Vector3d& point, double limit, double enough,
                                double lower) const {
  if (brick_table_) {
    return nearestCube(
        NearestCubeSearch<BrickRows>{
            {brick_table_, {brick_strides_[0], brick_strides_[1]}, code_values_}},
        point, limit, enough, lower);
  }
  if (values_.empty()) return limit;
  return nearestCube(NearestCubeSearch<DenseRows>{{values_.data(),
                                                   {static_cast<std::int64_t>(strides_[0]),
                                                    static_cast<std::int64_t>(strides_[1])}}},
                     point, limit, enough, lower);
}

template <typename Search>
double Esdf::nearestCube(Search search, const Eigen::Vector3d& point, double limit, double enough,
                         double lower) const {
  double centre_offset2 = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    search.scaled[axis] = (point[axis] - origin_[axis]) * inverse_resolution_;
    if (!std::isfinite(search.scaled[axis])) return limit;
    search.cell[axis] = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(std::floor(search.scaled[axis])), 0, dims_[axis] - 1);
    const double offset = search.scaled[axis] - (static_cast<double>(search.cell[axis]) + 0.5);
    centre_offset2 += offset * offset;
  }
  // In voxel units from here on. The nearest cube lies in a shell about the point: within a
  // lower bound of the distance (`lower`) every voxel is free, and within an upper bound
  // (the voxel's centre value, exact, and the way to it) there is a cube; both with float
  // rounding's slack. Only the shell is searched.
  const float raw =
      valueAt(static_cast<std::size_t>(search.cell[0]), static_cast<std::size_t>(search.cell[1]),
              static_cast<std::size_t>(search.cell[2]));
  // At the cap (the grid's diagonal, farther than any cube of the grid is from a voxel
  // centre): no voxel is occupied.
  if (raw >= static_cast<float>(max_distance_)) return limit;
  const double stored = raw * inverse_resolution_;
  double reach = limit * inverse_resolution_;
  // A truncated value at +T says only that the cube is at least T from the centre, no bound
  // above: the search goes out to the limit (the lower bounds still skip the ball inside).
  const bool beyond_truncation = raw >= static_cast<float>(truncation_);
  if (stored >= 0.0 && !beyond_truncation) {
    reach = std::min(reach, stored + std::sqrt(centre_offset2) + floatSlack(stored));
  }
  const double inner =
      std::max(0.0, lower * inverse_resolution_ - floatSlack(lower * inverse_resolution_));
  for (int axis = 0; axis < 3; ++axis) {
    search.from[axis] = std::max<std::int64_t>(
        0, static_cast<std::int64_t>(std::floor(search.scaled[axis] - reach)));
    search.to[axis] = std::min<std::int64_t>(
        dims_[axis] - 1, static_cast<std::int64_t>(std::floor(search.scaled[axis] + reach)));
  }
  search.inner2 = inner * inner;
  search.best2 = reach * reach;
  const double enough_voxels = enough * inverse_resolution_;
  // Stop early only on a cube provably nearer than `enough` (its distance rounds below it):
  // one at `enough` itself, within rounding, must not end the search for a nearer one.
  search.enough2 = enough > 0.0 ? enough_voxels * enough_voxels * (1.0 - 1e-12) : -1.0;
  search.run();
  if (search.found && search.best2 == 0.0) return -0.5 * resolution_;  // in (or on) a cube
  const double best = std::sqrt(search.best2) * resolution_;
  if (search.found) return std::min(best, limit);
  return limit;  // no cube within reach: at least the limit
}

}  // namespace kinolab

namespace kinolab {
namespace {

/// The side of ExactDistanceRun's blocks, in voxels: 1 and 2 measured alike, 4 slower
/// (BM_TrajectoryFigures); 2 gathers half as often as 1.
constexpr std::int64_t kBlock = 2;

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

/// The cubes of `shell` that can be nearest to a point of its block, over a field's z-rows
/// (`Rows`: DenseRows or BrickRows), appended to `cubes` (x, y, z each). Per column: in the
/// block's heights every occupied cube; beyond them the first occupied cube each way, nearer
/// than those past it to every point of the block.
template <typename Rows>
void gatherShell(const Rows& rows, const BlockShell& shell, std::vector<std::int32_t>& cubes) {
  const auto add = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    cubes.insert(cubes.end(), {static_cast<std::int32_t>(x), static_cast<std::int32_t>(y),
                               static_cast<std::int32_t>(z)});
  };
  const std::int64_t* low = shell.low;
  const std::int64_t* high = shell.high;
  const std::int64_t mz = shell.middle[2];
  const auto span = static_cast<std::int64_t>(std::sqrt(shell.reach2)) + 1;
  for (std::int64_t x = std::max<std::int64_t>(0, low[0] - span);
       x < std::min(shell.dims[0], high[0] + span); ++x) {
    const double bx2 = slabGap(low[0], high[0], x) * slabGap(low[0], high[0], x);
    if (bx2 > shell.reach2) continue;
    const double hx2 = centreGap(x - shell.middle[0]) * centreGap(x - shell.middle[0]);
    for (std::int64_t y = std::max<std::int64_t>(0, low[1] - span);
         y < std::min(shell.dims[1], high[1] + span); ++y) {
      const double bxy2 = bx2 + slabGap(low[1], high[1], y) * slabGap(low[1], high[1], y);
      if (bxy2 > shell.reach2) continue;
      const double hxy2 = hx2 + centreGap(y - shell.middle[1]) * centreGap(y - shell.middle[1]);
      // Heights within reach: k more each way than the block's (one to spare for rounding).
      const auto k = static_cast<std::int64_t>(std::sqrt(shell.reach2 - bxy2)) + 1;
      const std::int64_t bottom = std::max<std::int64_t>(0, low[2] - 1 - k);
      const std::int64_t top = std::min(shell.dims[2] - 1, high[2] + k);
      // The cubes meeting the free ball, (below, above), are skipped.
      std::int64_t below = mz;
      std::int64_t above = mz + 1;
      if (hxy2 < shell.inner2) {
        const double free_z = std::sqrt(shell.inner2 - hxy2);
        below = std::min(mz, floorInt(static_cast<double>(mz) - 0.5 - free_z));
        above = std::max(mz + 1, ceilInt(static_cast<double>(mz) + 0.5 + free_z));
      }
      const auto row = rows(x, y);
      for (std::int64_t z = low[2]; z < high[2]; ++z) {
        if ((z <= below || z >= above) && row[z] < 0.0f) add(x, y, z);
      }
      for (std::int64_t z = std::min(low[2] - 1, below); z >= bottom; --z) {
        if (row[z] < 0.0f) {
          add(x, y, z);
          break;
        }
      }
      for (std::int64_t z = std::max(high[2], above); z <= top; ++z) {
        if (row[z] < 0.0f) {
          add(x, y, z);
          break;
        }
      }
    }
  }
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
  if (field.brick_table_) {
    gatherShell(BrickRows{field.brick_table_,
                          {field.brick_strides_[0], field.brick_strides_[1]},
                          field.code_values_},
                shell, cubes_);
  } else {
    gatherShell(DenseRows{field.values_.data(),
                          {static_cast<std::int64_t>(field.strides_[0]),
                           static_cast<std::int64_t>(field.strides_[1])}},
                shell, cubes_);
  }
}

}  // namespace kinolab
