// Builds a world from an inline spec with the installed kinolab and its built-in plugins (the
// world generators are plugins) and prints one distance.
#include <iostream>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/version.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"

int main() {
  kinolab::registerBuiltinPlugins();
  const auto spec = kinolab::WorldSpec::fromText(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\n"
      "generators: [{type: box_list, boxes: [{min: [2, 0, 0], max: [2.4, 4, 2]}]}]\n",
      "inline", ".");
  const auto world = kinolab::World::build(spec);
  std::cout << "kinolab " << kinolab::kVersion << " distance " << world->distance({1.55, 2, 1})
            << '\n';
  return 0;
}
