#include "kinolab/core/plugin.hpp"

#include <dlfcn.h>

#include <filesystem>
#include <mutex>
#include <set>

namespace kinolab {
namespace {

std::map<std::string, std::string>& libraryVersions() {
  static std::map<std::string, std::string> versions;
  return versions;
}

}  // namespace

void PluginRegistrar::commit() {
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Pending& item = pending_[i];
    for (std::size_t j = 0; j < i; ++j) {
      if (pending_[j].kind == item.kind && pending_[j].key == item.key) {
        throw PluginError(origin_ + ": registers " + item.kind + " '" + item.key + "' twice");
      }
    }
    if (item.taken(item.key)) {
      throw PluginError(item.kind + " '" + item.key + "' from " + origin_ +
                        " is already registered; pick another key");
    }
  }
  for (auto& item : pending_) item.apply();
  pending_.clear();
  auto& versions = libraryVersions();
  for (auto& [name, version] : libraries_) versions.emplace(std::move(name), std::move(version));
  libraries_.clear();
}

const std::map<std::string, std::string>& pluginLibraryVersions() { return libraryVersions(); }

void loadPluginLibrary(const std::string& path) {
  static std::mutex mutex;
  static std::set<std::string> loaded;
  const std::lock_guard lock(mutex);

  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    throw PluginError("plugin library '" + path + "': no such file");
  }
  const std::string canonical = std::filesystem::canonical(path).string();
  if (loaded.count(canonical)) return;

  // Never closed: the factories it registered point into it.
  void* handle = dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* reason = dlerror();
    throw PluginError("plugin library '" + path +
                      "': cannot be loaded: " + (reason ? reason : "unknown reason"));
  }
  using AbiFunction = int (*)();
  using EntryFunction = void (*)(PluginRegistrar&);
  const auto abi = reinterpret_cast<AbiFunction>(dlsym(handle, "kinolab_plugin_abi_version"));
  const auto entry = reinterpret_cast<EntryFunction>(dlsym(handle, "kinolab_register_plugins"));
  if (!abi || !entry) {
    dlclose(handle);
    throw PluginError("plugin library '" + path +
                      "': no kinolab entry point (kinolab_register_plugins); define one with "
                      "KINOLAB_REGISTER_PLUGINS(registrar) from kinolab/core/plugin.hpp");
  }
  if (abi() != KINOLAB_PLUGIN_ABI_VERSION) {
    dlclose(handle);
    throw PluginError("plugin library '" + path + "': built for plugin ABI " +
                      std::to_string(abi()) + ", this kinolab has ABI " +
                      std::to_string(KINOLAB_PLUGIN_ABI_VERSION) + "; rebuild it");
  }
  PluginRegistrar registrar(canonical);
  entry(registrar);
  registrar.commit();
  loaded.insert(canonical);
}

}  // namespace kinolab
