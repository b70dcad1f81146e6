#pragma once
// The forest world and the 50 seeded queries the search and planner benchmarks share.
#include <algorithm>
#include <string>
#include <vector>

#include "kinolab/core/random.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::bench {

/// configs/worlds/forest.yaml (40 m x 40 m x 5 m), from the world cache.
inline const std::shared_ptr<const World>& forest() {
  static const auto world =
      WorldCache(WorldCache::defaultDirectory())
          .loadOrBuild(WorldSpec::fromFile(KINOLAB_SOURCE_DIR "/configs/worlds/forest.yaml"))
          .world;
  return world;
}

/// 50 queries 8 to 20 m apart at 1-2 m height, 0.6 m clear at both ends, at rest.
inline const std::vector<PlanningQuery>& queries() {
  static const auto list = [] {
    const World& world = *forest();
    Rng rng(2024);
    const auto draw = [&] {
      for (;;) {
        const Eigen::Vector3d p(rng.uniform(1, 39), rng.uniform(1, 39), rng.uniform(1.0, 2.0));
        if (world.isFree(p, 0.6)) return p;
      }
    };
    std::vector<PlanningQuery> result;
    while (result.size() < 50) {
      PlanningQuery query;
      query.start.col(0) = draw();
      query.goal = draw();
      const double distance = (query.goal - query.start.col(0)).norm();
      if (distance >= 8.0 && distance <= 20.0) result.push_back(query);
    }
    return result;
  }();
  return list;
}

inline double median(std::vector<double> values) {
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
