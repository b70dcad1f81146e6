#include "kinolab/flight/sensor.hpp"

#include <array>
#include <cmath>
#include <limits>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/flight/cell_walk.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(Sensor, "sensor", "sensors",
                               "range sensors of closed-loop flights (the flight's `sensor`)", 6)

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

RayCaster::RayCaster(const World& world) : world_(&world) {
  const VoxelGrid& grid = world.grid();
  const Eigen::Vector3i& n = grid.dims();
  bricks_ = (n.array() + kBrick - 1) / kBrick;
  masks_.assign(static_cast<std::size_t>(bricks_.prod()), 0);
  grid.forEachOccupied([&](const VoxelIndex& v) {
    const std::size_t brick =
        (static_cast<std::size_t>(v.x() / kBrick) * bricks_.y() + v.y() / kBrick) * bricks_.z() +
        v.z() / kBrick;
    const int bit = (v.x() % kBrick * kBrick + v.y() % kBrick) * kBrick + v.z() % kBrick;
    masks_[brick] |= std::uint64_t{1} << bit;
  });
  occupied_.resize(masks_.size());
  for (std::size_t brick = 0; brick < masks_.size(); ++brick) occupied_[brick] = masks_[brick] != 0;
}

namespace {

constexpr std::array<std::ptrdiff_t, 3> kBitStrides{16, 4, 1};  // a brick's voxels in its mask

/// The box of a brick's set voxels (`mask` not 0), in voxels from the brick's corner: [low,
/// high) per axis.
void maskExtent(std::uint64_t mask, Eigen::Vector3i& low, Eigen::Vector3i& high) {
  // Per axis, a bit for every index at which some voxel is set: the x-slabs are 16 bits of
  // the mask, the y-rows 4 bits of their OR, the z-bits the OR of those.
  std::uint32_t used[3] = {0, 0, 0};
  const std::uint64_t rows = (mask | mask >> 16 | mask >> 32 | mask >> 48) & 0xFFFF;
  for (int k = 0; k < 4; ++k) {
    used[0] |= ((mask >> (16 * k)) & 0xFFFF) != 0 ? 1u << k : 0u;
    used[1] |= ((rows >> (4 * k)) & 0xF) != 0 ? 1u << k : 0u;
  }
  used[2] = static_cast<std::uint32_t>((rows | rows >> 4 | rows >> 8 | rows >> 12) & 0xF);
  for (int axis = 0; axis < 3; ++axis) {
    low[axis] = __builtin_ctz(used[axis]);
    high[axis] = 32 - __builtin_clz(used[axis]);
  }
}

/// The walk through the voxels of the brick that `bricks` is in, from where the ray entered it
/// (`entered` > 0); `voxels` is the ray's walk through the grid's voxels from its start. The walk's
/// cells are the brick's 4^3 voxels (4 is RayCaster's brick: a mask of 64 bits) and its index
/// is the voxel's bit in the brick's mask.
/// Where faces meet at `entered` (the ray through an edge or a corner) the walk is where the
/// voxels' own traversal would be, which steps the axes of equal parameters in the order x, y,
/// z: a voxel face there on an axis after the one the ray entered the brick by is still ahead.
CellWalk voxelsOfBrick(const CellWalk& bricks, const CellWalk& voxels, std::int64_t entered) {
  int entry_axis = -1;  // the last axis the bricks' walk stepped at `entered`
  for (int axis = 0; axis < 3; ++axis) {
    if (bricks.sign[axis] != 0 && bricks.next[axis] - bricks.delta[axis] == entered) {
      entry_axis = axis;
    }
  }
  CellWalk walk;
  for (int axis = 0; axis < 3; ++axis) {
    const int sign = bricks.sign[axis];
    const std::int64_t delta = voxels.delta[axis];
    walk.sign[axis] = sign;
    walk.delta[axis] = delta;
    walk.stride[axis] = sign * kBitStrides[axis];
    if (sign == 0) {
      walk.cell[axis] = voxels.cell[axis] % 4;
      walk.next[axis] = CellWalk::kNever;
    } else {
      // The brick's voxel faces on this axis that the ray has yet to cross: its far face and
      // the three before it, those beyond `entered` (or at it, after the entry's axis).
      const std::int64_t far = bricks.next[axis];
      const std::int64_t from = axis > entry_axis ? entered - 1 : entered;  // (entered > 0)
      const int ahead =
          std::max(1, (far > from ? 1 : 0) + (far - delta > from ? 1 : 0) +
                          (far - 2 * delta > from ? 1 : 0) + (far - 3 * delta > from ? 1 : 0));
      walk.cell[axis] = sign > 0 ? 4 - ahead : ahead - 1;
      walk.next[axis] = far - (ahead - 1) * delta;
    }
    walk.index += walk.cell[axis] * kBitStrides[axis];
  }
  return walk;
}

/// The same for a brick the ray is in at its start (`entered` 0: the start's brick, or one it
/// enters over zero length from a start on a brick's face): the voxels' walk from the start
/// stepped over zero length into the brick (at most three steps, by the same rule); false when
/// it does not get there.
bool voxelsOfStartBrick(const CellWalk& bricks, const CellWalk& voxels, CellWalk& walk) {
  walk = voxels;
  for (int steps = 0;; ++steps) {
    bool there = true;
    for (int axis = 0; axis < 3; ++axis) there &= walk.cell[axis] / 4 == bricks.cell[axis];
    if (there) break;
    if (steps == 3 || walk.leave() != 0) return false;
    walk.step(0);
  }
  walk.index = 0;
  for (int axis = 0; axis < 3; ++axis) {
    walk.cell[axis] -= 4 * bricks.cell[axis];
    walk.stride[axis] = walk.sign[axis] * kBitStrides[axis];
    walk.index += walk.cell[axis] * kBitStrides[axis];
  }
  return true;
}

}  // namespace

