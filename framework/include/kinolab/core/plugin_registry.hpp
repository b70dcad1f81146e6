#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>
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

/// "plugin LIB (kind 'key')" for a plugin from a library, "kind 'key' (built-in (folder))"
/// otherwise: how errors from plugin code name it.
std::string describePlugin(std::string_view kind, const PluginInfo& info);

/// Called inside a catch block around a call into plugin code: a kinolab Error passes as it
/// is (it already says what was wrong), and so does std::bad_alloc (out of memory); any other
/// exception, standard or not (`throw 42`), becomes a PluginCodeError "WHO: CALL threw: what
/// it said".
[[noreturn]] void rethrowFromPlugin(std::string_view who, std::string_view call);

/// `call_plugin()`, its exceptions passed through rethrowFromPlugin(who, call).
template <typename Call>
auto guardPluginCall(std::string_view who, std::string_view call, Call&& call_plugin) {
  try {
    return call_plugin();
  } catch (...) {
    rethrowFromPlugin(who, call);
  }
}

/// What every registry has, whatever its interface: its kind and its plugins' declarations.
/// `kinolab list` and plugin-valued parameters (ParameterSpecs::plugin()) reach every kind
/// through this, by name (findPluginRegistry()).
class PluginRegistryBase {
 public:
  /// `kind` as in messages and parameter types ("heuristic"), `plural` as on the command line
  /// (`kinolab list heuristics`), `description` one line for `kinolab list`.
  PluginRegistryBase(std::string kind, std::string plural, std::string description);
  virtual ~PluginRegistryBase();
  PluginRegistryBase(const PluginRegistryBase&) = delete;
  PluginRegistryBase& operator=(const PluginRegistryBase&) = delete;

  const std::string& kind() const { return kind_; }
  const std::string& plural() const { return plural_; }
  const std::string& description() const { return description_; }

  /// Whether a plugin has this key. This and the other queries declare the plugins of modules
  /// not yet declared (detail::declarePendingModules(kind)) when they need them: a key not found,
  /// or every plugin.
  bool contains(std::string_view key) const;
  /// The plugin with this key; an unknown key is a PluginError listing the known ones.
  const PluginInfo& info(std::string_view key) const;
  /// Every plugin, sorted by key.
  std::vector<const PluginInfo*> list() const;
  std::vector<std::string> keys() const;
  /// The plugin's defaults overridden by `assignments`, validated (ConfigError when not;
  /// `where` locates a missing required parameter).
  ParameterSet resolve(std::string_view key, const std::vector<ParameterAssignment>& assignments,
                       std::string_view where = "") const;

  /// PluginRegistry::addDeferred() for a registry known by its kind (a module's manifest).
  virtual void addDeferredPlugin(PluginInfo info, std::function<void()> load) = 0;

 protected:
  /// Records a plugin's declaration; a key that is already taken is a PluginError naming
  /// both origins.
  void addInfo(PluginInfo info);

 private:
  std::string kind_;
  std::string plural_;
  std::string description_;
  /// The plugin with this key, or null (without declaring pending modules).
  const PluginInfo* find(std::string_view key) const;

  std::map<std::string, PluginInfo, std::less<>> infos_;
};

namespace detail {
/// Guards every registry's maps: shared to look up, unique to add. A map's entries are never
/// removed, so what a lookup returns stays valid after the lock.
std::shared_mutex& registryMutex();
/// Plugin modules are declared from their manifests on demand: `declare` runs (once, and
/// before any later registration of one of `kinds`, so a key taken twice is still found) when
/// a registry of one of `kinds` (empty: any) is asked for a key it lacks or for every plugin.
/// Reading the manifests cost a process that plans with built-in plugins alone about 8 % of
/// its time.
void addPendingModule(std::vector<std::string> kinds, std::function<void()> declare);
/// Runs the pending declarations of modules that may declare plugins of `kind` (empty: all),
/// one thread at a time; a call from inside one returns at once. After a declaration threw,
/// every later call throws its error again.
void declarePendingModules(std::string_view kind = {});
/// Pending declarations not yet run (for tests).
std::size_t pendingModules();
}  // namespace detail

/// The plugins of one kind (samplers, planners, heuristics, ...), by key. One instance per
/// kind lives in the framework library (`pluginRegistry<Interface>()`, defined with
/// KINOLAB_DEFINE_PLUGIN_REGISTRY), so in-tree plugins and libraries loaded at run time share
/// it.
template <typename Interface>
class PluginRegistry : public PluginRegistryBase {
 public:
  using PluginRegistryBase::PluginRegistryBase;
  explicit PluginRegistry(std::string kind) : PluginRegistryBase(kind, kind + "s", "") {}

  /// Adds a plugin; a key that is already taken is a PluginError naming both origins.
  void add(PluginInfo info, PluginFactory<Interface> factory) {
    std::string key = info.key;
    addInfo(std::move(info));
    const std::unique_lock lock(detail::registryMutex());
    factories_.emplace(std::move(key), std::move(factory));
  }

