#pragma once

#include <cmath>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace kinolab {

enum class MetricType { kReal, kInteger, kBoolean, kText };

/// One metric or statistic a run can carry, declared once: everything that stores, prints or
/// reads results (the plan command's JSON, the worker's JSON, the SQLite tables, the Python
/// loader, `kinolab list metrics`) derives from this declaration.
struct MetricSpec {
  std::string name;
  MetricType type = MetricType::kReal;
  std::string unit;  ///< "ms", "m", "count", "" (none)
  std::string doc;   ///< one line
  /// A figure of the machine (a time, a memory peak, a date, or a value sampled on the
  /// clock): it varies from run to run of the same case, so comparisons of repeated runs
  /// leave it out.
  bool clock = false;
  /// A progress series (MetricSpecs::series): values over the planning time, reported as
  /// PlanResult::progress and stored in the `progress` table, never as one value.
  bool series = false;

  /// "real", "integer", "boolean" or "text".
  std::string typeName() const;
};

/// A declared list of metrics, built fluently (as ParameterSpecs):
///
///   MetricSpecs().counter("expansions", "states expanded")
///                .clock("time_evaluation_ms", "time spent evaluating edges");
class MetricSpecs {
 public:
  MetricSpecs& real(std::string name, std::string unit, std::string doc);
  /// A count (integer, unit "count").
  MetricSpecs& counter(std::string name, std::string doc);
  /// A clock figure in milliseconds.
  MetricSpecs& clock(std::string name, std::string doc);
  /// Another figure of the machine (MetricSpec::clock): memory, a date, a value sampled on
  /// the clock.
  MetricSpecs& machine(std::string name, MetricType type, std::string unit, std::string doc);
  MetricSpecs& boolean(std::string name, std::string doc);
  MetricSpecs& text(std::string name, std::string doc);
  /// An anytime progress series (real, e.g. the best cost so far): a planner reports its
  /// values against its planning time (ProgressSample), as OMPL's planner progress
  /// properties; the store keeps them as a time series.
  MetricSpecs& series(std::string name, std::string unit, std::string doc);
  /// Appends another list; a name declared twice is an error.
  MetricSpecs& include(const MetricSpecs& other);

  const std::vector<MetricSpec>& all() const { return specs_; }
  const MetricSpec* find(std::string_view name) const;
  std::vector<std::string> names() const;

 private:
  MetricSpecs& add(MetricSpec spec);

  std::vector<MetricSpec> specs_;
};

/// A metric's value: none (not applicable: no trajectory, a crash), a number (booleans and
/// integers too), or text.
using MetricValue = std::variant<std::monostate, double, std::string>;
using MetricValues = std::vector<std::pair<std::string, MetricValue>>;

/// One value of a progress series (MetricSpecs::series): `value` after `time_ms` of
/// planning. A series is a step function: the value holds until its next sample.
struct ProgressSample {
  std::string name;
  double time_ms = 0.0;
  double value = 0.0;
};
using Progress = std::vector<ProgressSample>;

/// A number as a metric's value: none when it is not finite (NaN and infinity are never
/// stored as figures).
inline MetricValue numberOrNone(double value) {
  return std::isfinite(value) ? MetricValue(value) : MetricValue();
}

}  // namespace kinolab
