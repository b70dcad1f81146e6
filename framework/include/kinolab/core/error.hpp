#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace kinolab {

/// Base of every error kinolab throws for bad input or misuse. Expected planning outcomes
/// (no solution, timeout) are statuses, never exceptions.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A configuration file or value is malformed, misspelt, of the wrong type or out of range.
/// The message names the file, the line and the key path.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// A plugin's factory refuses a combination of parameter values (each valid alone), naming the
/// parameter it blames and any others that take part; configurePlanner() adds where the
/// blamed one was set, else where the first of the others was.
class ParameterConflict : public ConfigError {
 public:
  ParameterConflict(std::string parameter, const std::string& message,
                    std::vector<std::string> others = {})
      : ConfigError("parameter '" + parameter + "': " + message),
        parameter_(std::move(parameter)),
        others_(std::move(others)) {}
  const std::string& parameter() const { return parameter_; }
  const std::vector<std::string>& others() const { return others_; }

 private:
  std::string parameter_;
  std::vector<std::string> others_;
};

/// A file is missing, unreadable, corrupt or cannot be written.
class FileError : public Error {
 public:
  using Error::Error;
};

/// A plugin is unknown or registered twice, or its library cannot be loaded or lacks the
/// entry point.
class PluginError : public Error {
 public:
  using Error::Error;
};

/// A plugin's own code (its entry point, factory, plan, ...) threw something that is not a
/// kinolab error; the message names the plugin and the call (rethrowFromPlugin()).
class PluginCodeError : public PluginError {
 public:
  using PluginError::PluginError;
};

/// Memory ran out (std::bad_alloc) while doing named work: a build or a plan larger than this
/// process may use. The message names the work and the limit (whileDoing()); in an experiment
/// it is the run's status `oom`.
class OutOfMemory : public Error {
 public:
  using Error::Error;
};

/// A function was called with arguments that break its documented contract.
class InvalidArgument : public Error {
 public:
  using Error::Error;
};

}  // namespace kinolab
