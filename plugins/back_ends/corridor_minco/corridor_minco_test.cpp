// The corridor_minco back end: MINCO's gradient against finite differences, corridors that
// contain the shortcut path and keep the body's radius from every occupied cube, and refined
// lazy MP-A* paths on the small forest and walls worlds that pass the independent checker.
#include "corridor_minco.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <string>
#include <vector>

#include "corridor.hpp"
#include "kinolab/planner/back_end.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/validation/trajectory_checker.hpp"
#include "minco_problem.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

/// A front end's answer to one query: what the back end refines.
struct FrontEnd {
  PlanningQuery query;
  PlanResult result;
  std::vector<Eigen::Vector3d> path;
};

/// Lazy MP-A* (acceleration control, 27 controls, tau 0.4; no time budget, so deterministic)
/// on `count` seeded queries 3-9 m apart; only its exact answers.
struct FrontEnds {
  ConfiguredPlanner planner;
  std::vector<FrontEnd> answers;
};

const FrontEnds& frontEnds(const std::string& world_name, int count) {
  static std::map<std::string, FrontEnds> cache;
  const std::string key = world_name + std::to_string(count);
  if (auto found = cache.find(key); found != cache.end()) return found->second;
  FrontEnds front;
  front.planner = configurePlanner(
      "lazy_mp_astar", test::assignments({"sampler.samples_per_axis=3", "tau=0.4", "time_limit=0",
                                          "max_expansions=20000"}));
  const auto world = test::smallWorld(world_name);
  front.planner.planner->setup({world, 1});
  for (const PlanningQuery& query : test::randomQueries(*world, count, 31, 3.0, 9.0, 0.45)) {
    PlanResult result = front.planner.planner->plan(query, Budget{});
    if (result.status != PlanStatus::kExact) continue;
    std::vector<Eigen::Vector3d> path = backEndPath({}, result.trajectory);
    front.answers.push_back({query, std::move(result), std::move(path)});
  }
  return cache.emplace(key, std::move(front)).first->second;
}

std::unique_ptr<BackEnd> makeBackEnd(const FrontEnds& front, const std::string& world_name,
                                     const std::vector<std::string>& items = {}) {
  auto back_end = pluginRegistry<BackEnd>().create("corridor_minco", test::assignments(items));
  back_end->setup(test::smallWorld(world_name), front.planner.planner->body(),
                  front.planner.planner->limits());
  return back_end;
}

BackEndProblem problemOf(const FrontEnd& answer) {
  BackEndProblem problem;
  problem.start = answer.query.start;
  problem.goal = answer.query.goal;
  problem.path = answer.path;
  problem.front = &answer.result.trajectory;
  return problem;
}

double threadMilliseconds() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return 1e3 * static_cast<double>(now.tv_sec) + 1e-6 * static_cast<double>(now.tv_nsec);
}

double statistic(const BackEndResult& result, const std::string& name) {
  return test::statistic(result.statistics, name);
}

// A problem whose penalties are all active: waypoints outside their boxes, pieces too fast.
minco::MincoProblem penalisedProblem(int order) {
  ChainState start = ChainState::Zero();
  start.col(1) = Eigen::Vector3d(1.0, -0.5, 0.2);
  start.col(2) = Eigen::Vector3d(0.3, 0.4, -0.1);
  std::vector<minco::Polytope> corridors(2);
  for (int k = 0; k < 2; ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      corridors[k].add(Eigen::Vector3d::Unit(axis), 1.0 + 2.0 * k * (axis == 0));
      corridors[k].add(-Eigen::Vector3d::Unit(axis), 0.5 - 2.0 * k * (axis == 0));
    }
    corridors[k].add(Eigen::Vector3d(1, 1, 0).normalized(), 1.5 + k);
  }
  minco::ProblemWeights weights;
  weights.max_velocity = Eigen::Vector3d(0.8, 0.9, 1.0);
  weights.max_acceleration = Eigen::Vector3d(1.0, 1.2, 0.7);
  weights.corridor_margin = 0.05;
  return minco::MincoProblem(order, start, Eigen::Vector3d(3.0, 0.2, 0.1), corridors, {0, 0, 1},
                             weights);
}

