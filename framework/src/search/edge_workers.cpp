#include "edge_workers.hpp"

namespace kinolab {
namespace {

/// How often a waiting thread looks again before it sleeps: a few microseconds, about one
/// expansion's evaluation, so that the workers of a running search do not sleep between its
/// expansions, while idle ones (between plans) do not spin.
constexpr int kSpins = 4096;

}  // namespace

EdgeWorkers::EdgeWorkers(int threads) {
  for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { work(); });
}

EdgeWorkers::~EdgeWorkers() {
  stopping_ = true;
  generation_.fetch_add(1, std::memory_order_release);
  generation_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void EdgeWorkers::drain() {
  for (;;) {
    const std::size_t i = next_.fetch_add(1, std::memory_order_relaxed);
    if (i >= count_) return;
    try {
      (*job_)(i);
    } catch (...) {
      if (!failed_.exchange(true)) failure_ = std::current_exception();
    }
  }
}

void EdgeWorkers::work() {
  std::uint64_t seen = 0;
  for (;;) {
    for (int spin = 0; spin < kSpins && generation_.load(std::memory_order_acquire) == seen;
         ++spin) {
    }
    generation_.wait(seen, std::memory_order_acquire);
    seen = generation_.load(std::memory_order_acquire);
    if (stopping_) return;
    drain();
    acknowledged_.fetch_add(1, std::memory_order_acq_rel);
  }
}

void EdgeWorkers::run(std::size_t count, const std::function<void(std::size_t)>& job) {
  if (workers_.empty()) {
    for (std::size_t i = 0; i < count; ++i) job(i);
    return;
  }
  job_ = &job;
  count_ = count;
  next_.store(0, std::memory_order_relaxed);
  acknowledged_.store(0, std::memory_order_relaxed);
  failed_.store(false, std::memory_order_relaxed);
  failure_ = nullptr;
  generation_.fetch_add(1, std::memory_order_release);  // publishes the writes above
  generation_.notify_all();
  drain();
  const int workers = static_cast<int>(workers_.size());
  while (acknowledged_.load(std::memory_order_acquire) < workers) std::this_thread::yield();
  if (failed_.load(std::memory_order_relaxed)) std::rethrow_exception(failure_);
}

}  // namespace kinolab
