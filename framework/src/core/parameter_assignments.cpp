// Assignments of parameters as users write them: `NAME=VALUE` on the command line, and YAML
// mappings (nested plugin and group parameters flattened to NAME.KEY, lists kept whole).
#include <string>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/parameters.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/yaml_reader.hpp"

namespace kinolab {

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

/// The numbers of a sequence (nested sequences flattened) as text: "1,2,3" (no brackets).
std::string joinedScalars(const YamlReader& sequence) {
  std::string text;
  for (const YamlReader& item : sequence.items()) {
    std::string value;
    if (item.isSequence()) {  // kept in brackets: a nested list is not a list of numbers
      value = "[";
      value += joinedScalars(item);
      value += "]";
    } else {
      value = item.as<std::string>();
    }
    if (!value.empty()) text += (text.empty() ? "" : ",") + value;
  }
  return text;
}

/// The entries of `mapping` as assignments named `prefix` + key. A mapping value is a plugin
/// parameter's (its `type` chooses the plugin) or a group's; a sequence of mappings is a group
/// list's (`NAME.INDEX.KEY`); a sequence of numbers is one value ("[1,2,3]").
void appendAssignments(const YamlReader& mapping, const std::string& prefix,
                       std::vector<ParameterAssignment>& result) {
  for (const auto& [name, value] : mapping.entries()) {
    if (!prefix.empty() && name == "type") {
      result.push_back(
          {prefix.substr(0, prefix.size() - 1), value.as<std::string>(), value.where(), true});
    } else if (value.isMap()) {
      const std::size_t before = result.size();
      appendAssignments(value, prefix + name + ".", result);
      // An empty mapping still says the group is there.
      if (result.size() == before) result.push_back({prefix + name, "true", value.where(), true});
    } else if (value.isSequence() && !value.items().empty() && value.items().front().isMap()) {
      const auto items = value.items();
      for (std::size_t i = 0; i < items.size(); ++i) {
        if (!items[i].isMap()) items[i].fail("expected a mapping, as the first item is");
        if (items[i].entries().empty()) items[i].fail("an empty item: give its parameters");
        appendAssignments(items[i], prefix + name + "." + std::to_string(i) + ".", result);
      }
    } else if (value.isSequence()) {
      // In brackets: a list is never read as one number (`density: [1]` is refused).
      // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "[" + ...
      std::string text = "[";
      text += joinedScalars(value);
      text += "]";
      result.push_back({prefix + name, std::move(text), value.where()});
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
