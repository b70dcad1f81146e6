// The built-in `depth_camera` sensor (plugins/sensors/depth_camera), a header so that tests and
// other programs can make one directly.
#pragma once

#include <cmath>
#include <optional>
#include <vector>

#include "kinolab/flight/sensor.hpp"

namespace kinolab {

/// A pinhole depth camera looking along the vehicle's heading. The defaults are a common
/// stereo depth camera's (Intel RealSense D435: 640 x 480 at 30 Hz, 87 x 58 degrees, depth from
/// 0.2 m), used to 10 m with every fourth pixel as real mapping stacks do (Fast-Planner's
/// skip_pixel); range noise as measured for a structured-light depth camera (Nguyen, Izadi and
/// Lovell 2012: 1.2 mm + 1.9 mm/m^2 times range^2), 2 % of pixels lost, a frame 30 +- 10 ms old.
struct DepthCamera final : Sensor {
  double range = 10.0;
  double rate = 30.0;
  double fov_horizontal = 87.0 * M_PI / 180.0;  ///< rad (declared in degrees)
  double fov_vertical = 58.0 * M_PI / 180.0;    ///< rad
  int width = 640;
  int height = 480;
  int pixel_skip = 4;
  SensorNoise errors{.min_range = 0.2,
                     .sigma_base = 0.0012,
                     .sigma_quadratic = 0.0019,
                     .dropout = 0.02,
                     .latency = 0.03,
                     .latency_jitter = 0.01};

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("range", range, 0.1, 100.0, "sensor range, m");
    f.real("rate", rate, 0.5, 100.0, "frames per second (the flight loop's step)");
    f.real("fov_horizontal", fov_horizontal, 1.0, 170.0, "horizontal field of view, degrees",
           M_PI / 180.0);
    f.real("fov_vertical", fov_vertical, 1.0, 170.0, "vertical field of view, degrees",
           M_PI / 180.0);
    f.integer("width", width, 1, 4096, "pixels across");
    f.integer("height", height, 1, 4096, "pixels down");
    f.integer("pixel_skip", pixel_skip, 1, 4096,
              "every this-th pixel across and down is used (1: all of them)");
    errors.fields(f);
  }

  double maxRange() const override { return range; }
  double frameRate() const override { return rate; }
  std::vector<Eigen::Vector3d> rayDirections() const override;
  std::size_t rayCount() const override;
  SensorNoise noise() const override { return errors; }
  std::optional<PixelGrid> pixelGrid() const override;
};

}  // namespace kinolab
