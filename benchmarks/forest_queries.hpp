#pragma once
// The forest world and the 50 seeded queries the search and planner benchmarks share.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "kinolab/core/random.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::bench {

/// The shipped world configs/worlds/`name`.yaml, from the world cache (built on first use).
inline std::shared_ptr<const World> shippedWorld(const std::string& name) {
  return WorldCache(WorldCache::defaultDirectory())
      .loadOrBuild(WorldSpec::fromFile(KINOLAB_SOURCE_DIR "/configs/worlds/" + name + ".yaml"))
      .world;
}

/// configs/worlds/forest.yaml (40 m x 40 m x 5 m).
inline const std::shared_ptr<const World>& forest() {
  static const auto world = shippedWorld("forest");
  return world;
}

/// 50 seeded queries between `min_distance` and `max_distance` apart at 1-2 m height, 0.6 m
/// clear at both ends, at rest.
inline std::vector<PlanningQuery> forestQueries(std::uint64_t seed, double min_distance,
                                                double max_distance) {
  Rng rng(seed);
  const FreeQueryRegion region{Box{{1.0, 1.0, 1.0}, {39.0, 39.0, 2.0}}, 0.6, min_distance,
                               max_distance};
  return sampleFreeQueries(*forest(), region, 50, rng, "forest");
}

/// 50 queries 8 to 20 m apart (the planner comparison).
inline const std::vector<PlanningQuery>& queries() {
  static const auto list = forestQueries(2024, 8.0, 20.0);
  return list;
}

/// The paper's scale: 50 queries 10 to 30 m apart.
inline const std::vector<PlanningQuery>& paperScaleQueries() {
  static const auto list = forestQueries(2025, 10.0, 30.0);
  return list;
}

/// The median; NaN for no values.
inline double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

inline double statistic(const PlanResult& result, const std::string& name) {
  for (const auto& [key, value] : result.statistics) {
    if (key == name) return value;
  }
  return 0.0;
}

}  // namespace kinolab::bench
