#pragma once

#include <string>

namespace kinolab {

/// What a shell command printed (stdout and stderr, trailing white space removed) and its
/// exit status (1 when it did not exit normally).
struct CommandOutput {
  int status = 0;
  std::string output;
};

/// Runs `line` with /bin/sh and waits for it; with `timeout_seconds` > 0 it runs under
/// coreutils' `timeout` (for clients that block while a server is down).
CommandOutput runCommand(const std::string& line, int timeout_seconds = 0);

}  // namespace kinolab
