// Every registered heuristic, lower bound, search space, sensor, vehicle map and world
// generator (built-in,
// and any library named in $KINOLAB_TEST_PLUGINS) keeps its kind's contract
// (docs/extending/).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "kinolab/core/random.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/flight/vehicle_map.hpp"
#include "kinolab/plugins/lidar.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"
#include "kinolab/world/world_generator.hpp"
#include "support/planning.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

template <typename Interface>
std::vector<std::string> registered() {
  test::loadTestPlugins();
  return pluginRegistry<Interface>().keys();
}

/// Edges of order `order` on the small forest, from random moving states (a control grid of
/// 5 per axis, the limits included): what the heuristic and lower-bound checks walk.
struct EdgeSamples {
  std::shared_ptr<const World> world = test::smallWorld("forest");
  EdgeEvaluatorSettings settings;
  std::vector<Eigen::Vector3d> controls;

  explicit EdgeSamples(int order) {
    settings.order = order;
    settings.duration = order == 2 ? 0.4 : 0.3;
    settings.limits = DynamicLimits::uniform(2.0, 3.0, 8.0, 40.0);
    settings.weights.length = 0.5;
    settings.weights.control_effort = order == 2 ? 0.7 : 0.1;
    controls = controlGrid({-1.0, -0.4, 0.0, 0.6, 1.0}, settings.limits.bound[order]);
  }
  ChainState state(Rng& rng) const {
    ChainState state = ChainState::Zero();
    do {
      state.col(0) =
          Eigen::Vector3d(rng.uniform(0.5, 11.5), rng.uniform(0.5, 11.5), rng.uniform(0.5, 2.5));
    } while (!world->isFree(state.col(0), 0.3));
    for (int k = 1; k < settings.order; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        state(axis, k) = rng.uniform(-1.0, 1.0) * settings.limits.bound[k][axis];
      }
    }
    return state;
  }
};

class HeuristicConformance : public ::testing::TestWithParam<std::string> {};

// h(s) <= c(s, s') + h(s') for every valid edge's full cost, with the heuristic prepared for
// each goal (SearchHeuristic::forQuery): then weight 1 is optimal, and lazy search (whose
// queued bounds are at most the full costs) returns eager's cost.
TEST_P(HeuristicConformance, FiniteAndConsistentWithTheFullEdgeCosts) {
  const PluginInfo& info = pluginRegistry<HeuristicBuilder>().info(GetParam());
  EXPECT_FALSE(info.description.empty());
  int orders = 0;
  for (const int order : {2, 3}) {
    const EdgeSamples samples(order);
    const EdgeEvaluator evaluator(samples.world, samples.settings);
    std::shared_ptr<const SearchHeuristic> heuristic;
    try {
      heuristic =
          pluginRegistry<HeuristicBuilder>().create(GetParam(), {})->build({samples.settings, 0.5});
    } catch (const ParameterConflict&) {
      continue;  // declines this order (obvp above 2), as it may
    }
    ++orders;
    heuristic = heuristicForControls(heuristic, samples.controls);
    Rng rng(17 + order);
    int edges = 0;
    int violations = 0;
    int states = 0;
    int finite = 0;
    while (edges < 2000) {
      const ChainState state = samples.state(rng);
      const Eigen::Vector3d goal =
          state.col(0) +
          Eigen::Vector3d(rng.uniform(-6, 6), rng.uniform(-6, 6), rng.uniform(-2, 2));
      // The query's heuristic (one that reads the map prepares for this goal here).
      StopCondition never(Budget{});
      const auto prepared = heuristicForQuery(heuristic, *samples.world, goal, never);
      const double h = prepared->estimate(state, goal);
      // +infinity is allowed: "the goal is out of reach from here".
      ASSERT_TRUE(h >= 0.0) << h;
      finite += std::isfinite(h);
      for (const auto& control : samples.controls) {
        const EdgeEvaluation full =
            evaluator.full(state, control, samples.world->clearance(state.col(0)));
        if (!full.valid()) continue;
        ++edges;
        const double after = prepared->estimate(full.end, goal);
        ASSERT_TRUE(after >= 0.0) << after;
        violations += h > full.cost + after + 1e-9 * (1.0 + h);
      }
      ++states;
    }
    EXPECT_GT(finite, states / 2) << GetParam() << ": mostly goals it can reach";
    EXPECT_EQ(violations, 0) << GetParam() << " at order " << order << ": " << violations << " of "
                             << edges << " edges";
  }
  EXPECT_GT(orders, 0) << GetParam() << " serves neither order 2 nor 3";
}