TEST(CorridorMinco, MincoGradientMatchesFiniteDifferences) {
  for (const int order : {3, 4}) {
    SCOPED_TRACE("order " + std::to_string(order));
    minco::MincoProblem problem = penalisedProblem(order);
    Eigen::Matrix3Xd waypoints(3, 2);
    waypoints << 1.3, 2.2, 1.2, -0.4, 0.3, 0.9;
    const Eigen::VectorXd x = problem.variables(waypoints, Eigen::Vector3d(0.7, 0.5, 1.4));
    Eigen::VectorXd gradient;
    const double cost = problem.cost(x, gradient);
    ASSERT_TRUE(std::isfinite(cost));
    Eigen::VectorXd scratch;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double step = 1e-6;
      Eigen::VectorXd plus = x;
      Eigen::VectorXd minus = x;
      plus(i) += step;
      minus(i) -= step;
      const double numeric =
          (problem.cost(plus, scratch) - problem.cost(minus, scratch)) / (2 * step);
      EXPECT_NEAR(gradient(i), numeric, 1e-5 * std::max(1.0, std::abs(numeric)))
          << "variable " << i;
    }
  }
}

TEST(CorridorMinco, StretchingTheDurationsSlowsTheSamePathIntoTheLimits) {
  // From rest, stretching every duration by k is a uniform slow-down: the same path, speeds
  // divided by k, accelerations by k^2. Stretched by the factor found, the trajectory keeps
  // the limits (at 20 times finer samples than the factor's own, to a sampling slack).
  for (const int order : {3, 4}) {
    SCOPED_TRACE("order " + std::to_string(order));
    ChainState start = ChainState::Zero();
    std::vector<minco::Polytope> corridors(1);
    minco::MincoProblem problem(order, start, Eigen::Vector3d(3.0, 1.0, 0.5), corridors, {0, 0, 0},
                                minco::ProblemWeights{});
    Eigen::Matrix3Xd waypoints(3, 2);
    waypoints << 1.0, 2.0, 0.2, 0.8, 0.1, 0.3;
    const Eigen::VectorXd fast = problem.variables(waypoints, Eigen::Vector3d(0.4, 0.3, 0.5));
    const DynamicLimits limits = DynamicLimits::uniform(2.0, 3.0);
    const double factor = problem.stretchNeeded(fast, limits);
    ASSERT_GT(factor, 1.5);  // the fast one breaks its limits
    const Eigen::VectorXd slow = problem.stretched(fast, factor);
    EXPECT_NEAR(problem.stretchNeeded(slow, limits), 1.0, 1e-9);
    const Trajectory before = problem.trajectory(fast);
    const Trajectory after = problem.trajectory(slow);
    EXPECT_NEAR(after.duration(), factor * before.duration(), 1e-9);
    for (int i = 0; i <= 1000; ++i) {
      const double t = before.duration() * i / 1000;
      EXPECT_LT((after.evaluate(factor * t) - before.evaluate(t)).norm(), 1e-6) << t;
      EXPECT_LE(after.evaluate(factor * t, 1).cwiseAbs().maxCoeff(), 2.0 * 1.001) << t;
      EXPECT_LE(after.evaluate(factor * t, 2).cwiseAbs().maxCoeff(), 3.0 * 1.001) << t;
    }
  }
}

TEST(CorridorMinco, MincoMeetsItsBoundaryConditionsAndIsContinuous) {
  for (const int order : {3, 4}) {
    Eigen::Matrix3Xd head = Eigen::Matrix3Xd::Zero(3, order);
    head.col(1) = Eigen::Vector3d(1, 2, 3);
    head.col(2) = Eigen::Vector3d(-1, 0.5, 0);
    Eigen::Matrix3Xd tail = Eigen::Matrix3Xd::Zero(3, order);
    tail.col(0) = Eigen::Vector3d(4, 1, 2);
    minco::Minco minco(order, head, tail);
    Eigen::Matrix3Xd waypoints(3, 3);
    waypoints << 1, 2, 3, 0, 1, 0, 1, 1, 2;
    minco.setParameters(waypoints, Eigen::Vector4d(0.5, 1.0, 2.0, 0.7));
    for (int d = 0; d < order; ++d) {
      EXPECT_LT((minco.evaluate(0, 0.0, d) - head.col(d)).norm(), 1e-9);
      EXPECT_LT((minco.evaluate(3, 0.7, d) - tail.col(d)).norm(), 1e-9);
    }
    for (int i = 0; i < 3; ++i) {
      const double end = minco.durations()(i);
      EXPECT_LT((minco.evaluate(i, end, 0) - waypoints.col(i)).norm(), 1e-9);
      for (int d = 0; d <= 2 * order - 2; ++d) {
        const Eigen::Vector3d left = minco.evaluate(i, end, d);
        EXPECT_LT((left - minco.evaluate(i + 1, 0.0, d)).norm(), 1e-7 * std::max(1.0, left.norm()))
            << "order " << order << ", joint " << i << ", derivative " << d;
      }
    }
  }
}