double RayCaster::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                       double max_range, double from) const {
  // Amanatides and Woo's traversal over the bricks; through a brick that holds an obstacle,
  // the voxels' own traversal from where the ray enters it to where it leaves, on the brick's
  // mask. Both on the same fixed-point ray parameters (CellWalk::coarser()); the distance
  // returned is recomputed from the struck voxel's faces.
  const VoxelGrid& grid = world_->grid();
  const Eigen::Vector3d local = (origin - grid.origin()) / grid.resolution();  // in voxels
  if (!(max_range >= 0.0) || !grid.inside(local.array().floor().cast<int>().matrix())) {
    return INFINITY;  // as the voxels' traversal: nothing from outside the grid
  }
  from = from > 0.0 ? from : 0.0;
  if (from > max_range) return INFINITY;
  // Started farther on, from a point outside the grid: the ray has left it (a box is convex).
  const Eigen::Vector3d first = local + (from / grid.resolution()) * direction;
  if (from > 0.0 && !grid.inside(first.array().floor().cast<int>().matrix())) return INFINITY;
  const CellWalk start(first, direction, grid.dims());
  CellWalk bricks = start.coarser(kBrick, bricks_);
  const std::int64_t end = CellWalk::fixed((max_range - from) / grid.resolution());
  std::int64_t entered = 0;  // where the ray entered the brick
  while (entered <= end) {
    const std::int64_t leave = bricks.leave();
    if (occupied_[static_cast<std::size_t>(bricks.index)] != 0) {
      const std::uint64_t mask = masks_[static_cast<std::size_t>(bricks.index)];
      CellWalk voxels;
      bool walkable = true;
      if (entered > 0) {
        voxels = voxelsOfBrick(bricks, start, entered);
      } else {
        walkable = voxelsOfStartBrick(bricks, start, voxels);
      }
      std::int64_t in = entered;  // where the ray entered the voxel
      while (walkable && in <= end) {
        if ((mask >> voxels.index & 1) != 0) {
          std::array<int, 3> voxel{};
          for (int axis = 0; axis < 3; ++axis) {
            voxel[axis] = bricks.cell[axis] * kBrick + voxels.cell[axis];
          }
          const double distance = entry(local, direction, voxel);
          return distance <= max_range ? distance : INFINITY;  // (fixed point rounds down)
        }
        in = voxels.leave();
        voxels.step(in);
        if (!voxels.inside(Eigen::Vector3i::Constant(kBrick))) break;  // out of the brick
      }
    }
    entered = leave;
    bricks.step(leave);
    if (!bricks.inside(bricks_)) return INFINITY;
  }
  return INFINITY;
}

