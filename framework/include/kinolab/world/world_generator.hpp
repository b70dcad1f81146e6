#pragma once

#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "kinolab/core/random.hpp"
#include "kinolab/world/voxel_grid.hpp"

namespace kinolab {

class YamlReader;

/// One step of building a world: it adds occupied voxels to the grid. A world spec lists
/// several, applied in order (their union is the world), each with its own random stream.
class WorldGenerator {
 public:
  virtual ~WorldGenerator() = default;

  /// The `type:` key in a world spec.
  virtual std::string type() const = 0;
  /// Writes every parameter exactly (the hash input of the world cache); two generators
  /// with equal canonical text produce equal grids.
  virtual void writeCanonical(std::ostream& out) const = 0;
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

/// Reads one `generators:` entry (strict: unknown keys and out-of-range values throw
/// ConfigError with file, line and key path). `spec_directory` resolves relative map paths.
std::unique_ptr<WorldGenerator> makeWorldGenerator(const YamlReader& entry,
                                                   const std::string& spec_directory);

/// The generator types makeWorldGenerator knows, with a one-line description each.
std::vector<std::pair<std::string, std::string>> worldGeneratorTypes();

}  // namespace kinolab
