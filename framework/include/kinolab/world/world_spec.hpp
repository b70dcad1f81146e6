#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/world/voxel_grid.hpp"
#include "kinolab/world/world_generator.hpp"

namespace kinolab {

class YamlReader;

/// One `generators:` entry: the registered generator's key, its resolved parameters and the
/// generator made from them.
struct WorldGeneratorEntry {
  std::string type;
  ParameterSet parameters;
  std::shared_ptr<const WorldGenerator> generator;
};

/// What defines a world: bounds, resolution, seed and an ordered list of generators.
/// Read from YAML (configs/worlds/*.yaml):
///
///     name: forest
///     seed: 7
///     resolution: 0.1
///     bounds: {min: [0, 0, 0], max: [40, 40, 6]}   # optional for a map-file world
///     generators:
///       - {type: forest, density: 0.06, trunk_radius: [0.15, 0.3]}
///     layout: sparse      # optional: dense (the default) or sparse
///     truncation: 1.0     # sparse only: distances exact up to this many metres
///
/// A dense world holds every voxel (at most 10^9); a sparse one bricks of 8^3 voxels near
/// obstacles only, with the ESDF truncated (Esdf::truncated()), for worlds of up to 10^12.
/// The same spec gives the same grid bit for bit.
struct WorldSpec {
  std::string name;
  std::uint64_t seed = 0;
  double resolution = 0.1;
  Box bounds;
  GridLayout layout = GridLayout::kDense;
  /// The sparse layout's truncation distance, m.
  double truncation = kDefaultTruncation;
  static constexpr double kDefaultTruncation = 2.0;
  std::vector<WorldGeneratorEntry> generators;

  /// The keys read from the field list (`generators:` is read by hand: its entries name
  /// plugins), in the order of the canonical text.
  template <typename Fields>
  void fields(Fields& f) {
    f.text("name", name, "the world's name (a spec file's: its file name)", {.identity = false});
    f.integer("seed", seed, 0, 1LL << 62, "seed of the generators' random draws");
    f.real("resolution", resolution, 1e-3, 100.0, "voxel edge, m", {.required = true});
    f.group("bounds", bounds, "the world's box (a map-file world: the map's, when absent)");
    // Dense worlds keep the keys they had before layouts existed (and their cache files).
    const bool sparse = layout == GridLayout::kBricked;
    f.choice("layout", layout, {{"dense", GridLayout::kDense}, {"sparse", GridLayout::kBricked}},
             "every voxel held (dense), or bricks near obstacles only (sparse)",
             {.identity = sparse});
    // One to 90 voxels: checked once the resolution is known (fromYaml()).
    f.real("truncation", truncation, 0.0, INFINITY,
           "sparse: distances exact up to this far, m (1 to 90 voxels)", {.identity = sparse});
  }

  /// Loads and validates a spec file; errors name the file, line and key path.
  static WorldSpec fromFile(const std::string& path);
  /// Parses a spec from YAML text; `source` names it in messages, `spec_directory` resolves
  /// relative map paths.
  static WorldSpec fromText(const std::string& text, const std::string& source,
                            const std::string& spec_directory);
  /// Reads a spec from a YAML mapping (e.g. inline in an experiment file);
  /// `spec_directory` resolves relative map paths.
  static WorldSpec fromYaml(const YamlReader& node, const std::string& spec_directory);

  /// Exact text of everything that determines the grid (not the name, nor a map file's path:
  /// its content).
  std::string canonicalText() const;
  /// The voxels of the grid the spec builds (bounds / resolution, as VoxelGrid rounds them).
  double voxels() const { return VoxelGrid::voxelsAlong(bounds, resolution).prod(); }
  /// Hash of canonicalText(): the world cache key.
  std::uint64_t hash() const;
};

}  // namespace kinolab
