// Every registered back end (built-in, and any library named in $KINOLAB_TEST_PLUGINS) keeps
// the back-end contract (kinolab/planner/back_end.hpp, docs/back_ends.md): from a front end's
// answer it returns a trajectory the independent checker accepts, from the start state within
// the limits and (unless it keeps the front end's) to rest at the path's end, or a named
// failure; the same problem gives the same answer; a non-finite start or path is a failure,
// never a crash; through a planner it is timed apart and its failure has its own status.
#include <gtest/gtest.h>

#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/planner/back_end.hpp"
#include "support/planning.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

std::vector<std::string> registeredBackEnds() {
  test::loadTestPlugins();
  return pluginRegistry<BackEnd>().keys();
}

/// A front end's exact answers on the small forest: lazy MP-A* at its defaults, every other
/// query from a moving start (a replan's), and the problem a back end gets from each.
struct FrontEndAnswers {
  std::shared_ptr<const World> world = test::smallWorld("forest");
  ConfiguredPlanner front = configurePlanner("lazy_mp_astar", test::assignments({"time_limit=0"}));
  std::vector<PlanResult> results;
  std::vector<BackEndProblem> problems;

  FrontEndAnswers() {
    front.planner->setup({world, 3});
    std::vector<PlanningQuery> queries = test::randomQueries(*world, 8, 17, 3.0, 8.0, 0.7);
    for (std::size_t k = 0; k < queries.size(); ++k) {
      PlanningQuery query = queries[k];
      if (k % 2 == 1) {
        query.start.col(1) = 0.8 * (query.goal - query.start.col(0)).normalized();
        query.start(2, 1) = 0.0;
      }
      PlanResult result = front.planner->plan(query, Budget{INFINITY, 200000});
      if (result.status != PlanStatus::kExact) continue;
      results.push_back(std::move(result));
      BackEndProblem problem;
      problem.start = query.start;
      problem.goal = query.goal;
      problems.push_back(problem);
    }
    // The path and front pointers once the results stopped moving.
    for (std::size_t k = 0; k < results.size(); ++k) {
      problems[k].front = &results[k].trajectory;
      problems[k].path = backEndPath({}, results[k].trajectory);
    }
  }
};

const FrontEndAnswers& answers() {
  static const FrontEndAnswers instance;
  return instance;
}

std::unique_ptr<BackEnd> makeBackEnd(const std::string& key) {
  std::unique_ptr<BackEnd> back_end = pluginRegistry<BackEnd>().create(key, {});
  const FrontEndAnswers& front = answers();
  back_end->setup(front.world, front.front.planner->body(), front.front.planner->limits());
  return back_end;
}

class BackEndConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(BackEndConformance, ValidInValidOutOrANamedFailure) {
  const FrontEndAnswers& front = answers();
  ASSERT_GE(front.problems.size(), 6u) << "the front end answered too few queries";
  const std::unique_ptr<BackEnd> back_end = makeBackEnd(GetParam());
  const PlannerLimits limits = front.front.planner->limits();
  const TrajectoryChecker checker(front.world,
                                  checkerSettings(front.front.planner->body(), limits));
  int valid = 0;
  for (const BackEndProblem& problem : front.problems) {
    StopCondition stop(Budget{});
    const BackEndResult result = back_end->refine(problem, stop);
    if (result.trajectory.empty()) {
      EXPECT_FALSE(result.failure.empty()) << "no trajectory and no failure named";
      continue;
    }
    EXPECT_TRUE(result.failure.empty()) << result.failure;
    CheckQuery query;
    query.start = problem.start;
    query.require_goal = false;
    const CheckResult check = checker.check(result.trajectory, query);
    EXPECT_TRUE(check.valid) << check.check << " at t = " << check.time << ": " << check.detail;
    // The start state: position and velocity; a back end that refines also its acceleration
    // (`none` keeps the front end's first control, which order-2 primitives choose).
    for (int k = 0; k < (GetParam() == "none" ? 2 : 3); ++k) {
      EXPECT_LT((result.trajectory.evaluate(0.0, k) - problem.start.col(k)).norm(), 1e-6) << k;
    }
    if (GetParam() != "none") {  // `none` keeps the front end's end, not at rest
      EXPECT_LT((result.trajectory.endPosition() - problem.path.back()).norm(), 1e-6);
      EXPECT_LT(result.trajectory.evaluate(result.trajectory.duration(), 1).norm(), 1e-6);
    }
    valid += check.valid ? 1 : 0;
  }
  std::printf("[ %s ] valid %d / %zu\n", GetParam().c_str(), valid, front.problems.size());
  EXPECT_GE(2 * valid, static_cast<int>(front.problems.size()));  // a back end that works
}

