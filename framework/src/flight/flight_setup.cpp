// A flight's parameters and its setup from them: the sensor (guarded: its own errors name
// it), the vehicle map, the map model, the flight settings and the tracking model.
#include <cmath>
#include <memory>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/flight/flight.hpp"

namespace kinolab {

const ParameterSpecs& flightParameters() {
  static const ParameterSpecs specs =
      ParameterSpecs()
          .plugin("sensor", "sensor", "depth_camera",
                  "the range sensor (kinolab list sensors); set its parameters as sensor.NAME")
          .plugin("vehicle_map", "map", "probabilistic",
                  "the vehicle's map, its sensor model (kinolab list vehicle_maps); set its "
                  "parameters as map.NAME")
          .include(declareFields<MapModel>())
          .include(declareFields<FlightSettings>())
          .include(declareFields<TrackingModel>());
  return specs;
}

namespace {

/// A sensor whose every call is guarded (guardPluginCall): an exception from its code is a
/// PluginCodeError naming it, whatever it threw.
class GuardedSensor final : public Sensor {
 public:
  GuardedSensor(std::unique_ptr<Sensor> sensor, std::string name)
      : sensor_(std::move(sensor)), name_(std::move(name)) {}
  double maxRange() const override {
    return guardPluginCall(name_, "maxRange()", [&] { return sensor_->maxRange(); });
  }
  double frameRate() const override {
    return guardPluginCall(name_, "frameRate()", [&] { return sensor_->frameRate(); });
  }
  std::vector<Eigen::Vector3d> rayDirections() const override {
    return guardPluginCall(name_, "rayDirections()", [&] { return sensor_->rayDirections(); });
  }
  std::size_t rayCount() const override {
    return guardPluginCall(name_, "rayCount()", [&] { return sensor_->rayCount(); });
  }
  SensorNoise noise() const override {
    return guardPluginCall(name_, "noise()", [&] { return sensor_->noise(); });
  }
  std::optional<PixelGrid> pixelGrid() const override {
    return guardPluginCall(name_, "pixelGrid()", [&] { return sensor_->pixelGrid(); });
  }

 private:
  std::unique_ptr<Sensor> sensor_;
  std::string name_;
};

/// How errors from the code of the `kind` plugin a flight parameter `name` chose name it.
template <typename Interface>
std::string chosenPluginName(const ParameterSet& p, const std::string& name) {
  const PluginRegistry<Interface>& registry = pluginRegistry<Interface>();
  return describePlugin(registry.kind(), registry.info(p.text(name)));
}

}  // namespace

FlightSetup flightSetup(const ParameterSet& p) {
  FlightSetup setup;
  setup.sensor = std::make_shared<GuardedSensor>(pluginRegistry<Sensor>().createChosen(p, "sensor"),
                                                 chosenPluginName<Sensor>(p, "sensor"));
  const double range = setup.sensor->maxRange();
  const double rate = setup.sensor->frameRate();
  if (!(std::isfinite(range) && range > 0.0 && std::isfinite(rate) && rate > 0.0)) {
    throw PluginError("sensor '" + p.text("sensor") + "' reports a range of " +
                      formatNumber(range) + " m and a rate of " + formatNumber(rate) +
                      " Hz; both must be finite and positive");
  }
  // A sensor that returns nothing nearer than its range sees nothing at all.
  const double min_range = setup.sensor->noise().min_range;
  if (min_range >= range) {
    throw ConfigError("flight parameter 'sensor.min_range' " + formatNumber(min_range) +
                      " m: sensor '" + p.text("sensor") + "' reaches " + formatNumber(range) +
                      " m, so it would see nothing; expected less than its range");
  }
  setup.map = readFields<MapModel>(p);
  const std::size_t rays = setup.sensor->rayCount();
  const double steps = static_cast<double>(rays) * range / setup.map.resolution;
  if (rays > kMaxRaysPerFrame || steps > kMaxVoxelStepsPerFrame) {
    throw ConfigError(
        "flight: sensor '" + p.text("sensor") + "' casts " + std::to_string(rays) +
        " rays a frame of up to " + formatNumber(range) + " m, up to " + formatNumber(steps) +
        " voxel steps at map_resolution " + formatNumber(setup.map.resolution) + " m: about " +
        formatNumber(std::round(steps * 2.3e-6)) + " ms a frame to simulate; at most " +
        std::to_string(kMaxRaysPerFrame) + " rays and " + formatNumber(kMaxVoxelStepsPerFrame) +
        " steps (raise pixel_skip, lower the resolution, beams, channels or range, or coarsen "
        "map_resolution)");
  }
  // A new map for each flight, made as the parameters say (checked now, once).
  setup.make_map = [p, name = chosenPluginName<VehicleMap>(p, "map")] {
    std::unique_ptr<VehicleMap> map = pluginRegistry<VehicleMap>().createChosen(p, "map");
    map->nameAs(name);
    return map;
  };
  setup.make_map();
  setup.settings = readFields<FlightSettings>(p);
  setup.tracking = readFields<TrackingModel>(p);
  return setup;
}

}  // namespace kinolab