INSTANTIATE_TEST_SUITE_P(Registered, HeuristicConformance,
                         ::testing::ValuesIn(registered<HeuristicBuilder>()),
                         [](const auto& key) { return key.param; });

class LowerBoundConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(LowerBoundConformance, AtMostTheFullCostAndInvalidOnlyWhenTheEdgeIs) {
  const auto policy = pluginRegistry<EdgeEvaluationPolicy>().create(GetParam(), {});
  for (const int order : {2, 3}) {
    const EdgeSamples samples(order);
    const EdgeEvaluator evaluator(samples.world, samples.settings);
    Rng rng(5 + order);
    for (int i = 0; i < 200; ++i) {
      const ChainState state = samples.state(rng);
      const double clearance = samples.world->clearance(state.col(0));
      for (const auto& control : samples.controls) {
        const EdgeEvaluation full = evaluator.full(state, control, clearance);
        EdgeEvaluation estimate;
        const EdgeEstimate kind = policy->evaluate(evaluator, state, clearance, control, estimate);
        ASSERT_TRUE(estimate.end.isApprox(full.end, 1e-9)) << "the end state is the edge's";
        if (!estimate.valid()) {
          ASSERT_FALSE(full.valid()) << "a valid edge called invalid";
          continue;
        }
        if (!full.valid()) continue;  // a lower bound may pass what full evaluation rejects
        if (kind == EdgeEstimate::kLowerBound) {
          ASSERT_LE(estimate.cost, full.cost + 1e-9 * (1.0 + full.cost));
        } else {
          ASSERT_NEAR(estimate.cost, full.cost, 1e-9 * (1.0 + full.cost)) << "full or certified";
        }
      }
    }
  }
}

// With the bound, lazy search returns eager's cost (the paper's claim, for any bound).
TEST_P(LowerBoundConformance, LazySearchWithItReturnsEagersCost) {
  const auto world = test::smallWorld("forest");
  const auto queries = test::randomQueries(*world, 4, 31, 4.0, 9.0, 0.5);
  const std::vector<std::string> common = {"sampler.samples_per_axis=3", "tau=0.5"};
  auto lazy_items = common;
  lazy_items.push_back("lower_bound=" + GetParam());
  ConfiguredPlanner lazy = configurePlanner("lazy_mp_astar", test::assignments(lazy_items));
  ConfiguredPlanner eager = configurePlanner("eager_mp_astar", test::assignments(common));
  lazy.planner->setup({world, 1});
  eager.planner->setup({world, 1});
  for (const PlanningQuery& query : queries) {
    const PlanResult a = lazy.planner->plan(query, Budget{});
    const PlanResult b = eager.planner->plan(query, Budget{});
    ASSERT_EQ(a.status, b.status);
    if (b.status != PlanStatus::kExact) continue;
    EXPECT_TRUE(a.check.valid) << a.check.detail;
    EXPECT_NEAR(a.cost, b.cost, 1e-9 * (1.0 + b.cost));
  }
}

INSTANTIATE_TEST_SUITE_P(Registered, LowerBoundConformance,
                         ::testing::ValuesIn(registered<EdgeEvaluationPolicy>()),
                         [](const auto& key) { return key.param; });

class SearchSpaceConformance : public ::testing::TestWithParam<std::string> {};

// Keys are a function of the state and the start only (a space that keeps state between
// calls gives a fresh instance other keys), and a search over the space returns
// trajectories the independent checker accepts.
TEST_P(SearchSpaceConformance, KeysDependOnTheStateOnlyAndTrajectoriesPassTheChecker) {
  const auto used = pluginRegistry<SearchSpace>().create(GetParam(), {});
  const EdgeSamples samples(3);
  Rng rng(3);
  const ChainState start = samples.state(rng);
  std::vector<ChainState> states;
  std::vector<SearchSpace::Key> keys;
  for (int i = 0; i < 100; ++i) {
    states.push_back(samples.state(rng));
    keys.push_back(used->key(states.back(), start, 3));
  }
  const auto fresh = pluginRegistry<SearchSpace>().create(GetParam(), {});
  for (int i = 99; i >= 0; --i) {  // another order, another instance: the same keys
    EXPECT_EQ(fresh->key(states[i], start, 3), keys[i]);
  }
  const auto world = test::smallWorld("forest");
  ConfiguredPlanner planner = configurePlanner(
      "eager_mp_astar",
      test::assignments({"sampler.samples_per_axis=3", "tau=0.5", "search_space=" + GetParam()}));
  planner.planner->setup({world, 1});
  int exact = 0;
  for (const PlanningQuery& query : test::randomQueries(*world, 4, 7, 4.0, 9.0, 0.5)) {
    const PlanResult result = planner.planner->plan(query, Budget{});
    if (result.status != PlanStatus::kExact) continue;
    ++exact;
    EXPECT_TRUE(result.check.valid) << result.check.check << ": " << result.check.detail;
  }
  EXPECT_GT(exact, 0) << GetParam() << " solved none of 4 queries";
}

