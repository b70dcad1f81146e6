#include "body_collision.hpp"

#include <dlfcn.h>

#include <string>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"

namespace kinolab {
namespace {

using MakeBodyCollision = BodyCollision* (*)(const World&, double);

/// kinolab_modules/kinolab_fcl_body.so beside this library (the build tree's framework/ or the
/// installed lib/), loaded once, never unloaded.
MakeBodyCollision loadModule() {
  const std::string directory = frameworkLibraryDirectory();
  if (directory.empty()) throw PluginError("cannot find where the kinolab framework library lies");
  const std::string path = directory + "/kinolab_modules/kinolab_fcl_body.so";
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    throw PluginError("cannot load the checker's FCL module " + path + ": " +
                      (why ? why : "unknown error") +
                      " (it is built and installed with kinolab; rebuild or reinstall)");
  }
  const auto make =
      reinterpret_cast<MakeBodyCollision>(dlsym(handle, "kinolab_make_body_collision"));
  if (make == nullptr) {
    throw PluginError("the checker's FCL module " + path +
                      " has no kinolab_make_body_collision (a module of another kinolab?)");
  }
  return make;
}

}  // namespace

std::unique_ptr<BodyCollision> makeBodyCollision(const World& world, double radius) {
  static const MakeBodyCollision make = loadModule();  // once, on any thread
  return std::unique_ptr<BodyCollision>(make(world, radius));
}

}  // namespace kinolab
