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

double numberOr(const nlohmann::json& json, const char* key) {
  const auto found = json.find(key);
  return found != json.end() && found->is_number() ? found->get<double>() : NAN;
}

nlohmann::json finite(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
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
  nlohmann::json out;
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
    out = {{"status", toString(result.status)},
           {"message", result.message},
           {"planning_time_ms", result.planning_time_ms},
           {"cost", finite(result.cost)},
           {"distance_to_goal", finite(result.distance_to_goal)},
           {"checker_valid", result.check.valid},
           {"checker_check", result.check.check},
           {"checker_detail", result.check.detail}};
    if (!result.trajectory.empty()) {
      out["duration"] = result.trajectory.duration();
      out["length"] = result.trajectory.length();
      out["jerk_integral"] = finite(result.trajectory.jerkIntegral());
      out["min_clearance"] = finite(result.check.min_clearance);
      out["mean_clearance"] = finite(result.check.mean_clearance);
      if (experiment.store_trajectories) out["trajectory"] = trajectoryCsv(result.trajectory, 0.05);
    }
    if (store_tree) out["tree"] = treeCsv(tree);
    nlohmann::json statistics = nlohmann::json::array();
    for (const auto& [name, value] : result.statistics) {
      statistics.push_back({name, finite(value)});
    }
    out["statistics"] = std::move(statistics);
  } catch (const std::bad_alloc&) {
    out = {{"status", "oom"},
           {"message", "out of memory: the run exceeded its budget of " +
                           std::to_string(variant.budget.memory_mb) + " MB"}};
  } catch (const std::exception& error) {
    out = {{"status", "error"}, {"message", error.what()}};
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
  record.peak_memory_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;
  record.wall_time_ms = (seconds() - worker.started) * 1000.0;
  record.started_at = worker.started_at;

  if (worker.killed_for_time) {
    record.status = "timeout";
    record.message = "killed after " + formatNumber(record.wall_time_ms / 1000.0) +
                     " s: the planner ignored its time budget of " +
                     formatNumber(variant.budget.time) + " s";
    return record;
  }
  if (WIFSIGNALED(wait_status)) {
    record.status = "crash";
    record.message = std::string("the worker died of signal ") +
                     std::to_string(WTERMSIG(wait_status)) + " (" +
                     strsignal(WTERMSIG(wait_status)) + ")";
    return record;
  }
  nlohmann::json out = nlohmann::json::parse(worker.output, nullptr, false);
  if (!WIFEXITED(wait_status) || WEXITSTATUS(wait_status) != 0 || out.is_discarded() ||
      !out.contains("status")) {
    record.status = "crash";
    record.message = "the worker exited with status " +
                     std::to_string(WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1) +
                     " without a result";
    return record;
  }
  record.status = out["status"].get<std::string>();
  record.message = out.value("message", "");
  record.planning_time_ms = numberOr(out, "planning_time_ms");
  record.cost = numberOr(out, "cost");
  record.distance_to_goal = numberOr(out, "distance_to_goal");
  record.duration = numberOr(out, "duration");
  record.length = numberOr(out, "length");
  record.jerk_integral = numberOr(out, "jerk_integral");
  record.min_clearance = numberOr(out, "min_clearance");
  record.mean_clearance = numberOr(out, "mean_clearance");
  record.checker_valid = out.value("checker_valid", false) ? 1 : 0;
  record.checker_check = out.value("checker_check", "");
  record.checker_detail = out.value("checker_detail", "");
  record.trajectory_csv = out.value("trajectory", "");
  record.tree_csv = out.value("tree", "");
  if (out.contains("statistics")) {
    for (const auto& item : out["statistics"]) {
      record.statistics.emplace_back(item[0].get<std::string>(),
                                     item[1].is_number() ? item[1].get<double>() : NAN);
    }
  }
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

bool failed(const std::string& status) { return status != "exact" && status != "approximate"; }

/// Progress on stderr: a bar redrawn in place on a terminal, a line every 10 s or 10 %
/// otherwise.
class Progress {
 public:
  Progress(long long total, long long already)
      : total_(total), done_(already), tty_(isatty(STDERR_FILENO)), begin_(seconds()) {}

  void update(const std::string& status) {
    ++done_;
    ++ran_;
    failed_ += failed(status) ? 1 : 0;
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
      std::snprintf(text, sizeof(text), "\r[%s] %lld/%lld done, %lld failed, %.1f runs/s, %s left ",
                    bar.c_str(), done_, total_, failed_, rate, duration(left).c_str());
    } else {
      std::snprintf(text, sizeof(text), "run: %lld/%lld done, %lld failed, %.1f runs/s, %s left\n",
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
  values["ompl_version"] = kOmplVersion;
  values["ceres_version"] = kCeresVersion;
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
      shardOf(experiment.runs(), options.shard_index, options.shard_count);
  summary.planned = static_cast<long long>(runs.size());
  const std::string shard =
      std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count);

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
                                             {"plugins", join(experiment.plugins, "\n")},
                                             {"last_started_at", utcNow()}};
  if (!store.meta("started_at")) meta["started_at"] = meta["last_started_at"];
  for (const auto& [key, value] : provenance()) meta["provenance." + key] = value;
  store.setMeta(meta);

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
          ++summary.finished;
          ++summary.by_status[record.status];
          progress.update(record.status);
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
