// The `depth_camera` sensor: a pinhole camera's rays and pixel grid.
#include "kinolab/plugins/depth_camera.hpp"

#include <cmath>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"

namespace kinolab {

std::vector<Eigen::Vector3d> DepthCamera::rayDirections() const {
  // A pinhole: pixel centres on the image plane at x = 1, every pixel_skip-th one.
  std::vector<Eigen::Vector3d> directions;
  const double half_w = std::tan(0.5 * fov_horizontal);
  const double half_h = std::tan(0.5 * fov_vertical);
  directions.reserve(rayCount());
  for (int row = 0; row < height; row += pixel_skip) {
    const double v = half_h * (1.0 - 2.0 * (row + 0.5) / height);
    for (int column = 0; column < width; column += pixel_skip) {
      const double u = half_w * (1.0 - 2.0 * (column + 0.5) / width);
      directions.push_back(Eigen::Vector3d(1.0, u, v).normalized());
    }
  }
  return directions;
}

std::optional<PixelGrid> DepthCamera::pixelGrid() const {
  // rayDirections()'s u = half_w (1 - 2 (skip j + 1/2) / width) for used column j, inverted.
  const double half_w = std::tan(0.5 * fov_horizontal);
  const double half_h = std::tan(0.5 * fov_vertical);
  PixelGrid grid;
  grid.columns = (width + pixel_skip - 1) / pixel_skip;
  grid.rows = (height + pixel_skip - 1) / pixel_skip;
  grid.column_scale = -0.5 * width / (half_w * pixel_skip);
  grid.column_offset = (0.5 * width - 0.5) / pixel_skip;
  grid.row_scale = -0.5 * height / (half_h * pixel_skip);
  grid.row_offset = (0.5 * height - 0.5) / pixel_skip;
  return grid;
}

std::size_t DepthCamera::rayCount() const {
  const auto used = [&](int pixels) {
    return static_cast<std::size_t>((pixels + pixel_skip - 1) / pixel_skip);
  };
  return used(width) * used(height);
}

}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using kinolab::DepthCamera;
  registrar.add<kinolab::Sensor>(
      "depth_camera", "a pinhole depth camera looking along the heading",
      kinolab::declareFields<DepthCamera>(), [](const kinolab::ParameterSet& p) {
        return std::make_unique<DepthCamera>(kinolab::readFields<DepthCamera>(p));
      });
}
