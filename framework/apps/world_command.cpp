// `kinolab world SPEC.yaml --out DIR`: build or load a world and export it for a look.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "commands.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/world_cache.hpp"
#include "kinolab/world/world_export.hpp"

namespace kinolab::apps {
namespace {

struct WorldOptions {
  std::string spec_path;
  std::string out_dir;
  std::string cache_dir = WorldCache::defaultDirectory();
  bool no_cache = false;
  std::optional<double> slice_height;
};

void runWorld(const WorldOptions& options) {
  const WorldSpec spec = WorldSpec::fromFile(options.spec_path);
  if (!options.out_dir.empty()) {
    // Said before a build that may take minutes, not found after it.
    const std::string no_arrays = arraysNotExported(spec.layout, spec.voxels());
    if (!no_arrays.empty()) {
      std::printf("note: --out %s: %s\n", options.out_dir.c_str(), no_arrays.c_str());
      std::fflush(stdout);
    }
  }
  WorldLoad load;
  if (options.no_cache) {
    const auto start = std::chrono::steady_clock::now();
    load.world = World::build(spec);
    load.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  } else {
    load = WorldCache(options.cache_dir).loadOrBuild(spec);
  }
  const World& world = *load.world;
  const VoxelGrid& grid = world.grid();
  const Box bounds = grid.bounds();
  const double occupied = static_cast<double>(grid.occupiedCount());
  const char* how = load.source == WorldSource::kCache ? "loaded from cache" : "built";
  std::printf("world %s (spec %s)\n", world.name().c_str(), toHex(world.specHash()).c_str());
  std::printf("  voxels     %d x %d x %d = %zu at %.3g m\n", grid.dims().x(), grid.dims().y(),
              grid.dims().z(), grid.size(), grid.resolution());
  std::printf("  bounds     [%.2f, %.2f, %.2f] .. [%.2f, %.2f, %.2f] m\n", bounds.min.x(),
              bounds.min.y(), bounds.min.z(), bounds.max.x(), bounds.max.y(), bounds.max.z());
  std::printf("  occupied   %.0f voxels (%.2f %%)\n", occupied, 100.0 * occupied / grid.size());
  std::printf("  %-10s in %.3f s%s%s\n", how, load.seconds,
              load.cache_file.empty() ? "" : " (cache: ",
              load.cache_file.empty() ? "" : (load.cache_file + ")").c_str());
  const Esdf& esdf = world.esdf();
  std::printf("  memory     %.1f MB occupancy + %.1f MB distances", grid.memoryBytes() / 1e6,
              esdf.memoryBytes() / 1e6);
  if (grid.layout() == GridLayout::kBricked) {
    std::printf(" (sparse: %zu bricks of 512 voxels near obstacles, exact to %.3g m)",
                esdf.allocatedBricks(), esdf.truncation());
  }
  std::printf("\n");
  if (!load.note.empty()) std::printf("  note       %s\n", load.note.c_str());
  for (const auto& entry : spec.generators) {
    const std::string note =
        entry.generator->resamplingNote(load.world->bounds(), load.world->grid().resolution());
    if (!note.empty()) std::printf("  resampled  %s\n", note.c_str());
  }

  if (!options.out_dir.empty()) {
    // Default slice: 1 m above the floor, or mid-height in a lower map.
    const double height = options.slice_height.value_or(
        std::min(bounds.min.z() + 1.0, 0.5 * (bounds.min.z() + bounds.max.z())));
    const std::vector<std::string> written = exportWorld(world, options.out_dir, height);
    std::printf("  wrote      %s/{%s} (slice at z = %.2f m)\n", options.out_dir.c_str(),
                join(written, ", ").c_str(), height);
  }
}

}  // namespace

void addWorldCommand(CLI::App& app) {
  auto options = std::make_shared<WorldOptions>();
  CLI::App* command =
      app.add_subcommand("world",
                         "Build (or load from the cache) a world from its spec, print its size and "
                         "occupancy, and export its grid, ESDF and pictures");
  command
      ->add_option("spec", options->spec_path, "World spec YAML (e.g. configs/worlds/forest.yaml)")
      ->required();
  command->add_option("--out", options->out_dir,
                      "Write occupancy.npy, esdf.npy, world.yaml, top_view.png and "
                      "esdf_slice.png into this directory");
  command->add_option("--cache-dir", options->cache_dir, "World cache directory")
      ->capture_default_str();
  command->add_flag("--no-cache", options->no_cache, "Build without reading or writing the cache");
  command
      ->add_option("--slice-height", options->slice_height,
                   "Height (m) of the ESDF slice picture (default: 1 m above the floor)")
      ->check(within(-1e6, 1e6));
  std::string footer =
      "World generators (the `type:` of a `generators:` entry; their parameters: kinolab list "
      "worlds):\n";
  for (const PluginInfo* generator : pluginRegistry<WorldGenerator>().list()) {
    const std::string& type = generator->key;
    footer += "  " + type + std::string(10 - std::min<std::size_t>(type.size(), 9), ' ') +
              generator->description + "\n";
  }
  footer +=
      "Specs to start from: configs/worlds/*.yaml. Cache: $KINOLAB_CACHE_DIR overrides the "
      "default.";
  command->footer(footer);
  command->callback([options] { runWorld(*options); });
}

}  // namespace kinolab::apps
