#include "kinolab/world/world_spec.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "kinolab/core/error.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/yaml_fields.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/world/world_generator.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(WorldGenerator, "world", "worlds",
                               "world generators: the `type:` of a world spec's `generators:`", 5)

namespace {

// Bump when a generator's output for the same parameters changes, so old caches go stale.
// 4: the key is the declared parameters' canonical text.
constexpr int kGeneratorVersion = 4;  // 2: octomap occupied leaves by overlap

/// One `generators:` entry: its `type` chosen from the registry, its other keys the
/// generator's declared parameters (relative file paths against `spec_directory`).
WorldGeneratorEntry readGenerator(const YamlReader& entry, const std::string& spec_directory) {
  if (!entry.isMap()) entry.fail("expected a generator: a mapping with a type");
  const YamlReader type = entry["type"];
  WorldGeneratorEntry result;
  result.type = type.as<std::string>();
  const PluginRegistry<WorldGenerator>& registry = pluginRegistry<WorldGenerator>();
  if (!registry.contains(result.type)) {
    const auto known = registry.keys();
    type.fail("unknown world generator '" + result.type + "'" + didYouMean(result.type, known) +
              "; known worlds: " + join(known, ", "));
  }
  const ParameterSpecs& declared = registry.info(result.type).parameters;
  std::vector<ParameterAssignment> assignments;
  for (ParameterAssignment& assignment : assignmentsFromYaml(entry)) {
    if (assignment.name == "type") continue;
    const ParameterSpec* spec = declared.find(assignment.name);
    if (spec && spec->type == ParameterType::kPath && !assignment.value.empty() &&
        std::filesystem::path(assignment.value).is_relative()) {
      assignment.value =
          (std::filesystem::path(spec_directory) / assignment.value).lexically_normal().string();
    }
    assignments.push_back(std::move(assignment));
  }
  result.parameters = registry.resolve(result.type, assignments, entry.where());
  try {
    result.generator = registry.createResolved(result.type, result.parameters);
  } catch (const ParameterConflict& conflict) {
    // Values that are each in range but do not fit together: where the parameter was set.
    const auto node = entry.optional(conflict.parameter());
    (node ? *node : entry).fail(conflict.what());
  } catch (const FileError& error) {
    // A file that cannot be read: where the entry names it.
    for (const ParameterSpec& spec : declared.all()) {
      if (const auto node = entry.optional(spec.name); node && spec.type == ParameterType::kPath) {
        node->fail(error.what());
      }
    }
    entry.fail(error.what());
  }
  return result;
}

/// The parameters' canonical text without file paths (their content is the generator's).
std::string withoutPaths(const ParameterSpecs& declared, const ParameterSet& parameters) {
  std::string text;
  for (const auto& [name, value] : parameters.flattened()) {
    const ParameterSpec* spec = declared.find(name);
    if (spec && spec->type == ParameterType::kPath) continue;
    text += ' ' + name + '=' + formatParameterValue(value);
  }
  return text;
}

}  // namespace

WorldSpec WorldSpec::fromFile(const std::string& path) {
  const YamlReader root = YamlReader::loadFile(path);
  WorldSpec spec = fromYaml(root, std::filesystem::path(path).parent_path().string());
  if (spec.name.empty()) spec.name = std::filesystem::path(path).stem().string();
  return spec;
}

