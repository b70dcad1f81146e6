// `kinolab plan`: one query, one planner, one world; a JSON summary on the last line.
#include <signal.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/planner/result_csv.hpp"
#include "kinolab/view/scene.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::apps {
namespace {

struct PlanOptions {
  std::string world_path;
  std::string planner;
  std::vector<std::string> assignments;
  std::string start;
  std::string goal;
  std::string out_dir;
  std::uint64_t seed = 1;
  double sample_step = 0.01;
  double time_limit = 60.0;
  double grace = 5.0;
  std::string cache_dir = WorldCache::defaultDirectory();
};

/// The result in a few lines for a reader.
void printSummary(const PlanOptions& options, const World& world, const PlanResult& result) {
  std::printf("planner %s on world %s (%s), seed %llu\n", options.planner.c_str(),
              world.name().c_str(), toHex(world.specHash()).c_str(),
              static_cast<unsigned long long>(options.seed));
  std::printf("  status     %s%s%s\n", std::string(toString(result.status)).c_str(),
              result.message.empty() ? "" : ": ", result.message.c_str());
  std::printf("  time       %.3f ms, cost %s, D %.3f m\n", result.planning_time_ms,
              formatNumber(result.cost).c_str(), result.distance_to_goal);
  if (!result.trajectory.empty()) {
    if (result.check.valid) {
      std::printf("  checker    valid (min clearance %.3f m)\n", result.evaluation.min_clearance);
    } else {
      std::printf("  checker    INVALID, %s check: %s\n", result.check.check.c_str(),
                  result.check.detail.c_str());
    }
  }
}

/// trajectory.csv, tree.csv, result.json and view.html in --out.
void writeOutputs(const PlanOptions& options, const World& world, const Eigen::Vector3d& start,
                  const Eigen::Vector3d& goal, const PlanResult& result, const SearchTree& tree,
                  const nlohmann::ordered_json& json) {
  // trajectory.csv is bounded: a tiny step on a long trajectory would fill memory and disk.
  constexpr double kMaxRows = 1e6;
  if (const double rows = result.trajectory.duration() / options.sample_step; rows > kMaxRows) {
    throw ConfigError("--sample-step " + formatNumber(options.sample_step) + " s gives " +
                      formatNumber(std::ceil(rows)) + " rows of trajectory.csv for a " +
                      formatNumber(result.trajectory.duration()) +
                      " s trajectory; at most 1000000: use a larger step");
  }
  std::filesystem::create_directories(options.out_dir);
  const std::filesystem::path out(options.out_dir);
  writeFileAtomically((out / "trajectory.csv").string(),
                      trajectoryCsv(result.trajectory, options.sample_step));
  writeFileAtomically((out / "tree.csv").string(), treeCsv(tree));
  writeFileAtomically((out / "result.json").string(), json.dump(2) + "\n");
  view::Scene scene(options.planner + " in " + world.name());
  scene.setWorld(world);
  const int index = scene.addQuery(options.start + " to " + options.goal, start, goal);
  scene.addTrajectory(index, options.planner, result.trajectory);
  scene.addTree(index, options.planner, tree);
  const bool viewed = writeView((out / "view.html").string(), scene);
  std::printf("  wrote      %s/{trajectory.csv, tree.csv, result.json%s}\n",
              options.out_dir.c_str(), viewed ? ", view.html" : "");
}

void runPlan(const PlanOptions& options) {
  const Eigen::Vector3d start = parsePoint(options.start, "--start");
  const Eigen::Vector3d goal = parsePoint(options.goal, "--goal");
  ConfiguredPlanner configured =
      configurePlanner(options.planner, parseAssignments(options.assignments, "--set"));
  const WorldSpec spec = WorldSpec::fromFile(options.world_path);
  const WorldLoad load = WorldCache(options.cache_dir).loadOrBuild(spec);
  Planner& planner = *configured.planner;
  planner.setup({load.world, options.seed});

  PlanningQuery query;
  query.start.col(0) = start;
  query.goal = goal;
  SearchTree tree;
  const Budget budget{options.time_limit};
  const double limit = planner.budgetFor(budget).time_limit;
  PlanResult result;
  {
    // A planner stops at its budget; one that does not is stopped `grace` seconds later.
    const std::string message = "planner " + options.planner + " did not return within its " +
                                formatNumber(limit) + " s budget and " +
                                formatNumber(options.grace) + " s of grace: stopped (killed)";
    const Watchdog watchdog(
        limit + options.grace, message,
        killedSummary(options.planner, load.world->name(), options.seed, message));
    result = planner.plan(query, budget, options.out_dir.empty() ? nullptr : &tree);
  }

  printSummary(options, *load.world, result);

  // Every result metric, then every statistic, by their declared names and types, then the
  // progress series as [name, time_ms, value] samples.
  nlohmann::ordered_json json = {
      {"planner", options.planner}, {"world", load.world->name()}, {"seed", options.seed}};
  json.update(nlohmann::ordered_json::parse(toJson(resultValues(result), resultMetrics())));
  json.update(nlohmann::ordered_json::parse(
      toJson(statisticValues(result.statistics), declaredStatistics(*configured.info))));
  if (!result.progress.empty())
    json["progress"] = nlohmann::json::parse(progressToJson(result.progress));

  if (!options.out_dir.empty()) {
    writeOutputs(options, *load.world, start, goal, result, tree, json);
  }
  std::cout << json.dump() << std::endl;
  // A query the planner cannot start from or reach is bad input: the result is printed, and
  // the command fails.
  if (result.status == PlanStatus::kInvalidStart || result.status == PlanStatus::kInvalidGoal) {
    const bool start_problem = result.status == PlanStatus::kInvalidStart;
    throw ConfigError(
        std::string(start_problem ? "--start '" + options.start : "--goal '" + options.goal) +
        "': " + result.message);
  }
}

}  // namespace

