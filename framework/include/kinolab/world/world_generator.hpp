#pragma once

#include <optional>
#include <ostream>
#include <string>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/world/voxel_grid.hpp"

namespace kinolab {

/// One step of building a world: it adds occupied voxels to the grid. A world spec lists
/// several (`generators: [{type: forest, density: 0.1}, ...]`), applied in order (their union
/// is the world), each with its own random stream. A plugin kind ("world", `kinolab list
/// worlds`): the factory reads the generator's declared parameters, which the world cache's
/// key already holds (file paths excepted: see writeContentKey()).
class WorldGenerator {
 public:
  virtual ~WorldGenerator() = default;

  /// What the output depends on beyond the declared parameters, written exactly (the world
  /// cache's key): a map file's content hash, since its path is left out of the key so that a
  /// moved map keeps its cache. Nothing by default.
  virtual void writeContentKey(std::ostream& /*out*/) const {}
  /// The metric box this generator's content naturally spans (a map file's extent), used
  /// when the spec gives no bounds.
  virtual std::optional<Box> naturalBounds() const { return std::nullopt; }
  /// When the generator's content is resampled onto a grid of these bounds and resolution
  /// (a map file at another resolution or on a shifted grid), one line saying so; else "".
  virtual std::string resamplingNote(const Box& /*bounds*/, double /*resolution*/) const {
    return "";
  }
  /// Marks occupied voxels of `grid`.
  virtual void apply(VoxelGrid& grid, Rng& rng) const = 0;
};

/// The registry of world generators: built-in `empty`, `forest`, `boxes`, `walls`,
/// `box_list`, `city` and `octomap`.
template <>
PluginRegistry<WorldGenerator>& pluginRegistry<WorldGenerator>();

}  // namespace kinolab
