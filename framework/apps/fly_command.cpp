// `kinolab fly`: one closed-loop flight through a world seen only through a sensor; a JSON
// summary on the last line.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/planner/metrics.hpp"
#include "kinolab/planner/result_csv.hpp"
#include "kinolab/view/scene.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::apps {
namespace {

struct FlyOptions {
  std::string world_path;
  std::string planner;
  std::vector<std::string> assignments;
  std::vector<std::string> flight;
  std::string start;
  std::string goal;
  std::string out_dir;
  std::uint64_t seed = 1;
  double grace = 5.0;
  std::string cache_dir = WorldCache::defaultDirectory();
};

std::string point(const Eigen::Vector3d& p) {
  return formatNumber(p.x()) + "," + formatNumber(p.y()) + "," + formatNumber(p.z());
}

void writeOutputs(const FlyOptions& options, const World& world, const PlanningQuery& query,
                  const FlightResult& result, double map_resolution,
                  const nlohmann::ordered_json& summary) {
  const std::filesystem::path out(options.out_dir);
  std::filesystem::create_directories(out);
  writeFileAtomically((out / "flown.csv").string(), trajectoryCsv(result.flown, 0.01));
  std::string plans = "replan,t,x,y,z\n";
  for (std::size_t i = 0; i < result.replans.size(); ++i) {
    for (const TrajectorySample& s : result.replans[i].trajectory.sample(0.05)) {
      plans += std::to_string(i) + "," + formatNumber(s.time) + "," + point(s.position) + "\n";
    }
  }
  writeFileAtomically((out / "replans.csv").string(), replansCsv(result));
  writeFileAtomically((out / "plans.csv").string(), plans);
  result.map->write((out / "known_map.bt").string());
  writeFileAtomically((out / "summary.json").string(), summary.dump(2) + "\n");
  view::Scene scene("flight of " + options.planner + " through " + world.name());
  scene.setWorld(world);
  const int index = scene.addQuery(point(query.start.col(0)) + " to " + point(query.goal),
                                   query.start.col(0), query.goal);
  scene.addFlight(index, options.planner, result.flown, result.known_voxels, map_resolution);
  const bool viewed = writeView((out / "view.html").string(), scene);
  std::printf("  wrote      %s/{flown.csv, replans.csv, plans.csv, known_map.bt, summary.json%s}\n",
              options.out_dir.c_str(), viewed ? ", view.html" : "");
}

void runFly(const FlyOptions& options) {
  PlanningQuery query;
  query.start.col(0) = parsePoint(options.start, "--start");
  query.goal = parsePoint(options.goal, "--goal");
  const std::vector<ParameterAssignment> assignments =
      parseAssignments(options.assignments, "--set");
  // Validated before anything runs: the planner, its parameters and the flight's.
  const ConfiguredPlanner configured = configurePlanner(options.planner, assignments);
  FlightSetup setup = flightSetup(
      flightParameters().resolve(parseAssignments(options.flight, "--flight"), "flight"));
  const WorldSpec spec = WorldSpec::fromFile(options.world_path);
  const WorldLoad load = WorldCache(options.cache_dir).loadOrBuild(spec);
  // The 3D view replays the known map growing: a snapshot every half second.
  setup.settings.seed = options.seed;
  // A replan that does not return within its budget and the grace stops the flight.
  setup.guard_replan = [&options, &load](double budget) -> std::shared_ptr<void> {
    const std::string message = "planner " + options.planner +
                                " did not return from a replan within its " + formatNumber(budget) +
                                " s budget and " + formatNumber(options.grace) +
                                " s of grace: flight stopped";
    return std::make_shared<Watchdog>(
        budget + options.grace, message,
        killedSummary(options.planner, load.world->name(), options.seed, message));
  };
  if (!options.out_dir.empty() && setup.settings.snapshot_period <= 0.0) {
    setup.settings.snapshot_period = 0.5;
  }
  const FlightResult result = fly(load.world, *configured.planner, options.seed, query, setup);

  std::printf("flight of %s through world %s, seed %llu\n", options.planner.c_str(),
              load.world->name().c_str(), static_cast<unsigned long long>(options.seed));
  std::printf("  status     %s%s%s\n", result.status.c_str(), result.message.empty() ? "" : ": ",
              result.message.c_str());
  std::printf("  flight     %.2f s, %.2f m, %zu replans, %d frames\n", result.flown.duration(),
              result.flown.length(), result.replans.size(), result.frames);
  if (result.frames > 0) {
    std::printf("  per frame  sensor %.2f ms, map %.2f ms, window and ESDF %.2f ms\n",
                result.time_sense_ms / result.frames, result.time_map_ms / result.frames,
                result.time_window_ms / result.frames);
  }
  nlohmann::ordered_json summary = {
      {"planner", options.planner}, {"world", load.world->name()}, {"seed", options.seed}};
  summary.update(nlohmann::ordered_json::parse(toJson(flightValues(result), flightMetrics())));
  if (!options.out_dir.empty()) {
    writeOutputs(options, *load.world, query, result, setup.map.resolution, summary);
  }
  std::cout << summary.dump() << std::endl;
}

}  // namespace

