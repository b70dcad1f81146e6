#include "kinolab/core/process.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {

void writeAllTo(int fd, std::string_view text) {
  while (!text.empty()) {
    const ssize_t written = write(fd, text.data(), text.size());
    if (written <= 0) return;
    text.remove_prefix(static_cast<std::size_t>(written));
  }
}

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

/// This process's control groups' memory limit files: v2's memory.max ("0::/path" in
/// /proc/self/cgroup) and v1's memory.limit_in_bytes ("N:memory:/path"), each under its own
/// path and, inside a container that mounts its own group at the root, at the root.
std::vector<std::string> cgroupLimitFiles() {
  std::vector<std::string> files{"/sys/fs/cgroup/memory.max",
                                 "/sys/fs/cgroup/memory/memory.limit_in_bytes"};
  std::ifstream in("/proc/self/cgroup");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("0::", 0) == 0)
      files.push_back("/sys/fs/cgroup" + line.substr(3) + "/memory.max");
    if (const auto v1 = line.find(":memory:"); v1 != std::string::npos) {
      files.push_back("/sys/fs/cgroup/memory" + line.substr(v1 + 8) + "/memory.limit_in_bytes");
    }
  }
  return files;
}

}  // namespace

double processMemoryLimit() {
  double limit = static_cast<double>(sysconf(_SC_PHYS_PAGES)) * sysconf(_SC_PAGESIZE);
  if (!(limit > 0.0)) limit = std::numeric_limits<double>::infinity();
  for (const auto resource : {RLIMIT_AS, RLIMIT_DATA}) {
    rlimit value{};
    if (getrlimit(resource, &value) == 0 && value.rlim_cur != RLIM_INFINITY) {
      limit = std::min(limit, static_cast<double>(value.rlim_cur));
    }
  }
  for (const std::string& file : cgroupLimitFiles()) limit = std::min(limit, cgroupLimit(file));
  return limit;
}

std::string processMayUse() {
  const double bytes = processMemoryLimit();
  constexpr double kGiB = 1 << 30;
  const std::string amount = bytes >= kGiB
                                 ? formatNumber(std::floor(bytes / kGiB * 10.0) / 10.0) + " GiB"
                                 : formatNumber(std::floor(bytes / (1 << 20))) + " MiB";
  return "this process may use " + amount;
}

std::string outOfMemoryMessage(const std::string& what) {
  return "out of memory" + (what.empty() ? std::string() : " while " + what) + ": " +
         processMayUse() +
         " (the least of the machine's memory, ulimit -v and -d and its control group's limit)";
}

}  // namespace kinolab
