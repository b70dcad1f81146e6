#pragma once

#include <array>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace kinolab {

class YamlReader;

class ParameterSpecs;

/// kReals: a list of numbers (a point, an interval). kPath: a file; a relative path is
/// relative to the file that sets it. kPlugin: the key of a plugin of another kind (a control
/// sampler, a heuristic, a sensor, ...) that the declaring plugin is given, configured by its
/// own parameters, set as `NAME.PARAMETER` (ParameterSpecs::plugin()). kGroup: an optional
/// group of parameters, present when any is set (`canopy.radius`, YAML `canopy: {...}`).
/// kGroupList: a list of groups (`boxes.0.min`, YAML `boxes: [{min: ...}, ...]`).
enum class ParameterType {
  kBoolean,
  kInteger,
  kReal,
  kChoice,
  kText,
  kReals,
  kPath,
  kPlugin,
  kGroup,
  kGroupList
};

/// A parameter value: bool (and a group's presence), integer (and a group list's length),
/// real, text (choices, paths, plugin keys) or a list of numbers.
using ParameterValue = std::variant<bool, long long, double, std::string, std::vector<double>>;

/// One declared parameter: the same name is used in YAML, on the command line (`--set`), in
/// `kinolab list`, in results and in reports.
struct ParameterSpec {
  std::string name;
  ParameterType type = ParameterType::kReal;
  ParameterValue default_value;
  double minimum = -std::numeric_limits<double>::infinity();  // integer and real
  double maximum = std::numeric_limits<double>::infinity();
  std::vector<std::string> choices;  // choice
  std::string doc;
  std::string kind;       // plugin: the registry's kind ("sampler", "heuristic", ...)
  std::size_t count = 0;  // reals: how many (0: any number)
  bool interval = false;  // reals: [low, high] with low <= high; one number x is [x, x]
  bool required = false;  // no default: resolving without a value is an error
  std::shared_ptr<const ParameterSpecs> members;  // group and group list: each group's

  /// "bool", "int", "real", "choice", "text", "reals", "path", "group", "groups", or a plugin
  /// parameter's kind ("sampler").
  std::string typeName() const;
  /// What values are accepted: "[0, 1]", "quantile|random", "true|false", "any text".
  std::string rangeText() const;
};

/// One value to set, as text (`--set name=value`, or a YAML scalar), and where it came from
/// ("--set", "exp.yaml:12:5: planners[0].params.sigma") for messages.
struct ParameterAssignment {
  std::string name;
  std::string value;
  std::string where;
  /// Written as a YAML mapping (`{type: KEY}` or `{}`): only a plugin parameter or a group
  /// takes one.
  bool mapping = false;
};

/// Resolved values of every declared parameter, in declaration order.
class ParameterSet {
 public:
  bool boolean(std::string_view name) const { return std::get<bool>(find(name)); }
  long long integer(std::string_view name) const { return std::get<long long>(find(name)); }
  double real(std::string_view name) const { return std::get<double>(find(name)); }
  /// A choice or text value.
  const std::string& text(std::string_view name) const { return std::get<std::string>(find(name)); }
  const std::vector<double>& reals(std::string_view name) const {
    return std::get<std::vector<double>>(find(name));
  }
  /// The parameters of the plugin a plugin-valued parameter chose (its key is text(name)), or
  /// of a group (present when boolean(name)).
  const ParameterSet& nested(std::string_view name) const;
  /// The groups of a group list, in order.
  std::vector<const ParameterSet*> items(std::string_view name) const;
  /// True when the parameter was declared.
  bool has(std::string_view name) const;

  const std::vector<std::pair<std::string, ParameterValue>>& values() const { return values_; }
  /// Every value, nested ones as `NAME.PARAMETER` (a group list's as `NAME.INDEX.PARAMETER`)
  /// after their parameter: what `--set` would carry.
  std::vector<std::pair<std::string, ParameterValue>> flattened() const;
  /// "name=value;..." in declaration order, a plugin parameter's nested values in braces
  /// after it (`sampler=normal{sigma=0.5}`): what a run hash includes.
  std::string canonical() const;

 private:
  friend class ParameterSpecs;
  const ParameterValue& find(std::string_view name) const;