/// Points on a grid inside the polytope's box (its first six half-spaces) that it contains.
std::vector<Eigen::Vector3d> pointsInside(const minco::Polytope& polytope, double spacing) {
  const Eigen::Vector3d high(polytope.offsets(0), polytope.offsets(2), polytope.offsets(4));
  const Eigen::Vector3d low(-polytope.offsets(1), -polytope.offsets(3), -polytope.offsets(5));
  std::vector<Eigen::Vector3d> points;
  for (double x = low.x(); x <= high.x(); x += spacing) {
    for (double y = low.y(); y <= high.y(); y += spacing) {
      for (double z = low.z(); z <= high.z(); z += spacing) {
        if (polytope.contains({x, y, z}, 0.0)) points.emplace_back(x, y, z);
      }
    }
  }
  return points;
}

TEST(CorridorMinco, CorridorsContainTheShortcutPathAndKeepTheRadius) {
  for (const std::string world_name : {"forest", "walls"}) {
    SCOPED_TRACE(world_name);
    const FrontEnds& front = frontEnds(world_name, world_name == "forest" ? 20 : 25);
    ASSERT_GE(front.answers.size(), 8u);
    const auto world = test::smallWorld(world_name);
    const Body& body = front.planner.planner->body();
    const TrajectoryChecker checker(world, checkerSettings(body, front.planner.planner->limits()));
    int inside = 0;
    for (std::size_t q = 0; q < 8; ++q) {
      const FrontEnd& answer = front.answers[q];
      const auto path = minco::shortcutPath(*world, answer.path, body);
      ASSERT_GE(path.size(), 2u);
      EXPECT_LT(path.size(), answer.path.size());
      std::vector<minco::Polytope> polytopes;
      for (std::size_t k = 0; k + 1 < path.size(); ++k) {
        polytopes.push_back(
            minco::corridorAround(*world, path[k], path[k + 1], 1.0, body.keptRadius()));
        for (int j = 0; j <= 20; ++j) {  // the segment, joints included: they overlap there
          EXPECT_TRUE(polytopes.back().contains(path[k] + j / 20.0 * (path[k + 1] - path[k])));
        }
      }
      for (const minco::Polytope& polytope : polytopes) {
        for (const Eigen::Vector3d& point : pointsInside(polytope, 0.07)) {
          ++inside;
          ASSERT_FALSE(checker.collides(point)) << point.transpose();
          ASSERT_TRUE(world->bounds().contains(point));
        }
      }
    }
    EXPECT_GT(inside, 1000);
  }
}

struct SuccessCase {
  std::string world;
  int queries;
};

class CorridorMincoSuccess : public ::testing::TestWithParam<SuccessCase> {};

