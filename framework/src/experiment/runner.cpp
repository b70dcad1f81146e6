#include "kinolab/experiment/runner.hpp"

#include <signal.h>
#include <sys/wait.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>
#include <utility>

#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/version.hpp"
#include "kinolab/experiment/process_pool.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/experiment/run_work.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/planner/result_csv.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/view/scene.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab {
namespace {

/// The CPU model (the first "model name" of /proc/cpuinfo) and the cores this process may
/// use: what makes clock figures comparable across results.
std::string machineDescription() {
  std::string model = "unknown CPU";
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) {
      const auto start = line.find_first_not_of(" \t", line.find(':') + 1);
      if (line.find(':') != std::string::npos && start != std::string::npos) {
        model = line.substr(start);
      }
      break;
    }
  }
  return model + ", " + std::to_string(std::max(1u, std::thread::hardware_concurrency())) +
         " cores";
}

volatile std::sig_atomic_t g_stop_signal = 0;
void onStopSignal(int signal) { g_stop_signal = signal; }

double seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string duration(double s) {
  if (!std::isfinite(s)) return "--:--";
  const long total = std::lround(s);
  char text[32];
  if (total >= 3600) {
    std::snprintf(text, sizeof(text), "%ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  } else {
    std::snprintf(text, sizeof(text), "%02ld:%02ld", total / 60, total % 60);
  }
  return text;
}

/// The top and side views of a world for the report's figures.
WorldRecord worldRecord(const World& world, const std::string& id) {
  const VoxelGrid& grid = world.grid();
  const Eigen::Vector3i& n = grid.dims();
  WorldRecord record;
  record.world_hash = toHex(world.specHash());
  record.id = id;
  record.resolution = grid.resolution();
  for (int axis = 0; axis < 3; ++axis) {
    record.origin[axis] = grid.origin()[axis];
    record.dims[axis] = n[axis];
  }
  record.top.assign(static_cast<std::size_t>(n.x()) * n.y(), 0);
  record.side.assign(static_cast<std::size_t>(n.x()) * n.z(), 0);
  grid.forEachOccupied([&](const VoxelIndex& v) {
    auto& top = record.top[static_cast<std::size_t>(v.x()) * n.y() + v.y()];
    top = std::max<std::uint16_t>(top, static_cast<std::uint16_t>(v.z() + 1));
    record.side[static_cast<std::size_t>(v.x()) * n.z() + v.z()] = 1;
  });
  const auto [boxes, stride] = view::viewerBoxes(grid);
  record.box_stride = stride;
  for (const view::VoxelBox& box : boxes) {
    record.boxes.insert(record.boxes.end(), box.lo.begin(), box.lo.end());
    record.boxes.insert(record.boxes.end(), box.hi.begin(), box.hi.end());
  }
  return record;
}

/// Progress on stderr: a bar redrawn in place on a terminal, a line every 10 s or 10 %
/// otherwise; nothing when `shown` is false (the caller shows its own).
class ProgressBar {
 public:
  ProgressBar(long long total, long long already, bool shown)
      : total_(total),
        done_(already),
        tty_(isatty(STDERR_FILENO)),
        shown_(shown),
        begin_(seconds()) {}

  void update(bool success) {
    ++done_;
    ++ran_;
    failed_ += success ? 0 : 1;
    if (!shown_) return;
    const double now = seconds();
    const bool milestone = total_ > 0 && done_ * 10 / total_ != (done_ - 1) * 10 / total_;
    if (tty_ || now - last_line_ >= 10.0 || milestone || done_ == total_) {
      print(now);
      last_line_ = now;
    }
  }
  void finish() {
    if (tty_ && shown_) std::fputc('\n', stderr);
  }
  RunnerProgress state() const { return {done_, total_, failed_, seconds() - begin_}; }

 private:
  void print(double now) const {
    const double elapsed = now - begin_;
    const double rate = elapsed > 0.0 ? ran_ / elapsed : 0.0;
    const double left = rate > 0.0 ? (total_ - done_) / rate : INFINITY;
    char text[256];
    if (tty_) {
      const int width = 30;
      const int filled = total_ > 0 ? static_cast<int>(width * done_ / total_) : width;
      const std::string bar = std::string(filled, '#') + std::string(width - filled, '.');
      std::snprintf(text, sizeof(text),
                    "\r[%s] %lld/%lld done, %lld unsolved, %.1f runs/s, %s left ", bar.c_str(),
                    done_, total_, failed_, rate, duration(left).c_str());
    } else {
      std::snprintf(text, sizeof(text),
                    "run: %lld/%lld done, %lld unsolved, %.1f runs/s, %s left\n", done_, total_,
                    failed_, rate, duration(left).c_str());
    }
    std::fputs(text, stderr);
    std::fflush(stderr);
  }

  long long total_;
  long long done_;
  long long ran_ = 0;
  long long failed_ = 0;
  bool tty_;
  bool shown_;
  double begin_;
  double last_line_ = 0.0;
};

}  // namespace

