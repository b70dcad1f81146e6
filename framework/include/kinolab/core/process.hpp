#pragma once

#include <new>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kinolab/core/error.hpp"

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

/// Writes all of `text` to the file descriptor `fd`, stopping at an error (a closed pipe).
/// Async-signal-safe: only write(2), so a signal handler or a forked child about to _exit may
/// call it.
void writeAllTo(int fd, std::string_view text);

/// The memory this process may use, in bytes: the least of the machine's memory, its
/// address-space and data-segment limits (`ulimit -v`, `ulimit -d`) and its control group's
/// limit (a container's, a Slurm job's). Sizes read from input are checked against it before
/// anything is allocated.
double processMemoryLimit();

/// "this process may use 1.4 GiB" (rounded down; MiB below a GiB), for messages that refuse a
/// size or report running out.
std::string processMayUse();

/// The words of running out of memory while doing `what` ("building the world 'city'"; ""
/// when unknown), with what this process may use.
std::string outOfMemoryMessage(const std::string& what);

/// Runs `work` and returns what it returns; a std::bad_alloc inside becomes an OutOfMemory
/// naming `what`, so the innermost named work is the one reported (an outer one passes the
/// OutOfMemory on as any other Error).
template <typename Work>
decltype(auto) whileDoing(const std::string& what, Work&& work) {
  try {
    return std::forward<Work>(work)();
  } catch (const std::bad_alloc&) {
    throw OutOfMemory(outOfMemoryMessage(what));
  }
}

}  // namespace kinolab
