// The runner's process pool on its own: outputs come back, crashes and overruns become
// outcomes, at most `jobs` workers run at once, memory is limited.
#include "kinolab/experiment/process_pool.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <map>
#include <set>
#include <thread>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/process.hpp"

namespace kinolab {
namespace {

#if defined(__SANITIZE_ADDRESS__)
// AddressSanitizer turns a SIGSEGV into exit status 1 and ignores address-space limits (its
// shadow memory needs terabytes of them): the two tests that provoke those are skipped, and
// reported as skipped, in a sanitizer build.
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif

std::vector<WorkerOutcome> drain(ProcessPool& pool) {
  std::vector<WorkerOutcome> outcomes;
  while (!pool.empty()) {
    for (WorkerOutcome& outcome : pool.poll(20)) outcomes.push_back(std::move(outcome));
  }
  return outcomes;
}

TEST(ProcessPool, OutputsComeBackTaggedAndLargeOnesWhole) {
  ProcessPool pool(2);
  const std::string large(300000, 'x');  // more than a pipe buffer
  pool.start(7, 10.0, BudgetClock::kWall, 256, [] { return std::string("seven"); });
  pool.start(8, 10.0, BudgetClock::kWall, 256, [&] { return large; });
  EXPECT_TRUE(pool.full());
  std::map<std::size_t, std::string> outputs;
  for (const WorkerOutcome& outcome : drain(pool)) {
    EXPECT_TRUE(WIFEXITED(outcome.wait_status) && WEXITSTATUS(outcome.wait_status) == 0);
    EXPECT_FALSE(outcome.killed_for_time);
    EXPECT_GT(outcome.usage.ru_maxrss, 0);
    EXPECT_EQ(outcome.started_at.size(), 20u);  // 2026-11-23T11:05:00Z
    outputs[outcome.tag] = outcome.output;
  }
  EXPECT_EQ(outputs[7], "seven");
  EXPECT_EQ(outputs[8], large);
}

TEST(ProcessPool, ACrashIsASignalAndAnOverrunIsKilled) {
  if (kAddressSanitizer) GTEST_SKIP() << "AddressSanitizer handles SIGSEGV itself";
  ProcessPool pool(2);
  pool.start(1, 10.0, BudgetClock::kWall, 256, []() -> std::string {
    std::raise(SIGSEGV);
    return "unreachable";
  });
  pool.start(2, 0.2, BudgetClock::kWall, 256, [] {
    std::this_thread::sleep_for(std::chrono::seconds(30));
    return std::string("too late");
  });
  const auto begin = std::chrono::steady_clock::now();
  for (const WorkerOutcome& outcome : drain(pool)) {
    ASSERT_TRUE(WIFSIGNALED(outcome.wait_status)) << outcome.tag;
    if (outcome.tag == 1) {
      EXPECT_EQ(WTERMSIG(outcome.wait_status), SIGSEGV);
      EXPECT_FALSE(outcome.killed_for_time);
    } else {
      EXPECT_EQ(WTERMSIG(outcome.wait_status), SIGKILL);
      EXPECT_TRUE(outcome.killed_for_time);
      EXPECT_TRUE(outcome.output.empty());
    }
  }
  // Killed at its deadline, not after its 30 s sleep.
  EXPECT_LT(std::chrono::steady_clock::now() - begin, std::chrono::seconds(20));
}

TEST(ProcessPool, ACpuTimeLimitCountsWorkNotWaiting) {
  ProcessPool pool(2);
  // Waits 1 s and works not at all: within a 0.5 s CPU-time limit however long the wait.
  pool.start(1, 0.5, BudgetClock::kCpu, 256, [] {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    return std::string("slept");
  });
  // Works without end: killed once it has used 0.5 s of CPU time, however loaded the machine.
  pool.start(2, 0.5, BudgetClock::kCpu, 256, [] {
    volatile std::uint64_t spin = 0;
    for (;;) spin = spin + 1;
    return std::string("unreachable");
  });
  for (const WorkerOutcome& outcome : drain(pool)) {
    EXPECT_EQ(outcome.clock, BudgetClock::kCpu);
    if (outcome.tag == 1) {
      EXPECT_FALSE(outcome.killed_for_time);
      EXPECT_EQ(outcome.output, "slept");
    } else {
      EXPECT_TRUE(outcome.killed_for_time);
      // The limit is on the process's CPU clock (user + system time); rusage splits the same
      // time into user and system at tick resolution, so their sum may fall short by a tick.
      const auto seconds = [](const timeval& t) {
        return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
      };
      const double cpu = seconds(outcome.usage.ru_utime) + seconds(outcome.usage.ru_stime);
      EXPECT_GE(cpu, 0.45);
    }
  }
  // A worker that only waits is still killed, at kWaitingFactor times its limit of wall time.
  pool.start(3, 0.1, BudgetClock::kCpu, 256, [] {
    std::this_thread::sleep_for(std::chrono::seconds(60));
    return std::string("too late");
  });
  const auto begin = std::chrono::steady_clock::now();
  const std::vector<WorkerOutcome> waited = drain(pool);
  ASSERT_EQ(waited.size(), 1u);
  EXPECT_TRUE(waited.front().killed_for_time);
  EXPECT_LT(std::chrono::steady_clock::now() - begin, std::chrono::seconds(30));
}

TEST(ProcessPool, NeverRunsMoreThanItsJobsAtOnce) {
  ProcessPool pool(2);
  std::set<std::size_t> finished;
  std::size_t started = 0;
  int most = 0;
  int running = 0;
  while (finished.size() < 6) {
    while (started < 6 && !pool.full()) {
      pool.start(started++, 10.0, BudgetClock::kWall, 256, [] {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        return std::to_string(getpid());
      });
      most = std::max(most, ++running);
    }
    for (const WorkerOutcome& outcome : pool.poll(20)) {
      finished.insert(outcome.tag);
      --running;
    }
  }
  EXPECT_EQ(most, 2);
  EXPECT_THROW(ProcessPool(0), ConfigError);
}

TEST(ProcessPool, AWorkerAllocatingPastItsBudgetFailsInsideItself) {
  if (kAddressSanitizer) GTEST_SKIP() << "AddressSanitizer ignores address-space limits";
  ProcessPool pool(1);
  pool.start(0, 10.0, BudgetClock::kWall, 64, [] {
    try {
      std::vector<std::vector<char>> blocks;
      for (int i = 0; i < 64; ++i) blocks.emplace_back(std::size_t{16} << 20, 'x');
      return std::string("allocated 1 GiB within 64 MB");
    } catch (const std::bad_alloc&) {
      return std::string("bad_alloc");
    }
  });
  const std::vector<WorkerOutcome> outcomes = drain(pool);
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_EQ(outcomes.front().output, "bad_alloc");
}

TEST(ProcessPool, KillAllLeavesNothingRunning) {
  ProcessPool pool(2);
  for (std::size_t i = 0; i < 2; ++i) {
    pool.start(i, 60.0, BudgetClock::kWall, 256, [] {
      std::this_thread::sleep_for(std::chrono::seconds(60));
      return std::string();
    });
  }
  pool.killAll();
  EXPECT_TRUE(pool.empty());
  EXPECT_TRUE(pool.poll(0).empty());
}

}  // namespace
}  // namespace kinolab

