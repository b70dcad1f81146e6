#pragma once

#include <cstdlib>
#include <sstream>
#include <string>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/plugin.hpp"

namespace kinolab::test {

/// Registers the built-in plugins and loads every library named in $KINOLAB_TEST_PLUGINS
/// (colon-separated), so conformance suites also cover out-of-tree plugins. Idempotent.
inline void loadTestPlugins() {
  registerBuiltinPlugins();
  if (const char* extra = std::getenv("KINOLAB_TEST_PLUGINS")) {
    std::istringstream paths(extra);
    for (std::string path; std::getline(paths, path, ':');) {
      if (!path.empty()) loadPluginLibrary(path);
    }
  }
}

}  // namespace kinolab::test