namespace {

/// Every grid kinolab builds is handled exactly or refused here, before anything is
/// allocated: finite bounds at least a voxel wide, at most 1e9 voxels, a diagonal the exact
/// ESDF's 32-bit squared voxel distances hold, and memory the machine has.
void checkGridSize(const WorldSpec& spec, const YamlReader& node) {
  const Eigen::Vector3d extent = spec.bounds.max - spec.bounds.min;
  if (!spec.bounds.min.allFinite() || !spec.bounds.max.allFinite()) {
    node.fail("the bounds " + formatPoint(spec.bounds.min) + " .. " + formatPoint(spec.bounds.max) +
              " are not finite");
  }
  if (extent.minCoeff() < spec.resolution) {
    node.fail("the bounds " + formatPoint(spec.bounds.min) + " .. " + formatPoint(spec.bounds.max) +
              " are less than one voxel (" + formatNumber(spec.resolution) +
              " m) wide on some axis");
  }
  const Eigen::Vector3d dims = VoxelGrid::voxelsAlong(spec.bounds, spec.resolution);
  const double voxels = dims.prod();
  const double memory = processMemoryLimit();
  if (spec.layout == GridLayout::kBricked) {
    // Per brick of 512 voxels: its occupancy state (4 bytes) and its distances' pointer (8);
    // the bricks near obstacles come on top (64 bytes of occupancy, 1 KiB of distances). A
    // tile's exact transform spans the world's height.
    if (voxels > 1e12) {
      node["resolution"].fail("bounds and resolution give " + formatNumber(voxels) +
                              " voxels; a sparse world holds at most 1e12");
    }
    if (dims.z() > 20000) {
      node["resolution"].fail("the world is " + formatNumber(dims.z()) +
                              " voxels high; a sparse world is at most 20000");
    }
    if (memory > 0.0 && voxels / 512.0 * 12.0 > 0.6 * memory) {
      node["resolution"].fail("the sparse world's brick tables alone need " +
                              formatNumber(std::ceil(voxels / 512.0 * 12.0 / (1 << 30))) +
                              " GiB; " + processMayUse());
    }
    return;
  }
  if (voxels > 1e9) {
    node["resolution"].fail("bounds and resolution give " + formatNumber(voxels) +
                            " voxels; a dense world holds at most 1e9 (layout: sparse holds "
                            "more)");
  }
  // Squared distances in half voxels are 32-bit integers in the exact ESDF.
  const double diagonal = dims.norm();
  if (4.0 * diagonal * diagonal >= 2147483647.0) {
    const auto whole = [](double value) { return std::to_string(std::llround(value)); };
    node["resolution"].fail("the grid is " + whole(dims.x()) + " x " + whole(dims.y()) + " x " +
                            whole(dims.z()) + " voxels, a diagonal of " + whole(diagonal) +
                            "; the exact ESDF handles at most 23170 voxels of diagonal: use a "
                            "coarser resolution or a smaller world");
  }
  // Building holds the occupancy (1 byte), the ESDF (4) and one squared-distance field (4) per
  // voxel at once, and writing or reading the cache file the world and its buffer (5 + 5):
  // 14 bytes a voxel leaves room for the rest, and at most 60 % of the process's memory for
  // one world.
  const double bytes = voxels * 14.0;
  if (memory > 0.0 && bytes > 0.6 * memory) {
    node["resolution"].fail(formatNumber(voxels) + " voxels need about " +
                            formatNumber(std::ceil(bytes / (1 << 30))) + " GiB to build; " +
                            processMayUse() + ": use a coarser resolution or a smaller world");
  }
}

}  // namespace

WorldSpec WorldSpec::fromText(const std::string& text, const std::string& source,
                              const std::string& spec_directory) {
  return fromYaml(YamlReader::loadString(text, source), spec_directory);
}

WorldSpec WorldSpec::fromYaml(const YamlReader& node, const std::string& spec_directory) {
  if (!node.isMap()) node.fail("expected a world spec (a mapping with resolution and generators)");
  WorldSpec spec;
  readYamlFields(node, spec);
  for (const YamlReader& entry : node["generators"].items()) {
    spec.generators.push_back(readGenerator(entry, spec_directory));
  }
  if (spec.generators.empty()) node["generators"].fail("expected at least one generator");
  // At most 90 voxels of truncation: a voxel keeps its squared distance in half voxels in 16
  // bits.
  const double most = 90.0 * spec.resolution;
  if (const auto truncation = node.optional("truncation")) {
    if (spec.layout != GridLayout::kBricked) {
      truncation->fail("truncation applies to a sparse world only (layout: sparse)");
    }
    if (!(spec.truncation >= spec.resolution && spec.truncation <= most)) {
      truncation->fail("expected a number in [" + formatNumber(spec.resolution) + ", " +
                       formatNumber(most) + "], got " + formatNumber(spec.truncation));
    }
  } else if (spec.layout == GridLayout::kBricked &&
             !(spec.truncation >= spec.resolution && spec.truncation <= most)) {
    node["layout"].fail("the default truncation of " + formatNumber(spec.truncation) +
                        " m is not between one voxel and 90 voxels (" +
                        formatNumber(spec.resolution) + " to " + formatNumber(most) +
                        " m): set `truncation`");
  }
  if (const auto bounds = node.optional("bounds")) {
    if (!((spec.bounds.max - spec.bounds.min).minCoeff() >= spec.resolution)) {
      bounds->fail("expected finite bounds with max - min >= resolution on every axis");
    }
  } else {
    bool found = false;
    for (const auto& entry : spec.generators) {
      if (const auto natural = entry.generator->naturalBounds()) {
        spec.bounds = found ? Box{spec.bounds.min.cwiseMin(natural->min),
                                  spec.bounds.max.cwiseMax(natural->max)}
                            : *natural;
        found = true;
      }
    }
    if (!found) {
      node.fail(
          "missing required key 'bounds' ({min: [x, y, z], max: [x, y, z]}); only a "
          "map-file world can take its bounds from the map");
    }
  }
  checkGridSize(spec, node);
  node.finish();
  return spec;
}

std::string WorldSpec::canonicalText() const {
  std::string text = "kinolab-world generators=" + std::to_string(kGeneratorVersion) + " " +
                     canonicalFields(*this, {.names = true, .hex = true}) + "\n";
  for (const auto& entry : generators) {
    std::ostringstream out;
    out << entry.type
        << withoutPaths(pluginRegistry<WorldGenerator>().info(entry.type).parameters,
                        entry.parameters);
    entry.generator->writeContentKey(out);
    text += out.str() + '\n';
  }
  return text;
}

std::uint64_t WorldSpec::hash() const { return hashString(canonicalText()); }

}  // namespace kinolab
