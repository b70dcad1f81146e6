#pragma once

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace kinolab {

enum class MetricType { kReal, kInteger, kBoolean, kText };

/// Which way a metric is better, for tests and figures that rank planners.
enum class MetricDirection { kNone, kLower, kHigher };

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
  MetricDirection direction = MetricDirection::kNone;
  /// It means the same for every planner and flight (the independent checker's evaluation of
  /// the trajectory itself): a report may test it across planners. A planner's own figures
  /// (its cost, its counters) are not: they are compared only where their planners agree.
  bool comparable = false;

  /// "real", "integer", "boolean" or "text".
  std::string typeName() const;
  /// "lower", "higher" or "".
  std::string directionName() const;
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
  /// The last declared metric is better lower (higher), and comparable across planners:
  /// `.real("length", "m", "...").lower().comparable()`.
  MetricSpecs& lower();
  MetricSpecs& higher();
  MetricSpecs& comparable();

  /// Appends a declaration as it is (what a module's manifest reads back); a name declared
  /// twice is an error.
  MetricSpecs& add(MetricSpec spec);

  const std::vector<MetricSpec>& all() const { return specs_; }
  const MetricSpec* find(std::string_view name) const;
  std::vector<std::string> names() const;

 private:
  /// The last declared metric, for a modifier (its name in the error without one).
  MetricSpec& last(const char* modifier);

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

/// A result kind's metrics declared once with how each is read from a result: the
/// declarations (specs()) make the schema, the docs and what readers know of each column;
/// values() reads a result in declaration order.
template <typename Result>
class MetricList {
 public:
  using Getter = std::function<MetricValue(const Result&)>;

  /// Declares the one metric `spec` holds (built fluently: `MetricSpecs().real(...).lower()`),
  /// read by `get`.
  MetricList& add(const MetricSpecs& spec, Getter get) {
    if (spec.all().size() != 1) throw std::logic_error("MetricList::add: declare one metric");
    specs_.include(spec);
    getters_.push_back(std::move(get));
    return *this;
  }
  /// Declares every metric of `other`, read from the part of a result `part` returns (none
  /// for each when it returns null).
  template <typename Part, typename Projection>
  MetricList& include(const MetricList<Part>& other, Projection part) {
    specs_.include(other.specs());
    for (const auto& get : other.getters()) {
      getters_.push_back([get, part](const Result& result) -> MetricValue {
        const Part* piece = part(result);
        return piece ? get(*piece) : MetricValue{};
      });
    }
    return *this;
  }

  const MetricSpecs& specs() const { return specs_; }
  const std::vector<Getter>& getters() const { return getters_; }
  MetricValues values(const Result& result) const {
    MetricValues values;
    values.reserve(getters_.size());
    for (std::size_t i = 0; i < getters_.size(); ++i) {
      values.emplace_back(specs_.all()[i].name, getters_[i](result));
    }
    return values;
  }

 private:
  MetricSpecs specs_;
  std::vector<Getter> getters_;
};

}  // namespace kinolab
