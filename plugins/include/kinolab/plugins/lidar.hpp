// The built-in `lidar` sensor (plugins/sensors/lidar), a header so that tests and other
// programs can make one directly.
#pragma once

#include <cmath>
#include <optional>
#include <vector>

#include "kinolab/flight/sensor.hpp"

namespace kinolab {

/// A 360-degree lidar: `beams` around, `channels` spread over the vertical field of view.
struct Lidar final : Sensor {
  double range = 5.0;
  double rate = 10.0;
  double fov_vertical = M_PI / 3;  ///< rad (declared in degrees)
  int beams = 360;
  int channels = 16;
  SensorNoise errors;  ///< none by default

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("range", range, 0.1, 100.0, "sensor range, m");
    f.real("rate", rate, 0.5, 100.0, "revolutions per second (the flight loop's step)");
    f.real("fov_vertical", fov_vertical, 1.0, 170.0,
           "vertical field of view of the channels, degrees", M_PI / 180.0);
    f.integer("beams", beams, 1, 100000, "beams per revolution");
    f.integer("channels", channels, 1, 1024, "channels");
    errors.fields(f);
  }

  double maxRange() const override { return range; }
  double frameRate() const override { return rate; }
  std::vector<Eigen::Vector3d> rayDirections() const override;
  std::size_t rayCount() const override;
  SensorNoise noise() const override { return errors; }
};

}  // namespace kinolab
