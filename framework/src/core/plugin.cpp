#include "kinolab/core/plugin.hpp"

#include <dlfcn.h>
#include <link.h>

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <set>

namespace kinolab {
namespace {

std::map<std::string, std::string>& libraryVersions() {
  static std::map<std::string, std::string> versions;
  return versions;
}

void recordLibraries(const std::vector<std::pair<std::string, std::string>>& libraries) {
  auto& versions = libraryVersions();
  for (const auto& [name, version] : libraries) versions.emplace(name, version);
}

/// What the library's symbol table says `address` (from dlsym) is: "" when it is an object
/// of `size` bytes (size 0: a function), else what it is instead. A record smaller than
/// kinolab's would be read past its end, and data called as the entry point would crash.
std::string symbolProblem(void* address, std::size_t size) {
  Dl_info info{};
  ElfW(Sym)* symbol = nullptr;
  if (dladdr1(address, &info, reinterpret_cast<void**>(&symbol), RTLD_DL_SYMENT) == 0 ||
      symbol == nullptr) {
    return "is not in the library's symbol table";
  }
  const int type = ELF64_ST_TYPE(symbol->st_info);
  if (size == 0) return type == STT_FUNC ? "" : "is not a function";
  if (type != STT_OBJECT) return "is not data";
  // At least the record: reading it must stay inside the object. Larger is allowed, since a
  // sanitizer build pads globals (AddressSanitizer's red zone makes the record 32 bytes).
  if (symbol->st_size < size) {
    return "is " + std::to_string(symbol->st_size) + " bytes, not " + std::to_string(size);
  }
  return "";
}

/// Why a library built with `built` cannot be used here ("" when it can).
std::string abiMismatch(const KinolabPluginAbiRecord& built) {
  const KinolabPluginAbiRecord here = KINOLAB_PLUGIN_ABI_RECORD;
  if (built.magic != here.magic) return "its ABI record is not kinolab's";
  if (built.abi != here.abi) {
    return "built for plugin ABI " + std::to_string(built.abi) + ", this kinolab has ABI " +
           std::to_string(here.abi);
  }
  if (built.cxx11_abi != here.cxx11_abi || built.string_size != here.string_size) {
    return "built with another C++ standard library layout (_GLIBCXX_USE_CXX11_ABI " +
           std::to_string(built.cxx11_abi) + ", std::string of " +
           std::to_string(built.string_size) + " bytes; here " + std::to_string(here.cxx11_abi) +
           " and " + std::to_string(here.string_size) + ")";
  }
  return "";
}

}  // namespace

void PluginRegistrar::commit() {
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Pending& item = pending_[i];
    const std::string& key = item.info.key;
    for (std::size_t j = 0; j < i; ++j) {
      if (pending_[j].kind == item.kind && pending_[j].info.key == key) {
        throw PluginError(origin_ + ": registers " + item.kind + " '" + key + "' twice");
      }
    }
    if (item.taken(key)) {
      throw PluginError(item.kind + " '" + key + "' from " + origin_ +
                        " is already registered; pick another key");
    }
  }
  for (auto& item : pending_) item.apply();
  pending_.clear();
  recordLibraries(libraries_);
  libraries_.clear();
}

void PluginRegistrar::fulfil() {
  for (auto& item : pending_) {
    if (item.fulfil()) continue;
    // A module's own manifest is declared before it loads; another's, maybe not yet.
    detail::declarePendingModules(item.kind);
    if (!item.fulfil()) {
      throw PluginError(origin_ + " registers " + item.kind + " '" + item.info.key +
                        "', which its manifest does not declare: rebuild kinolab");
    }
  }
  pending_.clear();
  recordLibraries(libraries_);
  libraries_.clear();
}

PluginDeclarations PluginRegistrar::declarations() const {
  PluginDeclarations declarations;
  for (const Pending& item : pending_) declarations.plugins.emplace_back(item.kind, item.info);
  declarations.libraries = libraries_;
  return declarations;
}

const std::map<std::string, std::string>& pluginLibraryVersions() {
  detail::declarePendingModules();  // a module's manifest names its libraries
  return libraryVersions();
}