INSTANTIATE_TEST_SUITE_P(Registered, SearchSpaceConformance,
                         ::testing::ValuesIn(registered<SearchSpace>()),
                         [](const auto& key) { return key.param; });

class SensorConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(SensorConformance, UnitRaysPositiveRangeAndRateTheSameEveryCall) {
  const auto sensor = pluginRegistry<Sensor>().create(GetParam(), {});
  EXPECT_TRUE(std::isfinite(sensor->maxRange()) && sensor->maxRange() > 0.0);
  EXPECT_TRUE(std::isfinite(sensor->frameRate()) && sensor->frameRate() > 0.0);
  const auto rays = sensor->rayDirections();
  ASSERT_FALSE(rays.empty());
  for (const auto& ray : rays) ASSERT_NEAR(ray.norm(), 1.0, 1e-9);
  EXPECT_EQ(sensor->rayDirections(), rays);
  // A camera's pixel grid holds its rays, row by row: each projects onto its own pixel.
  const std::optional<PixelGrid> pixels = sensor->pixelGrid();
  if (pixels) {
    ASSERT_EQ(static_cast<std::size_t>(pixels->columns) * pixels->rows, rays.size());
    for (std::size_t k = 0; k < rays.size(); ++k) {
      const Eigen::Vector3d& d = rays[k];
      ASSERT_GT(d.x(), 0.0) << k;
      ASSERT_EQ(std::lround(pixels->column_scale * d.y() / d.x() + pixels->column_offset),
                static_cast<long>(k % pixels->columns))
          << "ray " << k;
      ASSERT_EQ(std::lround(pixels->row_scale * d.z() / d.x() + pixels->row_offset),
                static_cast<long>(k / pixels->columns))
          << "ray " << k;
    }
  }
  // A frame in the forest: at most one return a ray, hits within range, each on an occupied
  // voxel or (a noisy sensor) within five standard deviations of the range noise of one.
  const auto world = test::smallWorld("forest");
  const Eigen::Vector3d origin(6.0, 6.0, 1.5);
  Rng noise(1);
  const SensorFrame frame = senseFrame(*world, *sensor, origin, 0.3, noise);
  EXPECT_LE(frame.hits.size() + frame.misses.size(), rays.size());
  EXPECT_EQ(frame.image.ranges.size(), pixels ? rays.size() : 0u);
  EXPECT_GE(static_cast<double>(frame.hits.size() + frame.misses.size()),
            (1.0 - sensor->noise().dropout) * static_cast<double>(rays.size()) * 0.9);
  const VoxelGrid& grid = world->grid();
  for (const auto& hit : frame.hits) {
    const double range = (hit - origin).norm();
    EXPECT_LE(range, sensor->maxRange() + grid.resolution());
    EXPECT_GE(range, sensor->noise().min_range);
    EXPECT_LE(world->esdf().exactDistance(hit, 1.0), 5.0 * sensor->noise().sigma(range) + 1e-9)
        << "a hit in free space, farther from every obstacle than the noise explains";
  }
}

INSTANTIATE_TEST_SUITE_P(Registered, SensorConformance, ::testing::ValuesIn(registered<Sensor>()),
                         [](const auto& key) { return key.param; });

class VehicleMapConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(VehicleMapConformance, KnowsOnlyWhatWasSeenAndStartsOverOnSetup) {
  const auto world = test::smallWorld("forest");
  const VoxelGrid& truth = world->grid();
  const auto map = pluginRegistry<VehicleMap>().create(GetParam(), {});
  MapModel model;
  model.resolution = truth.resolution();
  map->setup(world->bounds(), model);
  EXPECT_EQ(map->knownFree() + map->knownOccupied(), 0u);
  Lidar lidar;
  lidar.range = 6.0;
  const Eigen::Vector3d origin(6.0, 6.0, 1.5);
  ASSERT_TRUE(world->isFree(origin, 0.3));
  Rng noise(1);
  map->insert(senseFrame(*world, lidar, origin, 0.3, noise), lidar.range);
  // What a noise-free sensor saw as an obstacle is one (on the truth's own lattice), and
  // nothing farther than the range is known.
  ASSERT_GT(map->knownOccupied(), 0u);
  for (const std::size_t voxel : map->occupiedVoxels()) {
    const Eigen::Vector3d c = map->voxelCenter(voxel);
    const VoxelIndex at = ((c - truth.origin()) / truth.resolution()).array().floor().cast<int>();
    ASSERT_TRUE(truth.inside(at));
    EXPECT_TRUE(truth.occupied(at)) << c.transpose();
  }
  const std::size_t known = map->knownFree() + map->knownOccupied();
  for (std::size_t i = 0; i < map->lattice().size(); ++i) {
    if (map->state(i) == VehicleMap::Voxel::kUnknown) continue;
    EXPECT_LE((map->voxelCenter(i) - origin).norm(), lidar.range + 2.0 * truth.resolution());
  }
  // markFree makes unseen voxels near the body known, never changes a seen one.
  const Eigen::Vector3d far(2.0, 10.0, 1.5);
  std::vector<VehicleMap::Voxel> before;
  for (std::size_t i = 0; i < map->lattice().size(); ++i) before.push_back(map->state(i));
  map->markFree(far, 0.5);
  EXPECT_GT(map->knownFree() + map->knownOccupied(), known);
  for (std::size_t i = 0; i < before.size(); ++i) {
    if (before[i] != VehicleMap::Voxel::kUnknown) {
      EXPECT_EQ(map->state(i), before[i]) << i;
    }
  }
  // A window's ESDF agrees with its occupancy, and a second setup forgets everything.
  const auto window = map->window(origin);
  EXPECT_GT(window->grid().occupiedCount(), 0u);
  map->setup(world->bounds(), model);
  EXPECT_EQ(map->knownFree() + map->knownOccupied(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Registered, VehicleMapConformance,
                         ::testing::ValuesIn(registered<VehicleMap>()),
                         [](const auto& key) { return key.param; });

class WorldGeneratorConformance : public ::testing::TestWithParam<std::string> {};

/// The generators that build at their defaults: those that need a value (a map file: the
/// `octomap` generator, tested with real maps in tests/unit/world_test.cpp) are not listed.
std::vector<std::string> generatorsWithDefaults() {
  std::vector<std::string> keys;
  for (const std::string& key : registered<WorldGenerator>()) {
    const auto& specs = pluginRegistry<WorldGenerator>().info(key).parameters.all();
    if (std::none_of(specs.begin(), specs.end(), [](const auto& s) { return s.required; })) {
      keys.push_back(key);
    }
  }
  return keys;
}

// At its defaults a generator gives the same grid for the same spec, bit for bit.
TEST_P(WorldGeneratorConformance, TheSameSpecGivesTheSameGrid) {
  const std::string text =
      "seed: 5\nresolution: 0.2\nbounds: {min: [0, 0, 0], max: [8, 8, 3]}\n"
      "generators: [{type: " +
      GetParam() + "}]\n";
  const auto a = World::build(WorldSpec::fromText(text, "spec.yaml", "."));
  const auto b = World::build(WorldSpec::fromText(text, "spec.yaml", "."));
  ASSERT_EQ(a->grid().size(), b->grid().size());
  for (std::size_t i = 0; i < a->grid().size(); ++i) {
    ASSERT_EQ(a->grid().occupied(i), b->grid().occupied(i)) << "voxel " << i;
  }
  EXPECT_EQ(WorldSpec::fromText(text, "spec.yaml", ".").hash(),
            WorldSpec::fromText(text, "other.yaml", ".").hash());
}

INSTANTIATE_TEST_SUITE_P(Registered, WorldGeneratorConformance,
                         ::testing::ValuesIn(generatorsWithDefaults()),
                         [](const auto& key) { return key.param; });

}  // namespace
}  // namespace kinolab
