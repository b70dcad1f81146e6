#pragma once

#include <sys/resource.h>

#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "kinolab/core/stop_condition.hpp"

namespace kinolab {

/// How a forked worker ended.
struct WorkerOutcome {
  std::size_t tag = 0;           ///< what the caller started it with
  std::string output;            ///< everything the work function returned (or "" when it died)
  int wait_status = 0;           ///< as waitpid() reports it
  rusage usage{};                ///< of the worker process (peak memory: ru_maxrss)
  bool killed_for_time = false;  ///< killed past its deadline by the pool
  BudgetClock clock = BudgetClock::kWall;  ///< the clock its deadline was on
  double wall_ms = 0.0;                    ///< from fork to exit
  std::string started_at;                  ///< UTC, ISO 8601
  double load_average = NAN;               ///< the machine's 1-minute load average when it started
};

/// At most `jobs` forked worker processes at once, each running one function whose return
/// value travels back through a pipe. Each worker gets an address-space limit (what it
/// inherits plus `memory_mb`), dies with the pool's process (PR_SET_PDEATHSIG), ignores
/// SIGINT (the caller decides what Ctrl-C does) and is killed once it has run `time_limit`
/// seconds on its clock: wall seconds since it started, or seconds of its own CPU time (then
/// also after kWaitingFactor times that on the wall clock: a worker that waits instead of
/// working). What a worker shares with the parent is copy-on-write: build expensive read-only
/// data (worlds, collision models) before starting workers. Not thread-safe.
class ProcessPool {
 public:
  explicit ProcessPool(int jobs);
  ~ProcessPool();  ///< kills and reaps every worker still running
  ProcessPool(const ProcessPool&) = delete;
  ProcessPool& operator=(const ProcessPool&) = delete;

  bool full() const { return static_cast<int>(workers_.size()) >= jobs_; }
  bool empty() const { return workers_.empty(); }

  /// A CPU-time limit's wall-clock backstop, as a multiple of the limit: a worker that has
  /// spent this long mostly waiting (asleep, blocked) is killed too.
  static constexpr double kWaitingFactor = 10.0;

  /// Forks a worker that runs `work` and exits; throws Error when it cannot fork.
  void start(std::size_t tag, double time_limit, BudgetClock clock, long long memory_mb,
             const std::function<std::string()>& work);
  /// Waits up to `timeout_ms` for worker output, kills the workers past their deadline and
  /// returns the ones that ended.
  std::vector<WorkerOutcome> poll(int timeout_ms);
  /// Kills and reaps every running worker (their outcomes are dropped).
  void killAll();

 private:
  struct Worker {
    int pid = -1;
    int fd = -1;
    WorkerOutcome outcome;
    double started = 0.0;
    double time_limit = 0.0;
    clockid_t cpu_clock{};  // the worker's CPU-time clock (BudgetClock::kCpu)
  };
  /// Whether `worker` has used up its time limit at wall time `now`.
  static bool pastDeadline(const Worker& worker, double now);

  int jobs_;
  std::vector<Worker> workers_;
};

/// The current UTC time, ISO 8601 ("2026-11-23T11:05:00Z").
std::string utcNow();

}  // namespace kinolab