// Every refined trajectory starts at the start state, passes the independent checker and ends
// at rest on the path's end, in the goal region; at least 90 % of them are refined. Measured
// (Release, default parameters): forest 20 / 20, 18 of them no longer than the front end's,
// median 24 L-BFGS iterations and 3.3-4 ms thread CPU time (a shared machine: it varies by 2x);
// walls 18 / 18 (of 25 queries), 17 no longer, 90 iterations, 8-9.5 ms. On 80 forest queries
// 80 / 80 (73 no longer), on 50 walls queries 38 / 38 (34 no longer).
TEST_P(CorridorMincoSuccess, RefinesMostPathsIntoCheckedTrajectories) {
  const SuccessCase& c = GetParam();
  const FrontEnds& front = frontEnds(c.world, c.queries);
  const auto world = test::smallWorld(c.world);
  const auto back_end = makeBackEnd(front, c.world);
  const TrajectoryChecker checker(
      world, checkerSettings(front.planner.planner->body(), front.planner.planner->limits()));
  int valid = 0;
  int not_longer = 0;
  std::vector<double> milliseconds;
  std::vector<double> iterations;
  for (const FrontEnd& answer : front.answers) {
    // The least of three runs' thread CPU times: the machine's other load left out.
    BackEndResult result;
    double least = INFINITY;
    for (int repetition = 0; repetition < 3; ++repetition) {
      StopCondition stop(Budget{});
      const double begin = threadMilliseconds();
      result = back_end->refine(problemOf(answer), stop);
      least = std::min(least, threadMilliseconds() - begin);
    }
    milliseconds.push_back(least);
    iterations.push_back(statistic(result, "minco_iterations"));
    if (!result.failure.empty()) {
      std::printf("  failure: %s\n", result.failure.c_str());
      EXPECT_TRUE(result.trajectory.empty());
      continue;
    }
    CheckQuery query;
    query.start = answer.query.start;
    query.goal = answer.query.goal;
    query.goal_radius = front.planner.planner->limits().goal_radius;
    const CheckResult check = checker.check(result.trajectory, query);
    EXPECT_TRUE(check.valid) << check.check << ": " << check.detail;
    for (int d = 0; d < 3; ++d) {
      EXPECT_LT((result.trajectory.evaluate(0.0, d) - answer.query.start.col(d)).norm(), 1e-9);
    }
    const double end = result.trajectory.duration();
    EXPECT_LT((result.trajectory.evaluate(end) - answer.path.back()).norm(), 1e-6);
    EXPECT_LT(result.trajectory.evaluate(end, 1).norm(), 1e-6);
    EXPECT_LT(result.trajectory.evaluate(end, 2).norm(), 1e-6);
    valid += check.valid;
    not_longer += end <= answer.result.trajectory.duration();
  }
  const auto median = [](std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values.empty() ? NAN : values[values.size() / 2];
  };
  std::printf(
      "[ corridor_minco on %s ] checker-valid %d / %zu exact front-end answers; "
      "no longer than the front end %d; median %.2f ms, %.0f L-BFGS iterations\n",
      c.world.c_str(), valid, front.answers.size(), not_longer, median(milliseconds),
      median(iterations));
  ASSERT_GE(front.answers.size(), 15u);
  EXPECT_GE(valid, static_cast<int>(std::ceil(0.9 * static_cast<double>(front.answers.size()))));
}

INSTANTIATE_TEST_SUITE_P(Worlds, CorridorMincoSuccess,
                         ::testing::Values(SuccessCase{"forest", 20}, SuccessCase{"walls", 25}),
                         [](const ::testing::TestParamInfo<SuccessCase>& param) {
                           return param.param.world;
                         });

TEST(CorridorMinco, StopsWhenTheBudgetIsSpent) {
  const FrontEnds& front = frontEnds("forest", 20);
  const auto back_end = makeBackEnd(front, "forest");
  // The query whose refinement takes the most iterations, refined again with 3 of them.
  std::size_t hardest = 0;
  double most = 0.0;
  for (std::size_t i = 0; i < front.answers.size(); ++i) {
    StopCondition stop(Budget{});
    const double iterations =
        statistic(back_end->refine(problemOf(front.answers[i]), stop), "minco_iterations");
    if (iterations > most) {
      most = iterations;
      hardest = i;
    }
  }
  ASSERT_GT(most, 10.0);
  Budget budget;
  budget.max_iterations = 3;
  StopCondition stop(budget);
  const BackEndResult result = back_end->refine(problemOf(front.answers[hardest]), stop);
  EXPECT_LE(statistic(result, "minco_iterations"), 3.0);
  EXPECT_EQ(result.trajectory.empty(), !result.failure.empty());
}