namespace {

using EntryFunction = void (*)(PluginRegistrar&);

/// Opens the plugin library at `canonical` (named `path` in messages) and returns its entry
/// point, once its ABI record and symbols are checked; a PluginError otherwise.
EntryFunction openPluginLibrary(const std::string& path, const std::string& canonical) {
  // Never closed: the factories it registers point into it.
  void* handle = dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* reason = dlerror();
    throw PluginError("plugin library '" + path +
                      "': cannot be loaded: " + (reason ? reason : "unknown reason"));
  }
  const std::string name = "plugin library '" + path + "'";
  // Plain data, read before any of the library's functions is called.
  const auto* record =
      static_cast<const KinolabPluginAbiRecord*>(dlsym(handle, "kinolab_plugin_abi_record"));
  const auto entry = reinterpret_cast<EntryFunction>(dlsym(handle, "kinolab_register_plugins"));
  if (!record || !entry) {
    const bool older = dlsym(handle, "kinolab_plugin_abi_version") != nullptr;
    dlclose(handle);
    if (older) {
      throw PluginError(name +
                        ": built for plugin ABI 5 or older (it has no ABI record), this "
                        "kinolab has ABI " +
                        std::to_string(KINOLAB_PLUGIN_ABI_VERSION) +
                        "; rebuild it against this kinolab");
    }
    throw PluginError(name +
                      ": no kinolab entry point (kinolab_register_plugins and "
                      "kinolab_plugin_abi_record); define them with "
                      "KINOLAB_REGISTER_PLUGINS(registrar) from kinolab/core/plugin.hpp");
  }
  for (const auto& [symbol, problem] :
       {std::pair{"kinolab_plugin_abi_record",
                  symbolProblem(const_cast<KinolabPluginAbiRecord*>(record),
                                sizeof(KinolabPluginAbiRecord))},
        std::pair{"kinolab_register_plugins", symbolProblem(reinterpret_cast<void*>(entry), 0)}}) {
    if (!problem.empty()) {
      dlclose(handle);
      throw PluginError(name + ": its " + symbol + " " + problem +
                        ": not a kinolab plugin library built by KINOLAB_REGISTER_PLUGINS");
    }
  }
  const std::string mismatch = abiMismatch(*record);
  if (!mismatch.empty()) {
    dlclose(handle);
    throw PluginError(name + ": " + mismatch + "; rebuild it against this kinolab");
  }
  return entry;
}

/// How a library's registrations are used: added to the registries, given to the deferred
/// plugins a manifest declared, or only read.
enum class Registration { kCommit, kFulfil, kDeclare };

/// Loads the library at `path` (once per file for kCommit and kFulfil) and uses what it
/// registers as `how` says.
PluginDeclarations loadLibrary(const std::string& path, Registration how) {
  static std::mutex mutex;
  static std::set<std::string> loaded;
  const std::lock_guard lock(mutex);

  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    throw PluginError("plugin library '" + path + "': no such file");
  }
  const std::string canonical = std::filesystem::canonical(path).string();
  if (how != Registration::kDeclare && loaded.count(canonical)) return {};
  const EntryFunction entry = openPluginLibrary(path, canonical);
  // On a throw the library stays open: what it registered so far points into it.
  PluginRegistrar registrar(canonical);
  try {
    entry(registrar);
  } catch (...) {
    rethrowFromPlugin("plugin " + path, "its entry point (kinolab_register_plugins)");
  }
  if (how == Registration::kDeclare) return registrar.declarations();
  if (how == Registration::kCommit) {
    registrar.commit();
  } else {
    registrar.fulfil();
  }
  loaded.insert(canonical);
  return {};
}

}  // namespace

void loadPluginLibrary(const std::string& path) { loadLibrary(path, Registration::kCommit); }

PluginDeclarations declarePluginLibrary(const std::string& path) {
  return loadLibrary(path, Registration::kDeclare);
}

namespace {

/// registerPluginModule()'s declarations, when they are needed.
void declarePluginModule(const std::string& module_path, const std::string& manifest_path,
                         const std::string& origin) {
  const PluginDeclarations declared = readPluginManifest(manifest_path);
  // Its kinds file said which registries need it declared; one that left a kind out would
  // hide that kind's plugins until everything is listed.
  if (const auto kinds = readPluginManifestKinds(manifest_path); !kinds.empty()) {
    for (const auto& [kind, info] : declared.plugins) {
      if (std::find(kinds.begin(), kinds.end(), kind) == kinds.end()) {
        throw PluginError("module manifest '" + manifest_path + "' declares " + kind + " '" +
                          info.key + "', which its kinds file '" +
                          pluginManifestKindsPath(manifest_path) +
                          "' does not list: rebuild or reinstall kinolab");
      }
    }
  }
  // Made once, by whichever of its plugins is made first (a failed load is tried again).
  struct Module {
    std::string path;
    std::once_flag once;
  };
  auto module = std::make_shared<Module>();
  module->path = module_path;
  const auto load = [module] {
    std::call_once(module->once, [&] { loadLibrary(module->path, Registration::kFulfil); });
  };
  for (const auto& [kind, declared_info] : declared.plugins) {
    PluginRegistryBase* registry = detail::findMutablePluginRegistry(kind);
    if (!registry) {
      throw PluginError("module manifest '" + manifest_path + "': unknown plugin kind '" + kind +
                        "' (of '" + declared_info.key + "'): rebuild kinolab");
    }
    PluginInfo info = declared_info;
    info.origin = origin;
    registry->addDeferredPlugin(std::move(info), load);
  }
  recordLibraries(declared.libraries);
}

}  // namespace

void registerPluginModule(const std::string& module_path, const std::string& manifest_path,
                          const std::string& origin) {
  detail::addPendingModule(readPluginManifestKinds(manifest_path),
                           [module_path, manifest_path, origin] {
                             declarePluginModule(module_path, manifest_path, origin);
                           });
}

}  // namespace kinolab
