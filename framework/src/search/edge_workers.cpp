#include "edge_workers.hpp"

#include <algorithm>

namespace kinolab {
namespace {

/// How often a waiting worker looks again, pausing between looks, before it sleeps: about a
/// third of a millisecond, longer than a search spends between two expansions, so that the
/// workers of a running search are awake when the next state's edges come (a sleeping one
/// takes tens of microseconds to wake), while idle ones (between plans) do not spin on.
constexpr int kSpins = 1 << 14;

/// A spinning thread's pause: lets the core's other hyper-thread run and saves power.
inline void pause() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

}  // namespace

EdgeWorkers::EdgeWorkers(int threads)
    // More threads than cores: a spinning thread would only keep a descheduled one waiting.
    : spins_(threads <= static_cast<int>(std::thread::hardware_concurrency()) ? kSpins : 0) {
  for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { work(); });
}

EdgeWorkers::~EdgeWorkers() {
  stopping_.store(true, std::memory_order_release);
  generation_.fetch_add(1, std::memory_order_release);
  generation_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

bool EdgeWorkers::claimAndRun(std::uint64_t run, std::size_t i) {
  std::uint64_t free = run << 2;
  if (!states_[i].compare_exchange_strong(free, run << 2 | 1, std::memory_order_acq_rel)) {
    return false;  // claimed by another thread (or left from an older run)
  }
  try {
    (*job_.load(std::memory_order_relaxed))(i);
  } catch (...) {
    if (!failed_.exchange(true)) failure_ = std::current_exception();
  }
  states_[i].store(run << 2 | 2, std::memory_order_release);
  done_.fetch_add(1, std::memory_order_release);
  return true;
}

void EdgeWorkers::drain(std::uint64_t run) {
  draining_.fetch_add(1, std::memory_order_acq_rel);
  drainRun(run);
  draining_.fetch_sub(1, std::memory_order_acq_rel);
}

void EdgeWorkers::drainRun(std::uint64_t run) {
  while (takeOne(run)) {
  }
}

bool EdgeWorkers::takeOne(std::uint64_t run) {
  for (;;) {
    std::uint64_t claim = next_.load(std::memory_order_acquire);
    if ((claim >> 32) != run) return false;  // a run that is over (or not yet published)
    // The count of this run, not of one being published: a stale look at a run whose indices
    // are all taken must not take one past its count (as the next run's larger count allowed).
    const std::uint64_t counted = counted_.load(std::memory_order_acquire);
    if ((counted >> 32) != run) return false;
    const std::size_t i = claim & 0xffffffffULL;
    if (i >= (counted & 0xffffffffULL)) return false;
    // Handed out only while the run is this one: its job stays until every index is done.
    if (!next_.compare_exchange_weak(claim, claim + 1, std::memory_order_acq_rel)) continue;
    claimAndRun(run, i);
    return true;
  }
}

void EdgeWorkers::work() {
  std::uint64_t seen = 0;
  for (;;) {
    for (int spin = 0; spin < spins_ && generation_.load(std::memory_order_acquire) == seen;
         ++spin) {
      pause();
    }
    generation_.wait(seen, std::memory_order_acquire);
    seen = generation_.load(std::memory_order_acquire);
    if (stopping_.load(std::memory_order_acquire)) return;
    drain(next_.load(std::memory_order_acquire) >> 32);
  }
}

void EdgeWorkers::wake() {
  generation_.fetch_add(1, std::memory_order_release);
  generation_.notify_all();
}

void EdgeWorkers::publish(std::size_t count, std::size_t capacity,
                          const std::function<void(std::size_t)>& job) {
  runs_ = (runs_ + 1) & 0xffffffffULL;  // the tag in next_'s upper half
  const std::uint64_t run = runs_;
  if (capacity > allocated_) {
    // Every index of the last run is done, but a worker the counter gave one to may not have
    // looked at its state yet (another thread ran it): wait till none is in a drain.
    while (draining_.load(std::memory_order_acquire) > 0) std::this_thread::yield();
    allocated_ = std::max<std::size_t>(capacity, 2 * allocated_);
    states_ = std::make_unique<std::atomic<std::uint64_t>[]>(allocated_);
  }
  for (std::size_t i = 0; i < capacity; ++i) states_[i].store(run << 2, std::memory_order_relaxed);
  count_ = count;
  capacity_ = capacity;
  job_.store(&job, std::memory_order_relaxed);
  counted_.store(run << 32 | count, std::memory_order_release);
  done_.store(0, std::memory_order_relaxed);
  failed_.store(false, std::memory_order_relaxed);
  failure_ = nullptr;
  next_.store(run << 32, std::memory_order_release);  // publishes the writes above
  wake();
}

void EdgeWorkers::waitAll() {
  // Only indices other threads claimed are waited for.
  for (int spin = 0; done_.load(std::memory_order_acquire) < count_; ++spin) {
    if (spin < spins_) {
      pause();
    } else {
      std::this_thread::yield();  // a worker running an index was descheduled: let it run
    }
  }
}

void EdgeWorkers::run(std::size_t count, const std::function<void(std::size_t)>& job,
                      const std::function<void()>& caller_first) {
  if (workers_.empty()) {
    if (caller_first) caller_first();
    for (std::size_t i = 0; i < count; ++i) job(i);
    return;
  }
  finish();
  publish(count, count, job);
  if (caller_first) {
    try {
      caller_first();
    } catch (...) {
      if (!failed_.exchange(true)) failure_ = std::current_exception();
    }
  }
  collect();
  if (failed_.load(std::memory_order_relaxed)) std::rethrow_exception(failure_);
}

void EdgeWorkers::collect() {
  drain(runs_);
  if (done_.load(std::memory_order_acquire) < count_) {
    // Indices the counter gave a worker that has not claimed them yet (it may be descheduled).
    for (std::size_t i = 0; i < count_; ++i) claimAndRun(runs_, i);
    waitAll();
  }
}

void EdgeWorkers::start(std::size_t count, std::size_t capacity,
                        const std::function<void(std::size_t)>& job) {
  finish();
  publish(count, std::max(count, capacity), job);
  started_ = true;
  if (workers_.empty()) drain(runs_);  // no team: the caller runs it now
}

void EdgeWorkers::extend(std::size_t count) {
  if (count <= count_) return;
  count_ = std::min(count, capacity_);
  counted_.store(runs_ << 32 | count_, std::memory_order_release);
  if (workers_.empty()) {
    drain(runs_);
  } else {
    wake();
  }
}

void EdgeWorkers::waitFor(std::size_t i) {
  if (!claimAndRun(runs_, i)) {
    // Another thread runs it: run the next indices meanwhile, then wait.
    const std::uint64_t finished = runs_ << 2 | 2;
    for (int spin = 0; states_[i].load(std::memory_order_acquire) != finished; ++spin) {
      if (takeOne(runs_)) continue;
      if (spin < spins_) {
        pause();
      } else {
        std::this_thread::yield();
      }
    }
  }
  if (failed_.load(std::memory_order_acquire)) finish();
}

void EdgeWorkers::finish() {
  if (!started_) return;
  started_ = false;
  collect();
  if (failed_.load(std::memory_order_relaxed)) std::rethrow_exception(failure_);
}

}  // namespace kinolab
