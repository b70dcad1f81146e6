// The manifest of a plugin module loaded on use: what the module declares (every plugin's kind,
// key, description, parameters and statistics, and the libraries it records), as JSON beside
// the module, so that kinolab knows its plugins without loading it.
#include <charconv>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "kinolab/core/files.hpp"
#include "kinolab/core/plugin.hpp"

namespace kinolab {
namespace {

using Json = nlohmann::json;

/// Bumped when the manifest's layout changes (a manifest of another format is refused).
constexpr int kManifestFormat = 1;

/// A number as text that reads back to the same double (infinities included).
Json number(double value) {
  char text[64];
  const auto end = std::to_chars(text, text + sizeof(text), value).ptr;
  return std::string(text, end);
}

double readNumber(const Json& json) {
  const auto& text = json.get_ref<const std::string&>();
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) {
    throw std::invalid_argument("'" + text + "' is not a number");
  }
  return value;
}

Json numbers(const std::vector<double>& values) {
  Json list = Json::array();
  for (const double value : values) list.push_back(number(value));
  return list;
}

std::vector<double> readNumbers(const Json& json) {
  std::vector<double> values;
  for (const Json& item : json) values.push_back(readNumber(item));
  return values;
}

/// An enumerator stored as its index, checked against the count on reading.
template <typename Enum>
Enum readEnum(const Json& json, int count, const char* what) {
  const int index = json.get<int>();
  if (index < 0 || index >= count) {
    throw std::invalid_argument(std::string(what) + " " + std::to_string(index) + " is unknown");
  }
  return static_cast<Enum>(index);
}

Json value(const ParameterValue& parameter) {
  Json json = Json::array({parameter.index()});
  std::visit(
      [&](const auto& held) {
        using Held = std::decay_t<decltype(held)>;
        if constexpr (std::is_same_v<Held, double>) {
          json.push_back(number(held));
        } else if constexpr (std::is_same_v<Held, std::vector<double>>) {
          json.push_back(numbers(held));
        } else {
          json.push_back(held);
        }
      },
      parameter);
  return json;
}

ParameterValue readValue(const Json& json) {
  switch (json.at(0).get<int>()) {
    case 0:
      return json.at(1).get<bool>();
    case 1:
      return json.at(1).get<long long>();
    case 2:
      return readNumber(json.at(1));
    case 3:
      return json.at(1).get<std::string>();
    case 4:
      return readNumbers(json.at(1));
    default:
      throw std::invalid_argument("a parameter value of unknown type");
  }
}

Json parameters(const ParameterSpecs& specs) {
  Json list = Json::array();
  for (const ParameterSpec& spec : specs.all()) {
    Json item = {{"name", spec.name},
                 {"type", static_cast<int>(spec.type)},
                 {"default", value(spec.default_value)},
                 {"minimum", number(spec.minimum)},
                 {"maximum", number(spec.maximum)},
                 {"choices", spec.choices},
                 {"doc", spec.doc},
                 {"kind", spec.kind},
                 {"count", spec.count},
                 {"interval", spec.interval},
                 {"required", spec.required}};
    if (spec.members) item["members"] = parameters(*spec.members);
    list.push_back(std::move(item));
  }
  return list;
}

ParameterSpecs readParameters(const Json& json) {
  ParameterSpecs specs;
  for (const Json& item : json) {
    ParameterSpec spec;
    spec.name = item.at("name").get<std::string>();
    spec.type = readEnum<ParameterType>(
        item.at("type"), static_cast<int>(ParameterType::kGroupList) + 1, "parameter type");
    spec.default_value = readValue(item.at("default"));
    spec.minimum = readNumber(item.at("minimum"));
    spec.maximum = readNumber(item.at("maximum"));
    spec.choices = item.at("choices").get<std::vector<std::string>>();
    spec.doc = item.at("doc").get<std::string>();
    spec.kind = item.at("kind").get<std::string>();
    spec.count = item.at("count").get<std::size_t>();
    spec.interval = item.at("interval").get<bool>();
    spec.required = item.at("required").get<bool>();
    if (item.contains("members")) {
      spec.members = std::make_shared<const ParameterSpecs>(readParameters(item["members"]));
    }
    specs.add(std::move(spec));
  }
  return specs;
}

Json statistics(const MetricSpecs& specs) {
  Json list = Json::array();
  for (const MetricSpec& spec : specs.all()) {
    list.push_back({{"name", spec.name},
                    {"type", static_cast<int>(spec.type)},
                    {"unit", spec.unit},
                    {"doc", spec.doc},
                    {"clock", spec.clock},
                    {"series", spec.series},
                    {"direction", static_cast<int>(spec.direction)},
                    {"comparable", spec.comparable}});
  }
  return list;
}

MetricSpecs readStatistics(const Json& json) {
  MetricSpecs specs;
  for (const Json& item : json) {
    MetricSpec spec;
    spec.name = item.at("name").get<std::string>();
    spec.type = readEnum<MetricType>(item.at("type"), 4, "statistic type");
    spec.unit = item.at("unit").get<std::string>();
    spec.doc = item.at("doc").get<std::string>();
    spec.clock = item.at("clock").get<bool>();
    spec.series = item.at("series").get<bool>();
    spec.direction = readEnum<MetricDirection>(item.at("direction"), 3, "statistic direction");
    spec.comparable = item.at("comparable").get<bool>();
    specs.add(std::move(spec));
  }
  return specs;
}

}  // namespace

