#pragma once

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab::test {

/// A world at 0.1 m of `generators` (the YAML list's items, one per line) within `bounds`;
/// `name` names its spec in errors.
inline std::shared_ptr<const World> worldOf(
    const std::string& generators, const std::string& bounds = "{min: [0, 0, 0], max: [20, 10, 3]}",
    const std::string& name = "test_world.yaml") {
  return World::build(WorldSpec::fromYaml(
      YamlReader::loadString("resolution: 0.1\nbounds: " + bounds + "\ngenerators:\n" + generators,
                             name),
      "."));
}

/// Small worlds (12 m x 12 m x 3 m at 0.1 m) of each generator, built once per process.
inline std::shared_ptr<const World> smallWorld(const std::string& kind) {
  static std::map<std::string, std::shared_ptr<const World>> worlds;
  if (auto found = worlds.find(kind); found != worlds.end()) return found->second;
  const std::string head =
      "name: " + kind + "\nseed: 11\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [12, 12, 3]}\n";
  std::string generators;
  if (kind == "forest") {
    generators =
        "generators: [{type: forest, density: 0.15, trunk_radius: [0.15, 0.3], "
        "trunk_height: [2.5, 3], min_spacing: 0.8, ground_plane: true}]\n";
  } else if (kind == "boxes") {
    generators =
        "generators: [{type: boxes, count: 25, size_x: [0.5, 2], size_y: [0.5, 2], "
        "size_z: [0.5, 3], on_ground: true}]\n";
  } else if (kind == "walls") {
    generators =
        "generators: [{type: walls, cell_size: 4.0, thickness: 0.3, height: 3.0, "
        "gap_width: 1.5, extra_openings: 0.3, border: true}]\n";
  } else {
    generators = "generators: [{type: empty}]\n";
  }
  auto world = World::build(
      WorldSpec::fromYaml(YamlReader::loadString(head + generators, kind + ".yaml"), "."));
  worlds.emplace(kind, world);
  return world;
}

/// Seeded start/goal pairs at rest, both with `clearance` (m) of free space, at least
/// `min_distance` and at most `max_distance` apart, 0.5 m inside the map's sides, at heights
/// in [0.8, 2.2] m (the shared sampler, kinolab/experiment/query_sampler.hpp).
inline std::vector<PlanningQuery> randomQueries(const World& world, int count, std::uint64_t seed,
                                                double min_distance, double max_distance,
                                                double clearance) {
  Rng rng(seed);
  const Box& bounds = world.bounds();
  const Box region{{bounds.min.x() + 0.5, bounds.min.y() + 0.5, 0.8},
                   {bounds.max.x() - 0.5, bounds.max.y() - 0.5, 2.2}};
  return sampleFreeQueries(world, {region, clearance, min_distance, max_distance}, count, rng,
                           world.name());
}

/// `key=value` items as assignments.
inline std::vector<ParameterAssignment> assignments(const std::vector<std::string>& items) {
  return parseAssignments(items, "test");
}

/// The statistic `name` of `statistics` (a planner's or a search's), NaN when absent.
inline double statistic(const std::vector<std::pair<std::string, double>>& statistics,
                        const std::string& name) {
  for (const auto& [key, value] : statistics) {
    if (key == name) return value;
  }
  return NAN;
}

}  // namespace kinolab::test