void addFlyCommand(CLI::App& app) {
  auto options = std::make_shared<FlyOptions>();
  CLI::App* command = app.add_subcommand(
      "fly",
      "Fly one query closed-loop: the vehicle sees the world only through its sensor, maps it "
      "and replans in a window around it in real time, and a quadrotor model tracks the plan; "
      "the flight is judged against the ground truth; a JSON summary as the last line");
  command->add_option("--world", options->world_path, "World spec YAML (the ground truth)")
      ->required();
  command->add_option("--planner", options->planner, "Planner key (kinolab list planners)")
      ->required();
  command->add_option("--set", options->assignments,
                      "Set a planner parameter, NAME=VALUE (repeatable)");
  command->add_option(
      "--flight", options->flight,
      "Set a flight parameter, NAME=VALUE (repeatable): sensor (and its own as "
      "sensor.NAME: sensor.range, sensor.width, ...; kinolab list sensors), "
      "map, map_resolution, window, window_margin, unknown, free_beyond, "
      "replan_period, "
      "replan_budget, latency, timing, clock, horizon, max_time, stuck_time, "
      "goal_tolerance, brake_acceleration, commit, keep_faster, planning_margin, tracking "
      "(kinolab list flight)");
  command->add_option("--start", options->start, "Start position x,y,z in metres (at rest)")
      ->required();
  command->add_option("--goal", options->goal, "Goal position x,y,z in metres")->required();
  command->add_option(
      "--out", options->out_dir,
      "Write flown.csv, replans.csv, plans.csv, known_map.bt, summary.json and view.html (the "
      "flight in 3D, the known map growing)");
  command->add_option("--seed", options->seed, "Seed of the planner's random streams")
      ->check(unsigned64())
      ->capture_default_str();
  command
      ->add_option("--grace", options->grace,
                   "Seconds past a replan's budget before a planner that has not returned stops "
                   "the flight (exit 1, status killed in the JSON line)")
      ->check(within(0.0, 86400.0))
      ->capture_default_str();
  command->add_option("--cache-dir", options->cache_dir, "World cache directory")
      ->capture_default_str();
  command->footer(
      "flown.csv: the flown trajectory as kinolab plan's trajectory.csv, every 0.01 s.\n"
      "replans.csv: per replan its frame time, reason, start, local goal, status, planning "
      "time, D, whether it was taken or kept (set aside for a committed trajectory that gets "
      "there first), the recovery and why not; plans.csv: every plan's positions every 0.05 s.\n"
      "known_map.bt: the vehicle's final OctoMap. Exit status 0 whenever the flight ran.");
  command->callback([options] { runFly(*options); });
}

}  // namespace kinolab::apps
