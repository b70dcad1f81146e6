#include "kinolab/primitives/edge_evaluator.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {
namespace {

std::shared_ptr<const World> worldFrom(const std::string& text) {
  return World::build(WorldSpec::fromYaml(YamlReader::loadString(text, "spec.yaml"), "."));
}

/// 10 m x 10 m x 3 m: a small dense forest with a ground plane, at 0.1 m (or, coarse, at
/// 0.5 m: the trunks become blocks of whole voxels).
std::shared_ptr<const World> smallForest(bool coarse = false) {
  const auto make = [](const char* resolution) {
    return worldFrom(std::string("seed: 3\nresolution: ") + resolution +
                     "\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\n"
                     "generators: [{type: forest, density: 0.25, trunk_radius: [0.1, 0.3], "
                     "trunk_height: [2.5, 3], min_spacing: 0.5, ground_plane: true}]\n");
  };
  static const auto fine = make("0.1");
  static const auto rough = make("0.5");
  return coarse ? rough : fine;
}

ChainState stateAt(const Eigen::Vector3d& position, const Eigen::Vector3d& velocity) {
  ChainState state = ChainState::Zero();
  state.col(0) = position;
  state.col(1) = velocity;
  return state;
}

TEST(EdgeEvaluator, MapFreeTermsByHand) {
  const auto world = worldFrom(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\ngenerators: [{type: empty}]\n");
  EdgeEvaluatorSettings settings;
  settings.duration = 0.5;
  settings.weights = {2.0, 3.0, 0.5, 1.0};
  const EdgeEvaluator evaluator(world, settings);
  // Constant velocity 1 m/s along x, no control: a straight 0.5 m.
  const ChainState start = stateAt({2, 5, 1.5}, {1, 0, 0});
  const EdgeEvaluation full = evaluator.full(start, Eigen::Vector3d::Zero());
  ASSERT_TRUE(full.valid());
  EXPECT_DOUBLE_EQ(full.length, 0.5);
  EXPECT_DOUBLE_EQ(full.obstacle_cost, 0.0);  // far from anything in an empty world
  EXPECT_NEAR(full.cost, 2.0 * 0.5 + 3.0 * 0.5, 1e-12);
  // Control effort |u|^2 tau, and the end state of x = x0 + v t + u t^2 / 2.
  const Eigen::Vector3d control(1.0, 2.0, 0.0);
  const EdgeEvaluation curved = evaluator.full(start, control);
  const EdgeEvaluation partial = evaluator.partial(start, control);
  EXPECT_NEAR(curved.end(0, 0), 2.0 + 0.5 + 0.125, 1e-12);
  EXPECT_NEAR(curved.end(1, 1), 1.0, 1e-12);
  EXPECT_NEAR(partial.cost - 3.0 * partial.length, 2.0 * 0.5 + 0.5 * 5.0 * 0.5, 1e-12);
  EXPECT_GT(curved.length, partial.length);  // polyline through the samples vs the chord
}

TEST(EdgeEvaluator, PolylineLengthConvergesToTheArcLength) {
  const auto world = worldFrom(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\ngenerators: [{type: empty}]\n");
  const ChainState start = stateAt({3, 5, 1.5}, {2, 0, 0});
  const Eigen::Vector3d control(0, 3, 0);
  // Arc length of (2t, 1.5 t^2) over [0, 1] by a fine midpoint rule.
  double arc = 0.0;
  for (int i = 0; i < 100000; ++i) {
    const double t = (i + 0.5) / 100000.0;
    arc += std::hypot(2.0, 3.0 * t) / 100000.0;
  }
  double previous_error = INFINITY;
  for (const int samples : {2, 8, 32}) {
    EdgeEvaluatorSettings settings;
    settings.duration = 1.0;
    settings.limits = DynamicLimits::uniform(5.0, 5.0);
    settings.weights.length = 1.0;  // the polyline is measured for the length term
    settings.sampling.samples = samples;
    const EdgeEvaluation full = EdgeEvaluator(world, settings).full(start, control);
    ASSERT_TRUE(full.valid());
    const double error = arc - full.length;
    EXPECT_GE(error, 0.0);  // a polyline through points of a curve is never longer
    EXPECT_LT(error, previous_error);
    previous_error = error;
  }
  EXPECT_LT(previous_error, 1e-3);
}

TEST(EdgeEvaluator, ObstaclePenaltyIsAQuadratureOverTheSamples) {
  // A wall at x >= 5; fly along it at 0.4 m from its face, so every sample has the same ESDF.
  const auto world = worldFrom(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\n"
      "generators: [{type: box_list, boxes: [{min: [5, 0, 0], max: [10, 10, 3]}]}]\n");
  EdgeEvaluatorSettings settings;
  settings.duration = 0.5;
  settings.body.radius = 0.2;
  settings.body.safety_band = 0.5;
  settings.weights = {0.0, 0.0, 0.0, 4.0};
  settings.sampling.samples = 5;
  const EdgeEvaluator evaluator(world, settings);
  const ChainState start = stateAt({4.55, 2, 1.55}, {0, 1, 0});  // a voxel centre
  const double distance = world->esdf().distance(start.col(0));
  EXPECT_NEAR(distance, 0.45, 1e-6);  // from the centre at 4.55 to the wall's face at 5
  const double phi = std::pow(1.0 - (distance - 0.2) / 0.5, 2);
  const EdgeEvaluation full = evaluator.full(start, Eigen::Vector3d::Zero());
  const EdgeEvaluation partial = evaluator.partial(start, Eigen::Vector3d::Zero());
  ASSERT_TRUE(full.valid() && partial.valid());
  EXPECT_NEAR(full.obstacle_cost, 4.0 * phi * 0.5, 1e-6);
  EXPECT_NEAR(partial.obstacle_cost, 4.0 * phi * 0.5 / 5, 1e-6);
  // The five quadrature samples (all inside the band) and the sphere tracing's points.
  EXPECT_GT(full.esdf_queries, 5);
  EXPECT_EQ(partial.esdf_queries, 1);
}

TEST(EdgeEvaluator, FarFromObstaclesAnEdgeCostsTwoQueries) {
  const auto world = worldFrom(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\ngenerators: [{type: empty}]\n");
  EdgeEvaluatorSettings settings;
  settings.sampling.samples = 50;
  const EdgeEvaluator evaluator(world, settings);
  const EdgeEvaluation full = evaluator.full(stateAt({3, 5, 1.5}, {1, 1, 0}), {2, -1, 0.5});
  ASSERT_TRUE(full.valid());
  EXPECT_EQ(full.esdf_queries, 2);  // the start covers the edge, then the end; no quadrature
  EXPECT_EQ(full.obstacle_cost, 0.0);
}

/// Partial <= full on every primitive; partial rejection implies full rejection; and full
/// evaluation finds every collision a dense check finds: 400 points per primitive, each
/// tested exactly against the occupied cubes (the checker's FCL test) with the radius less
/// the tolerance.
void checkAgainstDenseChecking(const EdgeEvaluatorSettings& settings, int* dense_collisions,
                               int* missed, bool coarse = false) {
  const auto world = smallForest(coarse);
  const EdgeEvaluator evaluator(world, settings);
  const IntegratorChain& chain = evaluator.chain();
  CheckerSettings body;
  body.body.radius = settings.body.radius;
  body.body.tolerance = settings.body.tolerance;
  const TrajectoryChecker exact(world, body);
  Rng rng(17);
  *dense_collisions = 0;
  *missed = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    ChainState start = ChainState::Zero();
    do {
      start.col(0) =
          Eigen::Vector3d(rng.uniform(0.5, 9.5), rng.uniform(0.5, 9.5), rng.uniform(0.5, 2.5));
    } while (!world->isFree(start.col(0), settings.body.radius));
    for (int k = 1; k < settings.order; ++k) {
      for (int axis = 0; axis < 3; ++axis) start(axis, k) = rng.uniform(-1.5, 1.5);
    }
    const double u = settings.limits.bound[settings.order].x();
    const Eigen::Vector3d control(rng.uniform(-u, u), rng.uniform(-u, u), rng.uniform(-u, u));
    const EdgeEvaluation partial = evaluator.partial(start, control);
    const EdgeEvaluation full = evaluator.full(start, control);
    ASSERT_EQ(partial.within_limits, full.within_limits);
    ASSERT_EQ(partial.end, full.end);
    if (!partial.valid()) {
      ASSERT_FALSE(full.valid()) << trial;
    } else if (full.valid()) {
      ASSERT_LE(partial.cost, full.cost * (1.0 + 1e-12)) << trial;
    }
    if (!full.within_limits) continue;
    bool dense_collision = false;
    for (int i = 0; i <= 400 && !dense_collision; ++i) {
      const Eigen::Vector3d p = chain.stateAt(start, control, settings.duration * i / 400).col(0);
      dense_collision = !world->bounds().contains(p) || exact.collides(p);
    }
    if (dense_collision) {
      ++*dense_collisions;
      if (full.collision_free) ++*missed;
    }
  }
}

TEST(EdgeEvaluator, FullEvaluationFindsEveryDenseCollision) {
  for (const auto mode : {EdgeSampling::Mode::kCount, EdgeSampling::Mode::kSpacing}) {
    for (const int order : {2, 3}) {
      EdgeEvaluatorSettings settings;
      settings.order = order;
      settings.limits = DynamicLimits::uniform(2.0, 3.0, 6.0);
      settings.sampling.mode = mode;
      int dense = 0;
      int missed = 0;
      checkAgainstDenseChecking(settings, &dense, &missed);
      EXPECT_GT(dense, 100) << "the forest should make many primitives collide";
      EXPECT_EQ(missed, 0) << "order " << order;
    }
  }
  // A small robot and a point robot are exact too, and so is every radius on a 0.5 m grid
  // (where the cubes are much larger than the robot).
  for (const bool coarse : {false, true}) {
    for (const double radius : {0.25, 0.05, 0.0}) {
      if (!coarse && radius == 0.25) continue;  // the default, above
      EdgeEvaluatorSettings small;
      small.body.radius = radius;
      int dense = 0;
      int missed = 0;
      checkAgainstDenseChecking(small, &dense, &missed, coarse);
      EXPECT_GT(dense, 50) << radius << (coarse ? " coarse" : "");
      EXPECT_EQ(missed, 0) << radius << (coarse ? " coarse" : "");
    }
  }
}

TEST(EdgeEvaluator, TheVerdictIsExactBothWays) {
  // On forests at 0.5, 0.25 and 0.1 m, 3,000 random primitives each, checked at 400 points
  // against the occupied cubes exactly (FCL): an edge that comes within radius less the
  // tolerance anywhere is refused (safety), and an edge that keeps radius plus half the
  // largest gap between the points (so the radius between them too) from every cube is
  // accepted (completeness; the proven bound alone refused some of these). Edges whose map
  // test (the Bernstein hull, conservative) fails are left out of the second count.
  for (const char* resolution : {"0.5", "0.25", "0.1"}) {
    SCOPED_TRACE(resolution);
    const auto world = worldFrom(std::string("seed: 3\nresolution: ") + resolution +
                                 "\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\n"
                                 "generators: [{type: forest, density: 0.25, trunk_radius: "
                                 "[0.1, 0.3], trunk_height: [2.5, 3], min_spacing: 0.5, "
                                 "ground_plane: true}]\n");
    EdgeEvaluatorSettings settings;
    settings.limits = DynamicLimits::uniform(2.0, 3.0, 6.0);
    const EdgeEvaluator evaluator(world, settings);
    CheckerSettings inner;
    inner.body.radius = settings.body.radius;
    inner.body.tolerance = settings.body.tolerance;
    const TrajectoryChecker within_tolerance(world, inner);
    Rng rng(23);
    int colliding = 0;
    int clear = 0;
    int rescued = 0;  // clear edges on which the proven bound fell below the radius
    for (int trial = 0; trial < 3000; ++trial) {
      // The velocity, then the position, each last coordinate first: the same draws on every
      // compiler (drawLastFirst).
      const auto velocity = drawLastFirst<Eigen::Vector3d>(
          [&](int axis) { return axis < 2 ? rng.uniform(-1.5, 1.5) : rng.uniform(-1, 1); });
      const auto position = drawLastFirst<Eigen::Vector3d>(
          [&](int axis) { return axis < 2 ? rng.uniform(0.5, 9.5) : rng.uniform(0.5, 2.5); });
      const ChainState start = stateAt(position, velocity);
      const auto control = drawLastFirst<Eigen::Vector3d>([&](int) { return rng.uniform(-3, 3); });
      if (!evaluator.controlOnly(start, control).collision_free) continue;  // limits or map
      const EdgeEvaluation full = evaluator.full(start, control);
      std::vector<Eigen::Vector3d> points;
      double gap = 0.0;
      for (int i = 0; i <= 400; ++i) {
        points.push_back(
            evaluator.chain().stateAt(start, control, settings.duration * i / 400).col(0));
        if (i > 0) gap = std::max(gap, (points[i] - points[i - 1]).norm());
      }
      bool collides = false;
      double nearest = INFINITY;
      double least_bound = INFINITY;
      for (const Eigen::Vector3d& p : points) {
        collides = collides || within_tolerance.collides(p);
        nearest = std::min(nearest, world->esdf().exactDistance(p, 10.0));
        least_bound = std::min(least_bound, world->clearance(p));
      }
      if (collides) {
        ++colliding;
        EXPECT_FALSE(full.collision_free) << "trial " << trial << ": a collision accepted";
      } else if (nearest >= settings.body.radius + 0.5 * gap) {
        ++clear;
        rescued += least_bound < settings.body.radius;
        EXPECT_TRUE(full.collision_free) << "trial " << trial << ": a clear edge refused";
        EXPECT_TRUE(evaluator.partial(start, control).collision_free) << "trial " << trial;
      }
    }
    EXPECT_GT(colliding, 100);
    EXPECT_GT(clear, 500);
    EXPECT_GT(rescued, 10) << "no clear edge came near enough for the bound to fail";
    std::printf(
        "[ exact both ways ] %s m: %d colliding refused, %d clear accepted (%d of them "
        "below the bound's radius)\n",
        resolution, colliding, clear, rescued);
  }
}

TEST(EdgeEvaluator, TheVerdictDoesNotDependOnSampling) {
  // Two quadrature samples or a hundred, or a spacing: the same edges collide.
  const auto world = smallForest();
  EdgeEvaluatorSettings sparse;
  sparse.sampling.samples = 2;
  EdgeEvaluatorSettings dense;
  dense.sampling.samples = 100;
  EdgeEvaluatorSettings spaced;
  spaced.sampling.mode = EdgeSampling::Mode::kSpacing;
  spaced.sampling.spacing = 0.3;
  const EdgeEvaluator a(world, sparse);
  const EdgeEvaluator b(world, dense);
  const EdgeEvaluator c(world, spaced);
  Rng rng(5);
  int collisions = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const ChainState start =
        stateAt({rng.uniform(0.5, 9.5), rng.uniform(0.5, 9.5), rng.uniform(0.5, 2.5)},
                {rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1, 1)});
    if (!world->isFree(start.col(0), sparse.body.radius)) continue;
    const Eigen::Vector3d control(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    const EdgeEvaluation ea = a.full(start, control);
    if (!ea.within_limits) continue;
    collisions += !ea.collision_free;
    EXPECT_EQ(ea.collision_free, b.full(start, control).collision_free) << trial;
    EXPECT_EQ(ea.collision_free, c.full(start, control).collision_free) << trial;
  }
  EXPECT_GT(collisions, 100);
}

TEST(EdgeEvaluator, ARadiusOfZeroIsAPointRobot) {
  // A wall at x >= 5: a point flying 5 cm from its face (along voxel centres, where the
  // clearance bound is exact) is free, one entering it is not.
  const auto world = worldFrom(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\n"
      "generators: [{type: box_list, boxes: [{min: [5, 0, 0], max: [10, 10, 3]}]}]\n");
  EdgeEvaluatorSettings settings;
  settings.body.radius = 0.0;
  settings.body.tolerance = 0.005;
  const EdgeEvaluator evaluator(world, settings);
  EXPECT_TRUE(evaluator.full(stateAt({4.95, 2.05, 1.55}, {0, 0, 0.5}), Eigen::Vector3d::Zero())
                  .collision_free);
  EXPECT_FALSE(
      evaluator.full(stateAt({4.9, 2, 1.5}, {0.5, 1, 0}), Eigen::Vector3d::Zero()).collision_free);
}

TEST(EdgeEvaluator, RejectsBadSettings) {
  const auto world = smallForest();
  EdgeEvaluatorSettings settings;
  settings.sampling.mode = EdgeSampling::Mode::kSpacing;
  settings.sampling.spacing = 0.0;
  EXPECT_THROW(EdgeEvaluator(world, settings), InvalidArgument);
  settings = {};
  settings.body.tolerance = 0.0;  // tracing would never finish
  EXPECT_THROW(EdgeEvaluator(world, settings), InvalidArgument);
  settings = {};
  settings.sampling.samples = 0;
  EXPECT_THROW(EdgeEvaluator(world, settings), InvalidArgument);
  settings = {};
  settings.weights.obstacle = -1.0;
  EXPECT_THROW(EdgeEvaluator(world, settings), InvalidArgument);
  settings = {};
  settings.duration = 0.0;
  EXPECT_THROW(EdgeEvaluator(world, settings), InvalidArgument);
}

}  // namespace
}  // namespace kinolab
