#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/metric_specs.hpp"
#include "kinolab/core/parameters.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {

/// What `kinolab list` shows of a plugin.
struct PluginInfo {
  std::string key;          ///< the name used in configs and on the command line
  std::string description;  ///< one line
  ParameterSpecs parameters;
  std::string origin;  ///< "built-in" or the path of the shared library it came from
  /// The statistics its instances report (planners); results carry exactly these.
  MetricSpecs statistics;
};

template <typename Interface>
using PluginFactory = std::function<std::unique_ptr<Interface>(const ParameterSet&)>;

/// The plugins of one kind (samplers, planners), by key. One instance per kind lives in the
/// framework library (`pluginRegistry<Interface>()`), so in-tree plugins and libraries loaded
/// at run time share it.
template <typename Interface>
class PluginRegistry {
 public:
  explicit PluginRegistry(std::string kind) : kind_(std::move(kind)) {}

  /// "sampler", "planner".
  const std::string& kind() const { return kind_; }

  bool contains(std::string_view key) const { return entries_.count(std::string(key)) > 0; }

  /// Adds a plugin; a key that is already taken is a PluginError naming both origins.
  void add(PluginInfo info, PluginFactory<Interface> factory) {
    if (const auto found = entries_.find(info.key); found != entries_.end()) {
      throw PluginError(kind_ + " '" + info.key + "' from " + info.origin +
                        " is already registered (from " + found->second.info.origin + ")");
    }
    std::string key = info.key;
    entries_.emplace(std::move(key), Entry{std::move(info), std::move(factory)});
  }

  /// The plugin with this key; an unknown key is a PluginError listing the known ones.
  const PluginInfo& info(std::string_view key) const { return entry(key).info; }

  /// Every plugin, sorted by key.
  std::vector<const PluginInfo*> list() const {
    std::vector<const PluginInfo*> result;
    for (const auto& [key, entry] : entries_) result.push_back(&entry.info);
    return result;
  }

  std::vector<std::string> keys() const {
    std::vector<std::string> result;
    for (const auto& [key, entry] : entries_) result.push_back(key);
    return result;
  }

  /// The plugin's defaults overridden by `assignments`, validated (ConfigError when not).
  ParameterSet resolve(std::string_view key,
                       const std::vector<ParameterAssignment>& assignments) const {
    const Entry& found = entry(key);
    return found.info.parameters.resolve(assignments, kind_ + " '" + found.info.key + "'");
  }

  /// A new instance with its defaults overridden by `assignments` (validated first).
  std::unique_ptr<Interface> create(std::string_view key,
                                    const std::vector<ParameterAssignment>& assignments) const {
    return createResolved(key, resolve(key, assignments));
  }

  /// A new instance from parameters that resolve() returned.
  std::unique_ptr<Interface> createResolved(std::string_view key,
                                            const ParameterSet& parameters) const {
    auto instance = entry(key).factory(parameters);
    if (!instance) throw PluginError(kind_ + " '" + std::string(key) + "': factory returned null");
    return instance;
  }

 private:
  struct Entry {
    PluginInfo info;
    PluginFactory<Interface> factory;
  };

  const Entry& entry(std::string_view key) const {
    const auto found = entries_.find(std::string(key));
    if (found == entries_.end()) {
      const auto known = keys();
      throw PluginError("unknown " + kind_ + " '" + std::string(key) + "'" +
                        didYouMean(key, known) + "; known " + kind_ +
                        "s: " + (known.empty() ? std::string("none") : join(known, ", ")));
    }
    return found->second;
  }

  std::string kind_;
  std::map<std::string, Entry, std::less<>> entries_;
};

/// The one registry of each plugin interface. Declared here, specialised and defined next to
/// each interface (e.g. ControlSampler in kinolab/primitives/control_sampler.hpp).
template <typename Interface>
PluginRegistry<Interface>& pluginRegistry();

}  // namespace kinolab
