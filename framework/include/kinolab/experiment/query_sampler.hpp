#pragma once

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "kinolab/core/random.hpp"
#include "kinolab/planner/planner.hpp"

namespace kinolab {

/// Where seeded random queries are drawn: positions uniform in `region` (x, y, z drawn in
/// that order), each at least `clearance` from every obstacle, start and goal between
/// `min_distance` and `max_distance` apart. The one sampler experiments, benchmarks and
/// tests share.
struct FreeQueryRegion {
  Box region;
  double clearance = 0.6;
  double min_distance = 0.0;
  double max_distance = INFINITY;
  /// > 0: x and y are snapped to lattice_offset + lattice_step k (k an integer) after the
  /// draw, inside the region.
  double lattice_step = 0.0;
  double lattice_offset = 0.0;
  /// When set: start and goal in one piece of the free space for a sphere of this radius (0: a
  /// point; FreeComponents, labelled once per call of sampleFreeQueries()).
  std::optional<double> connected_radius = std::nullopt;
};

/// A free position in `region` (`clearance` from obstacles, inside the map). Throws
/// ConfigError naming `what` and `world_id` after `max_draws` draws without one.
Eigen::Vector3d sampleFreePosition(const World& world, const Box& region, double clearance,
                                   Rng& rng, const std::string& what, const std::string& world_id,
                                   int max_draws = 100000);

/// `count` start/goal pairs at rest (start, then goal, until their distance fits and, with a
/// connected_radius, a way joins them), on the region's lattice if it has one. Throws
/// ConfigError naming `world_id` when a position or a pair cannot be placed in `max_draws`
/// draws.
std::vector<PlanningQuery> sampleFreeQueries(const World& world, const FreeQueryRegion& spec,
                                             int count, Rng& rng, const std::string& world_id,
                                             int max_draws = 100000);

}  // namespace kinolab
