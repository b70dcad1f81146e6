// Building an Esdf: the dense field of a grid by the exact signed transform (esdf_transform.cpp),
// or adopted values; its geometry. Truncated fields are built in esdf_truncated.cpp, the
// queries are in esdf.hpp, esdf_queries.cpp and esdf_exact_distance.cpp.
#include "kinolab/world/esdf.hpp"

#include <algorithm>
#include <cstdint>
#include <string>

#include "esdf_transform.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/huge_pages.hpp"

namespace kinolab {

void Esdf::setGeometry(const VoxelGrid& grid) {
  dims_ = grid.dims();
  resolution_ = grid.resolution();
  inverse_resolution_ = 1.0 / resolution_;
  origin_ = grid.origin();
  max_distance_ = (dims_.cast<double>() * resolution_).norm();
  strides_[0] = static_cast<std::size_t>(dims_.y()) * dims_.z();
  strides_[1] = static_cast<std::size_t>(dims_.z());
  strides_[2] = 1;
  for (int axis = 0; axis < 3; ++axis) {
    upper_[axis] = dims_[axis] - 1;
    lower_corner_[axis] = std::max(0, dims_[axis] - 2);
    shift_[axis] = origin_[axis] * inverse_resolution_ + 0.5;
    neighbour_step_[axis] = dims_[axis] > 1 ? strides_[axis] : 0;
    unit_step_[axis] = dims_[axis] > 1 ? 1 : 0;
    gradient_scale_[axis] = dims_[axis] > 1 ? inverse_resolution_ : 0.0;
  }
}

Esdf::Esdf(const VoxelGrid& grid, int threads) {
  if (grid.size() == 0) throw InvalidArgument("Esdf: empty grid");
  if (threads < 0) throw InvalidArgument("Esdf: threads must be >= 0");
  esdf_detail::checkTransformable(grid.dims(), "Esdf");
  threads = esdf_detail::buildThreads(grid, threads, kParallelVoxels);
  setGeometry(grid);
  std::vector<float> values = vectorOnHugePages<float>(grid.size());
  const auto cap = static_cast<float>(max_distance_);
  const auto half_voxel = static_cast<float>(0.5 * resolution_);  // the fields are in half voxels
  // Both distances in one signed field (the build holds 9 bytes a voxel: the occupancy, the
  // values and the field): a free voxel's value is its distance to the occupied cubes, an
  // occupied one's minus its distance to the free cubes.
  std::vector<std::int32_t> field;
  esdf_detail::signedSquaredDistances(grid, threads, field);
  esdf_detail::inParallel(grid.size(), threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const float distance =
          esdf_detail::cappedDistance(esdf_detail::decodeSigned(field[i]), half_voxel, cap);
      values[i] = field[i] < 0 ? -distance : distance;
    }
  });
  values_ = std::move(values);
}

Esdf::Esdf(const VoxelGrid& grid, ValueArray<float> values) : values_(std::move(values)) {
  if (values_.size() != grid.size()) {
    throw InvalidArgument("Esdf: " + std::to_string(values_.size()) + " values for " +
                          std::to_string(grid.size()) + " voxels");
  }
  setGeometry(grid);
}

std::span<const float> Esdf::values() const {
  if (brick_table_) {
    throw InvalidArgument(
        "Esdf::values: a truncated (sparse) field has no dense array; query it by voxel");
  }
  return values_.span();
}

}  // namespace kinolab
