// kinolab._core's plugin registries: every kind's plugins with their parameters and
// statistics, as `kinolab list` prints them, and loading a plugin library.
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab::python {

py::object parameterValue(const ParameterValue& value) {
  return std::visit([](const auto& v) -> py::object { return py::cast(v); }, value);
}

namespace {

py::list parameterList(const ParameterSpecs& specs) {
  py::list list;
  for (const ParameterSpec& spec : specs.all()) {
    py::dict item;
    item["name"] = spec.name;
    item["type"] = spec.typeName();
    item["default"] = parameterValue(spec.default_value);
    item["range"] = spec.rangeText();
    item["doc"] = spec.doc;
    list.append(item);
  }
  return list;
}

py::list metricList(const MetricSpecs& specs) {
  py::list list;
  for (const MetricSpec& spec : specs.all()) {
    py::dict item;
    item["name"] = spec.name;
    item["type"] = spec.typeName();
    item["unit"] = spec.unit;
    item["clock"] = spec.clock;
    item["series"] = spec.series;
    item["doc"] = spec.doc;
    list.append(item);
  }
  return list;
}

/// The plugins of one kind ("planners", "heuristics", ...: kinolab list's names) with their
/// parameters and statistics.
py::list pluginList(const std::string& kind) {
  const PluginRegistryBase* registry = findPluginRegistry(kind);
  if (!registry) {
    std::vector<std::string> kinds;
    for (const PluginRegistryBase* known : pluginRegistries()) kinds.push_back(known->plural());
    throw InvalidArgument("unknown plugin kind '" + kind + "'" + didYouMean(kind, kinds) +
                          "; kinds: " + join(kinds, ", "));
  }
  py::list list;
  for (const PluginInfo* info : registry->list()) {
    py::dict item;
    item["key"] = info->key;
    item["description"] = info->description;
    item["origin"] = info->origin;
    item["parameters"] = parameterList(info->parameters);
    item["statistics"] = metricList(info->statistics);
    list.append(item);
  }
  return list;
}

}  // namespace

void bindPlugins(py::module_& m) {
  m.def("plugins", &pluginList, py::arg("kind"),
        "The plugins of a kind (planners, samplers, heuristics, lower_bounds, worlds, sensors, "
        "search_spaces) with their parameters");
  m.def("plugin_kinds", [] {
    std::vector<std::string> kinds;
    for (const PluginRegistryBase* registry : pluginRegistries())
      kinds.push_back(registry->plural());
    return kinds;
  });
  m.def("load_plugin", &loadPluginLibrary);
  m.def("metrics", [] {
    py::dict dict;
    dict["result"] = metricList(resultMetrics());
    dict["statistics"] = metricList(commonStatistics());
    return dict;
  });
}

}  // namespace kinolab::python