namespace {

// Points in view nearer the camera's plane than kNear are within kNear times the image's
// corner ray's length of the camera (nearReach()): with no obstacle there, a brick is
// projected clipped to ahead >= kNear.
constexpr double kNear = 0.05;

/// The farthest a point in view of `pixels` nearer the camera's plane than kNear can be from
/// the camera: kNear times the length of the image's corner ray (1, u, v).
double nearReach(const PixelGrid& pixels) {
  const double corner_u = std::max(std::abs(pixels.column_offset + 0.5),
                                   std::abs(pixels.columns - 0.5 - pixels.column_offset)) /
                          std::abs(pixels.column_scale);
  const double corner_v =
      std::max(std::abs(pixels.row_offset + 0.5), std::abs(pixels.rows - 0.5 - pixels.row_offset)) /
      std::abs(pixels.row_scale);
  return kNear * std::sqrt(1.0 + corner_u * corner_u + corner_v * corner_v);
}

/// A box on the image plane: the (u, v) = (left, up) / ahead of the points added; empty (no
/// point added) when u_low > u_high.
struct ImageBox {
  double u_low = INFINITY;
  double u_high = -INFINITY;
  double v_low = INFINITY;
  double v_high = -INFINITY;

  /// Adds `q` (ahead, left, up; ahead > 0).
  void add(const Eigen::Vector3d& q) {
    const double u = q.y() / q.x();
    const double v = q.z() / q.x();
    u_low = std::min(u_low, u);
    u_high = std::max(u_high, u);
    v_low = std::min(v_low, v);
    v_high = std::max(v_high, v);
  }
  bool empty() const { return !(u_low <= u_high); }
};

/// The image box of the part ahead of kNear of the box [lo, hi] (world frame) seen by a camera
/// at `origin` heading (cos, sin) = (c, s) about z.
ImageBox projectBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                    const Eigen::Vector3d& origin, double c, double s) {
  // The box's corners in the camera's frame (ahead, left, up), then its part ahead of kNear:
  // the corners there and where its edges cross ahead = kNear.
  std::array<Eigen::Vector3d, 8> corners;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d d =
        Eigen::Vector3d(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z()) -
        origin;
    corners[k] = Eigen::Vector3d(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z());
  }
  ImageBox box;
  for (int k = 0; k < 8; ++k) {
    if (corners[k].x() >= kNear) box.add(corners[k]);
    for (int bit = 1; bit < 8; bit <<= 1) {  // the edges from this corner, once each
      if ((k & bit) != 0) continue;
      const Eigen::Vector3d& p = corners[k];
      const Eigen::Vector3d& q = corners[k | bit];
      if ((p.x() < kNear) != (q.x() < kNear)) {
        box.add(p + (kNear - p.x()) / (q.x() - p.x()) * (q - p));
      }
    }
  }
  return box;
}

/// Lowers `starts` (a distance per used pixel, row by row) to `nearest` (m) at the used pixels
/// whose rays' (u, v) lie in `box` (scales may be negative), with a hundredth of a pixel to
/// spare for rounding.
void lowerStarts(const PixelGrid& pixels, const ImageBox& box, double nearest,
                 std::vector<float>& starts) {
  const auto [column_from, column_to] = pixels.columnsIn(box.u_low, box.u_high);
  const auto [row_from, row_to] = pixels.rowsIn(box.v_low, box.v_high);
  // Rounded down, so that it stays a lower bound at any distance.
  auto bound = static_cast<float>(nearest);
  if (static_cast<double>(bound) > nearest) bound = std::nextafter(bound, 0.0f);
  for (int r = row_from; r <= row_to; ++r) {
    float* line = starts.data() + static_cast<std::size_t>(r) * pixels.columns;
    for (int k = column_from; k <= column_to; ++k) line[k] = std::min(line[k], bound);
  }
}

}  // namespace