std::map<std::string, std::string> provenance() {
  std::map<std::string, std::string> values;
  values["kinolab_version"] = kVersion;
  const CommandOutput head = runCommand({"git", "-C", kSourceDir, "rev-parse", "HEAD"}, 30);
  const std::string commit = head.status == 0 ? head.output : "";
  values["git_commit"] = commit.empty() ? "unknown" : commit;
  const CommandOutput status =
      runCommand({"git", "-C", kSourceDir, "status", "--porcelain", "--untracked-files=no"}, 30);
  values["git_dirty"] = commit.empty() || status.status != 0 ? "unknown"
                        : status.output.empty()              ? "false"
                                                             : "true";
  values["compiler"] = kCompiler;
  values["compiler_flags"] = kCompilerFlags;
  values["build_type"] = kBuildType;
  values["eigen_version"] = std::to_string(EIGEN_WORLD_VERSION) + "." +
                            std::to_string(EIGEN_MAJOR_VERSION) + "." +
                            std::to_string(EIGEN_MINOR_VERSION);
  for (const auto& [library, version] : pluginLibraryVersions()) {
    values[library + "_version"] = version;
  }
  values["fcl_version"] = kFclVersion;
  values["octomap_version"] = kOctomapVersion;
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) {
      values["cpu"] = line.substr(line.find(':') + 2);
      break;
    }
  }
  values["cpus"] = std::to_string(sysconf(_SC_NPROCESSORS_ONLN));
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  values["host"] = host;
  return values;
}

std::vector<std::string> runStatuses() {
  std::vector<std::string> statuses;
  for (const PlanStatus status :
       {PlanStatus::kExact, PlanStatus::kApproximate, PlanStatus::kNoSolution, PlanStatus::kTimeout,
        PlanStatus::kInvalidStart, PlanStatus::kInvalidGoal, PlanStatus::kInvalidTrajectory,
        PlanStatus::kBackEndFailed}) {
    statuses.emplace_back(toString(status));
  }
  for (const char* runner : {"crash", "killed", "oom", "error"}) statuses.emplace_back(runner);
  return statuses;
}

namespace {

/// Refuses a query whose start or goal no planner of `variant` could plan from or to (outside
/// the map, or in collision for the planner's body), naming the world, the query and why:
/// the run would otherwise end invalid_start or invalid_goal for every such planner. The body
/// is read from the planner's parameters (bodyFrom): no plugin code runs in the runner's own
/// process.
void requireValidQueries(const ExperimentVariant& variant, const ExperimentWorld& world,
                         const World& built, const std::vector<PlanningQuery>& queries) {
  for (const ExperimentPlanner& planner : variant.planners) {
    const Body body = bodyFrom(planner.parameters);
    for (std::size_t q = 0; q < queries.size(); ++q) {
      for (const auto& [what, position] :
           {std::pair<const char*, Eigen::Vector3d>{"start", queries[q].start.col(0)},
            {"goal", queries[q].goal}}) {
        if (const std::string problem = positionProblem(built, position, body); !problem.empty()) {
          throw ConfigError("queries: world '" + world.id + "'" +
                            (variant.label.empty() ? "" : " (sweep " + variant.label + ")") +
                            ", query " + std::to_string(q) + ": the " + what + " " + problem +
                            " (planner '" + planner.id + "', robot_radius " +
                            formatNumber(body.radius) +
                            "); move it, or raise the random queries' clearance");
        }
      }
    }
  }
}

}  // namespace

PlacedInputs placeInputs(
    const Experiment& experiment, const std::vector<const RunSpec*>& runs,
    const std::string& cache_dir,
    const std::function<void(const ExperimentWorld&, const std::shared_ptr<const World>&, bool)>&
        on_world) {
  const WorldCache cache(cache_dir.empty() ? WorldCache::defaultDirectory() : cache_dir);
  PlacedInputs inputs;
  for (const RunSpec* run : runs) {
    const ExperimentVariant& variant = experiment.variants[run->variant];
    const ExperimentWorld& world = variant.worlds[run->world];
    auto& built = inputs.worlds[world.spec.hash()];
    if (!built) {
      const WorldLoad load = cache.loadOrBuild(world.spec);
      built = load.world;
      if (on_world) on_world(world, built, load.source == WorldSource::kCache);
    }
    auto& list = inputs.queries[{run->variant, run->world}];
    if (list.empty()) {
      list = variant.queries.make(*built, world.id, experiment.seed);
      if (!experiment.flights) requireValidQueries(variant, world, *built, list);
    }
  }
  return inputs;
}

