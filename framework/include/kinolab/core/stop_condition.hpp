#pragma once

#include <time.h>

#include <cmath>
#include <limits>

namespace kinolab {

/// Which clock a planning call's time is read on.
enum class BudgetClock {
  /// The wall clock (monotonic): what the call took on this machine, its load included.
  kWall,
  /// The process's CPU time: what the call takes on a core of its own, whatever else the
  /// machine runs (parallel runs, builds, a cluster node's other jobs). A planner that waits
  /// (for a GPU, a lock, a sleep) is not charged for the wait; one with several threads is
  /// charged for every thread's work (a bound on its wall time on free cores).
  kCpu,
};

/// A clock reading in seconds.
inline double toSeconds(const timespec& time) {
  return static_cast<double>(time.tv_sec) + 1e-9 * static_cast<double>(time.tv_nsec);
}

/// Seconds on `clock` since an arbitrary origin.
inline double clockSeconds(BudgetClock clock) {
  timespec now{};
  clock_gettime(clock == BudgetClock::kCpu ? CLOCK_PROCESS_CPUTIME_ID : CLOCK_MONOTONIC, &now);
  return toSeconds(now);
}

/// Milliseconds on a clock since construction: a part of a planning call timed on its
/// budget's clock.
class Stopwatch {
 public:
  explicit Stopwatch(BudgetClock clock) : clock_(clock), begin_(clockSeconds(clock)) {}
  double milliseconds() const { return 1e3 * (clockSeconds(clock_) - begin_); }

 private:
  BudgetClock clock_;
  double begin_;
};

/// The budget of one planning call: time on a clock and iterations (expansions for
/// search-based planners, tree iterations for sampling-based ones). Infinite / max means no
/// limit.
struct Budget {
  double time_limit = INFINITY;  ///< seconds on `clock`
  long long max_iterations = std::numeric_limits<long long>::max();
  BudgetClock clock = BudgetClock::kWall;
};

/// Answers "should the planner stop?" against a budget started at construction; its
/// `elapsed()` is the call's time on the budget's clock (planning time, progress series).
/// Reading the wall clock costs tens of nanoseconds and the CPU clock about 0.2 us, so
/// `expired` reads it every `kClockStride` calls.
class StopCondition {
 public:
  explicit StopCondition(const Budget& budget)
      : budget_(budget), start_(clockSeconds(budget.clock)) {}

  /// True once the time or the iteration budget is spent.
  bool expired(long long iterations) {
    if (iterations >= budget_.max_iterations) return true;
    if (!std::isfinite(budget_.time_limit)) return false;
    if (++calls_ % kClockStride != 0 && !timed_out_) return false;
    timed_out_ = timed_out_ || elapsed() >= budget_.time_limit;
    return timed_out_;
  }
  /// As expired(), reading the clock at every call: for a caller whose calls are far apart,
  /// such as an OMPL planner's termination condition (asked once an iteration, and one
  /// iteration of BIT* may take milliseconds), where a read every kClockStride calls would
  /// add up to kClockStride - 1 iterations to the budget.
  bool expiredNow(long long iterations) {
    if (iterations >= budget_.max_iterations) return true;
    timed_out_ = timed_out_ || elapsed() >= budget_.time_limit;
    return timed_out_;
  }
  /// Seconds on the budget's clock since the budget started.
  double elapsed() const { return clockSeconds(budget_.clock) - start_; }
  const Budget& budget() const { return budget_; }

 private:
  static constexpr long long kClockStride = 16;
  Budget budget_;
  double start_;
  long long calls_ = 0;
  bool timed_out_ = false;
};

}  // namespace kinolab