void RayCaster::startDistances(const Eigen::Vector3d& origin, double yaw, const PixelGrid& pixels,
                               double max_range, std::vector<float>& starts) const {
  starts.clear();
  const VoxelGrid& grid = world_->grid();
  if (!(world_->clearance(origin) > nearReach(pixels) + grid.resolution())) return;
  starts.assign(static_cast<std::size_t>(pixels.columns) * pixels.rows, INFINITY);
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  const double side = kBrick * grid.resolution();
  // The bricks within max_range of the camera.
  const Eigen::Vector3d low = (origin.array() - max_range - grid.origin().array()) / side;
  const Eigen::Vector3d high = (origin.array() + max_range - grid.origin().array()) / side;
  Eigen::Vector3i first;
  Eigen::Vector3i last;
  for (int axis = 0; axis < 3; ++axis) {
    first[axis] = std::max(0, static_cast<int>(std::floor(low[axis])));
    last[axis] = std::min(bricks_[axis] - 1, static_cast<int>(std::floor(high[axis])));
  }
  for (int bx = first.x(); bx <= last.x(); ++bx) {
    for (int by = first.y(); by <= last.y(); ++by) {
      const std::size_t row = (static_cast<std::size_t>(bx) * bricks_.y() + by) * bricks_.z();
      for (int bz = first.z(); bz <= last.z(); ++bz) {
        if (occupied_[row + bz] == 0) continue;
        // The box of the brick's obstacle voxels (tighter than the brick's: a trunk fills a
        // part of most of its bricks).
        Eigen::Vector3i set_low;
        Eigen::Vector3i set_high;
        maskExtent(masks_[row + bz], set_low, set_high);
        const Eigen::Vector3i corner = kBrick * Eigen::Vector3i(bx, by, bz);
        const Eigen::Vector3d lo =
            grid.origin() + grid.resolution() * (corner + set_low).cast<double>();
        const Eigen::Vector3d hi =
            grid.origin() + grid.resolution() * (corner + set_high).cast<double>();
        const double nearest = (origin.cwiseMax(lo).cwiseMin(hi) - origin).norm();
        if (nearest > max_range) continue;
        const ImageBox box = projectBox(lo, hi, origin, c, s);
        if (box.empty()) continue;  // wholly behind
        lowerStarts(pixels, box, nearest, starts);
      }
    }
  }
}

double RayCaster::entry(const Eigen::Vector3d& local, const Eigen::Vector3d& direction,
                        const std::array<int, 3>& voxel) const {
  // The largest of the parameters where the ray crosses the cube's near face on each axis.
  double t = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    const double d = direction[axis];
    if (d == 0.0) continue;
    const double face = voxel[axis] + (d > 0.0 ? 0.0 : 1.0);
    t = std::max(t, (face - local[axis]) / d);
  }
  return t * world_->grid().resolution();
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
  // A camera's image: its rays are its used pixels, row by row.
  std::optional<PixelGrid> grid = sensor.pixelGrid();
  if (grid && static_cast<std::size_t>(grid->columns) * grid->rows != rays.size()) grid.reset();
  if (grid) {
    frame.image.grid = *grid;
    frame.image.yaw = yaw;
    frame.image.ranges.assign(rays.size(), std::numeric_limits<float>::quiet_NaN());
  }
  float* ranges = grid ? frame.image.ranges.data() : nullptr;
  // A camera's rays start where the bricks with an obstacle that could stop them begin (a
  // thousandth of a voxel before, for the bound's rounding): the empty space before is not
  // walked.
  std::vector<float> starts;
  if (grid) truth.startDistances(origin, yaw, *grid, range, starts);
  const double spare = 1e-3 * voxel;
  for (std::size_t k = 0; k < rays.size(); ++k) {
    if (errors.dropout > 0.0 && noise.uniform01() < errors.dropout) continue;
    const Eigen::Vector3d& ray = rays[k];
    const Eigen::Vector3d direction(c * ray.x() - s * ray.y(), s * ray.x() + c * ray.y(), ray.z());
    const double from = starts.empty() ? 0.0 : static_cast<double>(starts[k]) - spare;
    const double distance = truth.cast(origin, direction, range, from);
    double measured = INFINITY;
    if (distance <= range) {
      const double sigma = errors.sigma(distance);
      measured = distance + nudge + (sigma > 0.0 ? sigma * noise.normal() : 0.0);
      if (distance < errors.min_range || measured < errors.min_range) continue;
    }
    if (measured > range) {
      frame.misses.push_back(origin + (range + voxel) * direction);
      if (ranges) ranges[k] = INFINITY;
    } else {
      frame.hits.push_back(origin + measured * direction);
      if (ranges) ranges[k] = static_cast<float>(measured);
    }
  }
  return frame;
}

}  // namespace kinolab