  /// A plugin whose code lives in a module loaded on first use (kinolab_add_plugin(... ON_USE)):
  /// its declaration comes from the module's manifest, and the first create() calls `load`
  /// (once, whatever thread), whose registration fulfil()s the factory.
  void addDeferred(PluginInfo info, std::function<void()> load) {
    auto slot = std::make_shared<PluginFactory<Interface>>();
    {
      const std::unique_lock lock(detail::registryMutex());
      deferred_.emplace(info.key, slot);
    }
    std::string origin = info.origin;
    std::string key = info.key;
    add(std::move(info),
        [load = std::move(load), slot, origin, key, kind = kind()](const ParameterSet& parameters) {
          load();
          if (!*slot) {
            throw PluginError("the module of " + kind + " '" + key + "' (" + origin +
                              ") no longer registers it, but its manifest does: rebuild kinolab");
          }
          return (*slot)(parameters);
        });
  }
  void addDeferredPlugin(PluginInfo info, std::function<void()> load) override {
    addDeferred(std::move(info), std::move(load));
  }
  /// Gives a deferred plugin (addDeferred()) its factory; false when `key` is not one.
  bool fulfil(std::string_view key, PluginFactory<Interface> factory) {
    const std::shared_lock lock(detail::registryMutex());
    const auto slot = deferred_.find(key);
    if (slot == deferred_.end()) return false;
    *slot->second = std::move(factory);  // once, by the module's load (std::call_once)
    return true;
  }

  /// A new instance with its defaults overridden by `assignments` (validated first).
  std::unique_ptr<Interface> create(std::string_view key,
                                    const std::vector<ParameterAssignment>& assignments) const {
    return createResolved(key, resolve(key, assignments));
  }

  /// A new instance from parameters that resolve() returned.
  std::unique_ptr<Interface> createResolved(std::string_view key,
                                            const ParameterSet& parameters) const {
    const PluginInfo& plugin = info(key);  // an unknown key is an error listing the known ones
    const PluginFactory<Interface>* factory = nullptr;
    {
      const std::shared_lock lock(detail::registryMutex());
      factory = &factories_.find(key)->second;
    }
    std::unique_ptr<Interface> instance;
    try {
      instance = (*factory)(parameters);
    } catch (...) {
      rethrowFromPlugin(describePlugin(kind(), plugin), "its factory");
    }
    if (!instance) throw PluginError(describePlugin(kind(), plugin) + ": factory returned null");
    return instance;
  }

  /// The instance a plugin-valued parameter (ParameterSpecs::plugin()) of `parameters` chose,
  /// configured by its nested parameters.
  std::unique_ptr<Interface> createChosen(const ParameterSet& parameters,
                                          std::string_view name) const {
    return createResolved(parameters.text(name), parameters.nested(name));
  }

 private:
  std::map<std::string, PluginFactory<Interface>, std::less<>> factories_;
  std::map<std::string, std::shared_ptr<PluginFactory<Interface>>, std::less<>> deferred_;
};

/// The one registry of each plugin interface. Declared here, defined next to each interface
/// with KINOLAB_DEFINE_PLUGIN_REGISTRY (e.g. ControlSampler in control_sampler.cpp).
template <typename Interface>
PluginRegistry<Interface>& pluginRegistry();

/// The registry of this kind ("sampler", "heuristic"; the plural "heuristics" too), or null.
const PluginRegistryBase* findPluginRegistry(std::string_view kind);
/// Every registry, in the order the framework lists them.
std::vector<const PluginRegistryBase*> pluginRegistries();

namespace detail {
/// findPluginRegistry() for adding to it (a module's manifest declares plugins by kind).
PluginRegistryBase* findMutablePluginRegistry(std::string_view kind);
/// Adds a registry to the directory findPluginRegistry() searches (at most one per kind).
void listPluginRegistry(const PluginRegistryBase& registry, int order);
}  // namespace detail

}  // namespace kinolab

/// Defines pluginRegistry<Interface>() and lists it under `kind` (made when the library
/// loads, so `kinolab list` and plugin-valued parameters see every kind, registered to or
/// not); used inside namespace kinolab. `order` (a literal integer, unique) sorts the kinds
/// in listings.
#define KINOLAB_DEFINE_PLUGIN_REGISTRY(Interface, kind, plural, description, order)        \
  template <>                                                                              \
  PluginRegistry<Interface>& pluginRegistry<Interface>() {                                 \
    static PluginRegistry<Interface> registry(kind, plural, description);                  \
    static const bool listed = (detail::listPluginRegistry(registry, order), true);        \
    (void)listed;                                                                          \
    return registry;                                                                       \
  }                                                                                        \
  namespace {                                                                              \
  [[maybe_unused]] const bool registry_made_##order = (pluginRegistry<Interface>(), true); \
  }