bool writeView(const std::string& path, const view::Scene& scene) {
  try {
    view::viewerTemplatePath();
  } catch (const FileError& error) {  // a build without the viewer: the rest is written
    std::fprintf(stderr, "kinolab: no view.html: %s\n", error.what());
    return false;
  }
  view::writeViewHtml(path, scene.json());
  return true;
}

namespace {

/// What the armed watchdog prints, read by the signal handler: set before its timer starts.
std::atomic<const std::string*> armed_alarm_out{nullptr};
std::atomic<const std::string*> armed_alarm_err{nullptr};

/// SIGALRM: the budget and grace are over. Only async-signal-safe calls.
extern "C" void onWatchdogAlarm(int) {
  if (const std::string* out = armed_alarm_out.load()) writeAllTo(STDOUT_FILENO, *out);
  if (const std::string* err = armed_alarm_err.load()) writeAllTo(STDERR_FILENO, *err);
  _exit(1);  // the planner's thread cannot be stopped; nothing of it is written
}

/// Starts (seconds > 0) or stops (0) the process's one real-time interval timer.
void setAlarm(double seconds) {
  itimerval timer{};
  const double whole = std::floor(seconds);
  timer.it_value.tv_sec = static_cast<time_t>(whole);
  timer.it_value.tv_usec = static_cast<suseconds_t>((seconds - whole) * 1e6);
  if (seconds > 0.0 && timer.it_value.tv_sec == 0 && timer.it_value.tv_usec == 0) {
    timer.it_value.tv_usec = 1;  // 0 would disarm
  }
  if (setitimer(ITIMER_REAL, &timer, nullptr) != 0) {
    throw std::runtime_error(std::string("setitimer: ") + std::strerror(errno));
  }
}

}  // namespace

Watchdog::Watchdog(double seconds, std::string message, std::string json) {
  if (!(seconds < 1e9)) return;  // no budget, nothing to enforce
  if (armed_alarm_err.load()) throw std::logic_error("Watchdog: one at a time");
  out_ = json.empty() ? std::string() : json + "\n";
  err_ = "kinolab: error: " + message + "\n";
  std::fflush(nullptr);  // what was printed before comes first; the handler cannot flush
  static const bool installed = [] {
    struct sigaction action {};
    action.sa_handler = onWatchdogAlarm;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    return sigaction(SIGALRM, &action, nullptr) == 0;
  }();
  if (!installed) throw std::runtime_error("sigaction(SIGALRM) failed");
  armed_alarm_out = &out_;
  armed_alarm_err = &err_;
  armed_ = true;
  setAlarm(seconds);
}

