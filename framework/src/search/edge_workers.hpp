// Private to the search engine: the threads that evaluate a state's edges at once
// (PrimitiveGraph::estimateAll with SearchSettings::threads > 1).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <thread>
#include <vector>

namespace kinolab {

/// A fixed team of threads - 1 workers and the caller that runs a job over indices 0..count-1
/// and returns when every index is done. The indices are handed out by an atomic counter tagged
/// with the run's number (no lock: each thread takes the next one as it finishes one, and a
/// thread still looking at a run that is over takes nothing, its tag being old); a run starts by
/// publishing its number, which the workers spin on for a while (not when there are more threads
/// than cores), then sleep on (std::atomic::wait). The caller waits only for indices being run:
/// a worker that was descheduled or is still asleep is not waited for (the caller runs what is
/// left), so a busy machine costs no time slice a run. The caller learns nothing of which thread
/// ran which index: a job that writes its result to slot i makes the run's outcome the same at
/// every thread count.
class EdgeWorkers {
 public:
  explicit EdgeWorkers(int threads);
  ~EdgeWorkers();
  EdgeWorkers(const EdgeWorkers&) = delete;
  EdgeWorkers& operator=(const EdgeWorkers&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }
  /// Runs job(i) for every i < count; rethrows the first exception a job threw (the other
  /// indices still run).
  void run(std::size_t count, const std::function<void(std::size_t)>& job);

 private:
  void work();
  /// Runs the indices of run `run` that no thread has taken yet.
  void drain(std::uint64_t run);

  const int spins_;  ///< looks before a waiting thread sleeps (workers) or yields (the caller)
  std::vector<std::thread> workers_;
  std::uint64_t runs_ = 0;  ///< the caller's: the number of the last run
  std::atomic<const std::function<void(std::size_t)>*> job_{nullptr};
  std::atomic<std::uint64_t> counted_{0};  ///< the run's number << 32 | its count
  std::atomic<std::uint64_t> next_{0};        ///< the run's number << 32 | the next index
  std::atomic<std::size_t> done_{0};          ///< indices of the run finished
  std::atomic<std::uint64_t> generation_{0};  ///< the run the workers are woken for
  std::atomic<bool> failed_{false};
  std::exception_ptr failure_;
  std::atomic<bool> stopping_{false};
};

}  // namespace kinolab
