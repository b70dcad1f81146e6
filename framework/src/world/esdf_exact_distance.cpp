// Esdf::exactDistance(): the exact distance from a point to the nearest occupied voxel cube,
// searched over the shell between a proven lower bound and the nearest centre's value.
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
