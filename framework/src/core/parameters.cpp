#include "kinolab/core/parameters.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>

#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/yaml_reader.hpp"

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

/// The value of `text` for `spec`, or an explanation of why it is not one.
ParameterValue parseValue(const ParameterSpec& spec, const std::string& text,
                          const std::string& context) {
  const auto reject = [&](const std::string& expected) -> ParameterValue {
    throw ConfigError(context + ": expected " + expected + ", got '" + text + "'");
  };
  switch (spec.type) {
    case ParameterType::kBoolean:
      if (const auto value = parseBoolean(text)) return *value;
      return reject("true or false");
    case ParameterType::kInteger: {
      const auto value = parseInteger(text);
      if (!value) return reject("an integer in " + spec.rangeText());
      if (*value < spec.minimum || *value > spec.maximum) {
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
    case ParameterType::kChoice:
      if (std::find(spec.choices.begin(), spec.choices.end(), text) == spec.choices.end()) {
        return reject("one of " + spec.rangeText() + didYouMean(text, spec.choices));
      }
      return text;
    case ParameterType::kText:
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
    case ParameterType::kPlugin:
      return kind;
  }
  return "?";
}

std::string ParameterSpec::rangeText() const {
  switch (type) {
    case ParameterType::kBoolean:
      return "true|false";
    case ParameterType::kInteger:
    case ParameterType::kReal: {
      // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "[" + ...
      std::string text = "[";
      text += formatNumber(minimum);
      text += ", ";
      text += formatNumber(maximum);
      text += "]";
      return text;
    }
    case ParameterType::kChoice:
      return join(choices, "|");
    case ParameterType::kText:
      return "any text";
    case ParameterType::kPlugin: {
      const PluginRegistryBase* registry = findPluginRegistry(kind);
      return "key: list " + (registry ? registry->plural() : kind);
    }
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
  throw InvalidArgument("parameter '" + std::string(name) + "' is not a plugin parameter");
}

std::vector<std::pair<std::string, ParameterValue>> ParameterSet::flattened() const {
  std::vector<std::pair<std::string, ParameterValue>> result;
  for (const auto& [name, value] : values_) {
    result.emplace_back(name, value);
    for (const auto& [key, set] : nested_) {
      if (key != name) continue;
      for (auto& [inner, inner_value] : set->flattened()) {
        result.emplace_back(name + "." + inner, std::move(inner_value));
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
      if (key == name && !set->values_.empty()) text += '{' + set->canonical() + '}';
    }
  }
  return text;
}

ParameterSpecs& ParameterSpecs::add(ParameterSpec spec) {
  if (find(spec.name)) throw InvalidArgument("parameter '" + spec.name + "' declared twice");
  if (spec.name.find('.') != std::string::npos) {
    throw InvalidArgument("parameter '" + spec.name + "': '.' separates a plugin parameter's own");
  }
  if (spec.type == ParameterType::kPlugin && spec.kind == "sampler" && samplerParameter()) {
    throw InvalidArgument("parameter '" + spec.name + "': a plugin takes at most one sampler");
  }
  // A declared default must itself be acceptable.
  parseValue(spec, formatParameterValue(spec.default_value), "default of '" + spec.name + "'");
  specs_.push_back(std::move(spec));
  return *this;
}

ParameterSpecs& ParameterSpecs::boolean(std::string name, bool default_value, std::string doc) {
  return add({std::move(name), ParameterType::kBoolean, default_value, 0, 1, {}, std::move(doc), {}});
}

ParameterSpecs& ParameterSpecs::integer(std::string name, long long default_value,
                                        long long minimum, long long maximum, std::string doc) {
  return add({std::move(name),
              ParameterType::kInteger,
              default_value,
              static_cast<double>(minimum),
              static_cast<double>(maximum),
              {},
              std::move(doc),
              {}});
}

ParameterSpecs& ParameterSpecs::real(std::string name, double default_value, double minimum,
                                     double maximum, std::string doc) {
  return add(
      {std::move(name), ParameterType::kReal, default_value, minimum, maximum, {}, std::move(doc), {}});
}

ParameterSpecs& ParameterSpecs::choice(std::string name, std::string default_value,
                                       std::vector<std::string> choices, std::string doc) {
  return add({std::move(name), ParameterType::kChoice, std::move(default_value), 0, 0,
              std::move(choices), std::move(doc), {}});
}

ParameterSpecs& ParameterSpecs::text(std::string name, std::string default_value, std::string doc) {
  return add(
      {std::move(name), ParameterType::kText, std::move(default_value), 0, 0, {}, std::move(doc), {}});
}

ParameterSpecs& ParameterSpecs::plugin(std::string kind, std::string name,
                                       std::string default_value, std::string doc) {
  return add({std::move(name), ParameterType::kPlugin, std::move(default_value), 0, 0, {},
              std::move(doc), std::move(kind)});
}

ParameterSpecs& ParameterSpecs::sampler(std::string name, std::string default_value,
                                        std::string doc) {
  return plugin("sampler", std::move(name), std::move(default_value), std::move(doc));
}

ParameterSpecs& ParameterSpecs::include(const ParameterSpecs& group) {
  for (const ParameterSpec& spec : group.specs_) add(spec);
  return *this;
}

const ParameterSpec* ParameterSpecs::samplerParameter() const {
  for (const auto& spec : specs_) {
    if (spec.type == ParameterType::kPlugin && spec.kind == "sampler") return &spec;
  }
  return nullptr;
}

const ParameterSpec* ParameterSpecs::find(std::string_view name) const {
  for (const auto& spec : specs_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

ParameterSet ParameterSpecs::resolve(const std::vector<ParameterAssignment>& assignments,
                                     std::string_view owner) const {
  ParameterSet result;
  for (const auto& spec : specs_) result.values_.emplace_back(spec.name, spec.default_value);
  // Where each plugin parameter's key was set, and the assignments of its own parameters.
  std::vector<std::string> key_where(specs_.size());
  std::vector<std::vector<ParameterAssignment>> inner(specs_.size());
  for (const auto& assignment : assignments) {
    const auto dot = assignment.name.find('.');
    const ParameterSpec* spec = find(assignment.name.substr(0, dot));
    const bool nested = dot != std::string::npos;
    if (nested && (!spec || spec->type != ParameterType::kPlugin)) {
      throw ConfigError(assignment.where + ": " + std::string(owner) + ": unknown parameter '" +
                        assignment.name + "': it has no plugin parameter '" +
                        assignment.name.substr(0, dot) + "' to set it on");
    }
    if (!spec) {
      const auto names = namesOf(specs_);
      throw ConfigError(
          assignment.where + ": " + std::string(owner) + ": unknown parameter '" + assignment.name +
          "'" + didYouMean(assignment.name, names) +
          (names.empty() ? "; it takes no parameters" : "; its parameters: " + join(names, ", ")));
    }
    const std::size_t index = static_cast<std::size_t>(spec - specs_.data());
    if (nested) {
      ParameterAssignment own = assignment;
      own.name = assignment.name.substr(dot + 1);
      inner[index].push_back(std::move(own));
      continue;
    }
    const std::string context =
        assignment.where + ": " + std::string(owner) + ": parameter '" + assignment.name + "'";
    result.values_[index].second = parseValue(*spec, assignment.value, context);
    key_where[index] = assignment.where;
  }
  for (std::size_t index = 0; index < specs_.size(); ++index) {
    const ParameterSpec& spec = specs_[index];
    if (spec.type != ParameterType::kPlugin) continue;
    const std::string& key = std::get<std::string>(result.values_[index].second);
    const std::string where =
        key_where[index].empty() ? "the default of '" + spec.name + "'" : key_where[index];
    const PluginRegistryBase* registry = findPluginRegistry(spec.kind);
    if (!registry) {
      throw ConfigError(where + ": " + std::string(owner) + ": parameter '" + spec.name +
                        "' names a plugin of kind '" + spec.kind + "', which kinolab has not");
    }
    if (!registry->contains(key)) {
      const auto known = registry->keys();
      throw ConfigError(where + ": " + std::string(owner) + ": parameter '" + spec.name +
                        "': unknown " + spec.kind + " '" + key + "'" + didYouMean(key, known) +
                        "; known " + registry->plural() + ": " +
                        (known.empty() ? std::string("none") : join(known, ", ")));
    }
    result.nested_.emplace_back(
        spec.name, std::make_shared<const ParameterSet>(registry->resolve(key, inner[index])));
  }
  return result;
}

std::string formatParameterValue(const ParameterValue& value) {
  struct Formatter {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(long long i) const { return std::to_string(i); }
    std::string operator()(double d) const { return formatNumber(d); }
    std::string operator()(const std::string& s) const { return s; }
  };
  return std::visit(Formatter{}, value);
}

std::vector<ParameterAssignment> parseAssignments(const std::vector<std::string>& items,
                                                  std::string_view where) {
  std::vector<ParameterAssignment> result;
  for (const auto& item : items) {
    const auto equals = item.find('=');
    if (equals == std::string::npos || equals == 0) {
      throw ConfigError(std::string(where) + ": expected name=value, got '" + item + "'");
    }
    result.push_back({item.substr(0, equals), item.substr(equals + 1), std::string(where)});
  }
  return result;
}

namespace {

/// The entries of `mapping` as assignments named `prefix` + key; a mapping value is a plugin
/// parameter's: its `type` chooses the plugin, its other keys are the plugin's parameters.
void appendAssignments(const YamlReader& mapping, const std::string& prefix,
                       std::vector<ParameterAssignment>& result) {
  for (const auto& [name, value] : mapping.entries()) {
    if (!prefix.empty() && name == "type") {
      result.push_back({prefix.substr(0, prefix.size() - 1), value.as<std::string>(),
                        value.where()});
    } else if (value.isMap()) {
      appendAssignments(value, prefix + name + ".", result);
    } else {
      result.push_back({prefix + name, value.as<std::string>(), value.where()});
    }
  }
}

}  // namespace

std::vector<ParameterAssignment> assignmentsFromYaml(const YamlReader& mapping) {
  std::vector<ParameterAssignment> result;
  appendAssignments(mapping, "", result);
  return result;
}

}  // namespace kinolab
