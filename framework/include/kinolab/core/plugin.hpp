#pragma once

// What a plugin source file includes to register itself:
//
//   KINOLAB_REGISTER_PLUGINS(registrar) {
//     registrar.add<ControlSampler>("my_sampler", "one line", ParameterSpecs().real(...),
//                                   [](const ParameterSet& p) { return ...; });
//   }
//
// A planner also declares the statistics it reports (a fifth argument, MetricSpecs): each
// reaches `kinolab plan`'s JSON, results.sqlite and the report with no other edit.
//
// The same source builds in-tree (a folder under plugins/, compiled into kinolab) and
// out-of-tree (a shared library built against an installed kinolab and loaded with
// `--plugin PATH`); `kinolab_add_plugin()` in CMake chooses which.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "kinolab/core/parameters.hpp"
#include "kinolab/core/plugin_registry.hpp"

/// Bumped whenever a change to the plugin-facing headers breaks binary compatibility; a
/// library built against another version is refused when loaded.
#define KINOLAB_PLUGIN_ABI_VERSION 7

/// What a plugin library was built for, exported as plain data with C linkage
/// (`kinolab_plugin_abi_record`), so that loadPluginLibrary() reads it before any of the
/// library's functions is called and refuses a library built for another plugin ABI or
/// another C++ standard library layout.
struct KinolabPluginAbiRecord {
  std::uint32_t magic;        ///< kinolab's mark, 0x6b6e6c62 ("knlb")
  std::uint32_t abi;          ///< KINOLAB_PLUGIN_ABI_VERSION
  std::uint32_t cxx11_abi;    ///< _GLIBCXX_USE_CXX11_ABI: std::string's layout
  std::uint32_t string_size;  ///< sizeof(std::string)
};

#define KINOLAB_PLUGIN_ABI_RECORD \
  { 0x6b6e6c62u, KINOLAB_PLUGIN_ABI_VERSION, _GLIBCXX_USE_CXX11_ABI, sizeof(std::string) }

namespace kinolab {

/// What a plugin library declares: each plugin's kind and info, and the third-party libraries
/// it records (PluginRegistrar::library()).
struct PluginDeclarations {
  std::vector<std::pair<std::string, PluginInfo>> plugins;
  std::vector<std::pair<std::string, std::string>> libraries;
};

/// Collects the plugins one library (or one in-tree folder) registers and adds them all at
/// once, so a library with a clashing key adds nothing.
class PluginRegistrar {
 public:
  explicit PluginRegistrar(std::string origin) : origin_(std::move(origin)) {}

  template <typename Interface>
  void add(std::string key, std::string description, ParameterSpecs parameters,
           PluginFactory<Interface> factory, MetricSpecs statistics = {}) {
    PluginRegistry<Interface>& registry = pluginRegistry<Interface>();
    PluginInfo info{std::move(key), std::move(description), std::move(parameters), origin_,
                    std::move(statistics)};
    Pending item{registry.kind(),
                 info,
                 [&registry](const std::string& k) { return registry.contains(k); },
                 {},
                 {}};
    item.fulfil = [&registry, key = info.key, factory]() mutable {
      return registry.fulfil(key, std::move(factory));
    };
    item.apply = [&registry, info = std::move(info), factory = std::move(factory)]() mutable {
      registry.add(std::move(info), std::move(factory));
    };
    pending_.push_back(std::move(item));
  }

  /// Records the version of a third-party library the plugins of this library use
  /// (`library("ompl", OMPL_VERSION)`); it goes into every results database's provenance as
  /// `<name>_version`.
  void library(std::string name, std::string version) {
    libraries_.emplace_back(std::move(name), std::move(version));
  }

  /// Checks every pending key against the registries and each other, then adds them all.
  void commit();
  /// Gives each pending plugin's factory to the deferred plugin of its key that a module's
  /// manifest declared (PluginRegistry::addDeferred()); a plugin the manifest did not declare
  /// is a PluginError (the manifest is older than the module).
  void fulfil();
  /// What was registered so far, as declarations (kind, info) and library versions, without
  /// adding anything: what a module's manifest records.
  PluginDeclarations declarations() const;

 private:
  struct Pending {
    std::string kind;
    PluginInfo info;
    std::function<bool(const std::string&)> taken;
    std::function<void()> apply;
    std::function<bool()> fulfil;
  };

  std::string origin_;
  std::vector<Pending> pending_;
  std::vector<std::pair<std::string, std::string>> libraries_;
};

/// The third-party libraries registered plugins declared with PluginRegistrar::library(), by
/// name (a name declared twice keeps its first version).
const std::map<std::string, std::string>& pluginLibraryVersions();

/// Loads a plugin library (once per file, however its path is spelt): reads its ABI record,
/// calls its `kinolab_register_plugins` entry point and commits what it registered. A missing
/// file, a file that is not a loadable library, a missing entry point or record, an ABI
/// mismatch, an entry point that throws (anything) or a clashing key is a PluginError naming
/// the path, and the library registers nothing.
void loadPluginLibrary(const std::string& path);

/// What the plugin library at `path` declares, read by loading it (with loadPluginLibrary()'s
/// checks) into a registrar that adds nothing: a module's manifest is written from this.
PluginDeclarations declarePluginLibrary(const std::string& path);

/// Writes `declarations` as the JSON manifest of a module loaded on use (to a temporary file
/// renamed into place), and beside it the kinds it declares (pluginManifestKindsPath()), so a
/// process learns which registries a module adds to without parsing its manifest;
/// readPluginManifest() reads a manifest back, a missing, unreadable or malformed manifest
/// being a PluginError naming the file and what is wrong.
void writePluginManifest(const PluginDeclarations& declarations, const std::string& path);
PluginDeclarations readPluginManifest(const std::string& path);
/// The kinds file beside the manifest at `manifest_path` (its extension .kinds).
std::string pluginManifestKindsPath(const std::string& manifest_path);
/// The kinds the manifest at `manifest_path` declares, one a line in its kinds file; empty
/// when that file cannot be read (then the module may declare any kind).
std::vector<std::string> readPluginManifestKinds(const std::string& manifest_path);

/// Registers the plugins of a module loaded on use (kinolab_add_plugin(... ON_USE)): each is
/// declared from the module's manifest (so `kinolab list`, configurations and results see it)
/// when a registry of a kind it declares (its kinds file) is first asked for a key it lacks or
/// for all its plugins (detail::declarePendingModules()), with `origin` as its origin, and the
/// module at `module_path` is loaded (once) when the first of them is made. The manifest's library
/// versions are recorded with the declarations (pluginLibraryVersions() declares first).
void registerPluginModule(const std::string& module_path, const std::string& manifest_path,
                          const std::string& origin);

}  // namespace kinolab

#if defined(KINOLAB_BUILTIN_PLUGIN_ENTRY)
// In-tree: a uniquely named function that kinolab's generated builtin list calls.
#define KINOLAB_REGISTER_PLUGINS(registrar) \
  void KINOLAB_BUILTIN_PLUGIN_ENTRY(::kinolab::PluginRegistrar& registrar)
#else
// Out-of-tree: the exported C symbols loadPluginLibrary() looks up: the ABI record (data)
// and the entry point.
#define KINOLAB_REGISTER_PLUGINS(registrar)                                           \
  extern "C" __attribute__((visibility("default")))                                   \
  const KinolabPluginAbiRecord kinolab_plugin_abi_record = KINOLAB_PLUGIN_ABI_RECORD; \
  extern "C" __attribute__((visibility("default"))) void kinolab_register_plugins(    \
      ::kinolab::PluginRegistrar& registrar)
#endif
