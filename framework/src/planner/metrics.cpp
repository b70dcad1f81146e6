#include "kinolab/planner/metrics.hpp"

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/planner/planner.hpp"

namespace kinolab {

const MetricList<PlanResult>& planMetrics() {
  using R = PlanResult;
  const auto number = [](double R::*field) {
    return [field](const R& r) { return numberOrNone(r.*field); };
  };
  static const MetricList<R> list =
      MetricList<R>()
          .add(MetricSpecs().text(
                   "status",
                   "exact, approximate, no_solution, timeout (the planner spent its budget), "
                   "invalid_start, invalid_goal, invalid_trajectory, back_end_failed (the "
                   "front end's path, no trajectory from its back end); from the runner: crash, "
                   "killed (past its budget), oom, error"),
               [](const R& r) -> MetricValue { return std::string(toString(r.status)); })
          .add(MetricSpecs().text("message", "why, for statuses other than exact"),
               [](const R& r) -> MetricValue { return r.message; })
          .add(MetricSpecs()
                   .boolean("success", "exact and accepted by the independent checker")
                   .higher()
                   .comparable(),
               [](const R& r) -> MetricValue {
                 return isSuccess(r.status, r.check.valid) ? 1.0 : 0.0;
               })
          .add(MetricSpecs()
                   .clock("planning_time_ms", "the planner's own work (no checking, no figures)")
                   .lower()
                   .comparable(),
               number(&R::planning_time_ms))
          .add(MetricSpecs()
                   .real("cost", "",
                         "the planner's own objective (see objective): compared only between "
                         "planners of the same objective")
                   .lower(),
               number(&R::cost))
          .add(MetricSpecs().text("objective",
                                  "what cost measures: costs of equal objectives compare"),
               [](const R& r) -> MetricValue { return r.objective; })
          .add(MetricSpecs()
                   .real("distance_to_goal", "m",
                         "D: from the trajectory's closest point (or the start) to the goal")
                   .lower()
                   .comparable(),
               number(&R::distance_to_goal))
          .include(evaluationMetrics(),
                   [](const R& r) { return r.trajectory.empty() ? nullptr : &r.evaluation; })
          .add(MetricSpecs()
                   .boolean("checker_valid", "the independent checker accepts the trajectory")
                   .higher()
                   .comparable(),
               [](const R& r) -> MetricValue { return r.check.valid ? 1.0 : 0.0; })
          .add(MetricSpecs().text("checker_check",
                                  "the check that failed (collision, limits, start, goal, ...)"),
               [](const R& r) -> MetricValue { return r.check.check; })
          .add(MetricSpecs().text("checker_detail", "what that check found"),
               [](const R& r) -> MetricValue { return r.check.detail; })
          .add(MetricSpecs().real("checker_time", "s", "trajectory time of the failure"),
               [](const R& r) -> MetricValue {
                 return r.check.check.empty() ? MetricValue{} : numberOrNone(r.check.time);
               });
  return list;
}

const MetricSpecs& resultMetrics() { return planMetrics().specs(); }

const MetricSpecs& commonStatistics() {
  static const MetricSpecs specs =
      MetricSpecs().clock("time_check_ms", "the independent checker's time (not planning)");
  return specs;
}

bool isSuccess(PlanStatus status, bool checker_valid) {
  return status == PlanStatus::kExact && checker_valid;
}

MetricValues resultValues(const PlanResult& result) { return planMetrics().values(result); }

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