std::string describeRuns(const Experiment& experiment, const std::vector<RunSpec>& runs) {
  std::string text = "experiment " + experiment.name + " (" + experiment.source + "), config " +
                     experiment.config_hash + ": " + std::to_string(runs.size()) + " runs\n";
  const ExperimentVariant& first = experiment.variants.front();
  text += "  " + std::to_string(experiment.variants.size()) + " variant(s) x " +
          std::to_string(first.worlds.size()) + " world(s) x " +
          std::to_string(first.queries.count()) + " queries x " +
          std::to_string(first.planners.size()) + " planner(s) x " +
          std::to_string(first.repetitions) + " repetition(s) (first variant)\n\n";
  char line[512];
  std::snprintf(line, sizeof(line), "%-4s %-40s %-12s %7s %-16s %-16s %4s\n", "var", "sweep",
                "world", "queries", "planner", "type", "reps");
  text += line;
  for (std::size_t v = 0; v < experiment.variants.size(); ++v) {
    const ExperimentVariant& variant = experiment.variants[v];
    for (const ExperimentWorld& world : variant.worlds) {
      for (const ExperimentPlanner& planner : variant.planners) {
        std::snprintf(line, sizeof(line), "%-4zu %-40s %-12s %7d %-16s %-16s %4d\n", v,
                      variant.label.empty() ? "-" : variant.label.c_str(), world.id.c_str(),
                      variant.queries.count(), planner.id.c_str(), planner.type.c_str(),
                      variant.repetitions);
        text += line;
      }
    }
  }
  return text;
}

namespace {

/// Checks the shard's database: refuses another experiment (another name or master seed: its
/// cases are others), another shard,
/// another schema and (without --resume) one that holds runs; records the meta, the metric
/// declarations and the runs planned now. With --resume the experiment may have grown or
/// changed (planners, queries, repetitions, sweep values added; parameters changed): the runs
/// it still plans are kept, and those it no longer plans stay in the file, apart.
void prepareStore(ResultsStore& store, const Experiment& experiment, const RunnerOptions& options,
                  const std::vector<RunSpec>& runs) {
  const std::string shard = options.shard.text();
  // Another schema first: its meta may lack what tells experiments apart.
  if (const auto version = store.schemaVersion(); version && *version != kResultsSchemaVersion) {
    throw ConfigError(store.path() + " holds results of schema version " +
                      std::to_string(*version) + "; this kinolab writes version " +
                      std::to_string(kResultsSchemaVersion) +
                      ": run into a new --out directory (kinolab report still reads the old one)");
  }
  store.requireCurrentColumns();  // before the meta below is written
  if (const auto stored = store.meta("config_hash")) {
    const std::string name = store.meta("name").value_or("");
    const std::string seed = store.meta("seed").value_or("");
    if (name != experiment.name || seed != std::to_string(experiment.seed)) {
      throw ConfigError(store.path() + " holds another experiment ('" + name + "', seed " + seed +
                        "; this one is '" + experiment.name + "', seed " +
                        std::to_string(experiment.seed) + "); choose another --out directory");
    }
    if (*stored != experiment.config_hash && !options.resume) {
      throw ConfigError(store.path() + " holds runs of experiment '" + name +
                        "' as configured before (config hash " + *stored + ", now " +
                        experiment.config_hash +
                        "); pass --resume to add the runs it lacks (the runs it no longer plans "
                        "are kept apart, never pooled), or choose another --out directory");
    }
    if (store.meta("shard").value_or(shard) != shard) {
      throw ConfigError(store.path() + " holds shard " + *store.meta("shard") + ", not " + shard);
    }
  }
  if (const long long stored = store.runCount(); stored > 0 && !options.resume) {
    throw ConfigError(store.path() + " already holds " + std::to_string(stored) +
                      " runs; pass --resume to run only the missing ones, or choose another "
                      "--out directory");
  }
  std::map<std::string, std::string> meta = {
      {"name", experiment.name},
      {"seed", std::to_string(experiment.seed)},
      {"source", experiment.source},
      {"config", experiment.canonical},
      {"config_hash", experiment.config_hash},
      {"shard", shard},
      {"runs_planned", std::to_string(runs.size())},
      {"schema_version", std::to_string(kResultsSchemaVersion)},
      {"plugins", join(experiment.plugins, "\n")},
      {"last_started_at", utcNow()},
      {"machine", machineDescription()},
      {"cores", std::to_string(std::max(1u, std::thread::hardware_concurrency()))}};
  if (!store.meta("started_at")) meta["started_at"] = meta["last_started_at"];
  if (!experiment.reproduces_paper.empty()) {
    // What the report shows the paper's tables for: "id=row" lines.
    meta["reproduces.paper"] = experiment.reproduces_paper;
    std::string rows;
    for (const auto& [id, row] : experiment.reproduces_rows) rows += id + "=" + row + "\n";
    meta["reproduces.rows"] = rows;
    if (!experiment.reproduces_setting.empty()) {
      meta["reproduces.setting"] = join(experiment.reproduces_setting, "\n");
    }
  }
  for (const auto& [key, value] : provenance()) meta["provenance." + key] = value;
  store.setMeta(meta);
  std::vector<std::string> hashes;
  for (const RunSpec& run : runs) hashes.push_back(run.hash);
  store.setPlanned(hashes);
  store.declareMetrics("result", "",
                       experiment.flights ? flightRunMetrics().specs() : resultMetrics());
  store.declareMetrics("runner", "", runnerMetrics());
  std::set<std::string> planner_types;
  for (const ExperimentVariant& variant : experiment.variants) {
    for (const ExperimentPlanner& planner : variant.planners) planner_types.insert(planner.type);
  }
  for (const std::string& type : planner_types) {
    // A flight's statistics are the flight's, whatever its planner.
    store.declareMetrics("statistic", type,
                         experiment.flights
                             ? flightStatistics()
                             : declaredStatistics(pluginRegistry<Planner>().info(type)));
  }
}

/// The worlds and queries of the pending runs, built before the first worker so that every
/// worker shares them (copy-on-write), with one collision model per world.
struct SharedInputs : PlacedInputs {
  /// Kept while workers run: their collision models (dense worlds') are built here once and
  /// inherited by every worker (the body radius is irrelevant to the shared model).
  std::vector<TrajectoryChecker> checkers;

