// kinolab_module_manifest MODULE MANIFEST: writes the manifest of a plugin module loaded on use
// (what it declares), which kinolab reads instead of loading the module, and the kinds file
// beside it (MANIFEST with the extension .kinds). Run by the build
// (plugins/CMakeLists.txt), not by hand.
#include <cstdio>
#include <exception>
#include <string>

#include "kinolab/core/plugin.hpp"

int main(int argc, char** argv) {
  if (argc != 3 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::fprintf(argc == 2 ? stdout : stderr,
                 "Usage: kinolab_module_manifest MODULE.so MANIFEST.json\n"
                 "Writes what a kinolab plugin module declares (its plugins' keys, parameters "
                 "and statistics, the libraries it records) as the JSON manifest kinolab reads "
                 "instead of loading the module, and beside it the kinds it declares "
                 "(MANIFEST.kinds); the build runs it.\n");
    return argc == 2 ? 0 : 2;
  }
  try {
    kinolab::writePluginManifest(kinolab::declarePluginLibrary(argv[1]), argv[2]);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "kinolab_module_manifest: %s\n", error.what());
    return 1;
  }
  return 0;
}
