// One frame of a closed-loop flight on the dense forest: the sensor's rays into the ground
// truth, the map's insertion, and the kept planning window with its ESDF updated, at the
// default flight parameters but for the camera's pixel_skip and the map kind. The issue's
// budget: 10 ms for all three at 640 x 480. And the loop's check of a plan against what the
// known map vouches for (issue 56).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>

#include "forest_queries.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/world/trajectory_trace.hpp"

namespace kinolab {
namespace {

std::shared_ptr<const World> denseForest() {
  registerBuiltinPlugins();  // the forest's generator, the sensors and the maps
  static const std::shared_ptr<const World> world = bench::shippedWorld("dense_forest");
  return world;
}

/// The frame's pose: along a diagonal of the forest at 1.5 m, heading along it, at 2 m/s
/// (each frame sees mostly what the last one saw), restarting after 30 m.
Eigen::Vector3d pose(int frame, double rate) {
  const double s = 3.0 + std::fmod(2.0 / M_SQRT2 * frame / rate, 30.0 / M_SQRT2);
  return {s, s, 1.5};
}

/// Args: the camera's pixel_skip (0: the toy camera of the first flights, 32 x 24 at 10 Hz to
/// 5 m, noise-free) and the map kind (0 octomap, 1 probabilistic, 2 probabilistic with
/// exact_range 0: its ray walks' shortcut alone, as before exact_range); otherwise the
/// defaults of `kinolab fly` (flightParameters()).
void BM_FlightFrame(benchmark::State& state) {
  const auto world = denseForest();
  std::vector<ParameterAssignment> assignments;
  const auto set = [&](const std::string& name, const std::string& value) {
    assignments.push_back(ParameterAssignment{name, value, "benchmark", false});
  };
  set("map", state.range(1) == 0 ? "octomap" : "probabilistic");
  if (state.range(1) == 2) set("map.exact_range", "0");
  if (state.range(0) == 0) {
    for (const auto& [name, value] : {std::pair{"width", "32"},
                                      {"height", "24"},
                                      {"pixel_skip", "1"},
                                      {"range", "5"},
                                      {"rate", "10"},
                                      {"fov_horizontal", "90"},
                                      {"fov_vertical", "60"},
                                      {"min_range", "0"},
                                      {"sigma_base", "0"},
                                      {"sigma_quadratic", "0"},
                                      {"dropout", "0"}}) {
      set(std::string("sensor.") + name, value);
    }
  } else {
    set("sensor.pixel_skip", std::to_string(state.range(0)));
  }
  const FlightSetup setup = flightSetup(flightParameters().resolve(assignments, "flight"));
  const Sensor& sensor = *setup.sensor;
  const std::unique_ptr<VehicleMap> known = setup.make_map();
  MapModel model = setup.map;
  // As a flight sets it: the window sees as far as a default planner's body and margin reach.
  model.reach = MotionDefaults::kRobotRadius + setup.settings.planning_margin;
  known->setup(world->bounds(), model);
  VehicleMap& map = *known;
  int frame = 0;
  Rng noise(1);
  const std::vector<Eigen::Vector3d> rays = sensor.rayDirections();  // once, as a flight does
  const RayCaster truth(*world);
  double sense_ms = 0.0;
  double map_ms = 0.0;
  double window_ms = 0.0;
  double worst_ms = 0.0;
  // Frames that built the window anew (its domain moved) apart: their count, their window +
  // ESDF time and the worst frame among the others.
  double rebuilds = 0.0;
  double rebuild_ms = 0.0;
  double worst_kept_ms = 0.0;
  Box last_domain;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const Eigen::Vector3d p = pose(frame++, sensor.frameRate());
    if (!world->isFree(p, 0.25)) continue;
    auto t0 = Clock::now();
    const SensorFrame sensed = senseFrame(truth, sensor, rays, p, M_PI / 4, noise);
    auto t1 = Clock::now();
    map.insert(sensed, sensor.maxRange());
    auto t2 = Clock::now();
    const std::shared_ptr<const World> window = map.window(p);
    auto t3 = Clock::now();
    const double frame_ms = std::chrono::duration<double, std::milli>(t3 - t0).count();
    const double this_window_ms = std::chrono::duration<double, std::milli>(t3 - t2).count();
    sense_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    map_ms += std::chrono::duration<double, std::milli>(t2 - t1).count();
    window_ms += this_window_ms;
    worst_ms = std::max(worst_ms, frame_ms);
    const bool rebuilt =
        window->bounds().min != last_domain.min || window->bounds().max != last_domain.max;
    last_domain = window->bounds();
    if (rebuilt) {
      rebuilds += 1.0;
      rebuild_ms += this_window_ms;
    } else {
      worst_kept_ms = std::max(worst_kept_ms, frame_ms);
    }
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["rays"] = static_cast<double>(sensor.rayDirections().size());
  state.counters["sensor_ms"] = sense_ms / n;
  state.counters["map_ms"] = map_ms / n;
  state.counters["window_esdf_ms"] = window_ms / n;
  state.counters["worst_frame_ms"] = worst_ms;
  state.counters["rebuilds"] = rebuilds;
  state.counters["rebuild_window_ms"] = rebuilds > 0.0 ? rebuild_ms / rebuilds : 0.0;
  state.counters["worst_kept_frame_ms"] = worst_kept_ms;
}
// The same frames for every variant, fewer for the slow ones (the smoke test runs them all).
BENCHMARK(BM_FlightFrame)
    ->ArgNames({"pixel_skip", "probabilistic"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({4, 1})
    ->Args({4, 2})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(300);
BENCHMARK(BM_FlightFrame)
    ->ArgNames({"pixel_skip", "probabilistic"})
    ->Args({4, 0})
    ->Args({2, 1})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(30);

/// The flight's check of a plan before it is committed (commit: seen): sphere tracing of a
/// 3 m rest-to-rest move ahead of the vehicle, at the default planning radius (0.39 m kept),
/// on the distance to the nearest voxel the known map does not vouch for, after 30 default
/// camera frames along the diagonal (the vehicle at the last). What the loop pays for each cut
/// it tries, against the planning window's rebuild (BM_FlightFrame's rebuild_window_ms), which
/// a window with unknown space occupied would need.
void BM_VouchedTrace(benchmark::State& state) {
  const auto world = denseForest();
  const FlightSetup setup = flightSetup(flightParameters().resolve({}, "flight"));
  const std::unique_ptr<VehicleMap> map = setup.make_map();
  map->setup(world->bounds(), setup.map);
  Rng noise(1);
  const std::vector<Eigen::Vector3d> rays = setup.sensor->rayDirections();
  const RayCaster truth(*world);
  Eigen::Vector3d p;
  for (int frame = 0; frame < 30; ++frame) {
    p = pose(frame, setup.sensor->frameRate());
    map->insert(senseFrame(truth, *setup.sensor, rays, p, M_PI / 4, noise),
                setup.sensor->maxRange());
  }
  // 1.5 m accelerating, 1.5 m braking, along the diagonal (the camera's heading).
  const Eigen::Vector3d along = Eigen::Vector3d(1.0, 1.0, 0.0).normalized();
  ChainState start = ChainState::Zero();
  start.col(0) = p;
  const double half = std::sqrt(1.5 / 1.0);
  Trajectory move;
  move.append(TrajectorySegment::primitive(start, along, 2, half));
  start.col(0) = move.evaluate(half);
  start.col(1) = move.evaluate(half, 1);
  move.append(TrajectorySegment::primitive(start, -along, 2, half));
  const auto unvouched = [&](const Eigen::Vector3d& q, double radius) {
    return map->unvouchedDistance(q, radius + 0.2);
  };
  double queries = 0.0;
  double free = 0.0;
  for (auto _ : state) {
    const TraceResult trace = traceTrajectory(unvouched, map->bounds(), move, 0.39, 0.01);
    queries += trace.queries;
    free += trace.free ? 1.0 : 0.0;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["queries"] = queries / n;
  state.counters["free"] = free / n;
}
BENCHMARK(BM_VouchedTrace)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace kinolab
