// Esdf's queries over many points at once (distances(), distancesWithGradients()) and the
// centre bound of clearance verdicts.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "kinolab/core/error.hpp"
#include "kinolab/world/esdf.hpp"

namespace kinolab {
namespace {

using Pair = double __attribute__((vector_size(16)));
using Mask = std::int64_t __attribute__((vector_size(16)));
using Indices = std::int32_t __attribute__((vector_size(8)));

/// Where two points fall, one to a lane: their cells' lower corners (as dense indices), the
/// fractions within the cells, the gradient's scale per axis (zero along a clamped axis) and
/// the poison term (0 for a finite point, NaN otherwise).
struct PairCells {
  std::size_t base[2];
  Pair fraction[3];
  Pair scale[3];
  Pair poison;
};

/// A dense field's interpolation of two points at a time, a point to a lane of SSE2 pairs,
/// through Esdf::interpolate()'s arithmetic: per lane the same operations in the same order
/// (for each x side on its own), so the same values bit for bit. The field's geometry is
/// copied in (Esdf's members of the same names).
struct PairInterpolation {
  const float* values;
  double inverse_resolution;
  double shift[3];
  double upper[3];
  double lower_corner[3];
  double gradient_scale[3];
  std::size_t strides[3];
  std::size_t step[3];  // neighbour_step_

  /// Interpolates the points [0, 2 pairs) into `distances` (and `gradients`, kWithGradient) in
  /// chunks of kChunk pairs: the cells of chunk j + 1 found and their corners' cache lines
  /// requested into the outer caches (a prefetch to L1 would wait for its few fill buffers)
  /// before chunk j is interpolated.
  template <bool kWithGradient>
  void run(const Eigen::Vector3d* points, std::size_t pairs, double* distances,
           Eigen::Vector3d* gradients) const {
    constexpr std::size_t kChunk = 8;
    PairCells cells[2][kChunk];
    if (pairs > 0) find(points, 0, std::min(kChunk, pairs), cells[0]);
    for (std::size_t first = 0, j = 0; first < pairs; first += kChunk, j ^= 1) {
      if (first + kChunk < pairs) {
        find(points, first + kChunk, std::min(kChunk, pairs - first - kChunk), cells[j ^ 1]);
      }
      const std::size_t n = std::min(kChunk, pairs - first);
      for (std::size_t k = 0; k < n; ++k) {
        const std::size_t i = 2 * (first + k);
        blend<kWithGradient>(cells[j][k], distances + i, kWithGradient ? gradients + i : nullptr);
      }
    }
  }

  /// The cells of the `count` pairs from pair `first` into `out`, their corners requested.
  void find(const Eigen::Vector3d* points, std::size_t first, std::size_t count,
            PairCells* out) const {
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t i = 2 * (first + k);
      cellsOf(points[i], points[i + 1], out[k]);
      for (const std::size_t base : out[k].base) {
        const float* v = values + base;
        __builtin_prefetch(v, 0, 1);
        __builtin_prefetch(v + step[1] + step[2], 0, 1);
        __builtin_prefetch(v + step[0], 0, 1);
        __builtin_prefetch(v + step[0] + step[1] + step[2], 0, 1);
      }
    }
  }

  /// The cells of points `a` and `b`.
  void cellsOf(const Eigen::Vector3d& a, const Eigen::Vector3d& b, PairCells& cells) const {
    const Pair zero = {0.0, 0.0};
    cells.base[0] = 0;
    cells.base[1] = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const Pair raw = Pair{a[axis], b[axis]} * inverse_resolution - shift[axis];
      // std::max(0.0, raw), then std::min(.., upper), as the standard library selects: a NaN
      // coordinate becomes 0.
      const Pair low = zero < raw ? raw : zero;
      const Pair high = {upper[axis], upper[axis]};
      const Pair scaled = high < low ? high : low;
      const Mask unclamped = raw == scaled;
      cells.scale[axis] = unclamped ? Pair{gradient_scale[axis], gradient_scale[axis]} : zero;
      const Pair highest = {lower_corner[axis], lower_corner[axis]};
      // Truncation to 32 bits is the 64-bit one: an axis has at most checkTransformable()'s
      // 23,000-odd voxels.
      const Indices corner = __builtin_convertvector(highest < scaled ? highest : scaled, Indices);
      cells.fraction[axis] = scaled - __builtin_convertvector(corner, Pair);
      cells.base[0] += static_cast<std::size_t>(corner[0]) * strides[axis];
      cells.base[1] += static_cast<std::size_t>(corner[1]) * strides[axis];
    }
    cells.poison = Pair{a.x(), b.x()} * 0.0 + Pair{a.y(), b.y()} * 0.0 + Pair{a.z(), b.z()} * 0.0;
  }

