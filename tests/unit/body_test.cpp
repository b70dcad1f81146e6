// The body is declared once (kinolab/dynamics/body.hpp): the planner's start and goal rule
// and the independent checker keep the same radius, whatever the radius and tolerance; a
// planner reads it once from its parameters and a flight's margin reaches it through setup.
#include "kinolab/dynamics/body.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

/// A 4 m room with one occupied box at x in [2, 2.4].
std::shared_ptr<const World> boxWorld() {
  return World::build(WorldSpec::fromText(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\n"
      "generators: [{type: box_list, boxes: [{min: [2, 0, 0], max: [2.4, 4, 2]}]}]\n",
      "body_test", "."));
}

/// The checker's verdict on resting at `position`.
bool checkerAccepts(const std::shared_ptr<const World>& world, const Body& body,
                    const Eigen::Vector3d& position) {
  CheckerSettings settings;
  settings.body = body;
  const TrajectoryChecker checker(world, settings);
  ChainState rest = ChainState::Zero();
  rest.col(0) = position;
  Trajectory hold;
  hold.append(TrajectorySegment::primitive(rest, Eigen::Vector3d::Zero(), 2, 0.5));
  CheckQuery query;
  query.start = rest;
  query.goal = position;
  return checker.check(hold, query).valid;
}

TEST(Body, KeptRadiusIsTheRadiusLessTheToleranceNeverBelowZero) {
  EXPECT_DOUBLE_EQ((Body{0.25, 0.01, 0.5}.keptRadius()), 0.24);
  EXPECT_EQ((Body{0.005, 0.01, 0.5}.keptRadius()), 0.0);
  EXPECT_EQ((Body{0.0, 0.01, 0.5}.keptRadius()), 0.0);
  const Body grown = Body{0.25, 0.02, 0.3}.grown(0.15);
  EXPECT_DOUBLE_EQ(grown.radius, 0.4);
  EXPECT_EQ(grown.tolerance, 0.02);
  EXPECT_EQ(grown.safety_band, 0.3);
  EXPECT_DOUBLE_EQ((Body{0.25, 0.01, 0.5}.costReach()), 0.75);
}

TEST(Body, TheStartRuleAndTheCheckerKeepTheSameRadiusEvenBelowTheTolerance) {
  // Before the body was declared once, "radius less tolerance" was written three ways and
  // a body thinner than its tolerance was accepted inside an occupied cube.
  const auto world = boxWorld();
  for (const Body& body : {Body{0.25, 0.01, 0.5}, Body{0.1, 0.05, 0.5}, Body{0.005, 0.01, 0.5},
                           Body{0.0, 0.01, 0.5}}) {
    for (const double x : {1.5, 1.7, 1.73, 1.77, 1.8, 1.9, 1.93, 1.97, 1.99, 2.0, 2.1, 2.3}) {
      const Eigen::Vector3d position(x, 2.0, 1.0);
      const std::string problem = positionProblem(*world, position, body);
      SCOPED_TRACE("radius " + std::to_string(body.radius) + ", tolerance " +
                   std::to_string(body.tolerance) + ", x " + std::to_string(x) + ": " + problem);
      EXPECT_EQ(problem.empty(), checkerAccepts(world, body, position));
      // The box's face is at x = 2 (no x sits on a kept radius, where touching is a tie):
      // a start is refused exactly within the kept radius.
      const double distance = std::max(2.0 - x, 0.0);
      if (distance > body.keptRadius() + 1e-9) {
        EXPECT_TRUE(problem.empty());
      }
      if (distance < body.keptRadius() - 1e-9 || x >= 2.0) {
        EXPECT_FALSE(problem.empty());
      }
    }
  }
}

TEST(Body, APlannerReadsItsBodyOnceAndAMarginReachesItThroughSetup) {
  test::loadTestPlugins();
  ConfiguredPlanner configured =
      configurePlanner("lazy_mp_astar", {{"robot_radius", "0.3", "test"},
                                         {"collision_tolerance", "0.02", "test"},
                                         {"safety_distance", "0.7", "test"}});
  Planner& planner = *configured.planner;
  EXPECT_EQ(planner.body().radius, 0.3);
  EXPECT_EQ(planner.body().tolerance, 0.02);
  EXPECT_EQ(planner.body().safety_band, 0.7);
  const auto world = boxWorld();
  planner.setup({world, 1, 0.15});
  EXPECT_DOUBLE_EQ(planner.body().radius, 0.45);
  EXPECT_EQ(planner.configuredBody().radius, 0.3);
  // The grown body is what the planner refuses starts with: 0.4 m from the box is free for
  // the body (0.28 kept) but not for the body and margin (0.43 kept).
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(1.6, 2.0, 1.0);
  query.goal = Eigen::Vector3d(1.0, 2.0, 1.0);
  EXPECT_EQ(planner.plan(query, Budget{}).status, PlanStatus::kInvalidStart);
  planner.setup({world, 1});  // no margin: the body again
  EXPECT_EQ(planner.body().radius, 0.3);
  EXPECT_NE(planner.plan(query, Budget{}).status, PlanStatus::kInvalidStart);
  EXPECT_THROW(planner.setup({world, 1, -0.1}), InvalidArgument);
  // A planner without body parameters is a point.
  EXPECT_EQ(bodyFrom(ParameterSet()).radius, 0.0);
}

TEST(Body, TheSamplerIsAnOrdinaryPluginParameter) {
  test::loadTestPlugins();
  // Chosen and configured as any plugin parameter; the planner makes it in its factory.
  ConfiguredPlanner coarse =
      configurePlanner("eager_mp_astar",
                       {{"sampler", "uniform", "test"}, {"sampler.samples_per_axis", "3", "test"}});
  ConfiguredPlanner fine =
      configurePlanner("eager_mp_astar",
                       {{"sampler", "uniform", "test"}, {"sampler.samples_per_axis", "5", "test"}});
  const auto world = boxWorld();
  coarse.planner->setup({world, 1});
  fine.planner->setup({world, 1});
  const auto& coarse_search = dynamic_cast<MotionPrimitivePlanner&>(*coarse.planner).search();
  const auto& fine_search = dynamic_cast<MotionPrimitivePlanner&>(*fine.planner).search();
  EXPECT_EQ(coarse_search.controls().size(), 27u);
  EXPECT_EQ(fine_search.controls().size(), 125u);
  EXPECT_EQ(coarse.parameters.text("sampler"), "uniform");
  EXPECT_THROW(configurePlanner("eager_mp_astar", {{"sampler", "gauss", "test"}}), Error);
}

}  // namespace
}  // namespace kinolab
