#include "kinolab/experiment/process_pool.hpp"

#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <ctime>
#include <fstream>

#include "kinolab/core/error.hpp"
#include "kinolab/core/process.hpp"

namespace kinolab {
namespace {

double seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Limits this process's address space to what it has now plus the budget.
void limitMemory(long long budget_mb) {
  long long pages = 0;
  std::ifstream("/proc/self/statm") >> pages;
  const rlim_t limit = static_cast<rlim_t>(pages * sysconf(_SC_PAGESIZE)) +
                       static_cast<rlim_t>(budget_mb) * 1024 * 1024;
  const rlimit value{limit, limit};
  setrlimit(RLIMIT_AS, &value);
}

/// The worker: run `work`, write its output to `fd`, exit without running the parent's
/// destructors (its database connections and files belong to the parent).
[[noreturn]] void runWorker(int fd, long long memory_mb, const std::function<std::string()>& work) {
  std::signal(SIGINT, SIG_IGN);
  std::signal(SIGTERM, SIG_DFL);
  prctl(PR_SET_PDEATHSIG, SIGKILL);  // a killed parent takes its workers with it
  if (getppid() == 1) _exit(1);      // ... also when it died before the line above
  limitMemory(memory_mb);
  std::string text;
  try {
    text = work();
  } catch (...) {
    _exit(3);  // the work function is meant to turn its failures into output
  }
  writeAllTo(fd, text);
  _exit(0);
}

}  // namespace

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

ProcessPool::ProcessPool(int jobs) : jobs_(jobs) {
  if (jobs < 1) throw ConfigError("-j " + std::to_string(jobs) + ": expected >= 1");
}

ProcessPool::~ProcessPool() { killAll(); }

void ProcessPool::start(std::size_t tag, double time_limit, BudgetClock clock, long long memory_mb,
                        const std::function<std::string()>& work) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw Error("process pool: cannot create a pipe");
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t pid = fork();
  if (pid < 0) {
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    throw Error("process pool: cannot fork a worker");
  }
  if (pid == 0) {
    close(pipe_fds[0]);
    runWorker(pipe_fds[1], memory_mb, work);
  }
  close(pipe_fds[1]);
  Worker worker;
  worker.pid = pid;
  worker.fd = pipe_fds[0];
  worker.outcome.tag = tag;
  worker.outcome.clock = clock;
  if (clock == BudgetClock::kCpu && clock_getcpuclockid(pid, &worker.cpu_clock) != 0) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    close(pipe_fds[0]);
    throw Error("process pool: cannot read a worker's CPU-time clock");
  }
  worker.outcome.started_at = utcNow();
  double load = NAN;
  if (getloadavg(&load, 1) == 1) worker.outcome.load_average = load;
  worker.started = seconds();
  worker.time_limit = time_limit;
  workers_.push_back(std::move(worker));
}

bool ProcessPool::pastDeadline(const Worker& worker, double now) {
  const double wall = now - worker.started;
  if (worker.outcome.clock == BudgetClock::kWall) return wall > worker.time_limit;
  timespec cpu{};
  // The clock is gone once the worker has exited (its pipe closes next): not past it then.
  if (clock_gettime(worker.cpu_clock, &cpu) != 0) return false;
  return toSeconds(cpu) > worker.time_limit || wall > kWaitingFactor * worker.time_limit;
}

std::vector<WorkerOutcome> ProcessPool::poll(int timeout_ms) {
  std::vector<pollfd> fds;
  for (const Worker& worker : workers_) fds.push_back({worker.fd, POLLIN, 0});
  ::poll(fds.data(), fds.size(), timeout_ms);
  const double now = seconds();
  std::vector<WorkerOutcome> finished;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < workers_.size(); ++i) {
    Worker& worker = workers_[i];
    bool closed = false;
    if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) {
      char buffer[65536];
      const ssize_t n = read(worker.fd, buffer, sizeof(buffer));
      if (n > 0) {
        worker.outcome.output.append(buffer, static_cast<std::size_t>(n));
      } else {
        closed = true;
      }
    }
    if (!closed && !worker.outcome.killed_for_time && pastDeadline(worker, now)) {
      worker.outcome.killed_for_time = true;
      kill(worker.pid, SIGKILL);
    }
    if (!closed) {
      if (kept != i) workers_[kept] = std::move(worker);
      ++kept;
      continue;
    }
    close(worker.fd);
    wait4(worker.pid, &worker.outcome.wait_status, 0, &worker.outcome.usage);
    worker.outcome.wall_ms = (seconds() - worker.started) * 1000.0;
    finished.push_back(std::move(worker.outcome));
  }
  workers_.resize(kept);
  return finished;
}

void ProcessPool::killAll() {
  for (Worker& worker : workers_) {
    kill(worker.pid, SIGKILL);
    waitpid(worker.pid, nullptr, 0);
    close(worker.fd);
  }
  workers_.clear();
}

}  // namespace kinolab
