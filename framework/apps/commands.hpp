#pragma once

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "kinolab/core/text.hpp"

namespace kinolab::view {
class Scene;
}

namespace kinolab::apps {

/// A number in [low, high], finite (CLI::Range lets NaN through): every numeric option of
/// kinolab is range-checked with this, so no value switches a safety off.
inline CLI::Validator within(double low, double high) {
  const std::string range = "[" + formatNumber(low) + ", " + formatNumber(high) + "]";
  return CLI::Validator(
      [low, high, range](std::string& text) -> std::string {
        double value = 0.0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value) ||
            value < low || value > high) {
          return "'" + text + "' is not a number in " + range;
        }
        return "";
      },
      "NUMBER in " + range);
}

/// A whole number in [0, 2^64 - 1], exactly (a seed): nothing beyond it is clamped, and a
/// sign, a fraction or an exponent is refused.
inline CLI::Validator unsigned64() {
  const std::string range = "[0, 18446744073709551615]";
  return CLI::Validator(
      [range](std::string& text) -> std::string {
        std::uint64_t value = 0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (text.empty() || error != std::errc() || end != text.data() + text.size()) {
          return "'" + text + "' is not a whole number in " + range;
        }
        return "";
      },
      "INTEGER in " + range);
}

/// A hard stop for plugin code that ignores its budget: unless cancelled (destroyed) within
/// `seconds`, it prints `message` (to stderr, and `json` as the last stdout line when given)
/// and ends the process with status 1. A planner that never returns cannot be stopped any
/// other way inside one process; `kinolab run` kills its worker instead. The process's
/// real-time interval timer (SIGALRM) keeps the time, no thread: one watchdog at a time.
class Watchdog {
 public:
  Watchdog(double seconds, std::string message, std::string json);
  ~Watchdog();
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

 private:
  std::string out_;  // the JSON line, or nothing
  std::string err_;  // the error line
  bool armed_ = false;
};

/// The JSON summary line of a planner the watchdog stopped (`plan` and `fly`): status
/// `killed`, message "timeout: `message`".
std::string killedSummary(const std::string& planner, const std::string& world, std::uint64_t seed,
                          const std::string& message);

/// Exactly three finite numbers "x,y,z" (metres) from `option`, or a ConfigError naming it.
Eigen::Vector3d parsePoint(const std::string& text, const std::string& option);

/// Writes the 3D view of `scene` to `path`; false (and a note on stderr) in a build without
/// the viewer.
bool writeView(const std::string& path, const view::Scene& scene);

/// Each subcommand adds itself (options, help and the action to run) to the main app.
void addExportCommand(CLI::App& app);
void addFlyCommand(CLI::App& app);
void addListCommand(CLI::App& app);
void addPlanCommand(CLI::App& app);
void addReportCommand(CLI::App& app);
void addRunCommand(CLI::App& app);
void addSlurmCommand(CLI::App& app);
void addSamplingStudyCommand(CLI::App& app);
void addTestPluginCommand(CLI::App& app);
void addWorldCommand(CLI::App& app);

}  // namespace kinolab::apps
