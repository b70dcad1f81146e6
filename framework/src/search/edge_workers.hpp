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
/// and returns when every index is done. The indices are handed out by an atomic counter (no
/// lock: each thread takes the next one as it finishes one); a run starts by publishing a new
/// generation the workers spin on for a while (not when there are more threads than cores),
/// then sleep on (std::atomic::wait), and ends
/// when every worker has acknowledged it, so that no worker can still touch a run that is over.
/// The caller learns nothing of which thread ran which index: a job that writes its result to
/// slot i makes the run's outcome the same at every thread count.
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
  void drain();

  const int spins_;  ///< looks before a waiting thread sleeps (workers) or yields (the caller)
  std::vector<std::thread> workers_;
  const std::function<void(std::size_t)>* job_ = nullptr;
  std::size_t count_ = 0;
  std::atomic<std::size_t> next_{0};
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> acknowledged_{0};
  std::atomic<bool> failed_{false};
  std::exception_ptr failure_;
  bool stopping_ = false;
};

}  // namespace kinolab
