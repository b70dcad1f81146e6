#include "kinolab/core/parameters.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <sstream>

#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {
namespace {

std::vector<std::string> namesOf(const std::vector<ParameterSpec>& specs) {
  std::vector<std::string> names;
  for (const auto& spec : specs) names.push_back(spec.name);
  return names;
}

std::optional<bool> parseBoolean(const std::string& text) {
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "true" || lower == "yes" || lower == "on" || lower == "1") return true;
  if (lower == "false" || lower == "no" || lower == "off" || lower == "0") return false;
  return std::nullopt;
}

std::optional<long long> parseInteger(const std::string& text) {
  if (text.empty()) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (errno != 0 || end != text.c_str() + text.size()) return std::nullopt;
  return value;
}

std::optional<double> parseReal(const std::string& text) {
  if (text.empty()) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (errno != 0 || end != text.c_str() + text.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

/// Numbers separated by commas or spaces, optionally in brackets: "1, 2", "[1 2]", "".
std::optional<std::vector<double>> parseReals(std::string text) {
  // One pair of brackets at most, around the whole list: a nested list is not a point.
  const auto first = text.find_first_not_of(' ');
  const auto last = text.find_last_not_of(' ');
  if (first != std::string::npos && text[first] == '[' && text[last] == ']') {
    text = text.substr(first + 1, last - first - 1);
  }
  if (text.find_first_of("[]") != std::string::npos) return std::nullopt;
  std::replace(text.begin(), text.end(), ',', ' ');
  std::istringstream words(text);
  std::vector<double> values;
  for (std::string word; words >> word;) {
    const auto value = parseReal(word);
    if (!value) return std::nullopt;
    values.push_back(*value);
  }
  return values;
}

/// The value of `text` for `spec`, or an explanation of why it is not one.
ParameterValue parseValue(const ParameterSpec& spec, const std::string& text,
                          const std::string& context) {
  const auto reject = [&](const std::string& expected) -> ParameterValue {
    throw ConfigError(context + ": expected " + expected + ", got '" + text + "'");
  };
  switch (spec.type) {
    case ParameterType::kBoolean:
    case ParameterType::kGroup:
      if (const auto value = parseBoolean(text)) return *value;
      return reject("true or false");
    case ParameterType::kInteger: {
      const auto value = parseInteger(text);
      if (!value || *value < spec.minimum || *value > spec.maximum) {
        return reject("an integer in " + spec.rangeText());
      }
      return *value;
    }
    case ParameterType::kReal: {
      const auto value = parseReal(text);
      if (!value || *value < spec.minimum || *value > spec.maximum) {
        return reject("a number in " + spec.rangeText());
      }
      return *value;
    }
    case ParameterType::kReals: {
      auto values = parseReals(text);
      if (values && spec.interval && values->size() == 1) values->push_back(values->front());
      const bool counted = values && (spec.count == 0 || values->size() == spec.count);
      const bool in_range = counted && std::all_of(values->begin(), values->end(), [&](double v) {
                              return v >= spec.minimum && v <= spec.maximum;
                            });
      if (!in_range || (spec.interval && (*values)[0] > (*values)[1])) {
        return reject(spec.rangeText());
      }
      return *values;
    }
    case ParameterType::kChoice:
      if (std::find(spec.choices.begin(), spec.choices.end(), text) == spec.choices.end()) {
        return reject("one of " + spec.rangeText() + didYouMean(text, spec.choices));
      }
      return text;
    case ParameterType::kGroupList: {
      // Only the empty list is set as a whole (`boxes: []`); items are set one by one.
      const auto values = parseReals(text);
      if (!values || !values->empty()) return reject("[] (items are set as NAME.INDEX.PARAMETER)");
      return 0LL;
    }
    case ParameterType::kText:
    case ParameterType::kPath:
    case ParameterType::kPlugin:
      return text;
  }
  return reject("a value");
}

}  // namespace

std::string ParameterSpec::typeName() const {
  switch (type) {
    case ParameterType::kBoolean:
      return "bool";
    case ParameterType::kInteger:
      return "int";
    case ParameterType::kReal:
      return "real";
    case ParameterType::kChoice:
      return "choice";
    case ParameterType::kText:
      return "text";
    case ParameterType::kReals:
      return interval ? "interval" : "reals";
    case ParameterType::kPath:
      return "path";
    case ParameterType::kPlugin:
      return kind;
    case ParameterType::kGroup:
      return "group";
    case ParameterType::kGroupList:
      return "groups";
  }
  return "?";
}

std::string ParameterSpec::rangeText() const {
  // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "[" + ...
  std::string bounds = "[";
  bounds += formatNumber(minimum);
  bounds += ", ";
  bounds += formatNumber(maximum);
  bounds += "]";
  switch (type) {
    case ParameterType::kBoolean:
      return "true|false";
    case ParameterType::kInteger:
    case ParameterType::kReal:
      return bounds;
    case ParameterType::kReals:
      if (interval) return "[low, high] within " + bounds;
      return (count ? std::to_string(count) : std::string("any number of")) + " numbers in " +
             bounds;
    case ParameterType::kChoice:
      return join(choices, "|");
    case ParameterType::kText:
      return "any text";
    case ParameterType::kPath:
      return "a file";
    case ParameterType::kPlugin: {
      const PluginRegistryBase* registry = findPluginRegistry(kind);
      return "key: list " + (registry ? registry->plural() : kind);
    }
    case ParameterType::kGroup:
      return "NAME.PARAMETER";
    case ParameterType::kGroupList:
      return "NAME.INDEX.PARAMETER";
  }
  return "?";
}

const ParameterValue& ParameterSet::find(std::string_view name) const {
  for (const auto& [key, value] : values_) {
    if (key == name) return value;
  }
  // A plugin asking for a parameter it never declared is a bug in that plugin.
  throw InvalidArgument("parameter '" + std::string(name) + "' was never declared");
}

const ParameterSet& ParameterSet::nested(std::string_view name) const {
  for (const auto& [key, set] : nested_) {
    if (key == name) return *set;
  }
  throw InvalidArgument("parameter '" + std::string(name) + "' is not a plugin parameter or group");
}

std::vector<const ParameterSet*> ParameterSet::items(std::string_view name) const {
  const auto count = static_cast<std::size_t>(std::get<long long>(find(name)));
  // One pass over the nested sets (NAME.INDEX), not a search per item: a list of 10^6 boxes
  // is read in linear time.
  std::vector<const ParameterSet*> result(count, nullptr);
  const std::string prefix = std::string(name) + ".";
  for (const auto& [key, set] : nested_) {
    if (!key.starts_with(prefix)) continue;
    const auto index = parseInteger(key.substr(prefix.size()));
    if (index && *index >= 0 && static_cast<std::size_t>(*index) < count)
      result[*index] = set.get();
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (!result[i]) (void)nested(prefix + std::to_string(i));  // throws, naming the item
  }
  return result;
}

std::vector<std::pair<std::string, ParameterValue>> ParameterSet::flattened() const {
  std::vector<std::pair<std::string, ParameterValue>> result;
  for (const auto& [name, value] : values_) {
    result.emplace_back(name, value);
    for (const auto& [key, set] : nested_) {
      if (key != name && !key.starts_with(name + ".")) continue;
      for (auto& [inner, inner_value] : set->flattened()) {
        result.emplace_back(key + "." + inner, std::move(inner_value));
      }
    }
  }
  return result;
}

bool ParameterSet::has(std::string_view name) const {
  return std::any_of(values_.begin(), values_.end(),
                     [name](const auto& entry) { return entry.first == name; });
}

std::string ParameterSet::canonical() const {
  std::string text;
  for (const auto& [name, value] : values_) {
    if (!text.empty()) text += ';';
    text += name + '=' + formatParameterValue(value);
    for (const auto& [key, set] : nested_) {
      if (set->values_.empty()) continue;
      if (key == name) text += '{' + set->canonical() + '}';
      if (key.starts_with(name + ".")) text += '[' + set->canonical() + ']';
    }
  }
  return text;
}

ParameterSpecs& ParameterSpecs::add(ParameterSpec spec) {
  if (find(spec.name)) throw InvalidArgument("parameter '" + spec.name + "' declared twice");
  if (spec.name.empty() || spec.name.find('.') != std::string::npos) {
    throw InvalidArgument("parameter '" + spec.name + "': a name without '.' (it nests)");
  }
  // A declared default must itself be acceptable.
  if (spec.type != ParameterType::kGroupList && spec.type != ParameterType::kPath) {
    parseValue(spec, formatParameterValue(spec.default_value), "default of '" + spec.name + "'");
  }
  specs_.push_back(std::move(spec));
  return *this;
}

namespace {

ParameterSpec declare(std::string name, ParameterType type, ParameterValue default_value,
                      std::string doc, double minimum = 0.0, double maximum = 0.0) {
  ParameterSpec spec;
  spec.name = std::move(name);
  spec.type = type;
  spec.default_value = std::move(default_value);
  spec.doc = std::move(doc);
  spec.minimum = minimum;
  spec.maximum = maximum;
  return spec;
}

}  // namespace

ParameterSpecs& ParameterSpecs::boolean(std::string name, bool default_value, std::string doc) {
  return add(declare(std::move(name), ParameterType::kBoolean, default_value, std::move(doc)));
}

ParameterSpecs& ParameterSpecs::integer(std::string name, long long default_value,
                                        long long minimum, long long maximum, std::string doc) {
  return add(declare(std::move(name), ParameterType::kInteger, default_value, std::move(doc),
                     static_cast<double>(minimum), static_cast<double>(maximum)));
}

ParameterSpecs& ParameterSpecs::real(std::string name, double default_value, double minimum,
                                     double maximum, std::string doc) {
  return add(declare(std::move(name), ParameterType::kReal, default_value, std::move(doc), minimum,
                     maximum));
}

ParameterSpecs& ParameterSpecs::choice(std::string name, std::string default_value,
                                       std::vector<std::string> choices, std::string doc) {
  ParameterSpec spec =
      declare(std::move(name), ParameterType::kChoice, std::move(default_value), std::move(doc));
  spec.choices = std::move(choices);
  return add(std::move(spec));
}

ParameterSpecs& ParameterSpecs::text(std::string name, std::string default_value, std::string doc) {
  return add(
      declare(std::move(name), ParameterType::kText, std::move(default_value), std::move(doc)));
}

ParameterSpecs& ParameterSpecs::reals(std::string name, std::vector<double> default_value,
                                      double minimum, double maximum, std::size_t count,
                                      std::string doc) {
  ParameterSpec spec = declare(std::move(name), ParameterType::kReals, std::move(default_value),
                               std::move(doc), minimum, maximum);
  spec.count = count;
  return add(std::move(spec));
}

ParameterSpecs& ParameterSpecs::interval(std::string name, std::array<double, 2> default_value,
                                         double minimum, double maximum, std::string doc) {
  ParameterSpec spec = declare(std::move(name), ParameterType::kReals,
                               std::vector<double>{default_value[0], default_value[1]},
                               std::move(doc), minimum, maximum);
  spec.count = 2;
  spec.interval = true;
  return add(std::move(spec));
}

ParameterSpecs& ParameterSpecs::path(std::string name, std::string doc) {
  return add(declare(std::move(name), ParameterType::kPath, std::string(), std::move(doc)));
}

ParameterSpecs& ParameterSpecs::plugin(std::string kind, std::string name,
                                       std::string default_value, std::string doc) {
  ParameterSpec spec =
      declare(std::move(name), ParameterType::kPlugin, std::move(default_value), std::move(doc));
  spec.kind = std::move(kind);
  return add(std::move(spec));
}

ParameterSpecs& ParameterSpecs::group(std::string name, ParameterSpecs members, std::string doc) {
  ParameterSpec spec = declare(std::move(name), ParameterType::kGroup, false, std::move(doc));
  spec.members = std::make_shared<const ParameterSpecs>(std::move(members));
  return add(std::move(spec));
}

ParameterSpecs& ParameterSpecs::groupList(std::string name, ParameterSpecs members,
                                          std::string doc) {
  ParameterSpec spec = declare(std::move(name), ParameterType::kGroupList, 0LL, std::move(doc));
  spec.members = std::make_shared<const ParameterSpecs>(std::move(members));
  return add(std::move(spec));
}

ParameterSpecs& ParameterSpecs::required() {
  if (specs_.empty()) throw InvalidArgument("required(): no parameter declared yet");
  specs_.back().required = true;
  return *this;
}

ParameterSpecs& ParameterSpecs::include(const ParameterSpecs& group) {
  for (const ParameterSpec& spec : group.specs_) add(spec);
  return *this;
}

const ParameterSpec* ParameterSpecs::find(std::string_view name) const {
  for (const auto& spec : specs_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

namespace {

/// What resolve() collects per declared parameter before the nested ones are resolved.
struct Pending {
  std::string where;                                    ///< where its own value was set
  std::vector<ParameterAssignment> inner;               ///< a plugin's or group's
  std::vector<std::vector<ParameterAssignment>> items;  ///< a group list's, by index
};

/// Items come in order, so a list holds what its file writes out: this bounds an index's
/// digits, not the memory (a box_list of 10^6 boxes is valid).
constexpr long long kMaxItems = 10000000;

/// A plugin parameter's chosen plugin, resolved with its own assignments.
ParameterSet resolvePlugin(const ParameterSpec& spec, const std::string& key,
                           const Pending& pending, const std::string& owner) {
  const std::string where =
      pending.where.empty() ? "the default of '" + spec.name + "'" : pending.where;
  const PluginRegistryBase* registry = findPluginRegistry(spec.kind);
  if (!registry) {
    throw ConfigError(where + ": " + owner + ": parameter '" + spec.name +
                      "' names a plugin of kind '" + spec.kind + "', which kinolab has not");
  }
  if (!registry->contains(key)) {
    const auto known = registry->keys();
    throw ConfigError(where + ": " + owner + ": parameter '" + spec.name + "': unknown " +
                      spec.kind + " '" + key + "'" + didYouMean(key, known) + "; known " +
                      registry->plural() + ": " +
                      (known.empty() ? std::string("none") : join(known, ", ")));
  }
  return registry->resolve(key, pending.inner, where);
}

/// `inner` (INDEX.PARAMETER, from `assignment`) into the group list's pending items.
void addItemAssignment(const ParameterSpec& spec, ParameterAssignment inner,
                       const ParameterAssignment& assignment, const std::string& owner,
                       Pending& pending) {
  const auto next = inner.name.find('.');
  const std::string index = inner.name.substr(0, next);
  const bool digits =
      !index.empty() && index.size() <= 7 && (index.size() == 1 || index.front() != '0') &&
      std::all_of(index.begin(), index.end(), [](char c) { return c >= '0' && c <= '9'; });
  const auto item = digits ? parseInteger(index) : std::nullopt;
  // Items come in order: an index at most one past the last (no gaps, no huge index).
  const auto count = static_cast<long long>(pending.items.size());
  if (!item || *item > count || *item >= kMaxItems || next == std::string::npos) {
    throw ConfigError(assignment.where + ": " + owner + ": parameter '" + assignment.name +
                      "': expected " + spec.name + ".INDEX.PARAMETER, INDEX one of 0.." +
                      std::to_string(std::min(count, kMaxItems - 1)) + " (items in order)");
  }
  inner.name = inner.name.substr(next + 1);
  if (pending.items.size() <= static_cast<std::size_t>(*item)) pending.items.resize(*item + 1);
  pending.items[*item].push_back(std::move(inner));
}

}  // namespace

ParameterSet ParameterSpecs::resolve(const std::vector<ParameterAssignment>& assignments,
                                     std::string_view owner, std::string_view where) const {
  const std::string own(owner);
  ParameterSet result;
  for (const auto& spec : specs_) result.values_.emplace_back(spec.name, spec.default_value);
  std::vector<Pending> pending(specs_.size());
  std::vector<bool> assigned(specs_.size(), false);
  for (const auto& assignment : assignments) {
    const auto dot = assignment.name.find('.');
    const bool nested = dot != std::string::npos;
    const ParameterSpec* spec = find(assignment.name.substr(0, dot));
    const bool nests =
        spec && (spec->type == ParameterType::kPlugin || spec->type == ParameterType::kGroup ||
                 spec->type == ParameterType::kGroupList);
    if (nested && !nests) {
      throw ConfigError(assignment.where + ": " + own + ": unknown parameter '" + assignment.name +
                        "': it has no plugin parameter '" + assignment.name.substr(0, dot) +
                        "' to set it on");
    }
    if (!spec) {
      const auto names = namesOf(specs_);
      throw ConfigError(
          assignment.where + ": " + own + ": unknown parameter '" + assignment.name + "'" +
          didYouMean(assignment.name, names) +
          (names.empty() ? "; it takes no parameters" : "; its parameters: " + join(names, ", ")));
    }
    const std::size_t index = static_cast<std::size_t>(spec - specs_.data());
    assigned[index] = true;
    if (!nested && assignment.mapping && spec->type != ParameterType::kPlugin &&
        spec->type != ParameterType::kGroup) {
      throw ConfigError(assignment.where + ": " + own + ": parameter '" + assignment.name +
                        "': expected a value (" + spec->rangeText() + "), not a mapping");
    }
    if (!nested) {
      const std::string context =
          assignment.where + ": " + own + ": parameter '" + assignment.name + "'";
      result.values_[index].second = parseValue(*spec, assignment.value, context);
      pending[index].where = assignment.where;
      continue;
    }
    ParameterAssignment inner = assignment;
    inner.name = assignment.name.substr(dot + 1);
    if (spec->type == ParameterType::kGroup) result.values_[index].second = true;
    if (spec->type != ParameterType::kGroupList) {
      pending[index].inner.push_back(std::move(inner));
    } else {
      addItemAssignment(*spec, std::move(inner), assignment, own, pending[index]);
      result.values_[index].second = static_cast<long long>(pending[index].items.size());
    }
  }
  for (std::size_t index = 0; index < specs_.size(); ++index) {
    const ParameterSpec& spec = specs_[index];
    if (spec.required && !assigned[index]) {
      throw ConfigError((where.empty() ? std::string() : std::string(where) + ": ") + own +
                        ": missing parameter '" + spec.name + "' (" + spec.doc + ")");
    }
    const std::string inside = own + ": " + spec.name;
    if (spec.type == ParameterType::kPlugin) {
      const std::string& key = std::get<std::string>(result.values_[index].second);
      result.nested_.emplace_back(spec.name, std::make_shared<const ParameterSet>(
                                                 resolvePlugin(spec, key, pending[index], own)));
    } else if (spec.type == ParameterType::kGroup) {
      result.nested_.emplace_back(spec.name,
                                  std::make_shared<const ParameterSet>(
                                      spec.members->resolve(pending[index].inner, inside, where)));
    } else if (spec.type == ParameterType::kGroupList) {
      const auto& items = pending[index].items;
      for (std::size_t i = 0; i < items.size(); ++i) {
        result.nested_.emplace_back(
            spec.name + "." + std::to_string(i),
            std::make_shared<const ParameterSet>(spec.members->resolve(
                items[i], inside + "[" + std::to_string(i) + "]",
                items[i].empty() ? where : std::string_view(items[i].front().where))));
      }
    }
  }
  return result;
}

std::string formatParameterValue(const ParameterValue& value) {
  struct Formatter {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(long long i) const { return std::to_string(i); }
    std::string operator()(double d) const { return formatNumber(d); }
    std::string operator()(const std::string& s) const { return s; }
    std::string operator()(const std::vector<double>& v) const {
      std::string text = "[";
      for (std::size_t i = 0; i < v.size(); ++i) text += (i ? ", " : "") + formatNumber(v[i]);
      return text + "]";
    }
  };
  return std::visit(Formatter{}, value);
}

}  // namespace kinolab
