#include "kinolab/planner/metrics.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "kinolab/core/error.hpp"
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
          .real("min_clearance", "m", "smallest ESDF clearance along the trajectory")
          .real("mean_clearance", "m", "mean ESDF clearance along the trajectory")
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

void checkStatisticsDeclared(const PlanResult& result, const MetricSpecs& declared,
                             std::string_view planner) {
  std::set<std::string_view> seen;
  for (const auto& [name, value] : result.statistics) {
    if (!declared.find(name)) {
      throw PluginError("planner '" + std::string(planner) + "' reported the statistic '" + name +
                        "', which it does not declare; add it to the MetricSpecs of its "
                        "registration (kinolab list metrics shows what is declared)");
    }
    if (!seen.insert(name).second) {
      throw PluginError("planner '" + std::string(planner) + "' reported the statistic '" + name +
                        "' twice");
    }
  }
}

}  // namespace kinolab
