// `kinolab list [KIND] [--json]`: every registered plugin with its parameters and statistics;
// `kinolab list metrics`: the result schema, every metric and statistic a run can carry.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/planner/planner.hpp"

namespace kinolab::apps {
namespace {

struct Kind {
  std::string name;  // plural, as on the command line
  std::vector<const PluginInfo*> plugins;
};

/// Every plugin kind, from the registries, in the order they are listed.
std::vector<Kind> allKinds() {
  std::vector<Kind> kinds;
  for (const PluginRegistryBase* registry : pluginRegistries()) {
    kinds.push_back({registry->plural(), registry->list()});
  }
  return kinds;
}

nlohmann::json toJson(const ParameterValue& value) {
  return std::visit([](const auto& v) { return nlohmann::json(v); }, value);
}

nlohmann::json toJson(const MetricSpecs& specs) {
  nlohmann::json list = nlohmann::json::array();
  for (const MetricSpec& spec : specs.all()) {
    list.push_back({{"name", spec.name},
                    {"type", spec.typeName()},
                    {"unit", spec.unit},
                    {"clock", spec.clock},
                    {"series", spec.series},
                    {"direction", spec.directionName()},
                    {"comparable", spec.comparable},
                    {"doc", spec.doc}});
  }
  return list;
}

void printMetrics(const char* title, const MetricSpecs& specs) {
  std::printf("  %s\n", title);
  for (const MetricSpec& spec : specs.all()) {
    std::printf("      %-26s %-8s %-8s %-6s %-6s %-4s %s\n", spec.name.c_str(),
                spec.typeName().c_str(), spec.unit.empty() ? "-" : spec.unit.c_str(),
                spec.series  ? "series"
                : spec.clock ? "clock"
                             : "",
                spec.directionName().c_str(), spec.comparable ? "all" : "own", spec.doc.c_str());
  }
}

/// The result schema: result and runner metrics (columns of `runs`), then the statistics
/// every planner reports and each planner's own.
void listMetrics(bool json) {
  const auto planners = pluginRegistry<Planner>().list();
  if (json) {
    nlohmann::json statistics = {{"common", toJson(commonStatistics())}};
    for (const PluginInfo* planner : planners) {
      statistics[planner->key] = toJson(planner->statistics);
    }
    // The edge states of stored search trees, by their one definition (toString).
    nlohmann::json edge_states = nlohmann::json::array();
    for (const auto state : {SearchTreeEdge::State::kPartial, SearchTreeEdge::State::kFull,
                             SearchTreeEdge::State::kCertified, SearchTreeEdge::State::kRejected}) {
      edge_states.push_back(std::string(toString(state)));
    }
    std::cout << nlohmann::json{{"schema_version", kResultsSchemaVersion},
                                {"result", toJson(resultMetrics())},
                                {"runner", toJson(runnerMetrics())},
                                {"statistics", statistics},
                                {"flight", toJson(flightMetrics())},
                                {"edge_states", edge_states}}
                     .dump(2)
              << '\n';
    return;
  }
  std::printf(
      "metrics (name, type, unit, clock figure, which way is better, comparable across all "
      "planners or only a planner's own, meaning)\n");
  printMetrics("every result (columns of results.sqlite's runs table):", resultMetrics());
  printMetrics("the runner, for every run (runs table):", runnerMetrics());
  printMetrics("statistics of every planner (statistics table):", commonStatistics());
  for (const PluginInfo* planner : planners) {
    const std::string title = "statistics of planner '" + planner->key + "':";
    printMetrics(title.c_str(), planner->statistics);
  }
  printMetrics("every flight (kinolab fly):", flightMetrics());
}

/// The flight's parameters, listed like a plugin's (`kinolab fly --flight NAME=VALUE`).
const PluginInfo& flightInfo() {
  static const PluginInfo info{"flight",
                               "closed-loop flight: sensor, map and replanning loop "
                               "(kinolab fly --flight NAME=VALUE)",
                               flightParameters(), "built-in", MetricSpecs()};
  return info;
}

/// The experiment file's own keys and a world spec's (their field lists), listed like a plugin's
/// parameters; the keys that name plugins (worlds, planners, generators, flight) have their
/// own kinds.
const PluginInfo& experimentInfo() {
  static const PluginInfo info = [] {
    ParameterSpecs keys = declareFields<Experiment>();
    keys.include(declareFields<ExperimentVariant>());
    return PluginInfo{"experiment",
                      "the experiment file's keys (kinolab run FILE) beside worlds, planners, "
                      "flight, plugins, extends, sweep and reproduces (docs/experiments.md)",
                      std::move(keys), "built-in", MetricSpecs()};
  }();
  return info;
}

const PluginInfo& worldSpecInfo() {
  static const PluginInfo info{"world_spec",
                               "a world spec's keys (configs/worlds/*.yaml, or inline in an "
                               "experiment) beside its generators (kinolab list worlds)",
                               declareFields<WorldSpec>(), "built-in", MetricSpecs()};
  return info;
}

/// The kinds `kinolab list` shows beside the plugin kinds, each with its keys (made when
/// listed).
struct FileKind {
  const char* name;
  const PluginInfo& (*info)();
};
constexpr FileKind kFileKinds[] = {
    {"flight", &flightInfo}, {"experiment", &experimentInfo}, {"world_spec", &worldSpecInfo}};

nlohmann::json toJson(const ParameterSpecs& specs) {
  nlohmann::json parameters = nlohmann::json::array();
  for (const auto& spec : specs.all()) {
    nlohmann::json parameter = {{"name", spec.name},
                                {"type", spec.typeName()},
                                {"default", toJson(spec.default_value)},
                                {"doc", spec.doc}};
    if (spec.type == ParameterType::kInteger || spec.type == ParameterType::kReal) {
      // JSON has no infinity: an open end is null.
      const bool integer = spec.type == ParameterType::kInteger;
      const auto bound = [integer](double x) -> nlohmann::json {
        if (!std::isfinite(x)) return nullptr;
        return integer ? nlohmann::json(static_cast<long long>(x)) : nlohmann::json(x);
      };
      parameter["minimum"] = bound(spec.minimum);
      parameter["maximum"] = bound(spec.maximum);
    }
    if (spec.type == ParameterType::kChoice) parameter["choices"] = spec.choices;
    if (spec.type == ParameterType::kPlugin) parameter["kind"] = spec.kind;
    if (spec.type == ParameterType::kReals) {
      parameter["minimum"] = spec.minimum;
      parameter["maximum"] = spec.maximum;
      parameter["count"] = spec.count;
    }
    if (spec.required) parameter["required"] = true;
    if (spec.members) parameter["members"] = toJson(*spec.members);
    parameters.push_back(parameter);
  }
  return parameters;
}

nlohmann::json toJson(const PluginInfo& plugin) {
  return {{"key", plugin.key},
          {"description", plugin.description},
          {"origin", plugin.origin},
          {"parameters", toJson(plugin.parameters)},
          {"statistics", toJson(plugin.statistics)}};
}

/// The widths of the parameter columns: at least the widest entry of each, members included.
struct Columns {
  int name = 0;
  int type = 7;
  int value = 10;
  int range = 18;
};

std::string defaultText(const ParameterSpec& spec) {
  return spec.required ? "(required)" : formatParameterValue(spec.default_value);
}

void measure(const ParameterSpecs& parameters, const std::string& prefix, Columns& columns) {
  for (const auto& spec : parameters.all()) {
    const std::string name = prefix + spec.name;
    columns.name = std::max(columns.name, static_cast<int>(name.size()));
    columns.type = std::max(columns.type, static_cast<int>(spec.typeName().size()));
    columns.value = std::max(columns.value, static_cast<int>(defaultText(spec).size()));
    columns.range = std::max(columns.range, static_cast<int>(spec.rangeText().size()));
    if (spec.members) {
      const bool list = spec.type == ParameterType::kGroupList;
      measure(*spec.members, name + (list ? ".INDEX." : "."), columns);
    }
  }
}

/// One line per parameter; a group's and a group list's members below it as NAME.PARAMETER
/// (NAME.INDEX.PARAMETER).
void printParameters(const ParameterSpecs& parameters, const std::string& prefix,
                     const Columns& columns) {
  for (const auto& spec : parameters.all()) {
    const std::string name = prefix + spec.name;
    std::printf("      %-*s %-*s default %-*s %-*s %s\n", columns.name, name.c_str(), columns.type,
                spec.typeName().c_str(), columns.value, defaultText(spec).c_str(), columns.range,
                spec.rangeText().c_str(), spec.doc.c_str());
    if (spec.members) {
      const bool list = spec.type == ParameterType::kGroupList;
      printParameters(*spec.members, name + (list ? ".INDEX." : "."), columns);
    }
  }
}

void printText(const Kind& kind) {
  std::printf("%s (%zu)\n", kind.name.c_str(), kind.plugins.size());
  for (const PluginInfo* plugin : kind.plugins) {
    std::printf("  %-16s %s\n", plugin->key.c_str(), plugin->description.c_str());
    std::printf("  %-16s from %s\n", "", plugin->origin.c_str());
    Columns columns;
    measure(plugin->parameters, "", columns);
    printParameters(plugin->parameters, "", columns);
  }
}

struct ListOptions {
  std::string kind;
  bool json = false;
};

void runList(const ListOptions& options) {
  if (options.kind == "metrics") return listMetrics(options.json);
  std::vector<Kind> kinds = allKinds();
  for (const FileKind& kind : kFileKinds) kinds.push_back({kind.name, {&kind.info()}});
  if (!options.kind.empty()) {
    std::erase_if(kinds, [&](const Kind& kind) { return kind.name != options.kind; });
  }
  if (options.json) {
    nlohmann::json document = nlohmann::json::object();
    for (const auto& kind : kinds) {
      document[kind.name] = nlohmann::json::array();
      for (const PluginInfo* plugin : kind.plugins) document[kind.name].push_back(toJson(*plugin));
    }
    std::cout << document.dump(2) << '\n';
    return;
  }
  for (const auto& kind : kinds) printText(kind);
}

}  // namespace

void addListCommand(CLI::App& app) {
  auto options = std::make_shared<ListOptions>();
  CLI::App* command = app.add_subcommand(
      "list",
      "List the registered plugins (built-in and loaded with --plugin) and their parameters");
  // Names only: listing the plugins themselves would read every module's manifest.
  std::vector<std::string> kind_names;
  for (const PluginRegistryBase* registry : pluginRegistries()) {
    kind_names.push_back(registry->plural());
  }
  const std::string description =
      "Only this kind of plugin (" + join(kind_names, ", ") +
      "), `flight` (the parameters of kinolab fly), `experiment` or `world_spec` (the keys of "
      "those files) or `metrics`: every metric and statistic a run or flight can carry";
  for (const FileKind& kind : kFileKinds) kind_names.push_back(kind.name);
  kind_names.push_back("metrics");
  command->add_option("kind", options->kind, description)
      ->check(CLI::Validator(
          [kind_names](const std::string& kind) -> std::string {
            if (std::find(kind_names.begin(), kind_names.end(), kind) != kind_names.end()) {
              return "";
            }
            return "unknown kind '" + kind + "'" + didYouMean(kind, kind_names) +
                   "; kinds: " + join(kind_names, ", ");
          },
          "KIND"));
  command->add_flag("--json", options->json, "Print JSON instead of a table");
  command->footer("Set a parameter with --set name=value or under `params:` in a config.");
  command->callback([options] { runList(*options); });
}

}  // namespace kinolab::apps