namespace kinolab {
namespace {

TEST(WhileDoing, TheInnermostNamedWorkNamesWhatRanOutOfMemoryAndOtherErrorsPass) {
  const auto exhausted = [] {
    throw std::bad_alloc();
    return 0;
  };
  try {
    whileDoing("building the world 'a'",
               [&] { return whileDoing("planning with planner 'b'", exhausted); });
    FAIL() << "no OutOfMemory";
  } catch (const OutOfMemory& error) {
    EXPECT_EQ(std::string(error.what())
                  .rfind("out of memory while planning with planner 'b': "
                         "this process may use ",
                         0),
              0u)
        << error.what();
  }
  EXPECT_THROW(whileDoing("x", [] { throw ConfigError("bad"); }), ConfigError);
  EXPECT_EQ(whileDoing("x", [] { return 7; }), 7);
}

TEST(WhileDoing, TheMemoryLimitIsTheProcesssOwnDataLimitWhenThatIsTheLeast) {
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_DATA, &saved), 0);
  const rlim_t limit = rlim_t{512} << 20;
  if (saved.rlim_max != RLIM_INFINITY && saved.rlim_max < limit) GTEST_SKIP();
  const double before = processMemoryLimit();
  rlimit lowered = saved;
  lowered.rlim_cur = limit;
  ASSERT_EQ(setrlimit(RLIMIT_DATA, &lowered), 0);
  const double during = processMemoryLimit();
  const std::string words = processMayUse();
  ASSERT_EQ(setrlimit(RLIMIT_DATA, &saved), 0);
  EXPECT_EQ(during, std::min(before, static_cast<double>(limit)));
  if (before > static_cast<double>(limit)) {
    EXPECT_EQ(words, "this process may use 512 MiB");
  }
  EXPECT_EQ(processMemoryLimit(), before);
}

}  // namespace
}  // namespace kinolab
