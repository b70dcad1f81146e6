// Private to the world library: a field's z-rows as the exact-distance searches read them
// (Esdf::exactDistance(), ExactDistanceRun), and the slack on bounds made from its floats.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace kinolab::esdf_rows {

/// The slack, in voxels, on a bound made from a stored float distance of `voxels` voxels:
/// float rounding of the stored values (about 6e-8 relative) and of the sums made of them,
/// with room to spare; a fixed slack alone falls short beyond about 500 voxels.
inline double floatSlack(double voxels) { return 1e-4 + 4e-7 * std::abs(voxels); }

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

}  // namespace kinolab::esdf_rows
