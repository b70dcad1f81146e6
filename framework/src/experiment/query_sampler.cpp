#include "kinolab/experiment/query_sampler.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/free_components.hpp"

namespace kinolab {
namespace {

[[noreturn]] void cannotPlace(const std::string& what, const std::string& world_id, int draws,
                              const std::string& hint = "lower the clearance or distances") {
  throw ConfigError("queries: could not place " + what + " in world '" + world_id + "' in " +
                    std::to_string(draws) + " draws; " + hint);
}

}  // namespace

Eigen::Vector3d sampleFreePosition(const World& world, const Box& region, double clearance,
                                   Rng& rng, const std::string& what, const std::string& world_id,
                                   int max_draws) {
  for (int draw = 0; draw < max_draws; ++draw) {
    const auto p = drawLastFirst<Eigen::Vector3d>(
        [&](int i) { return rng.uniform(region.min[i], region.max[i]); });
    if (world.isFree(p, clearance)) return p;
  }
  cannotPlace(what, world_id, max_draws);
}

namespace {

/// A free position whose x and y lie on the region's lattice.
Eigen::Vector3d sampleLatticePosition(const World& world, const FreeQueryRegion& spec, Rng& rng,
                                      const std::string& what, const std::string& world_id,
                                      int max_draws) {
  const double step = spec.lattice_step;
  const auto first = [&](int axis) {
    return std::ceil((spec.region.min[axis] - spec.lattice_offset) / step);
  };
  const auto last = [&](int axis) {
    return std::floor((spec.region.max[axis] - spec.lattice_offset) / step);
  };
  if (first(0) > last(0) || first(1) > last(1)) {
    throw ConfigError("queries: the lattice has no point in the query region of world '" +
                      world_id + "'");
  }
  for (int draw = 0; draw < max_draws; ++draw) {
    Eigen::Vector3d p;
    for (int axis = 0; axis < 2; ++axis) {
      const double k = std::floor(rng.uniform(first(axis), last(axis) + 1.0));
      p[axis] = spec.lattice_offset + step * std::min(k, last(axis));
    }
    p.z() = rng.uniform(spec.region.min.z(), spec.region.max.z());
    if (world.isFree(p, spec.clearance)) return p;
  }
  cannotPlace(what, world_id, max_draws);
}

}  // namespace

std::vector<PlanningQuery> sampleFreeQueries(const World& world, const FreeQueryRegion& spec,
                                             int count, Rng& rng, const std::string& world_id,
                                             int max_draws) {
  std::vector<PlanningQuery> queries;
  queries.reserve(static_cast<std::size_t>(std::max(count, 0)));
  std::optional<FreeComponents> components;
  if (spec.connected_radius && count > 0) components.emplace(world, *spec.connected_radius);
  for (int i = 0; i < count; ++i) {
    for (int attempt = 0;; ++attempt) {
      if (attempt == max_draws && components) {
        cannotPlace("a random pair joined by a way for a radius of " +
                        formatNumber(*spec.connected_radius) + " m (queries.random.connected)",
                    world_id, max_draws, "lower the clearance or distances, or drop connected");
      }
      if (attempt == max_draws) cannotPlace("a random pair", world_id, max_draws);
      PlanningQuery query;
      if (spec.lattice_step > 0.0) {
        query.start.col(0) =
            sampleLatticePosition(world, spec, rng, "a random start", world_id, max_draws);
        query.goal = sampleLatticePosition(world, spec, rng, "a random goal", world_id, max_draws);
      } else {
        query.start.col(0) = sampleFreePosition(world, spec.region, spec.clearance, rng,
                                                "a random start", world_id, max_draws);
        query.goal = sampleFreePosition(world, spec.region, spec.clearance, rng, "a random goal",
                                        world_id, max_draws);
      }
      const double distance = (query.goal - query.start.col(0)).norm();
      if (distance >= spec.min_distance && distance <= spec.max_distance &&
          (!components || components->joined(query.start.col(0), query.goal))) {
        queries.push_back(query);
        break;
      }
    }
  }
  return queries;
}

}  // namespace kinolab
