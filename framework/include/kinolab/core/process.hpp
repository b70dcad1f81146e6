#pragma once

#include <string>
#include <vector>

namespace kinolab {

/// What a command printed (stdout and stderr, trailing white space removed) and its exit
/// status (1 when it did not exit normally, 127 when it could not be started).
struct CommandOutput {
  int status = 0;
  std::string output;
  int signal = 0;  ///< the signal that ended it (SIGSEGV, SIGABRT, ...), 0 when it exited
};

/// Runs a program with an argument vector (`arguments[0]` is looked up on the PATH) and waits
/// for it; no shell ever sees the arguments, so nothing in them is interpreted. With
/// `timeout_seconds` > 0 it is killed after that long (for clients that block while a
/// server is down) and the status is 124, as coreutils' `timeout` reports it.
CommandOutput runCommand(const std::vector<std::string>& arguments, int timeout_seconds = 0);

/// The memory this process may use, in bytes: the least of the machine's memory, its
/// address-space limit (`ulimit -v`) and its control group's limit (a container's, a Slurm
/// job's). Sizes read from input are checked against it before anything is allocated.
double processMemoryLimit();

/// What the current thread is doing, for the message when memory runs out ("building the
/// world 'city'"): an Activity names it while it lives, the innermost one wins.
class Activity {
 public:
  explicit Activity(std::string what);
  ~Activity();
  Activity(const Activity&) = delete;
  Activity& operator=(const Activity&) = delete;
  /// The innermost living activity's words, or "" when none.
  static std::string current();
};

}  // namespace kinolab
