#include "kinolab/experiment/runner.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "kinolab/core/error.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/version.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/planner/result_csv.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab {
namespace {

volatile std::sig_atomic_t g_stop_signal = 0;
void onStopSignal(int signal) { g_stop_signal = signal; }

double seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
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

/// Limits the worker's address space to what it has now plus the budget.
void limitMemory(long long budget_mb) {
  long long pages = 0;
  std::ifstream("/proc/self/statm") >> pages;
  const rlim_t limit = static_cast<rlim_t>(pages * sysconf(_SC_PAGESIZE)) +
                       static_cast<rlim_t>(budget_mb) * 1024 * 1024;
  const rlimit value{limit, limit};
  setrlimit(RLIMIT_AS, &value);
}

/// The worker: plan one run and write its result as JSON to `fd`, then exit without
/// running the parent's destructors (its database connection belongs to the parent).
[[noreturn]] void work(int fd, const Experiment& experiment, const RunSpec& run,
                       const std::shared_ptr<const World>& world, const PlanningQuery& query) {
  std::signal(SIGINT, SIG_IGN);  // the runner decides what happens on Ctrl-C
  std::signal(SIGTERM, SIG_DFL);
  prctl(PR_SET_PDEATHSIG, SIGKILL);  // a killed runner takes its workers with it
  if (getppid() == 1) _exit(1);      // ... also when it died before the line above
  const ExperimentVariant& variant = experiment.variants[run.variant];
  limitMemory(variant.budget.memory_mb);
  nlohmann::json out;  // {"metrics": {...}, "statistics": {...}, "trajectory", "tree"}
  try {
    const ExperimentPlanner& spec = variant.planners[run.planner];
    ConfiguredPlanner configured = configurePlanner(spec.type, spec.assignments);
    configured.planner->setup({world, configured.sampler, run.seed});
    Budget budget{variant.budget.time, std::numeric_limits<long long>::max()};
    if (variant.budget.iterations > 0) budget.max_iterations = variant.budget.iterations;
    SearchTree tree;
    const bool store_tree =
        experiment.store_tree_queries < 0 || run.query < experiment.store_tree_queries;
    const PlanResult result = configured.planner->plan(query, budget, store_tree ? &tree : nullptr);
    out["metrics"] = nlohmann::json::parse(toJson(resultValues(result), resultMetrics()));
    out["statistics"] = nlohmann::json::parse(
        toJson(statisticValues(result.statistics), configured.info->statistics));
    if (!result.trajectory.empty() && experiment.store_trajectories) {
      out["trajectory"] = trajectoryCsv(result.trajectory, 0.05);
    }
    if (store_tree) out["tree"] = treeCsv(tree);
  } catch (const std::bad_alloc&) {
    out = {{"metrics",
            {{"status", "oom"},
             {"message", "out of memory: the run exceeded its budget of " +
                             std::to_string(variant.budget.memory_mb) + " MB"}}}};
  } catch (const std::exception& error) {
    out = {{"metrics", {{"status", "error"}, {"message", error.what()}}}};
  }
  const std::string text = out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = write(fd, text.data() + written, text.size() - written);
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  _exit(0);
}

struct Worker {
  pid_t pid = -1;
  int fd = -1;
  std::string output;
  const RunSpec* run = nullptr;
  double started = 0.0;
  double deadline = 0.0;
  bool killed_for_time = false;
  std::string started_at;
};

/// The record of a finished worker, from its output and how it ended.
RunRecord recordOf(const Experiment& experiment, const Worker& worker, int wait_status,
                   const rusage& usage, const PlanningQuery& query) {
  const RunSpec& run = *worker.run;
  const ExperimentVariant& variant = experiment.variants[run.variant];
  const ExperimentWorld& world = variant.worlds[run.world];
  const ExperimentPlanner& planner = variant.planners[run.planner];
  RunRecord record;
  record.run_hash = run.hash;
  record.variant = static_cast<int>(run.variant);
  record.sweep = variant.label;
  record.world = world.id;
  record.world_hash = toHex(world.spec.hash());
  record.query = run.query;
  record.planner = planner.id;
  record.planner_type = planner.type;
  record.sampler = planner.sampler;
  record.repetition = run.repetition;
  record.seed = toHex(run.seed);
  for (int axis = 0; axis < 3; ++axis) {
    record.start[axis] = query.start(axis, 0);
    record.goal[axis] = query.goal[axis];
  }
  const double wall_time_ms = (seconds() - worker.started) * 1000.0;
  const auto finish = [&](std::string status, std::string message) {
    record.metrics.insert(record.metrics.begin(), {{"status", std::move(status)},
                                                   {"message", std::move(message)},
                                                   {"success", 0.0}});
  };
  record.metrics = {{"peak_memory_mb", static_cast<double>(usage.ru_maxrss) / 1024.0},
                    {"wall_time_ms", wall_time_ms},
                    {"started_at", worker.started_at}};

  if (worker.killed_for_time) {
    finish("killed", "killed after " + formatNumber(wall_time_ms / 1000.0) +
                         " s: the planner ignored its time budget of " +
                         formatNumber(variant.budget.time) + " s");
    return record;
  }
  if (WIFSIGNALED(wait_status)) {
    finish("crash", std::string("the worker died of signal ") +
                        std::to_string(WTERMSIG(wait_status)) + " (" +
                        strsignal(WTERMSIG(wait_status)) + ")");
    return record;
  }
  const nlohmann::json out = nlohmann::json::parse(worker.output, nullptr, false);
  if (!WIFEXITED(wait_status) || WEXITSTATUS(wait_status) != 0 || out.is_discarded() ||
      !out.contains("metrics") || !out["metrics"].contains("status")) {
    finish("crash", "the worker exited with status " +
                        std::to_string(WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1) +
                        " without a result");
    return record;
  }
  MetricValues metrics = metricValuesFromJson(out["metrics"].dump());
  record.metrics.insert(record.metrics.begin(), metrics.begin(), metrics.end());
  if (out.contains("statistics")) record.statistics = metricValuesFromJson(out["statistics"].dump());
  record.trajectory_csv = out.value("trajectory", "");
  record.tree_csv = out.value("tree", "");
  return record;
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
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      for (int z = 0; z < n.z(); ++z) {
        if (!grid.occupied(grid.index(x, y, z))) continue;
        auto& top = record.top[static_cast<std::size_t>(x) * n.y() + y];
        top = std::max<std::uint16_t>(top, static_cast<std::uint16_t>(z + 1));
        record.side[static_cast<std::size_t>(x) * n.z() + z] = 1;
      }
    }
  }
  return record;
}

