#include "edge_workers.hpp"

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

void EdgeWorkers::drain(std::uint64_t run) {
  for (;;) {
    std::uint64_t claim = next_.load(std::memory_order_acquire);
    if ((claim >> 32) != run) return;  // a run that is over (or not yet published)
    // The count of this run, not of one being published: a stale look at a run whose indices
    // are all taken must not take one past its count (as the next run's larger count allowed:
    // the index ran twice, and the caller could return before one was done).
    const std::uint64_t counted = counted_.load(std::memory_order_acquire);
    if ((counted >> 32) != run) return;
    const std::size_t i = claim & 0xffffffffULL;
    if (i >= (counted & 0xffffffffULL)) return;
    // Taken only while the run is this one: its job and count stay until every taken index
    // is done.
    if (!next_.compare_exchange_weak(claim, claim + 1, std::memory_order_acq_rel)) continue;
    try {
      (*job_.load(std::memory_order_relaxed))(i);
    } catch (...) {
      if (!failed_.exchange(true)) failure_ = std::current_exception();
    }
    done_.fetch_add(1, std::memory_order_release);
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
    drain(seen);
  }
}

void EdgeWorkers::run(std::size_t count, const std::function<void(std::size_t)>& job) {
  if (workers_.empty()) {
    for (std::size_t i = 0; i < count; ++i) job(i);
    return;
  }
  const std::uint64_t run = ++runs_ & 0xffffffffULL;
  job_.store(&job, std::memory_order_relaxed);
  counted_.store(run << 32 | count, std::memory_order_release);
  done_.store(0, std::memory_order_relaxed);
  failed_.store(false, std::memory_order_relaxed);
  failure_ = nullptr;
  next_.store(run << 32, std::memory_order_release);  // publishes the writes above
  generation_.store(run, std::memory_order_release);
  generation_.notify_all();
  drain(run);
  // Only indices other threads took are waited for.
  for (int spin = 0; done_.load(std::memory_order_acquire) < count; ++spin) {
    if (spin < spins_) {
      pause();
    } else {
      std::this_thread::yield();  // a worker running an index was descheduled: let it run
    }
  }
  if (failed_.load(std::memory_order_relaxed)) std::rethrow_exception(failure_);
}

}  // namespace kinolab