void writePluginManifest(const PluginDeclarations& declarations, const std::string& path) {
  Json plugins = Json::array();
  for (const auto& [kind, info] : declarations.plugins) {
    plugins.push_back({{"kind", kind},
                       {"key", info.key},
                       {"description", info.description},
                       {"parameters", parameters(info.parameters)},
                       {"statistics", statistics(info.statistics)}});
  }
  Json libraries = Json::array();
  for (const auto& [name, version] : declarations.libraries) {
    libraries.push_back({{"name", name}, {"version", version}});
  }
  const Json manifest = {
      {"format", kManifestFormat}, {"plugins", plugins}, {"libraries", libraries}};
  writeFileAtomically(path, manifest.dump() + "\n");
  std::set<std::string> kinds;
  for (const auto& [kind, info] : declarations.plugins) kinds.insert(kind);
  std::string lines;
  for (const std::string& kind : kinds) lines += kind + "\n";
  writeFileAtomically(pluginManifestKindsPath(path), lines);
}

std::string pluginManifestKindsPath(const std::string& manifest_path) {
  return std::filesystem::path(manifest_path).replace_extension(".kinds").string();
}

std::vector<std::string> readPluginManifestKinds(const std::string& manifest_path) {
  std::ifstream file(pluginManifestKindsPath(manifest_path));
  std::vector<std::string> kinds;
  for (std::string line; std::getline(file, line);) {
    if (!line.empty()) kinds.push_back(line);
  }
  return kinds;
}

PluginDeclarations readPluginManifest(const std::string& path) {
  const std::string where = "module manifest '" + path + "'";
  std::ifstream file(path);
  if (!file) throw PluginError(where + ": cannot be read; rebuild or reinstall kinolab");
  std::stringstream text;
  text << file.rdbuf();
  PluginDeclarations declarations;
  try {
    const Json manifest = Json::parse(text.str());
    if (manifest.at("format").get<int>() != kManifestFormat) {
      throw std::invalid_argument("format " + manifest.at("format").dump() + ", expected " +
                                  std::to_string(kManifestFormat));
    }
    for (const Json& plugin : manifest.at("plugins")) {
      PluginInfo info;
      info.key = plugin.at("key").get<std::string>();
      info.description = plugin.at("description").get<std::string>();
      info.parameters = readParameters(plugin.at("parameters"));
      info.statistics = readStatistics(plugin.at("statistics"));
      declarations.plugins.emplace_back(plugin.at("kind").get<std::string>(), std::move(info));
    }
    for (const Json& library : manifest.at("libraries")) {
      declarations.libraries.emplace_back(library.at("name").get<std::string>(),
                                          library.at("version").get<std::string>());
    }
  } catch (const std::exception& error) {  // nlohmann's, a spec refused, a bad number
    throw PluginError(where + ": " + error.what() + "; rebuild or reinstall kinolab");
  }
  return declarations;
}

}  // namespace kinolab