TEST_P(BackEndConformance, TheSameProblemGivesTheSameAnswer) {
  const std::unique_ptr<BackEnd> back_end = makeBackEnd(GetParam());
  for (const BackEndProblem& problem : answers().problems) {
    StopCondition first_stop(Budget{});
    StopCondition second_stop(Budget{});
    const BackEndResult first = back_end->refine(problem, first_stop);
    const BackEndResult second = back_end->refine(problem, second_stop);
    EXPECT_EQ(first.failure, second.failure);
    ASSERT_EQ(first.trajectory.segments().size(), second.trajectory.segments().size());
    EXPECT_EQ(first.trajectory.duration(), second.trajectory.duration());
    for (std::size_t s = 0; s < first.trajectory.segments().size(); ++s) {
      EXPECT_EQ(first.trajectory.segments()[s].coefficients,
                second.trajectory.segments()[s].coefficients);
    }
  }
}

TEST_P(BackEndConformance, ANonFiniteStartOrPathIsAFailureNotACrash) {
  const std::unique_ptr<BackEnd> back_end = makeBackEnd(GetParam());
  ASSERT_FALSE(answers().problems.empty());
  BackEndProblem bad_start = answers().problems.front();
  bad_start.start(0, 1) = NAN;
  bad_start.front = nullptr;  // a trajectory from a NaN start is not the front end's
  BackEndProblem bad_path = answers().problems.front();
  bad_path.path[bad_path.path.size() / 2].x() = INFINITY;
  bad_path.front = nullptr;
  for (const BackEndProblem* problem : {&bad_start, &bad_path}) {
    StopCondition stop(Budget{});
    const BackEndResult result = back_end->refine(*problem, stop);
    EXPECT_TRUE(result.trajectory.empty());
    EXPECT_FALSE(result.failure.empty());
  }
}

TEST_P(BackEndConformance, AOnePointPathOrASpentBudgetIsAnAnswerNotACrash) {
  const std::unique_ptr<BackEnd> back_end = makeBackEnd(GetParam());
  ASSERT_FALSE(answers().problems.empty());
  BackEndProblem one_point = answers().problems.front();
  one_point.path = {one_point.start.col(0)};
  one_point.front = nullptr;
  StopCondition unlimited(Budget{});
  // A path that stays where it starts: a failure, or a trajectory to rest there.
  const BackEndResult degenerate = back_end->refine(one_point, unlimited);
  EXPECT_NE(degenerate.trajectory.empty(), degenerate.failure.empty()) << degenerate.failure;
  if (!degenerate.trajectory.empty()) {
    EXPECT_LT((degenerate.trajectory.endPosition() - one_point.path.front()).norm(), 1e-6);
  }
  // No time at all: a trajectory (checked by the planner) or a named failure.
  StopCondition spent(Budget{0.0});
  const BackEndResult late = back_end->refine(answers().problems.front(), spent);
  EXPECT_NE(late.trajectory.empty(), late.failure.empty()) << late.failure;
}

TEST_P(BackEndConformance, APlannerRunsItTimedApartAndItsFailureHasItsOwnStatus) {
  const FrontEndAnswers& front = answers();
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar", test::assignments({"time_limit=0", "back_end=" + GetParam()}));
  configured.planner->setup({front.world, 3});
  ASSERT_FALSE(front.problems.empty());
  PlanningQuery query;
  query.start = front.problems.front().start;
  query.goal = front.problems.front().goal;
  const PlanResult result = configured.planner->plan(query, Budget{INFINITY, 200000});
  ASSERT_TRUE(result.status == PlanStatus::kExact || result.status == PlanStatus::kBackEndFailed)
      << toString(result.status) << ": " << result.message;
  double front_ms = NAN;
  double back_ms = NAN;
  for (const auto& [name, value] : result.statistics) {
    if (name == "time_front_end_ms") front_ms = value;
    if (name == "time_back_end_ms") back_ms = value;
  }
  if (makeBackEnd(GetParam())->keepsFrontEnd()) {
    // Not run (the front end's trajectory stands): nothing to time, no cost to a plan.
    EXPECT_TRUE(std::isnan(front_ms) && std::isnan(back_ms)) << front_ms << ", " << back_ms;
  } else {
    EXPECT_GE(front_ms, 0.0);
    EXPECT_GE(back_ms, 0.0);
    EXPECT_LE(front_ms + back_ms, result.planning_time_ms + 1e-6);
  }
  if (result.status == PlanStatus::kExact) {
    EXPECT_TRUE(result.check.valid) << result.check.detail;
    if (GetParam() != "none") {
      EXPECT_EQ(result.objective, "trajectory length");
    }
  } else {
    EXPECT_TRUE(result.trajectory.empty());
    EXPECT_EQ(result.message.rfind("back end " + GetParam() + ": ", 0), 0u) << result.message;
  }
}

TEST_P(BackEndConformance, UnknownParametersAreRefusedWhereTheyAreSet) {
  EXPECT_THROW(configurePlanner(
                   "lazy_mp_astar",
                   test::assignments({"back_end=" + GetParam(), "back_end.no_such_parameter=1"})),
               ConfigError);
}

INSTANTIATE_TEST_SUITE_P(Registered, BackEndConformance, ::testing::ValuesIn(registeredBackEnds()),
                         [](const auto& key) { return key.param; });

}  // namespace
}  // namespace kinolab