  const std::shared_ptr<const World>& world(const Experiment& experiment,
                                            const RunSpec& run) const {
    return worlds.at(experiment.variants[run.variant].worlds[run.world].spec.hash());
  }
  const PlanningQuery& query(const RunSpec& run) const {
    return queries.at({run.variant, run.world}).at(static_cast<std::size_t>(run.query));
  }
};

/// The placed worlds and queries, shared with the workers; each world recorded in the store
/// and given its collision model.
SharedInputs shareInputs(const Experiment& experiment, PlacedInputs placed, ResultsStore& store) {
  SharedInputs inputs;
  static_cast<PlacedInputs&>(inputs) = std::move(placed);
  std::set<std::uint64_t> shared;
  for (const ExperimentVariant& variant : experiment.variants) {
    for (const ExperimentWorld& world : variant.worlds) {
      const auto built = inputs.worlds.find(world.spec.hash());
      if (built == inputs.worlds.end() || !shared.insert(world.spec.hash()).second) continue;
      std::fprintf(stderr, "run: world %s (%s)\n", world.id.c_str(),
                   toHex(world.spec.hash()).c_str());
      store.insertWorld(worldRecord(*built->second, world.id));
      CheckerSettings settings;
      settings.body.radius = 1e3;
      const TrajectoryChecker& checker = inputs.checkers.emplace_back(built->second, settings);
      // A dense world's model is made once, here, and inherited by every worker; a sparse
      // world is made for size (a 400 m city's whole model took 45 s and 1.1 GB), so each
      // worker makes the tiles its trajectories reach.
      if (built->second->grid().layout() == GridLayout::kDense) checker.makeCollisionModel();
    }
  }
  return inputs;
}

/// SIGINT and SIGTERM set g_stop_signal while it lives; the old handlers come back after.
class StopSignals {
 public:
  StopSignals() {
    g_stop_signal = 0;
    struct sigaction action {};
    action.sa_handler = onStopSignal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

/// Starts `run` in a worker tagged `tag`, with its budgets: the time of all its plans (each the
/// planner's time limit: the experiment's budget unless its entry sets its own; a flight has
/// the experiment's, on its replans' clock) plus the grace, and the experiment's memory.
void startRun(ProcessPool& pool, std::size_t tag, const Experiment& experiment, const RunSpec& run,
              const SharedInputs& inputs, double grace_seconds) {
  const ExperimentVariant& variant = experiment.variants[run.variant];
  const double time_limit = experiment.flights
                                ? variant.budget.time
                                : variant.planners[run.planner].timeLimit(variant.budget);
  // Every plan of the timing protocol has the time budget.
  const double plans = experiment.flights ? 1.0 : variant.timing.warmup + variant.timing.repeats;
  // A flight's limit is on its replans' clock (CPU time by default: load does not end it).
  const BudgetClock clock =
      experiment.flights ? readFields<FlightSettings>(variant.flight).clock : BudgetClock::kWall;
  pool.start(tag, plans * time_limit + grace_seconds, clock, variant.budget.memory_mb, [&] {
    return (experiment.flights ? flyRun : planRun)(experiment, run, inputs.world(experiment, run),
                                                   inputs.query(run));
  });
}

}  // namespace

namespace {

/// Refuses workers x a planner's threads beyond the machine's cores: the timing of an
/// oversubscribed run measures the scheduler, not the planner (a search's answer is the same at
/// every thread count, its time is not).
void requireCoresFor(const Experiment& experiment, int jobs) {
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (const ExperimentVariant& variant : experiment.variants) {
    for (const ExperimentPlanner& planner : variant.planners) {
      if (!planner.parameters.has("threads")) continue;
      const long long threads = planner.parameters.integer("threads");
      if (threads * jobs > cores) {
        throw ConfigError(experiment.source + ": planners '" + planner.id +
                          "', key threads: " + std::to_string(threads) + " threads x -j " +
                          std::to_string(jobs) + " workers need " + std::to_string(threads * jobs) +
                          " cores; this " + "machine has " + std::to_string(cores) +
                          ": expected threads x jobs <= " + std::to_string(cores));
      }
    }
  }
}

}  // namespace

RunnerSummary runExperiment(const Experiment& experiment, const RunnerOptions& options) {
  const double begin = seconds();
  requireCoresFor(experiment, options.jobs);
  RunnerSummary summary;
  ProcessPool pool(options.jobs);
  const std::vector<RunSpec> runs = options.shard.select(experiment.runs());
  summary.planned = static_cast<long long>(runs.size());
  // The worlds built and every query placed before the results directory is touched: a
  // query that cannot be placed leaves nothing behind.
  std::vector<const RunSpec*> all;
  for (const RunSpec& run : runs) all.push_back(&run);
  PlacedInputs placed = placeInputs(experiment, all, options.cache_dir);
  // One writer per results directory: a second runner stops here, before any work.
  const DirectoryLock lock(options.out_dir, "kinolab run " + experiment.source);
  ResultsStore store((std::filesystem::path(options.out_dir) / "results.sqlite").string());
  prepareStore(store, experiment, options, runs);
  if (!options.retry.empty()) {
    const long long removed = store.removeRuns(options.retry);
    std::fprintf(stderr, "run: %lld stored runs with status %s will run again\n", removed,
                 join({options.retry.begin(), options.retry.end()}, " or ").c_str());
  }

  const std::set<std::string> done = store.runHashes();
  std::vector<const RunSpec*> pending;
  for (const RunSpec& run : runs) {
    if (done.count(run.hash)) {
      ++summary.skipped;
    } else {
      pending.push_back(&run);
    }
  }
  const SharedInputs inputs = shareInputs(experiment, std::move(placed), store);

  std::fprintf(stderr, "run: %s, shard %s: %zu runs, %lld already done, %zu to run, -j %d\n",
               experiment.name.c_str(), options.shard.text().c_str(), runs.size(), summary.skipped,
               pending.size(), options.jobs);
  const StopSignals signals;
  ProgressBar progress(summary.planned, summary.skipped, !options.on_progress);
  std::size_t next = 0;
  while ((next < pending.size() && !g_stop_signal) || !pool.empty()) {
    while (!g_stop_signal && next < pending.size() && !pool.full()) {
      startRun(pool, next, experiment, *pending[next], inputs, options.grace_seconds);
      ++next;
    }
    if (g_stop_signal) {
      pool.killAll();  // runs in flight are not recorded: the database stays resumable
      break;
    }
    for (const WorkerOutcome& outcome : pool.poll(50)) {
      const RunSpec& run = *pending[outcome.tag];
      const RunRecord record = recordOf(experiment, run, outcome, inputs.query(run));
      store.insert(record);
      const bool success = record.number("success") == 1.0;
      ++summary.finished;
      summary.succeeded += success ? 1 : 0;
      ++summary.by_status[record.text("status")];
      progress.update(success);
      if (options.on_progress) options.on_progress(progress.state());
    }
  }
  progress.finish();
  summary.interrupted = g_stop_signal != 0;
  if (!summary.interrupted) store.setMeta({{"finished_at", utcNow()}});
  summary.seconds = seconds() - begin;
  return summary;
}

}  // namespace kinolab
