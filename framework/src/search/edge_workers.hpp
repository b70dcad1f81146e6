// Private to the search engine: the threads that evaluate a state's edges at once
// (PrimitiveGraph::estimateAll with SearchSettings::threads > 1) and a lazy search's edges
// ahead of their pops (PrimitiveGraph::startAhead).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

namespace kinolab {

/// A fixed team of threads - 1 workers and the caller that runs a job over indices 0..count-1.
/// The indices are handed out in order by an atomic counter tagged with the run's number (no
/// lock: each thread takes the next one as it finishes one, and a thread still looking at a
/// run that is over takes nothing, its tag being old); each index is then claimed once, by
/// whichever thread claims it first (the caller may claim one out of order). New work wakes
/// the workers, which spin on it for a while (not when there are more threads than cores),
/// then sleep (std::atomic::wait). The caller learns nothing of which thread ran which index:
/// a job that writes its result to slot i makes the run's outcome the same at every thread
/// count.
///
/// A run is either joined at once (run(): the caller takes indices too and returns when every
/// index is done) or left to the workers (start(): the caller goes on with its own work, may
/// add indices, extend(), and later waits for one index, waitFor(), or for all, finish()). The
/// caller waits only for indices being run: a worker that was descheduled or is still asleep
/// is not waited for (the caller runs what is left), so a busy machine costs no time slice a
/// run. One run at a time.
class EdgeWorkers {
 public:
  explicit EdgeWorkers(int threads);
  ~EdgeWorkers();
  EdgeWorkers(const EdgeWorkers&) = delete;
  EdgeWorkers& operator=(const EdgeWorkers&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }
  /// Runs job(i) for every i < count; rethrows the first exception a job threw (the other
  /// indices still run). `caller_first`, if given, runs on the calling thread once the run is
  /// published, before that thread takes indices: work of the caller's own (that need not be
  /// safe to run beside itself) done while the other threads run the job.
  void run(std::size_t count, const std::function<void(std::size_t)>& job,
           const std::function<void()>& caller_first = nullptr);

  /// Publishes a run of job(i), i < count, for the workers, with room for `capacity` indices
  /// (extend()), and returns at once. `job` must stay alive, and what it reads of an index
  /// unchanged, until finish().
  void start(std::size_t count, std::size_t capacity, const std::function<void(std::size_t)>& job);
  /// Adds the indices up to `count` (at most the run's capacity) to the started run: what the
  /// job reads of them must be written before.
  void extend(std::size_t count);
  /// Whether a started run is not yet finished (finish()).
  bool started() const { return started_; }
  /// The started run's indices and room for them.
  std::size_t count() const { return count_; }
  std::size_t capacity() const { return capacity_; }
  /// The started run's indices not yet done (without waiting).
  std::size_t outstanding() const { return count_ - done_.load(std::memory_order_acquire); }
  /// Returns when index i of the started run is done: runs it here if no thread has claimed
  /// it, else runs the next indices while the thread that did runs it. When a job has thrown by
  /// then (index i's own included), ends the run (finish()) and rethrows the first exception.
  void waitFor(std::size_t i);
  /// Returns when every index of the started run is done (taking the ones left), and ends it;
  /// rethrows the first exception a job threw. Nothing when no run is started.
  void finish();

 private:
  void work();
  /// Runs the indices of run `run` that the counter has not handed out yet (drainRun()),
  /// counted in draining_ meanwhile.
  void drain(std::uint64_t run);
  void drainRun(std::uint64_t run);
  /// Takes the next index of run `run` from the counter and runs it unless claimed: false
  /// when the counter has none.
  bool takeOne(std::uint64_t run);
  /// Runs every index of the caller's run that no thread has claimed and waits for the rest.
  void collect();
  /// Runs index i of run `run` unless a thread claimed it: true when this thread ran it.
  bool claimAndRun(std::uint64_t run, std::size_t i);
  void publish(std::size_t count, std::size_t capacity,
               const std::function<void(std::size_t)>& job);
  /// New work for the workers.
  void wake();
  /// Waits for every index claimed (a worker running one that was descheduled is let run).
  void waitAll();

  const int spins_;  ///< looks before a waiting thread sleeps (workers) or yields (the caller)
  std::vector<std::thread> workers_;
  std::uint64_t runs_ = 0;     ///< the caller's: the number of the last run (32 bits)
  bool started_ = false;       ///< the caller's: a run of start() not yet finished
  std::size_t count_ = 0;      ///< the caller's: the last run's count
  std::size_t capacity_ = 0;   ///< the caller's: the last run's room
  std::size_t allocated_ = 0;  ///< the caller's: the size of states_
  std::atomic<const std::function<void(std::size_t)>*> job_{nullptr};
  std::atomic<std::uint64_t> counted_{0};  ///< the run's number << 32 | its count
  std::atomic<std::uint64_t> next_{0};     ///< the run's number << 32 | the next index
  std::atomic<std::size_t> done_{0};       ///< indices of the run finished
  /// Per index: the run's number << 2 | 0 free, 1 claimed, 2 done (the job's writes
  /// published); the run's number makes a claim meant for an older run fail.
  std::unique_ptr<std::atomic<std::uint64_t>[]> states_;
  std::atomic<std::uint64_t> generation_{0};  ///< bumped for new work
  std::atomic<int> draining_{0};              ///< threads in drain()
  std::atomic<bool> failed_{false};
  std::exception_ptr failure_;
  std::atomic<bool> stopping_{false};
};

}  // namespace kinolab
