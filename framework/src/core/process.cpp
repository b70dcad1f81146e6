#include "kinolab/core/process.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <limits>

#include "kinolab/core/error.hpp"

namespace kinolab {

CommandOutput runCommand(const std::vector<std::string>& arguments, int timeout_seconds) {
  if (arguments.empty()) throw InvalidArgument("runCommand: no program");
  std::vector<char*> argv;
  for (const std::string& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
  argv.push_back(nullptr);
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw Error("cannot run " + arguments.front() + ": no pipe");
  const pid_t pid = fork();
  if (pid < 0) {
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    throw Error("cannot run " + arguments.front() + ": fork failed");
  }
  if (pid == 0) {
    dup2(pipe_fds[1], STDOUT_FILENO);
    dup2(pipe_fds[1], STDERR_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  close(pipe_fds[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_seconds);
  CommandOutput result;
  bool timed_out = false;
  for (;;) {
    pollfd fd{pipe_fds[0], POLLIN, 0};
    int wait_ms = -1;
    if (timeout_seconds > 0) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) {
        kill(pid, SIGKILL);
        timed_out = true;
        break;
      }
      wait_ms = static_cast<int>(left.count());
    }
    if (poll(&fd, 1, wait_ms) <= 0) continue;
    char buffer[4096];
    const ssize_t n = read(pipe_fds[0], buffer, sizeof(buffer));
    if (n <= 0) break;
    result.output.append(buffer, static_cast<std::size_t>(n));
  }
  close(pipe_fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  result.status = timed_out ? 124 : WIFEXITED(status) ? WEXITSTATUS(status) : 1;
  result.signal = !timed_out && WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  while (!result.output.empty() && (result.output.back() == '\n' || result.output.back() == ' ')) {
    result.output.pop_back();
  }
  return result;
}

namespace {

/// A control group's memory limit from a file holding bytes or "max"; infinity when there is
/// none or it cannot be read.
double cgroupLimit(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text == "max") return std::numeric_limits<double>::infinity();
  try {
    const double bytes = std::stod(text);
    // cgroup v1 writes "no limit" as a page-rounded 2^63.
    return bytes > 0.0 && bytes < 1e18 ? bytes : std::numeric_limits<double>::infinity();
  } catch (const std::exception&) {
    return std::numeric_limits<double>::infinity();
  }
}

/// This process's control group (v2: "0::/path" in /proc/self/cgroup), "" when unknown.
std::string ownCgroup() {
  std::ifstream in("/proc/self/cgroup");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("0::", 0) == 0) return line.substr(3);
  }
  return "";
}

thread_local std::vector<std::string> activities;

}  // namespace

double processMemoryLimit() {
  double limit = static_cast<double>(sysconf(_SC_PHYS_PAGES)) * sysconf(_SC_PAGESIZE);
  if (!(limit > 0.0)) limit = std::numeric_limits<double>::infinity();
  rlimit address_space{};
  if (getrlimit(RLIMIT_AS, &address_space) == 0 && address_space.rlim_cur != RLIM_INFINITY) {
    limit = std::min(limit, static_cast<double>(address_space.rlim_cur));
  }
  limit = std::min(limit, cgroupLimit("/sys/fs/cgroup" + ownCgroup() + "/memory.max"));
  limit = std::min(limit, cgroupLimit("/sys/fs/cgroup/memory/memory.limit_in_bytes"));
  return limit;
}

Activity::Activity(std::string what) { activities.push_back(std::move(what)); }

Activity::~Activity() { activities.pop_back(); }

std::string Activity::current() { return activities.empty() ? "" : activities.back(); }

}  // namespace kinolab
