#include "kinolab/core/process.hpp"

#include <sys/wait.h>

#include <cstdio>

#include "kinolab/core/error.hpp"

namespace kinolab {

CommandOutput runCommand(const std::string& line, int timeout_seconds) {
  const std::string command =
      (timeout_seconds > 0 ? "timeout " + std::to_string(timeout_seconds) + " " : "") + line +
      " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw Error("cannot run: " + line);
  CommandOutput result;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe)) result.output += buffer;
  const int status = pclose(pipe);
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
  while (!result.output.empty() && (result.output.back() == '\n' || result.output.back() == ' ')) {
    result.output.pop_back();
  }
  return result;
}

}  // namespace kinolab
