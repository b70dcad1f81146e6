// The `lidar` sensor: beams around, channels up and down.
#include "kinolab/plugins/lidar.hpp"

#include <cmath>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"

namespace kinolab {

std::size_t Lidar::rayCount() const { return static_cast<std::size_t>(beams) * channels; }

std::vector<Eigen::Vector3d> Lidar::rayDirections() const {
  std::vector<Eigen::Vector3d> directions;
  directions.reserve(static_cast<std::size_t>(beams) * channels);
  for (int channel = 0; channel < channels; ++channel) {
    const double elevation = channels > 1 ? fov_vertical * (channel / (channels - 1.0) - 0.5) : 0.0;
    for (int beam = 0; beam < beams; ++beam) {
      const double azimuth = 2.0 * M_PI * beam / beams;
      directions.emplace_back(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    }
  }
  return directions;
}

}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using kinolab::Lidar;
  registrar.add<kinolab::Sensor>("lidar", "a 360-degree lidar: beams around, channels up and down",
                                 kinolab::declareFields<Lidar>(),
                                 [](const kinolab::ParameterSet& p) {
                                   return std::make_unique<Lidar>(kinolab::readFields<Lidar>(p));
                                 });
}
