#pragma once

#include <span>
#include <type_traits>
#include <vector>

namespace kinolab {

/// A copy of a grid's or field's values (VoxelGrid::occupancy(), Esdf::values()) to compare
/// with EXPECT_EQ.
template <typename T>
std::vector<std::remove_const_t<T>> asVector(std::span<T> values) {
  return {values.begin(), values.end()};
}

}  // namespace kinolab