/// Progress on stderr: a bar redrawn in place on a terminal, a line every 10 s or 10 %
/// otherwise.
class Progress {
 public:
  Progress(long long total, long long already)
      : total_(total), done_(already), tty_(isatty(STDERR_FILENO)), begin_(seconds()) {}

  void update(bool success) {
    ++done_;
    ++ran_;
    failed_ += success ? 0 : 1;
    const double now = seconds();
    const bool milestone = total_ > 0 && done_ * 10 / total_ != (done_ - 1) * 10 / total_;
    if (tty_ || now - last_line_ >= 10.0 || milestone || done_ == total_) {
      print(now);
      last_line_ = now;
    }
  }
  void finish() {
    if (tty_) std::fputc('\n', stderr);
  }

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
      std::snprintf(text, sizeof(text), "\r[%s] %lld/%lld done, %lld unsolved, %.1f runs/s, %s left ",
                    bar.c_str(), done_, total_, failed_, rate, duration(left).c_str());
    } else {
      std::snprintf(text, sizeof(text), "run: %lld/%lld done, %lld unsolved, %.1f runs/s, %s left\n",
                    done_, total_, failed_, rate, duration(left).c_str());
    }
    std::fputs(text, stderr);
    std::fflush(stderr);
  }

  long long total_;
  long long done_;
  long long ran_ = 0;
  long long failed_ = 0;
  bool tty_;
  double begin_;
  double last_line_ = 0.0;
};

}  // namespace