  std::vector<std::pair<std::string, ParameterValue>> values_;
  std::vector<std::pair<std::string, std::shared_ptr<const ParameterSet>>> nested_;
};

/// The declared parameters of one plugin, built fluently in its registration:
///
///   ParameterSpecs().integer("samples_per_axis", 5, 2, 64, "values per control axis")
///                   .real("sigma", 0.5, 0.05, 10.0, "standard deviation / u_max");
class ParameterSpecs {
 public:
  ParameterSpecs& boolean(std::string name, bool default_value, std::string doc);
  ParameterSpecs& integer(std::string name, long long default_value, long long minimum,
                          long long maximum, std::string doc);
  ParameterSpecs& real(std::string name, double default_value, double minimum, double maximum,
                       std::string doc);
  ParameterSpecs& choice(std::string name, std::string default_value,
                         std::vector<std::string> choices, std::string doc);
  ParameterSpecs& text(std::string name, std::string default_value, std::string doc);
  /// `count` numbers in [minimum, maximum] (count 0: any number of them).
  ParameterSpecs& reals(std::string name, std::vector<double> default_value, double minimum,
                        double maximum, std::size_t count, std::string doc);
  /// [low, high] with low <= high, both in [minimum, maximum]; one number x means [x, x].
  ParameterSpecs& interval(std::string name, std::array<double, 2> default_value, double minimum,
                           double maximum, std::string doc);
  /// A file; a relative path set in a file is relative to that file's directory.
  ParameterSpecs& path(std::string name, std::string doc);
  /// An optional group of parameters (`canopy: {radius: ...}`): present when any of them, or
  /// the group itself (`canopy=true`), is set; its values are nested(name).
  ParameterSpecs& group(std::string name, ParameterSpecs members, std::string doc);
  /// A list of groups (`boxes: [{min: ..., max: ...}, ...]`), each with `members`; items(name).
  ParameterSpecs& groupList(std::string name, ParameterSpecs members, std::string doc);
  /// Makes the last declared parameter required: it has no default, and resolving without a
  /// value is an error.
  ParameterSpecs& required();
  /// A plugin of `kind` (a registry's kind: "heuristic", "sensor", ...) that this plugin is
  /// given: the value is its key (checked against the registry when resolved) and
  /// `NAME.PARAMETER` sets its parameters. The plugin makes the instance with
  /// `pluginRegistry<Interface>().createChosen(parameters, NAME)`.
  ParameterSpecs& plugin(std::string kind, std::string name, std::string default_value,
                         std::string doc);
  /// Appends a declared group (e.g. motionParameters()); a name declared twice is an error.
  ParameterSpecs& include(const ParameterSpecs& group);

  /// Appends a declaration as it is (what a module's manifest reads back; plugins use the
  /// typed methods above); a name declared twice or a default it refuses is an error.
  ParameterSpecs& add(ParameterSpec spec);

  const std::vector<ParameterSpec>& all() const { return specs_; }
  const ParameterSpec* find(std::string_view name) const;

  /// The defaults with `assignments` applied in order. An unknown name, a value of the wrong
  /// type or out of range, an unknown plugin key or a wrong nested parameter throws
  /// ConfigError naming where the value came from, `owner` (e.g. "sampler 'normal'"), the
  /// parameter and what it accepts; a required parameter without a value names `where`
  /// (where the owner was written).
  ParameterSet resolve(const std::vector<ParameterAssignment>& assignments, std::string_view owner,
                       std::string_view where = "") const;

 private:
  std::vector<ParameterSpec> specs_;
};

/// Text for a value: "true", "42", "0.5", "quantile".
std::string formatParameterValue(const ParameterValue& value);

/// Parses `name=value` items (from repeated --set options).
std::vector<ParameterAssignment> parseAssignments(const std::vector<std::string>& items,
                                                  std::string_view where);

/// The entries of a YAML mapping (`params: {sigma: 0.4}`) as assignments, each located at its
/// own line. A plugin parameter may be a mapping: `heuristic: {type: obvp}` or
/// `sensor: {type: lidar, beams: 720}` is `sensor=lidar`, `sensor.beams=720`.
std::vector<ParameterAssignment> assignmentsFromYaml(const YamlReader& mapping);

}  // namespace kinolab