Watchdog::~Watchdog() {
  if (!armed_) return;
  setAlarm(0.0);
  armed_alarm_err = nullptr;
  armed_alarm_out = nullptr;
}

std::string killedSummary(const std::string& planner, const std::string& world, std::uint64_t seed,
                          const std::string& message) {
  return nlohmann::ordered_json{{"planner", planner},
                                {"world", world},
                                {"seed", seed},
                                {"status", "killed"},
                                {"message", "timeout: " + message}}
      .dump();
}

Eigen::Vector3d parsePoint(const std::string& text, const std::string& option) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');) items.push_back(item);
  if (!text.empty() && text.back() == ',') items.emplace_back();
  if (items.size() != 3) {
    throw ConfigError(option + " '" + printable(text) + "': expected three numbers x,y,z (metres)");
  }
  Eigen::Vector3d point;
  for (int axis = 0; axis < 3; ++axis) {
    const std::string& item = items[static_cast<std::size_t>(axis)];
    const auto [end, error] = std::from_chars(item.data(), item.data() + item.size(), point[axis]);
    if (error != std::errc() || end != item.data() + item.size() || !std::isfinite(point[axis])) {
      throw ConfigError(option + " '" + printable(text) + "': '" + printable(item) +
                        "' is not a finite number; expected x,y,z (metres)");
    }
  }
  return point;
}

void addPlanCommand(CLI::App& app) {
  auto options = std::make_shared<PlanOptions>();
  CLI::App* command = app.add_subcommand(
      "plan",
      "Plan one query with one planner in one world, check the trajectory independently, and "
      "print a JSON summary as the last line");
  command->add_option("--world", options->world_path, "World spec YAML (configs/worlds/*.yaml)")
      ->required();
  command->add_option("--planner", options->planner, "Planner key (kinolab list planners)")
      ->required();
  command->add_option("--set", options->assignments,
                      "Set a planner parameter, NAME=VALUE (repeatable); sampler parameters as "
                      "sampler.NAME=VALUE");
  command->add_option("--start", options->start, "Start position x,y,z in metres (at rest)")
      ->required();
  command->add_option("--goal", options->goal, "Goal position x,y,z in metres")->required();
  command->add_option("--out", options->out_dir,
                      "Write trajectory.csv, tree.csv (the search tree), result.json and view.html "
                      "(the world, trajectory and tree in 3D) here");
  command->add_option("--seed", options->seed, "Seed of the planner's random streams")
      ->check(unsigned64())
      ->capture_default_str();
  command->add_option("--sample-step", options->sample_step, "Time step of trajectory.csv, s")
      ->check(within(1e-4, 10.0))
      ->capture_default_str();
  command
      ->add_option("--time-limit", options->time_limit,
                   "Time budget of the plan, s (the tighter of this and the planner's own "
                   "time_limit)")
      ->check(within(1e-3, 1e6))
      ->capture_default_str();
  command
      ->add_option("--grace", options->grace,
                   "Seconds past the budget before a planner that has not returned is stopped "
                   "(exit 1, status killed in the JSON line), as `kinolab run` kills its workers")
      ->check(within(0.0, 86400.0))
      ->capture_default_str();
  command->add_option("--cache-dir", options->cache_dir, "World cache directory")
      ->capture_default_str();
  command->footer(
      "trajectory.csv: t (s), position x,y,z (m), velocity (m/s), acceleration (m/s^2) and jerk "
      "(m/s^3), sampled every --sample-step seconds and at the end.\n"
      "tree.csv: one row per point of each search-tree edge (parent to child), with its "
      "evaluation state (partial, full, certified, rejected) and whether the child was closed.\n"
      "Exit status 0 whenever planning ran (whatever its status); 1 for bad input, an invalid "
      "start or goal (outside the map, in collision for the body) included.");
  command->callback([options] { runPlan(*options); });
}

}  // namespace kinolab::apps