std::map<std::string, std::string> provenance() {
  std::map<std::string, std::string> values;
  values["kinolab_version"] = kVersion;
  const std::string git = std::string("git -C '") + kSourceDir + "' ";
  const CommandOutput head = runCommand(git + "rev-parse HEAD");
  const std::string commit = head.status == 0 ? head.output : "";
  values["git_commit"] = commit.empty() ? "unknown" : commit;
  values["git_dirty"] =
      commit.empty()
          ? "unknown"
          : (runCommand(git + "status --porcelain --untracked-files=no").output.empty() ? "false"
                                                                                        : "true");
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

RunnerSummary runExperiment(const Experiment& experiment, const RunnerOptions& options) {
  if (options.jobs < 1) throw ConfigError("-j " + std::to_string(options.jobs) + ": expected >= 1");
  const double begin = seconds();
  RunnerSummary summary;
  const std::vector<RunSpec> runs =
      options.shard.select(experiment.runs());
  summary.planned = static_cast<long long>(runs.size());
  const std::string shard = options.shard.text();

  std::filesystem::create_directories(options.out_dir);
  ResultsStore store((std::filesystem::path(options.out_dir) / "results.sqlite").string());
  if (const auto stored = store.meta("config_hash")) {
    if (*stored != experiment.config_hash) {
      throw ConfigError(store.path() + " holds another experiment (config hash " + *stored +
                        ", this one is " + experiment.config_hash +
                        "); choose another --out directory");
    }
    if (store.meta("shard").value_or(shard) != shard) {
      throw ConfigError(store.path() + " holds shard " + *store.meta("shard") + ", not " + shard);
    }
  }
  if (const auto version = store.schemaVersion(); version && *version != kResultsSchemaVersion) {
    throw ConfigError(store.path() + " holds results of schema version " +
                      std::to_string(*version) + "; this kinolab writes version " +
                      std::to_string(kResultsSchemaVersion) +
                      ": run into a new --out directory (kinolab report still reads the old one)");
  }
  const std::set<std::string> done = store.runHashes();
  if (!done.empty() && !options.resume) {
    throw ConfigError(store.path() + " already holds " + std::to_string(done.size()) +
                      " runs; pass --resume to run only the missing ones, or choose another "
                      "--out directory");
  }
  std::map<std::string, std::string> meta = {{"name", experiment.name},
                                             {"source", experiment.source},
                                             {"config", experiment.canonical},
                                             {"config_hash", experiment.config_hash},
                                             {"shard", shard},
                                             {"runs_planned", std::to_string(runs.size())},
                                             {"schema_version",
                                              std::to_string(kResultsSchemaVersion)},
                                             {"plugins", join(experiment.plugins, "\n")},
                                             {"last_started_at", utcNow()}};
  if (!store.meta("started_at")) meta["started_at"] = meta["last_started_at"];
  if (!experiment.reproduces_paper.empty()) {
    // What the report shows the paper's tables for: "id=row" lines.
    meta["reproduces.paper"] = experiment.reproduces_paper;
    std::string rows;
    for (const auto& [id, row] : experiment.reproduces_rows) rows += id + "=" + row + "\n";
    meta["reproduces.rows"] = rows;
  }
  for (const auto& [key, value] : provenance()) meta["provenance." + key] = value;
  store.setMeta(meta);
  store.declareMetrics("result", "", resultMetrics());
  store.declareMetrics("runner", "", runnerMetrics());
  std::set<std::string> planner_types;
  for (const ExperimentVariant& variant : experiment.variants) {
    for (const ExperimentPlanner& planner : variant.planners) planner_types.insert(planner.type);
  }
  for (const std::string& type : planner_types) {
    MetricSpecs statistics = commonStatistics();
    statistics.include(pluginRegistry<Planner>().info(type).statistics);
    store.declareMetrics("statistic", type, statistics);
  }

  std::vector<const RunSpec*> pending;
  for (const RunSpec& run : runs) {
    if (done.count(run.hash)) {
      ++summary.skipped;
    } else {
      pending.push_back(&run);
    }
  }

  // Worlds and queries, built before the first worker so that every worker shares them.
  const WorldCache cache(options.cache_dir.empty() ? WorldCache::defaultDirectory()
                                                   : options.cache_dir);
  std::map<std::uint64_t, std::shared_ptr<const World>> worlds;
  // A checker per world, kept while workers run: their collision models are built here once
  // and inherited by every worker (the body radius is irrelevant to the shared model).
  std::vector<TrajectoryChecker> shared_checkers;
  std::map<std::pair<std::size_t, std::size_t>, std::vector<PlanningQuery>> queries;
  for (const RunSpec* run : pending) {
    const ExperimentVariant& variant = experiment.variants[run->variant];
    const ExperimentWorld& world = variant.worlds[run->world];
    auto& built = worlds[world.spec.hash()];
    if (!built) {
      std::fprintf(stderr, "run: world %s (%s)\n", world.id.c_str(),
                   toHex(world.spec.hash()).c_str());
      built = cache.loadOrBuild(world.spec).world;
      store.insertWorld(worldRecord(*built, world.id));
      CheckerSettings settings;
      settings.robot_radius = 1e3;
      shared_checkers.emplace_back(built, settings);
    }
    auto& list = queries[{run->variant, run->world}];
    if (list.empty()) list = variant.queries.make(*built, world.id, experiment.seed);
  }

  std::fprintf(stderr, "run: %s, shard %s: %zu runs, %lld already done, %zu to run, -j %d\n",
               experiment.name.c_str(), shard.c_str(), runs.size(), summary.skipped, pending.size(),
               options.jobs);
  g_stop_signal = 0;
  struct sigaction action {};
  action.sa_handler = onStopSignal;
  sigemptyset(&action.sa_mask);
  struct sigaction old_int {
  }, old_term{};
  sigaction(SIGINT, &action, &old_int);
  sigaction(SIGTERM, &action, &old_term);

  Progress progress(summary.planned, summary.skipped);
  std::deque<const RunSpec*> queue(pending.begin(), pending.end());
  std::vector<Worker> workers;
  const auto queryOf = [&](const RunSpec& run) -> const PlanningQuery& {
    return queries.at({run.variant, run.world}).at(static_cast<std::size_t>(run.query));
  };
  try {
    while ((!queue.empty() && !g_stop_signal) || !workers.empty()) {
      while (!g_stop_signal && !queue.empty() && static_cast<int>(workers.size()) < options.jobs) {
        const RunSpec& run = *queue.front();
        queue.pop_front();
        int pipe_fds[2];
        if (pipe(pipe_fds) != 0) throw Error("run: cannot create a pipe");
        const auto& world =
            worlds.at(experiment.variants[run.variant].worlds[run.world].spec.hash());
        std::fflush(nullptr);
        const pid_t pid = fork();
        if (pid < 0) throw Error("run: cannot fork a worker");
        if (pid == 0) {
          close(pipe_fds[0]);
          work(pipe_fds[1], experiment, run, world, queryOf(run));
        }
        close(pipe_fds[1]);
        Worker worker;
        worker.pid = pid;
        worker.fd = pipe_fds[0];
        worker.run = &run;
        worker.started = seconds();
        const ExperimentBudget& budget = experiment.variants[run.variant].budget;
        worker.deadline = worker.started + budget.time + options.grace_seconds;
        worker.started_at = utcNow();
        workers.push_back(std::move(worker));
      }
      if (g_stop_signal) {
        for (Worker& worker : workers) kill(worker.pid, SIGKILL);
      }

      std::vector<pollfd> fds;
      for (const Worker& worker : workers) fds.push_back({worker.fd, POLLIN, 0});
      poll(fds.data(), fds.size(), 50);
      const double now = seconds();
      for (std::size_t i = 0; i < workers.size();) {
        Worker& worker = workers[i];
        bool closed = false;
        if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) {
          char buffer[65536];
          const ssize_t n = read(worker.fd, buffer, sizeof(buffer));
          if (n > 0) {
            worker.output.append(buffer, static_cast<std::size_t>(n));
          } else {
            closed = true;
          }
        }
        if (!closed && now > worker.deadline && !worker.killed_for_time) {
          worker.killed_for_time = true;
          kill(worker.pid, SIGKILL);
        }
        if (!closed) {
          ++i;
          continue;
        }
        close(worker.fd);
        int status = 0;
        rusage usage{};
        wait4(worker.pid, &status, 0, &usage);
        if (!g_stop_signal) {
          const RunRecord record =
              recordOf(experiment, worker, status, usage, queryOf(*worker.run));
          store.insert(record);
          const bool success = record.number("success") == 1.0;
          ++summary.finished;
          summary.succeeded += success ? 1 : 0;
          ++summary.by_status[record.text("status")];
          progress.update(success);
        }
        fds.erase(fds.begin() + static_cast<std::ptrdiff_t>(i));
        workers.erase(workers.begin() + static_cast<std::ptrdiff_t>(i));
      }
    }
  } catch (...) {
    for (Worker& worker : workers) {
      kill(worker.pid, SIGKILL);
      waitpid(worker.pid, nullptr, 0);
      close(worker.fd);
    }
    sigaction(SIGINT, &old_int, nullptr);
    sigaction(SIGTERM, &old_term, nullptr);
    throw;
  }
  progress.finish();
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  summary.interrupted = g_stop_signal != 0;
  if (!summary.interrupted) store.setMeta({{"finished_at", utcNow()}});
  summary.seconds = seconds() - begin;
  return summary;
}

}  // namespace kinolab