// With a corridor weight 100 times lighter than the default, the first solve leaves some
// trajectories in collision (or a hair beyond a limit); the later rounds (10x the weights each)
// repair them. Measured: one round, 17 / 20 pass; three rounds, 19 / 20.
TEST(CorridorMinco, HeavierPenaltiesRepairAFailedCheck) {
  const FrontEnds& front = frontEnds("forest", 20);
  const auto one_round = makeBackEnd(front, "forest", {"weight_corridor=1e4", "max_rounds=1"});
  const auto three_rounds = makeBackEnd(front, "forest", {"weight_corridor=1e4", "max_rounds=3"});
  int first_valid = 0;
  int repaired_valid = 0;
  for (const FrontEnd& answer : front.answers) {
    StopCondition stop(Budget{});
    const BackEndResult first = one_round->refine(problemOf(answer), stop);
    const BackEndResult repaired = three_rounds->refine(problemOf(answer), stop);
    if (!first.failure.empty()) {  // what the rounds repair: a collision or a limit
      EXPECT_TRUE(first.failure.find("collision check") != std::string::npos ||
                  first.failure.find("limits check") != std::string::npos)
          << first.failure;
    }
    first_valid += first.failure.empty();
    repaired_valid += repaired.failure.empty();
  }
  std::printf("[ corridor_minco, corridor weight 1e4 ] one round %d / %zu, three rounds %d\n",
              first_valid, front.answers.size(), repaired_valid);
  EXPECT_LT(first_valid, static_cast<int>(front.answers.size()));
  EXPECT_GT(repaired_valid, first_valid);
}

TEST(CorridorMinco, SameProblemSameTrajectory) {
  const FrontEnds& front = frontEnds("walls", 25);
  ASSERT_FALSE(front.answers.empty());
  const auto back_end = makeBackEnd(front, "walls", {"order=4"});
  StopCondition first_stop(Budget{});
  StopCondition second_stop(Budget{});
  const BackEndResult first = back_end->refine(problemOf(front.answers.front()), first_stop);
  const BackEndResult second = back_end->refine(problemOf(front.answers.front()), second_stop);
  ASSERT_EQ(first.trajectory.segments().size(), second.trajectory.segments().size());
  EXPECT_EQ(first.failure, second.failure);
  for (std::size_t i = 0; i < first.trajectory.segments().size(); ++i) {
    EXPECT_EQ(first.trajectory.segments()[i].duration, second.trajectory.segments()[i].duration);
    EXPECT_EQ(first.trajectory.segments()[i].coefficients,
              second.trajectory.segments()[i].coefficients);
  }
  EXPECT_EQ(statistic(first, "minco_iterations"), statistic(second, "minco_iterations"));
}

TEST(CorridorMinco, RefusesNonFiniteInputsWithAFailure) {
  const FrontEnds& front = frontEnds("forest", 20);
  ASSERT_FALSE(front.answers.empty());
  const auto back_end = makeBackEnd(front, "forest");
  BackEndProblem problem = problemOf(front.answers.front());
  problem.start(0, 1) = NAN;
  StopCondition stop(Budget{});
  const BackEndResult result = back_end->refine(problem, stop);
  EXPECT_TRUE(result.trajectory.empty());
  EXPECT_NE(result.failure.find("not finite"), std::string::npos) << result.failure;
  problem = problemOf(front.answers.front());
  problem.path[1].y() = INFINITY;
  EXPECT_FALSE(back_end->refine(problem, stop).failure.empty());
  problem.path.clear();
  EXPECT_FALSE(back_end->refine(problem, stop).failure.empty());
}

TEST(CorridorMinco, MatchesAMovingStart) {
  const FrontEnds& front = frontEnds("forest", 20);
  ASSERT_FALSE(front.answers.empty());
  const auto back_end = makeBackEnd(front, "forest");
  // Start from the front end's own state a second into its trajectory: moving, accelerating.
  const FrontEnd& answer = front.answers.front();
  const Trajectory& trajectory = answer.result.trajectory;
  ASSERT_GT(trajectory.duration(), 1.5);
  BackEndProblem problem = problemOf(answer);
  for (int d = 0; d < 3; ++d) problem.start.col(d) = trajectory.evaluate(1.0, d);
  problem.start.col(3).setZero();
  ASSERT_GT(problem.start.col(1).norm(), 0.3);
  problem.path.erase(problem.path.begin(),
                     problem.path.begin() + static_cast<long>(1.0 / kBackEndPathStep));
  StopCondition stop(Budget{});
  const BackEndResult result = back_end->refine(problem, stop);
  ASSERT_TRUE(result.failure.empty()) << result.failure;
  for (int d = 0; d < 3; ++d) {
    EXPECT_LT((result.trajectory.evaluate(0.0, d) - problem.start.col(d)).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace kinolab
