#pragma once

#include <string>
#include <string_view>

#include "kinolab/core/metric_specs.hpp"

namespace kinolab {

struct PlanResult;
enum class PlanStatus;

/// The metrics of every planning result, whatever the planner, declared once with how each
/// is read from a result: status, message, success, planning time, the planner's own cost and
/// its objective, D, the checker's evaluation of the trajectory (evaluationMetrics()) and its
/// verdict.
const MetricList<PlanResult>& planMetrics();
/// Their declarations.
const MetricSpecs& resultMetrics();
/// The statistics Planner::plan() adds to every planner's own (the checker's time).
const MetricSpecs& commonStatistics();

/// The one definition of a successful run: an exact solution the independent checker
/// accepts. Approximate answers, budget stops and rejected trajectories are not successes.
bool isSuccess(PlanStatus status, bool checker_valid);

/// The values of resultMetrics() for a result, in declaration order.
MetricValues resultValues(const PlanResult& result);

/// A planner's statistics as metric values (NaN and infinity become none).
MetricValues statisticValues(const std::vector<std::pair<std::string, double>>& statistics);

/// Progress samples as JSON ([[name, time_ms, value], ...]) and back.
std::string progressToJson(const Progress& progress);
Progress progressFromJson(const std::string& json);

/// A JSON object of `values`, typed by `specs` (booleans as true/false, integers as
/// integers); none is null. A name `specs` does not declare is an InvalidArgument.
std::string toJson(const MetricValues& values, const MetricSpecs& specs);
/// The values of a JSON object written by toJson() (booleans become 1 or 0).
MetricValues metricValuesFromJson(const std::string& json);

/// Throws PluginError naming `planner` when it reported a statistic that `declared`
/// (declaredStatistics()) does not declare as a value, or one twice; or a progress sample of
/// a name `declared` does not declare as a series, with a time or value that is not finite,
/// or earlier than the series' previous sample.
void checkStatisticsDeclared(const PlanResult& result, const MetricSpecs& declared,
                             std::string_view planner);

}  // namespace kinolab
