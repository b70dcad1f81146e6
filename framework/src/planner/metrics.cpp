#include "kinolab/planner/metrics.hpp"

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/planner/planner.hpp"

namespace kinolab {

const MetricSpecs& resultMetrics() {
  static const MetricSpecs specs =
      MetricSpecs()
          .text("status",
                "exact, approximate, no_solution, timeout (the planner spent its budget), "
                "invalid_start, invalid_goal, invalid_trajectory; from the runner: crash, "
                "killed (past its budget), oom, error")
          .text("message", "why, for statuses other than exact")
          .boolean("success", "exact and accepted by the independent checker")
          .clock("planning_time_ms", "the planner's own work (no checking, no figures)")
          .real("cost", "", "the planner's own cost of its trajectory")
          .real("distance_to_goal", "m",
                "D: from the trajectory's closest point (or the start) to the goal")
          .real("duration", "s", "trajectory duration")
          .real("length", "m", "trajectory length")
          .real("jerk_integral", "m^2/s^5", "integral of the squared jerk")
          .real("min_clearance", "m",
                "least exact distance from the trajectory's checked positions to the occupied "
                "voxel cubes, less the robot radius")
          .real("mean_clearance", "m",
                "mean exact distance from the trajectory's checked positions to the occupied "
                "voxel cubes, less the robot radius")
          .boolean("checker_valid", "the independent checker accepts the trajectory")
          .text("checker_check", "the check that failed (collision, limits, start, goal, ...)")
          .text("checker_detail", "what that check found")
          .real("checker_time", "s", "trajectory time of the failure");
  return specs;
}

const MetricSpecs& commonStatistics() {
  static const MetricSpecs specs =
      MetricSpecs().clock("time_check_ms", "the independent checker's time (not planning)");
  return specs;
}

bool isSuccess(PlanStatus status, bool checker_valid) {
  return status == PlanStatus::kExact && checker_valid;
}

MetricValues resultValues(const PlanResult& result) {
  const bool has_trajectory = !result.trajectory.empty();
  const auto ofTrajectory = [&](auto compute) -> MetricValue {
    return has_trajectory ? numberOrNone(compute()) : MetricValue{};
  };
  const CheckResult& check = result.check;
  return {
      {"status", std::string(toString(result.status))},
      {"message", result.message},
      {"success", isSuccess(result.status, check.valid) ? 1.0 : 0.0},
      {"planning_time_ms", numberOrNone(result.planning_time_ms)},
      {"cost", numberOrNone(result.cost)},
      {"distance_to_goal", numberOrNone(result.distance_to_goal)},
      {"duration", ofTrajectory([&] { return result.trajectory.duration(); })},
      {"length", ofTrajectory([&] { return result.trajectory.length(); })},
      {"jerk_integral", ofTrajectory([&] { return result.trajectory.jerkIntegral(); })},
      {"min_clearance", ofTrajectory([&] { return check.min_clearance; })},
      {"mean_clearance", ofTrajectory([&] { return check.mean_clearance; })},
      {"checker_valid", check.valid ? 1.0 : 0.0},
      {"checker_check", check.check},
      {"checker_detail", check.detail},
      {"checker_time", check.check.empty() ? MetricValue{} : numberOrNone(check.time)},
  };
}

MetricValues statisticValues(const std::vector<std::pair<std::string, double>>& statistics) {
  MetricValues values;
  values.reserve(statistics.size());
  for (const auto& [name, value] : statistics) {
    values.emplace_back(name, numberOrNone(value));
  }
  return values;
}

std::string toJson(const MetricValues& values, const MetricSpecs& specs) {
  nlohmann::ordered_json object = nlohmann::ordered_json::object();
  for (const auto& [name, value] : values) {
    // A name the schema does not declare would be dropped by the store: an error here, where
    // it is reported, never a silent NULL.
    const MetricSpec* spec = specs.find(name);
    if (!spec) {
      throw InvalidArgument("metric '" + name + "' is not declared" +
                            didYouMean(name, specs.names()) + "; declare it (MetricSpecs)");
    }
    nlohmann::ordered_json& item = object[name];
    if (const auto* text = std::get_if<std::string>(&value)) {
      item = *text;
    } else if (const auto* number = std::get_if<double>(&value); number && std::isfinite(*number)) {
      const MetricType type = spec->type;
      if (type == MetricType::kBoolean) {
        item = *number != 0.0;
      } else if (type == MetricType::kInteger) {
        item = static_cast<long long>(*number);
      } else {
        item = *number;
      }
    }  // none (and a non-finite number) stays null
  }
  return object.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

MetricValues metricValuesFromJson(const std::string& json) {
  const auto object = nlohmann::ordered_json::parse(json);
  if (!object.is_object()) throw InvalidArgument("metric values: expected a JSON object");
  MetricValues values;
  for (const auto& [name, item] : object.items()) {
    if (item.is_string()) {
      values.emplace_back(name, item.get<std::string>());
    } else if (item.is_boolean()) {
      values.emplace_back(name, item.get<bool>() ? 1.0 : 0.0);
    } else if (item.is_number()) {
      values.emplace_back(name, item.get<double>());
    } else {
      values.emplace_back(name, std::monostate{});
    }
  }
  return values;
}

namespace {

[[noreturn]] void undeclared(std::string_view planner, std::string_view what,
                             const std::string& name, std::string_view problem) {
  throw PluginError("planner '" + std::string(planner) + "' reported the " + std::string(what) +
                    " '" + name + "', " + std::string(problem));
}

}  // namespace

void checkStatisticsDeclared(const PlanResult& result, const MetricSpecs& declared,
                             std::string_view planner) {
  constexpr std::string_view kAdd =
      "; add it to the MetricSpecs of its registration (kinolab list metrics shows what is "
      "declared)";
  std::set<std::string_view> seen;
  for (const auto& [name, value] : result.statistics) {
    const MetricSpec* spec = declared.find(name);
    if (!spec || spec->series) {
      undeclared(planner, "statistic", name,
                 std::string(spec ? "which it declares as a progress series (report it in "
                                    "PlanResult::progress)"
                                  : "which it does not declare") +
                     std::string(kAdd));
    }
    if (!seen.insert(name).second) undeclared(planner, "statistic", name, "twice");
  }
  std::map<std::string_view, double> last;
  for (const ProgressSample& sample : result.progress) {
    const MetricSpec* spec = declared.find(sample.name);
    if (!spec || !spec->series) {
      undeclared(planner, "progress series", sample.name,
                 "which it does not declare with MetricSpecs::series" + std::string(kAdd));
    }
    if (!std::isfinite(sample.time_ms) || !std::isfinite(sample.value)) {
      undeclared(planner, "progress series", sample.name,
                 "with a sample that is not finite (time " + formatNumber(sample.time_ms) +
                     " ms, value " + formatNumber(sample.value) + ")");
    }
    const auto [previous, first] = last.emplace(sample.name, sample.time_ms);
    if (!first && sample.time_ms < previous->second) {
      undeclared(planner, "progress series", sample.name,
                 "out of time order (" + formatNumber(sample.time_ms) + " ms after " +
                     formatNumber(previous->second) + " ms)");
    }
    previous->second = sample.time_ms;
  }
}

std::string progressToJson(const Progress& progress) {
  nlohmann::json samples = nlohmann::json::array();
  for (const ProgressSample& sample : progress)
    samples.push_back({sample.name, sample.time_ms, sample.value});
  return samples.dump();
}

Progress progressFromJson(const std::string& json) {
  const auto samples = nlohmann::json::parse(json);
  if (!samples.is_array()) throw InvalidArgument("progress: expected a JSON array");
  Progress progress;
  for (const auto& sample : samples) {
    if (!sample.is_array() || sample.size() != 3 || !sample[0].is_string() ||
        !sample[1].is_number() || !sample[2].is_number()) {
      throw InvalidArgument("progress: expected [name, time_ms, value], got " + sample.dump());
    }
    progress.push_back(
        {sample[0].get<std::string>(), sample[1].get<double>(), sample[2].get<double>()});
  }
  return progress;
}

}  // namespace kinolab
