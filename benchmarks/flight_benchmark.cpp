// One frame of a closed-loop flight on the dense forest: the sensor's rays into the ground
// truth, the OctoMap insertion (with the map's mirror), and the planning window with its exact
// ESDF, at the default flight parameters. The budget: 10 ms for all three.
#include <benchmark/benchmark.h>

#include <cmath>

#include "kinolab/flight/flight.hpp"
#include "kinolab/world/world_cache.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {
namespace {

std::shared_ptr<const World> denseForest() {
  static const std::shared_ptr<const World> world =
      WorldCache(WorldCache::defaultDirectory())
          .loadOrBuild(WorldSpec::fromFile(KINOLAB_SOURCE_DIR "/configs/worlds/dense_forest.yaml"))
          .world;
  return world;
}

/// Poses 0.2 m apart along a diagonal of the forest at 1.5 m, heading along it: a flight's
/// frames at 2 m/s and 10 Hz, each seeing mostly what the last one saw.
Eigen::Vector3d pose(int frame) {
  const double s = 3.0 + 0.2 * (frame % 150);
  return {s, s, 1.5};
}

void BM_FlightFrame(benchmark::State& state) {
  const auto world = denseForest();
  // The defaults of `kinolab fly` (flightParameters()).
  const FlightSetup setup = flightSetup(flightParameters().resolve({}, "flight"));
  const Sensor& sensor = *setup.sensor;
  const std::unique_ptr<VehicleMap> known = setup.make_map();
  known->setup(world->bounds(), setup.map);
  VehicleMap& map = *known;
  int frame = 0;
  double sense_ms = 0.0;
  double map_ms = 0.0;
  double window_ms = 0.0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const Eigen::Vector3d p = pose(frame++);
    if (!world->isFree(p, 0.25)) continue;
    auto t0 = Clock::now();
    const SensorFrame sensed = senseFrame(world->grid(), sensor, p, M_PI / 4);
    auto t1 = Clock::now();
    map.insert(sensed, sensor.maxRange());
    auto t2 = Clock::now();
    benchmark::DoNotOptimize(map.window(p));
    auto t3 = Clock::now();
    sense_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    map_ms += std::chrono::duration<double, std::milli>(t2 - t1).count();
    window_ms += std::chrono::duration<double, std::milli>(t3 - t2).count();
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["sensor_ms"] = sense_ms / n;
  state.counters["map_ms"] = map_ms / n;
  state.counters["window_esdf_ms"] = window_ms / n;
}
BENCHMARK(BM_FlightFrame)->Unit(benchmark::kMillisecond)->Iterations(150);

}  // namespace
}  // namespace kinolab
