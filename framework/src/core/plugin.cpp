#include "kinolab/core/plugin.hpp"

#include <dlfcn.h>
#include <link.h>

#include <filesystem>
#include <mutex>
#include <set>

namespace kinolab {
namespace {

std::map<std::string, std::string>& libraryVersions() {
  static std::map<std::string, std::string> versions;
  return versions;
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
  const std::string name = "plugin library '" + path + "'";
  // Plain data, read before any of the library's functions is called.
  const auto* record =
      static_cast<const KinolabPluginAbiRecord*>(dlsym(handle, "kinolab_plugin_abi_record"));
  using EntryFunction = void (*)(PluginRegistrar&);
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
  const KinolabPluginAbiRecord built = *record;  // copied: the library may be closed below
  const KinolabPluginAbiRecord here = KINOLAB_PLUGIN_ABI_RECORD;
  std::string mismatch;
  if (built.magic != here.magic) {
    mismatch = "its ABI record is not kinolab's";
  } else if (built.abi != here.abi) {
    mismatch = "built for plugin ABI " + std::to_string(built.abi) + ", this kinolab has ABI " +
               std::to_string(here.abi);
  } else if (built.cxx11_abi != here.cxx11_abi || built.string_size != here.string_size) {
    mismatch = "built with another C++ standard library layout (_GLIBCXX_USE_CXX11_ABI " +
               std::to_string(built.cxx11_abi) + ", std::string of " +
               std::to_string(built.string_size) + " bytes; here " +
               std::to_string(here.cxx11_abi) + " and " + std::to_string(here.string_size) + ")";
  }
  if (!mismatch.empty()) {
    dlclose(handle);
    throw PluginError(name + ": " + mismatch + "; rebuild it against this kinolab");
  }
  // On a throw the library stays open: what it registered so far points into it.
  PluginRegistrar registrar(canonical);
  try {
    entry(registrar);
  } catch (...) {
    rethrowFromPlugin("plugin " + path, "its entry point (kinolab_register_plugins)");
  }
  registrar.commit();
  loaded.insert(canonical);
}

}  // namespace kinolab
