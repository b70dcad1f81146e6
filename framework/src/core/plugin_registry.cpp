#include "kinolab/core/plugin_registry.hpp"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <new>

namespace kinolab {
namespace {

struct Listed {
  const PluginRegistryBase* registry;
  int order;
};

std::vector<Listed>& directory() {
  static std::vector<Listed> registries;
  return registries;
}

std::mutex& directoryMutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

PluginRegistryBase::PluginRegistryBase(std::string kind, std::string plural,
                                       std::string description)
    : kind_(std::move(kind)), plural_(std::move(plural)), description_(std::move(description)) {
  // Made before any registry is complete, so destroyed after every registry (whose
  // destructor leaves the directory).
  directoryMutex();
  directory();
}

PluginRegistryBase::~PluginRegistryBase() {
  const std::lock_guard lock(directoryMutex());
  std::erase_if(directory(), [this](const Listed& listed) { return listed.registry == this; });
}

const PluginInfo* PluginRegistryBase::find(std::string_view key) const {
  const std::shared_lock lock(detail::registryMutex());
  const auto found = infos_.find(key);
  return found == infos_.end() ? nullptr : &found->second;
}

bool PluginRegistryBase::contains(std::string_view key) const {
  if (find(key)) return true;
  detail::declarePendingModules(kind_);
  return find(key) != nullptr;
}

const PluginInfo& PluginRegistryBase::info(std::string_view key) const {
  if (const PluginInfo* found = find(key)) return *found;
  detail::declarePendingModules(kind_);
  if (const PluginInfo* found = find(key)) return *found;
  const auto known = keys();
  throw PluginError("unknown " + kind_ + " '" + std::string(key) + "'" + didYouMean(key, known) +
                    "; known " + plural_ + ": " +
                    (known.empty() ? std::string("none") : join(known, ", ")));
}

std::vector<const PluginInfo*> PluginRegistryBase::list() const {
  detail::declarePendingModules(kind_);
  const std::shared_lock lock(detail::registryMutex());
  std::vector<const PluginInfo*> result;
  for (const auto& [key, info] : infos_) result.push_back(&info);
  return result;
}

std::vector<std::string> PluginRegistryBase::keys() const {
  detail::declarePendingModules(kind_);
  const std::shared_lock lock(detail::registryMutex());
  std::vector<std::string> result;
  for (const auto& [key, info] : infos_) result.push_back(key);
  return result;
}

ParameterSet PluginRegistryBase::resolve(std::string_view key,
                                         const std::vector<ParameterAssignment>& assignments,
                                         std::string_view where) const {
  const PluginInfo& found = info(key);
  return found.parameters.resolve(assignments, kind_ + " '" + found.key + "'", where);
}

void PluginRegistryBase::addInfo(PluginInfo info) {
  detail::declarePendingModules(kind_);
  const std::unique_lock lock(detail::registryMutex());
  if (const auto found = infos_.find(info.key); found != infos_.end()) {
    throw PluginError(kind_ + " '" + info.key + "' from " + info.origin +
                      " is already registered (from " + found->second.origin + ")");
  }
  std::string key = info.key;
  infos_.emplace(std::move(key), std::move(info));
}

const PluginRegistryBase* findPluginRegistry(std::string_view kind) {
  const std::lock_guard lock(directoryMutex());
  for (const Listed& listed : directory()) {
    if (listed.registry->kind() == kind || listed.registry->plural() == kind) {
      return listed.registry;
    }
  }
  return nullptr;
}

std::vector<const PluginRegistryBase*> pluginRegistries() {
  const std::lock_guard lock(directoryMutex());
  std::vector<Listed> sorted = directory();
  std::sort(sorted.begin(), sorted.end(),
            [](const Listed& a, const Listed& b) { return a.order < b.order; });
  std::vector<const PluginRegistryBase*> result;
  for (const Listed& listed : sorted) result.push_back(listed.registry);
  return result;
}

namespace detail {

std::shared_mutex& registryMutex() {
  static std::shared_mutex mutex;
  return mutex;
}

namespace {
struct PendingModule {
  std::vector<std::string> kinds;  // empty: any
  std::function<void()> declare;
};
struct PendingModules {
  std::recursive_mutex mutex;  // held while declaring; a declaration's own registrations re-enter
  std::vector<PendingModule> modules;
  std::exception_ptr failure;       // the first declaration that threw
  std::atomic<bool> settled{true};  // nothing pending, nothing failed
};
PendingModules& pending() {
  static PendingModules modules;
  return modules;
}
}  // namespace

void addPendingModule(std::vector<std::string> kinds, std::function<void()> declare) {
  PendingModules& pending_modules = pending();
  const std::lock_guard lock(pending_modules.mutex);
  pending_modules.modules.push_back({std::move(kinds), std::move(declare)});
  pending_modules.settled = false;
}

void declarePendingModules(std::string_view kind) {
  PendingModules& pending_modules = pending();
  if (pending_modules.settled) return;
  const std::lock_guard lock(pending_modules.mutex);
  if (pending_modules.failure) std::rethrow_exception(pending_modules.failure);
  // Those of `kind` taken out first: their registrations call back in here.
  std::vector<PendingModule> chosen;
  std::vector<PendingModule> kept;
  for (PendingModule& module : pending_modules.modules) {
    const bool take =
        kind.empty() || module.kinds.empty() ||
        std::find(module.kinds.begin(), module.kinds.end(), kind) != module.kinds.end();
    (take ? chosen : kept).push_back(std::move(module));
  }
  pending_modules.modules = std::move(kept);
  for (PendingModule& module : chosen) {
    try {
      module.declare();
    } catch (...) {
      // Not run again (it may have declared part of its plugins): every later need says why.
      pending_modules.failure = std::current_exception();
      throw;
    }
  }
  pending_modules.settled = pending_modules.modules.empty();
}

std::size_t pendingModules() {
  PendingModules& pending_modules = pending();
  const std::lock_guard lock(pending_modules.mutex);
  return pending_modules.modules.size();
}

PluginRegistryBase* findMutablePluginRegistry(std::string_view kind) {
  // The directory lists them as const; each is a registry's own (non-const) static object.
  return const_cast<PluginRegistryBase*>(findPluginRegistry(kind));
}

void listPluginRegistry(const PluginRegistryBase& registry, int order) {
  const std::lock_guard lock(directoryMutex());
  for (const Listed& listed : directory()) {
    if (listed.registry->kind() == registry.kind()) {
      throw PluginError("two registries of kind '" + registry.kind() + "'");
    }
  }
  directory().push_back({&registry, order});
}

}  // namespace detail
std::string describePlugin(std::string_view kind, const PluginInfo& info) {
  const std::string name = std::string(kind) + " '" + info.key + "'";
  if (info.origin.rfind("built-in", 0) == 0) return name + " (" + info.origin + ")";
  return "plugin " + info.origin + " (" + name + ")";
}

void rethrowFromPlugin(std::string_view who, std::string_view call) {
  const std::string prefix = std::string(who) + ": " + std::string(call) + " threw";
  try {
    throw;
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;  // out of memory is the run's status, not the plugin's fault
  } catch (const std::exception& error) {
    throw PluginCodeError(prefix + ": " + error.what());
  } catch (...) {
    throw PluginCodeError(prefix + " something that is not a std::exception");
  }
}

}  // namespace kinolab