  /// The two points' values into distance[0, 1] and, kWithGradient, gradient[0, 1].
  template <bool kWithGradient>
  void blend(const PairCells& cells, double* distance, Eigen::Vector3d* gradient) const {
    const float* a = values + cells.base[0];
    const float* b = values + cells.base[1];
    const auto corner = [&](std::size_t offset) { return Pair{a[offset], b[offset]}; };
    const Pair c000 = corner(0);
    const Pair c001 = corner(step[2]);
    const Pair c010 = corner(step[1]);
    const Pair c011 = corner(step[1] + step[2]);
    const Pair c100 = corner(step[0]);
    const Pair c101 = corner(step[0] + step[2]);
    const Pair c110 = corner(step[0] + step[1]);
    const Pair c111 = corner(step[0] + step[1] + step[2]);
    const Pair tx = cells.fraction[0];
    const Pair ty = cells.fraction[1];
    const Pair tz = cells.fraction[2];
    const Pair dz_low0 = c001 - c000;  // interpolate()'s dz_low, the x0 side
    const Pair dz_low1 = c101 - c100;
    const Pair dz_high0 = c011 - c010;
    const Pair dz_high1 = c111 - c110;
    const Pair e00 = c000 + dz_low0 * tz;  // e0, x0 side
    const Pair e01 = c100 + dz_low1 * tz;
    const Pair e10 = c010 + dz_high0 * tz;
    const Pair e11 = c110 + dz_high1 * tz;
    const Pair dy0 = e10 - e00;
    const Pair dy1 = e11 - e01;
    const Pair c0 = e00 + dy0 * ty;
    const Pair c1 = e01 + dy1 * ty;
    const Pair dx = c1 - c0;
    const Pair value = c0 + dx * tx + cells.poison;
    distance[0] = value[0];
    distance[1] = value[1];
    if constexpr (kWithGradient) {
      const Pair dz0 = dz_low0 + (dz_high0 - dz_low0) * ty;
      const Pair dz1 = dz_low1 + (dz_high1 - dz_low1) * ty;
      const Pair gx = dx * cells.scale[0];
      const Pair gy = (dy0 + (dy1 - dy0) * tx) * cells.scale[1];
      const Pair gz = (dz0 + (dz1 - dz0) * tx) * cells.scale[2];
      gradient[0] = {gx[0], gy[0], gz[0]};
      gradient[1] = {gx[1], gy[1], gz[1]};
    }
  }
};

}  // namespace

template <bool kWithGradient>
void Esdf::batch(const Eigen::Vector3d* points, std::size_t count, double* distances,
                 Eigen::Vector3d* gradients) const {
  const auto one = [&](std::size_t i) {
    distances[i] =
        interpolate<kWithGradient>(points[i], kWithGradient ? &gradients[i] : nullptr, nullptr);
  };
  if (brick_table_) {  // a truncated field's bricks: one at a time
    for (std::size_t i = 0; i < count; ++i) one(i);
    return;
  }
  const PairInterpolation pairs{values_.data(),
                                inverse_resolution_,
                                {shift_[0], shift_[1], shift_[2]},
                                {upper_[0], upper_[1], upper_[2]},
                                {lower_corner_[0], lower_corner_[1], lower_corner_[2]},
                                {gradient_scale_[0], gradient_scale_[1], gradient_scale_[2]},
                                {strides_[0], strides_[1], strides_[2]},
                                {neighbour_step_[0], neighbour_step_[1], neighbour_step_[2]}};
  pairs.run<kWithGradient>(points, count / 2, distances, gradients);
  if (count % 2 == 1) one(count - 1);
}

void Esdf::distances(std::span<const Eigen::Vector3d> points, std::span<double> distances) const {
  if (distances.size() != points.size()) {
    throw InvalidArgument("Esdf::distances: " + std::to_string(distances.size()) +
                          " distances for " + std::to_string(points.size()) + " points");
  }
  batch<false>(points.data(), points.size(), distances.data(), nullptr);
}

void Esdf::distancesWithGradients(std::span<const Eigen::Vector3d> points,
                                  std::span<double> distances,
                                  std::span<Eigen::Vector3d> gradients) const {
  if (distances.size() != points.size() || gradients.size() != points.size()) {
    throw InvalidArgument("Esdf::distancesWithGradients: " + std::to_string(distances.size()) +
                          " distances and " + std::to_string(gradients.size()) + " gradients for " +
                          std::to_string(points.size()) + " points");
  }
  batch<true>(points.data(), points.size(), distances.data(), gradients.data());
}

double Esdf::centreBound(const Eigen::Vector3d& point) const {
  if (values_.empty() && !brick_table_) return -INFINITY;
  std::size_t lower[3];
  double low[3];   // offset (voxels) from the lower centre along each axis
  double high[3];  // and from the upper one
  for (int axis = 0; axis < 3; ++axis) {
    const double raw = point[axis] * inverse_resolution_ - shift_[axis];
    if (!std::isfinite(raw)) return -INFINITY;
    lower[axis] = static_cast<std::size_t>(
        static_cast<std::int64_t>(std::min(std::max(0.0, std::floor(raw)), lower_corner_[axis])));
    low[axis] = raw - static_cast<double>(lower[axis]);
    // On a one-voxel axis both "corners" are the one centre.
    high[axis] = unit_step_[axis] != 0 ? low[axis] - 1.0 : low[axis];
  }
  double best = -INFINITY;
  for (int corner = 0; corner < 8; ++corner) {
    std::size_t cell[3];
    double squared = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const bool upper = (corner >> axis) & 1;
      cell[axis] = lower[axis] + (upper ? unit_step_[axis] : 0);
      const double offset = upper ? high[axis] : low[axis];
      squared += offset * offset;
    }
    best = std::max(best, valueAt(cell[0], cell[1], cell[2]) - resolution_ * std::sqrt(squared));
  }
  return best;
}

}  // namespace kinolab
