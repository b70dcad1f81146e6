#pragma once

#include <chrono>
#include <cmath>
#include <limits>

namespace kinolab {

/// The budget of one planning call: wall time and iterations (expansions for search-based
/// planners, tree iterations for sampling-based ones). Infinite / max means no limit.
struct Budget {
  double time_limit = INFINITY;  ///< seconds
  long long max_iterations = std::numeric_limits<long long>::max();
};

/// Answers "should the planner stop?" against a budget started at construction. Reading the
/// clock costs tens of nanoseconds, so it is read every `kClockStride` calls.
class StopCondition {
 public:
  explicit StopCondition(const Budget& budget)
      : budget_(budget), start_(std::chrono::steady_clock::now()) {}

  /// True once the time or the iteration budget is spent.
  bool expired(long long iterations) {
    if (iterations >= budget_.max_iterations) return true;
    if (!std::isfinite(budget_.time_limit)) return false;
    if (++calls_ % kClockStride != 0 && !timed_out_) return false;
    timed_out_ = timed_out_ || elapsed() >= budget_.time_limit;
    return timed_out_;
  }
  /// Seconds since the budget started.
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  const Budget& budget() const { return budget_; }

 private:
  static constexpr long long kClockStride = 16;
  Budget budget_;
  std::chrono::steady_clock::time_point start_;
  long long calls_ = 0;
  bool timed_out_ = false;
};

}  // namespace kinolab
