#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <numeric>
#include <set>
#include <thread>

#include "kinolab/core/random.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"
#include "kinolab/search/motion_primitive_search.hpp"
#include "kinolab/search/search_policies.hpp"
#include "search/edge_workers.hpp"
#include "support/errors.hpp"
#include "support/planning.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

/// The message of the ConfigError that configuring lazy MP-A* with `items` throws.
std::string configErrorOf(const std::vector<std::string>& items) {
  return test::errorOf<ConfigError>(
      [&] { configurePlanner("lazy_mp_astar", test::assignments(items)); });
}

ChainState randomState(Rng& rng, const World& world, int order) {
  ChainState state = ChainState::Zero();
  for (;;) {
    state.col(0) =
        Eigen::Vector3d(rng.uniform(0.5, 11.5), rng.uniform(0.5, 11.5), rng.uniform(0.5, 2.5));
    if (world.isFree(state.col(0), 0.3)) break;
  }
  for (int k = 1; k < order; ++k) {
    for (int axis = 0; axis < 3; ++axis) state(axis, k) = rng.uniform(-1.5, 1.5);
  }
  return state;
}

/// A heuristic that overestimates: time_optimal times 1.5 (deliberately inconsistent).
class InflatedHeuristic final : public SearchHeuristic {
 public:
  InflatedHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius)
      : inner_(edges, goal_radius) {}
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return 1.5 * inner_.estimate(state, goal);
  }

 private:
  TimeOptimalHeuristic inner_;
};

struct ConsistencyCount {
  int edges = 0;       ///< valid primitives checked
  int finite = 0;      ///< of them, those from a state with a finite estimate
  int violations = 0;  ///< h(s) > c_lower(s, s') + h(s')
};

/// `inner` times `scale` (deliberately inconsistent when the scale is above 1), prepared as
/// `inner` is for the controls and each query.
class ScaledHeuristic final : public SearchHeuristic {
 public:
  ScaledHeuristic(std::shared_ptr<const SearchHeuristic> inner, double scale)
      : inner_(std::move(inner)), scale_(scale) {}
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return scale_ * inner_->estimate(state, goal);
  }
  std::shared_ptr<const SearchHeuristic> forControls(
      const std::vector<Eigen::Vector3d>& controls) const override {
    return std::make_shared<ScaledHeuristic>(heuristicForControls(inner_, controls), scale_);
  }
  std::shared_ptr<const SearchHeuristic> forQuery(const World& world, const Eigen::Vector3d& goal,
                                                  StopCondition& stop) const override {
    return std::make_shared<ScaledHeuristic>(heuristicForQuery(inner_, world, goal, stop), scale_);
  }

 private:
  std::shared_ptr<const SearchHeuristic> inner_;
  double scale_;
};

/// Checks h(s) <= c_lower(s, s') + h(s') on random primitives (the sampler's grid of 5 per
/// axis, at the limit included) from random moving states, against random goals, with the
/// weakest lower bound the search queues (no map term). The heuristic is prepared for the
/// controls and for each goal, as a search prepares it. `lattice` is the lattice heuristic,
/// "lattice_horizon_3" it with tables of 3 primitives (so that most states are past them) and
/// "inflated_lattice" it times 1.05: their states move at whole numbers of the grid's velocity
/// step (as every state of a search from rest does), so that the exact lattice is what is
/// checked; "lattice_moving" is the lattice heuristic from the random moving states (its
/// relaxation on finer cells).
ConsistencyCount checkConsistency(const std::string& heuristic_name, int order, double goal_radius,
                                  int primitives) {
  const auto world = test::smallWorld("forest");
  Rng rng(4 + order);
  EdgeEvaluatorSettings settings;
  settings.order = order;
  settings.duration = order == 2 ? 0.4 : (order == 3 ? 0.3 : 0.2);
  settings.limits = DynamicLimits::uniform(2.0, 3.0, 8.0, 40.0);
  settings.weights.length = 0.5;
  settings.weights.control_effort = order == 2 ? 0.7 : 0.1;
  // Past the tables' horizon the bound is in time alone: effort must not hide it.
  if (heuristic_name == "lattice_horizon_3") settings.weights.control_effort = 0.01;
  const EdgeEvaluator evaluator(world, settings);
  const bool lattice = heuristic_name == "lattice" || heuristic_name == "lattice_horizon_3" ||
                       heuristic_name == "inflated_lattice";
  std::shared_ptr<const SearchHeuristic> heuristic =
      heuristic_name == "inflated" ? std::make_shared<InflatedHeuristic>(settings, goal_radius)
      : heuristic_name == "inflated_lattice"
          ? std::make_shared<ScaledHeuristic>(heuristicFor("lattice", settings, goal_radius), 1.05)
      : heuristic_name == "lattice_moving" ? heuristicFor("lattice", settings, goal_radius)
      : heuristic_name == "lattice_horizon_3"
          ? pluginRegistry<HeuristicBuilder>()
                .create("lattice", test::assignments({"horizon=3"}))
                ->build({settings, goal_radius})
      : heuristic_name == "time_optimal_whole"
          ? pluginRegistry<HeuristicBuilder>()
                .create("time_optimal", test::assignments({"whole_primitives=true"}))
                ->build({settings, goal_radius})
          : heuristicFor(heuristic_name, settings, goal_radius);
  const auto controls = controlGrid({-1.0, -0.4, 0.0, 0.6, 1.0}, settings.limits.bound[order]);
  heuristic = heuristicForControls(heuristic, controls);
  // The grid's step: 0.2 u_max (-1.2 = -2 x 0.6 at u_max 3), a velocity step of 0.2 u_max tau.
  const double velocity_step = 0.2 * settings.limits.bound[order].x() * settings.duration;
  const int velocity_steps = static_cast<int>(settings.limits.bound[1].x() / velocity_step);
  ConsistencyCount count;
  while (count.edges < primitives) {
    ChainState state = ChainState::Zero();
    // Draws one at a time (drawLastFirst): the same states and goals on every compiler.
    state.col(0) = drawLastFirst<Eigen::Vector3d>(
        [&](int axis) { return axis < 2 ? rng.uniform(0.5, 11.5) : rng.uniform(0.5, 2.5); });
    for (int k = 1; k < order; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        state(axis, k) =
            lattice ? velocity_step * std::floor(rng.uniform(-velocity_steps, velocity_steps + 1))
                    : rng.uniform(-1.0, 1.0) * settings.limits.bound[k][axis];
      }
    }
    // Goals near and far, so that states inside, at and beyond the goal region all occur.
    const auto offset = drawLastFirst<Eigen::Vector3d>(
        [&](int axis) { return axis < 2 ? rng.uniform(-6, 6) : rng.uniform(-2, 2); });
    const double scale = rng.uniform01() < 0.3 ? 0.1 : 1.0;
    const Eigen::Vector3d goal = state.col(0) + scale * offset;
    // The query's heuristic (a map-reading one searches the free space towards this goal).
    StopCondition never(Budget{});
    const auto prepared = heuristicForQuery(heuristic, *world, goal, never);
    const double h = prepared->estimate(state, goal);
    for (const auto& control : controls) {
      const EdgeEvaluation bound = evaluator.controlOnly(state, control);
      // Consistency is owed to valid edges (a map-reading heuristic may say "unreachable",
      // infinity, where the body cannot be).
      if (!bound.valid() ||
          !evaluator.full(state, control, world->clearance(state.col(0))).valid()) {
        continue;
      }
      ++count.edges;
      const double after = prepared->estimate(bound.end, goal);
      EXPECT_TRUE(h >= 0.0 && after >= 0.0) << h << " " << after;  // NaN fails too
      count.finite += std::isfinite(h);
      count.violations += h > bound.cost + after + 1e-9 * (1.0 + h);
    }
  }
  return count;
}

TEST(SearchHeuristic, EveryBuiltInHeuristicIsConsistentWithTheWeakestLowerBound) {
  for (const int order : {2, 3, 4}) {
    for (const std::string name :
         {"euclidean", "min_time", "time_optimal", "time_optimal_whole", "obvp", "max", "geodesic",
          "lattice", "lattice_horizon_3", "lattice_moving"}) {
      if ((name == "obvp" || name.rfind("lattice", 0) == 0) && order != 2) continue;
      for (const double goal_radius : {0.5, 0.01}) {
        // (Every moving state makes its tables on cells finer than the lattice's: fewer.)
        const int primitives = name == "lattice_moving" ? 2000 : 10000;
        const ConsistencyCount count = checkConsistency(name, order, goal_radius, primitives);
        EXPECT_GE(count.edges, primitives);
        // Not vacuous: many goals are reachable (others lie outside the map or in a trunk;
        // for the lattice, a goal ball of 1 cm holds a state of the start's lattice, whose
        // points are 4.8 cm apart on each axis here, about one time in ten).
        EXPECT_GT(count.finite,
                  count.edges / (name.rfind("lattice", 0) == 0 && goal_radius < 0.1 ? 20 : 4))
            << name;
        EXPECT_EQ(count.violations, 0)
            << name << " at order " << order << ", goal radius " << goal_radius << ": "
            << count.violations << " of " << count.edges << " edges";
      }
    }
  }
}

TEST(SearchHeuristic, TheConsistencyCheckCatchesAnInflatedHeuristic) {
  for (const int order : {2, 3}) {
    const ConsistencyCount count = checkConsistency("inflated", order, 0.5, 10000);
    EXPECT_GT(count.violations, 0) << "order " << order;
  }
  // The lattice heuristic is tight: 5 % more breaks it on its own lattice.
  for (const double goal_radius : {0.5, 0.01}) {
    EXPECT_GT(checkConsistency("inflated_lattice", 2, goal_radius, 10000).violations, 0)
        << goal_radius;
  }
}

TEST(SearchHeuristic, ObvpAtAnotherOrderIsAConfigErrorNamingWhereItWasSet) {
  test::loadTestPlugins();
  const std::string message = configErrorOf({"order=3", "heuristic=obvp"});
  EXPECT_EQ(message.rfind("test: planner 'lazy_mp_astar': parameter 'heuristic': obvp needs "
                          "order 2",
                          0),
            0u)
      << message;
  // max at order 3 is time_optimal alone, not an error.
  EXPECT_NO_THROW(
      configurePlanner("lazy_mp_astar", test::assignments({"order=3", "heuristic=max"})));
}

TEST(SearchHeuristic, TightHeuristicsDominateTheVelocityBlindOnes) {
  // From rest the time-optimal bound adds the acceleration ramp; moving away it adds the
  // turn; obvp adds the effort; max is the largest. All are equal to 0 inside the goal.
  EdgeEvaluatorSettings settings;
  settings.limits = DynamicLimits::uniform(2.0, 1.0);
  settings.weights = {10.0, 0.0, 1.0, 0.0};
  const Eigen::Vector3d goal(20.0, 0.0, 0.0);
  ChainState state = ChainState::Zero();
  const auto h = [&](const std::string& name) {
    return heuristicFor(name, settings, 0.01)->estimate(state, goal);
  };
  // 19.99 m from rest: 2 s ramp (2 m), then 17.99 m at 2 m/s: 10.995 s.
  EXPECT_NEAR(h("time_optimal"), 10.0 * (2.0 + 17.99 / 2.0), 1e-9);
  EXPECT_NEAR(h("min_time"), 10.0 * 19.99 / 2.0, 1e-9);
  state(0, 1) = -2.0;  // flying away at full speed: 2 s to stop, 2 s back to speed
  EXPECT_NEAR(h("time_optimal"), 10.0 * (4.0 + 19.99 / 2.0), 1e-9);
  EXPECT_GT(h("obvp"), 0.0);
  EXPECT_EQ(h("max"), std::max(h("time_optimal"), h("obvp")));
  // Jerk control from rest: the acceleration needs a_max / j_max = 0.5 s to build up, so
  // the bound exceeds the order-2 one (which jumps to a_max at once), by j_max integrals.
  EdgeEvaluatorSettings jerk = settings;
  jerk.order = 3;
  jerk.limits = DynamicLimits::uniform(2.0, 1.0, 2.0);
  const auto h3 = [&](const ChainState& s) {
    return heuristicFor("time_optimal", jerk, 0.01)->estimate(s, goal);
  };
  state(0, 1) = 0.0;
  // Speed bound: t^2 for t <= 0.5, then 0.25 + (t - 0.5); it reaches 2 at t = 2.25 having
  // covered 1/24 + 0.25 * 1.75 + 1.75^2 / 2 = 2.0104 m; then 17.9796 m at 2 m/s.
  EXPECT_NEAR(h3(state), 10.0 * (2.25 + (19.99 - (1.0 / 24 + 0.4375 + 1.53125)) / 2.0), 1e-9);
  EXPECT_GT(h3(state), h("time_optimal"));
  state(0, 2) = 1.0;  // already accelerating at a_max: the order-2 bound again
  EXPECT_NEAR(h3(state), h("time_optimal"), 1e-9);
  state(0, 2) = 0.0;
  // Unconstrained double integrator from rest over d: f(T) = w_T T + 3 w_U d^2 / T^3, least
  // at T = (9 w_U d^2 / w_T)^(1/4).
  state(0, 1) = 0.0;
  const double d = 19.99;
  const double t = std::pow(9.0 * d * d / 10.0, 0.25);
  EXPECT_NEAR(h("obvp"), 10.0 * t + 3.0 * d * d / (t * t * t), 1e-9);
  state.col(0) = goal;
  for (const std::string name : {"euclidean", "min_time", "time_optimal", "obvp", "max"}) {
    EXPECT_EQ(h(name), 0.0) << name;
  }
}

TEST(MotionPrimitiveSearch, CertifiedEdgesCostExactlyWhatFullEvaluationFinds) {
  const auto world = test::smallWorld("forest");
  Rng rng(8);
  for (const double length_weight : {0.0, 0.7}) {
    EdgeEvaluatorSettings settings;
    settings.weights.length = length_weight;
    const EdgeEvaluator evaluator(world, settings);
    int certified = 0;
    int uncertain = 0;
    for (int trial = 0; trial < 3000; ++trial) {
      const ChainState start = randomState(rng, *world, 2);
      const Eigen::Vector3d control(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
      EdgeEvaluation partial = evaluator.partial(start, control);
      const EdgeEvaluation lower = evaluator.controlOnly(start, control);
      const EdgeEvaluation full = evaluator.full(start, control);
      if (lower.valid() && partial.valid()) {
        EXPECT_LE(lower.cost, partial.cost + 1e-12);
      }
      if (!evaluator.certify(start, world->distance(start.col(0)), control, partial)) {
        uncertain += partial.valid();
        continue;
      }
      ++certified;
      ASSERT_TRUE(full.valid());
      EXPECT_EQ(partial.cost, full.cost);
      EXPECT_EQ(partial.obstacle_cost, 0.0);
      EXPECT_EQ(partial.esdf_queries, 1);  // the end sample only
    }
    EXPECT_GT(certified, 20);
    EXPECT_GT(uncertain, 100);
  }
}

TEST(GoalShot, TheObvpCubicJoinsTheStateToRestAtTheGoalWithTheStatedEffort) {
  EdgeEvaluatorSettings edges;
  edges.weights.control_effort = 0.5;
  edges.weights.length = 0.3;
  const ObvpShot shot(edges, 5.0);
  Rng rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    ChainState state = ChainState::Zero();
    state.col(0) = Eigen::Vector3d(rng.uniform(0, 3), rng.uniform(0, 3), rng.uniform(0, 3));
    state.col(1) = Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const Eigen::Vector3d goal(rng.uniform(0, 3), rng.uniform(0, 3), rng.uniform(0, 3));
    const double t = rng.uniform(0.3, 3.0);
    const TrajectorySegment cubic = ObvpShot::cubic(state, goal, t);
    EXPECT_LT((cubic.evaluate(0.0) - state.col(0)).norm(), 1e-12);
    EXPECT_LT((cubic.evaluate(0.0, 1) - state.col(1)).norm(), 1e-12);
    EXPECT_LT((cubic.evaluate(t) - goal).norm(), 1e-9);
    EXPECT_LT(cubic.evaluate(t, 1).norm(), 1e-9);
    // The cost: w_T T + w_U (integral of |a|^2, here by the midpoint rule) + w_L length.
    Trajectory one;
    one.append(cubic);
    double effort = 0.0;
    constexpr int kSteps = 4000;
    for (int i = 0; i < kSteps; ++i) {
      effort += cubic.evaluate((i + 0.5) * t / kSteps, 2).squaredNorm() * t / kSteps;
    }
    EXPECT_NEAR(shot.cost(one), t + 0.5 * effort + 0.3 * one.length(), 1e-6 * (1.0 + effort));
  }
  // Beyond its reach it does not try; its shots keep the limits when it can stretch to them.
  ChainState far = ChainState::Zero();
  EXPECT_TRUE(shot.shoot(far, Eigen::Vector3d(6, 0, 0)).empty());
  const Trajectory near = shot.shoot(far, Eigen::Vector3d(4, 1, 0));
  ASSERT_FALSE(near.empty());
  for (const TrajectorySample& sample : near.sample(0.01)) {
    EXPECT_LE(sample.velocity.cwiseAbs().maxCoeff(), 2.0 + 1e-9);
    EXPECT_LE(sample.acceleration.cwiseAbs().maxCoeff(), 3.0 + 1e-9);
  }
}

/// A search of the small world `kind` from `start` to `goal`, with or without a shot.
struct ShotSearch {
  MotionPrimitiveSearch search;
  MotionPrimitiveSearch::Outcome outcome;

  ShotSearch(const std::string& kind, const ChainState& start, const Eigen::Vector3d& goal,
             std::shared_ptr<const GoalShot> shot)
      : search(test::smallWorld(kind), controlGrid({-1.0, 0.0, 1.0}, Eigen::Vector3d(3, 3, 3)),
               SearchSettings(), policies(std::move(shot))) {
    StopCondition stop(Budget{});
    outcome = search.search(start, goal, stop);
  }
  static SearchPolicies policies(std::shared_ptr<const GoalShot> shot) {
    SearchPolicies p;
    p.edges = std::make_shared<FullEvaluationPolicy>();
    p.heuristic = std::make_shared<TimeOptimalHeuristic>(EdgeEvaluatorSettings(), 0.5);
    p.space = std::make_shared<LatticeSpace>(LatticeSpace::Resolution());
    p.shot = std::move(shot);
    return p;
  }
  double statistic(const std::string& name) const {
    return test::statistic(search.statistics(), name);
  }
};

TEST(GoalShot, AnAcceptedShotEndsTheSearchWithAPathTheCheckerAccepts) {
  ChainState start = ChainState::Zero();
  start.col(0) = Eigen::Vector3d(1, 1, 1.5);
  const Eigen::Vector3d goal(7, 5, 1.5);
  const auto shot = std::make_shared<ObvpShot>(EdgeEvaluatorSettings(), 4.0);
  const ShotSearch with("empty", start, goal, shot);
  const ShotSearch without("empty", start, goal, nullptr);
  ASSERT_EQ(with.outcome, MotionPrimitiveSearch::Outcome::kGoal);
  ASSERT_EQ(without.outcome, MotionPrimitiveSearch::Outcome::kGoal);
  EXPECT_GE(with.statistic("shots"), 1.0);
  EXPECT_TRUE(std::isnan(without.statistic("shots")));  // only with a shot policy
  EXPECT_LT(with.search.counters().expansions, without.search.counters().expansions);
  // The path ends with the shot, at rest at the goal, and passes the independent checker.
  const Trajectory path = with.search.trajectory();
  EXPECT_LT((path.endPosition() - goal).norm(), 1e-9);
  EXPECT_LT(path.evaluate(path.duration(), 1).norm(), 1e-9);
  const TrajectoryChecker checker(test::smallWorld("empty"), CheckerSettings());
  CheckQuery query;
  query.start = start;
  query.goal = goal;
  EXPECT_TRUE(checker.check(path, query).valid) << checker.check(path, query).detail;
  EXPECT_TRUE(std::isfinite(with.search.cost()) && with.search.cost() > 0.0);
}

TEST(GoalShot, AShotThroughAnObstacleIsRefusedAndTheSearchGoesOn) {
  // Through the walls world, shots from within 6 m of the goal: those that
  // cross a wall are refused by the checker, and the path found still passes it.
  const auto world = test::smallWorld("walls");
  const auto query = test::randomQueries(*world, 1, 5, 8.0, 11.0, 0.5).front();
  const auto shot = std::make_shared<ObvpShot>(EdgeEvaluatorSettings(), 6.0);
  const ShotSearch with("walls", query.start, query.goal, shot);
  ASSERT_EQ(with.outcome, MotionPrimitiveSearch::Outcome::kGoal);
  EXPECT_GT(with.statistic("shots_rejected"), 0.0);
  const TrajectoryChecker checker(world, CheckerSettings());
  CheckQuery check;
  check.start = query.start;
  check.goal = query.goal;
  EXPECT_TRUE(checker.check(with.search.trajectory(), check).valid);
}

/// A long query through the walls outgrows 1 MB of nodes (or vertices) and edge records long
/// before it is solved: the lazy-family search at `lookahead` stops at its memory budget.
void expectAMemoryBudgetStop(const std::string& lookahead) {
  const auto walls = test::smallWorld("walls");
  const auto far = test::randomQueries(*walls, 1, 5, 9.0, 11.0, 0.5).front();
  ConfiguredPlanner capped = configurePlanner(
      "lazy_mp_astar", test::assignments({"sampler.samples_per_axis=3", "time_limit=0",
                                          "lookahead=" + lookahead, "memory_limit_mb=1"}));
  capped.planner->setup({walls, 1});
  const PlanResult result = capped.planner->plan(far, Budget{});
  EXPECT_TRUE(result.status == PlanStatus::kApproximate || result.status == PlanStatus::kTimeout)
      << result.message;
  EXPECT_NE(result.message.find("memory budget"), std::string::npos) << result.message;
}

TEST(LazySp, ABudgetStopReturnsTheEvaluatedStartOfTheLastLazyPath) {
  // Across the second and later lazy searches the nodes are rebuilt: what a budget stop
  // returns must be the last path's own edges, checked, starting at the start.
  test::loadTestPlugins();
  const auto world = test::smallWorld("forest");
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  const auto plan = [&](const std::string& budget) {
    ConfiguredPlanner configured = configurePlanner(
        "lazy_mp_astar",
        test::assignments({"sampler.samples_per_axis=3", "time_limit=0", "lookahead=inf", budget}));
    configured.planner->setup({world, 1});
    return configured.planner->plan(query, Budget{});
  };
  const auto statistic = [](const PlanResult& result, const std::string& name) {
    return test::statistic(result.statistics, name);
  };
  // Unbounded first: the budgets below stop half-way, after several lazy searches.
  const PlanResult whole = plan("max_expansions=0");
  ASSERT_EQ(whole.status, PlanStatus::kExact) << whole.message;
  ASSERT_GE(statistic(whole, "lazy_searches"), 4.0);
  const long long half = static_cast<long long>(statistic(whole, "expansions") / 2);
  const PlanResult result = plan("max_expansions=" + std::to_string(half));
  ASSERT_TRUE(result.status == PlanStatus::kApproximate || result.status == PlanStatus::kTimeout)
      << result.message;
  EXPECT_GE(statistic(result, "lazy_searches"), 2.0);
  EXPECT_NE(result.message.find("budget spent"), std::string::npos) << result.message;
  if (!result.trajectory.empty()) {
    EXPECT_TRUE(result.check.valid) << result.check.detail;
    EXPECT_LT((result.trajectory.startPosition() - query.start.col(0)).norm(), 1e-12);
    EXPECT_LE(result.cost, whole.cost);  // a start of a path no cheaper than the answer
  }
  // The memory budget holds too.
  expectAMemoryBudgetStop("inf");
  // The cells space is refused: its keys do not tell a state's evaluations apart.
  EXPECT_THROW(
      configurePlanner("lazy_mp_astar", test::assignments({"lookahead=inf", "search_space=cells"})),
      ConfigError);
}

TEST(LraStar, ABudgetStopReturnsACheckedStartAndBadLookaheadsAreRefused) {
  // LRA* (a finite lookahead above 1) stopped half-way returns the evaluated, valid start of
  // the path to its best frontier vertex; its memory budget holds; and a lookahead that is not
  // a whole number from 1 or "inf" is refused naming the parameter.
  test::loadTestPlugins();
  const auto world = test::smallWorld("forest");
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  const auto plan = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> items = {"sampler.samples_per_axis=3", "time_limit=0", "lookahead=4"};
    items.insert(items.end(), extra.begin(), extra.end());
    ConfiguredPlanner configured = configurePlanner("lazy_mp_astar", test::assignments(items));
    configured.planner->setup({world, 1});
    return configured.planner->plan(query, Budget{});
  };
  const auto statistic = [](const PlanResult& result, const std::string& name) {
    return test::statistic(result.statistics, name);
  };
  const PlanResult whole = plan({"max_expansions=0"});
  ASSERT_EQ(whole.status, PlanStatus::kExact) << whole.message;
  EXPECT_TRUE(whole.check.valid) << whole.check.detail;
  ASSERT_GT(statistic(whole, "rewired_vertices"), 0.0);
  const long long half = static_cast<long long>(statistic(whole, "expansions") / 2);
  const PlanResult result = plan({"max_expansions=" + std::to_string(half)});
  ASSERT_TRUE(result.status == PlanStatus::kApproximate || result.status == PlanStatus::kTimeout)
      << result.message;
  EXPECT_NE(result.message.find("budget spent"), std::string::npos) << result.message;
  if (!result.trajectory.empty()) {
    EXPECT_TRUE(result.check.valid) << result.check.detail;
    EXPECT_LT((result.trajectory.startPosition() - query.start.col(0)).norm(), 1e-12);
  }
  expectAMemoryBudgetStop("4");
  for (const char* bad : {"0", "-2", "2.5", "four", "", "1e3", "99999999999"}) {
    SCOPED_TRACE(bad);
    const std::string message = configErrorOf({std::string("lookahead=") + bad});
    EXPECT_NE(message.find("lookahead"), std::string::npos) << message;
  }
  EXPECT_THROW(
      configurePlanner("lazy_mp_astar", test::assignments({"lookahead=3", "search_space=cells"})),
      ConfigError);
}

TEST(Planner, StartsAreHeldToTheCollisionRuleEdgesUse) {
  // An edge is free when it keeps robot_radius less collision_tolerance (0.25 - 0.01 m) from
  // every cube: a start with 0.245 m of clearance is a start, one with 0.235 m is not.
  test::loadTestPlugins();
  const auto world = test::smallWorld("walls");
  const auto query = test::randomQueries(*world, 1, 3, 4.0, 6.0, 0.6).front();
  // Towards the nearest obstacle from a free start, the point with the wanted clearance.
  const auto at = [&](double wanted) {
    Eigen::Vector3d free = query.start.col(0);
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    world->esdf().distanceWithGradient(free, &gradient);
    Eigen::Vector3d blocked = free - 2.0 * gradient.normalized();
    for (int i = 0; i < 60; ++i) {
      const Eigen::Vector3d middle = 0.5 * (free + blocked);
      (world->clearance(middle) >= wanted ? free : blocked) = middle;
    }
    return free;
  };
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar",
      test::assignments({"sampler.samples_per_axis=3", "time_limit=0", "max_expansions=2000"}));
  configured.planner->setup({world, 1});
  PlanningQuery near = query;
  near.start.col(0) = at(0.245);
  ASSERT_GE(world->clearance(near.start.col(0)), 0.245);
  ASSERT_LT(world->clearance(near.start.col(0)), 0.25);
  EXPECT_NE(configured.planner->plan(near, Budget{}).status, PlanStatus::kInvalidStart);
  near.start.col(0) = at(0.235);
  ASSERT_LT(world->clearance(near.start.col(0)), 0.24);
  const PlanResult refused = configured.planner->plan(near, Budget{});
  EXPECT_EQ(refused.status, PlanStatus::kInvalidStart);
  EXPECT_NE(refused.message.find("less the collision tolerance"), std::string::npos)
      << refused.message;
}

TEST(MotionPrimitiveSearch, BudgetStopReturnsThePathToTheNearestState) {
  test::loadTestPlugins();
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar",
      test::assignments({"sampler.samples_per_axis=3", "time_limit=0", "max_expansions=40",
                         "heuristic=time_optimal"}));  // a search the budget stops
  const auto world = test::smallWorld("forest");
  configured.planner->setup({world, 1});
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  const PlanResult result = configured.planner->plan(query, Budget{});
  ASSERT_EQ(result.status, PlanStatus::kApproximate) << result.message;
  EXPECT_TRUE(result.check.valid) << result.check.detail;  // without the goal condition
  const double start_distance = (query.start.col(0) - query.goal).norm();
  EXPECT_LT(result.distance_to_goal, start_distance - 0.5);
  EXPECT_NEAR((result.trajectory.endPosition() - query.goal).norm(), result.distance_to_goal, 0.05);
}

TEST(MotionPrimitiveSearch, TreesForFiguresAreCappedAndKeepEveryKindOfEdge) {
  test::loadTestPlugins();
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar",
      test::assignments({"sampler.samples_per_axis=5", "time_limit=0", "max_expansions=800",
                         "lower_bound=lipschitz", "heuristic=time_optimal"}));
  const auto world = test::smallWorld("forest");
  configured.planner->setup({world, 1});
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  SearchTree full_tree;
  configured.planner->plan(query, Budget{}, &full_tree);
  const auto& search = dynamic_cast<const MotionPrimitivePlanner&>(*configured.planner).search();
  // Uncapped: every queued edge (800 expansions of 125 controls, the invalid ones dropped).
  const SearchTree all = search.tree(std::numeric_limits<std::size_t>::max());
  ASSERT_GT(all.size(), 20000u);
  EXPECT_LE(full_tree.size(), kMaxTreeEdges);
  EXPECT_GE(full_tree.size(), kMaxTreeEdges / 2);
  const SearchTree small = search.tree(1000);
  EXPECT_LE(small.size(), 1000u);
  EXPECT_GE(small.size(), 500u);
  // Every kind survives the decimation: lazy's queued edges, full ones and the certified.
  for (const auto state : {SearchTreeEdge::State::kPartial, SearchTreeEdge::State::kFull,
                           SearchTreeEdge::State::kCertified}) {
    EXPECT_TRUE(std::any_of(small.begin(), small.end(), [state](const SearchTreeEdge& edge) {
      return edge.state == state;
    })) << toString(state);
  }
}

/// Plans at once; building its tree takes 300 ms.
class SlowTreePlanner final : public Planner {
 protected:
  void doSetup(const PlannerContext&) override {}
  PlanResult doPlan(const PlanningQuery&, StopCondition&) override {
    PlanResult result;
    result.status = PlanStatus::kNoSolution;
    return result;
  }
  SearchTree doTree(std::size_t) const override {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    return SearchTree(3);
  }
  PlannerLimits plannerLimits() const override { return {}; }
};

TEST(Planner, BuildingTheTreeForFiguresIsNotPlanningTime) {
  SlowTreePlanner planner;
  planner.setup({test::smallWorld("forest"), 1});
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(0.6, 0.6, 1.0);
  query.goal = Eigen::Vector3d(0.7, 0.6, 1.0);
  SearchTree tree;
  const PlanResult result = planner.plan(query, Budget{}, &tree);
  EXPECT_EQ(tree.size(), 3u);
  EXPECT_LT(result.planning_time_ms, 150.0);  // the 300 ms of doTree are not in it
}

TEST(StopCondition, ReadsTheClockEvery16CallsOrAtEveryCallWhenAskedNow) {
  // A budget spent before the first call: the strided check (searches: an expansion costs
  // microseconds) sees it at its 16th call, expiredNow (OMPL planners, whose iterations may
  // take milliseconds) at its first.
  StopCondition strided(Budget{0.0});
  int calls = 1;
  while (!strided.expired(calls)) ++calls;
  EXPECT_EQ(calls, 16);
  StopCondition now(Budget{0.0});
  EXPECT_TRUE(now.expiredNow(1));
  StopCondition unlimited(Budget{INFINITY, 3});
  EXPECT_FALSE(unlimited.expiredNow(2));
  EXPECT_TRUE(unlimited.expiredNow(3));
}

TEST(Planner, ABudgetOnTheCpuClockIsNotSpentByWaiting) {
  // 100 ms of sleep spend a 50 ms budget on the wall clock, not on the CPU's; a planner's
  // budget keeps the caller's clock.
  for (const BudgetClock clock : {BudgetClock::kWall, BudgetClock::kCpu}) {
    StopCondition stop(Budget{0.05, std::numeric_limits<long long>::max(), clock});
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    bool expired = false;
    for (long long i = 0; i < 64; ++i) expired = stop.expired(i) || expired;  // past the stride
    EXPECT_EQ(expired, clock == BudgetClock::kWall);
    EXPECT_EQ(stop.elapsed() >= 0.1, clock == BudgetClock::kWall) << stop.elapsed();
  }
  SlowTreePlanner planner;
  planner.setup({test::smallWorld("forest"), 1});
  EXPECT_EQ(planner.budgetFor(Budget{1.0, 5, BudgetClock::kCpu}).clock, BudgetClock::kCpu);
}

TEST(MotionPrimitiveSearch, NoSearchOutgrowsItsMemoryBudgetEvenWithoutATimeLimit) {
  test::loadTestPlugins();
  ConfiguredPlanner configured = configurePlanner(
      "eager_mp_astar",
      test::assignments({"sampler.samples_per_axis=5", "time_limit=0", "memory_limit_mb=2",
                         "heuristic=time_optimal"}));  // a search that outgrows 2 MB
  const auto world = test::smallWorld("forest");
  configured.planner->setup({world, 1});
  const auto query = test::randomQueries(*world, 1, 21, 8.0, 11.0, 0.5).front();
  const PlanResult result = configured.planner->plan(query, Budget{});
  ASSERT_EQ(result.status, PlanStatus::kApproximate) << result.message;
  EXPECT_NE(result.message.find("memory budget spent"), std::string::npos) << result.message;
  const auto& planner = dynamic_cast<const MotionPrimitivePlanner&>(*configured.planner);
  // Stopped once past it: a container that just doubled may hold up to twice the limit.
  EXPECT_LE(planner.search().memoryBytes(), 2.0 * 2.0 * 1024 * 1024);
}

/// A 4 m x 4 m x 2 m room whose corner (2-4 m, 2-4 m) is walled off from floor to ceiling.
std::shared_ptr<const World> enclosedCornerWorld() {
  return World::build(WorldSpec::fromYaml(
      YamlReader::loadString(
          "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\n"
          "generators: [{type: box_list, boxes: [{min: [2, 2, 0], max: [4, 2.2, 2]}, "
          "{min: [2, 2, 0], max: [2.2, 4, 2]}]}]\n",
          "enclosed.yaml"),
      "."));
}

TEST(MotionPrimitiveSearch, AnEnclosedGoalExhaustsTheSearch) {
  test::loadTestPlugins();
  // The goal sits in a closed box: no path exists. (tau 0.3 s: the gentlest control, 3 m/s^2,
  // keeps max_velocity from rest, so the lattice moves and the search exhausts a real space.)
  const auto world = enclosedCornerWorld();
  ConfiguredPlanner configured = configurePlanner(
      "lazy_mp_astar", test::assignments({"sampler.samples_per_axis=3", "time_limit=0",
                                          "max_velocity=1", "tau=0.3"}));
  configured.planner->setup({world, 1});
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(0.8, 0.8, 1.0);
  query.goal = Eigen::Vector3d(3.2, 3.2, 1.0);
  const PlanResult result = configured.planner->plan(query, Budget{});
  EXPECT_EQ(result.status, PlanStatus::kNoSolution) << result.message;
  EXPECT_GT(test::statistic(result.statistics, "expansions"), 1000.0);  // it went somewhere
}

TEST(MotionPrimitiveSearch, EveryMemberOfTheLazyFamilyReportsTheNearestStateReachedAsEagerDoes) {
  // On an enclosed goal, eager answers no_solution with the path to the state it reached
  // nearest the goal, and D from there. LRA* and LazySP answered with no path, D from the start.
  test::loadTestPlugins();
  const auto world = enclosedCornerWorld();
  PlanningQuery query;
  query.start.col(0) = Eigen::Vector3d(0.8, 0.8, 1.0);
  query.goal = Eigen::Vector3d(3.2, 3.2, 1.0);
  const auto plan = [&](const std::string& key, std::vector<std::string> items) {
    for (const std::string item :
         {"sampler.samples_per_axis=3", "time_limit=0", "max_velocity=1", "tau=0.3"}) {
      items.push_back(item);
    }
    ConfiguredPlanner configured = configurePlanner(key, test::assignments(items));
    configured.planner->setup({world, 1});
    return configured.planner->plan(query, Budget{});
  };
  const PlanResult eager = plan("eager_mp_astar", {});
  ASSERT_EQ(eager.status, PlanStatus::kNoSolution) << eager.message;
  ASSERT_FALSE(eager.trajectory.empty());
  const double from_start = (query.start.col(0) - query.goal).norm();
  EXPECT_LT(eager.distance_to_goal, from_start - 1.0);
  for (const std::string lookahead : {"4", "inf"}) {
    SCOPED_TRACE("lookahead " + lookahead);
    const PlanResult lazy = plan("lazy_mp_astar", {"lookahead=" + lookahead});
    ASSERT_EQ(lazy.status, PlanStatus::kNoSolution) << lazy.message;
    EXPECT_TRUE(lazy.check.valid) << lazy.check.detail;
    EXPECT_NEAR(lazy.distance_to_goal, eager.distance_to_goal, 1e-9);
  }
}

/// The geodesic heuristic alone with one voxel step a primitive (v tau < voxel) and w_T = 1:
/// its estimate is tau times the voxel steps H.
std::shared_ptr<const SearchHeuristic> geodesicSteps(double tau, double robot_radius,
                                                     double goal_radius,
                                                     const std::string& memory_limit_mb = "2048") {
  EdgeEvaluatorSettings edges;
  edges.duration = tau;
  edges.limits = DynamicLimits::uniform(2.0, 3.0);
  edges.weights = {1.0, 0.0, 0.0, 0.0};
  edges.body.radius = robot_radius;
  return pluginRegistry<HeuristicBuilder>()
      .create("geodesic",
              test::assignments({"time_optimal=off", "memory_limit_mb=" + memory_limit_mb}))
      ->build({edges, goal_radius});
}

TEST(GeodesicHeuristic, CountsTheStepsABreadthFirstSearchFinds) {
  // Random grids, some with columns taller than a 64-bit word (the search packs z into words),
  // against a plain breadth-first search over 26-neighbours from the goal ball's voxels, through
  // the voxels whose centre's distance plus half a voxel's diagonal reaches the body's radius
  // less the collision tolerance; and the same grids bricked, with a field truncated just past
  // that test's value (a sparse world's), give the same counts.
  Rng rng(31);
  const double tau = 0.04;  // 2 m/s x 0.04 s < 0.1 m: one step a primitive
  for (const Eigen::Vector3i& dims :
       {Eigen::Vector3i(9, 7, 70), Eigen::Vector3i(12, 11, 20), Eigen::Vector3i(4, 5, 130)}) {
    for (const double robot_radius : {0.0, 0.12}) {
      VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * 0.1}, 0.1);
      for (std::size_t i = 0; i < grid.size(); ++i) grid.setOccupied(i, rng.uniform01() < 0.08);
      const auto world = std::make_shared<World>("random", 0, grid, Esdf(grid));
      const double goal_radius = 0.15;
      const Eigen::Vector3d goal =
          (dims.cast<double>() * 0.1)
              .cwiseProduct(Eigen::Vector3d(rng.uniform01(), rng.uniform01(), rng.uniform01()));
      const double threshold = std::max(robot_radius, MotionDefaults::kCollisionTolerance) -
                               MotionDefaults::kCollisionTolerance -
                               (0.5 * std::sqrt(3.0) + 1e-4) * 0.1;
      constexpr int kUnreached = -1;
      std::vector<int> steps(grid.size(), kUnreached);
      std::vector<VoxelIndex> queue;
      const auto open = [&](const VoxelIndex& v) {
        return grid.inside(v) && steps[grid.index(v)] == kUnreached &&
               world->esdf().voxelDistance(grid.index(v)) >= threshold;
      };
      for (int x = 0; x < dims.x(); ++x) {
        for (int y = 0; y < dims.y(); ++y) {
          for (int z = 0; z < dims.z(); ++z) {
            const VoxelIndex v(x, y, z);
            const Eigen::Vector3d low = v.cast<double>() * 0.1;
            const Eigen::Vector3d gap =
                (low - goal).cwiseMax(goal - low - Eigen::Vector3d::Constant(0.1)).cwiseMax(0.0);
            if (gap.norm() <= goal_radius && open(v)) {
              steps[grid.index(v)] = 0;
              queue.push_back(v);
            }
          }
        }
      }
      for (std::size_t next = 0; next < queue.size(); ++next) {
        const VoxelIndex v = queue[next];
        for (int dx = -1; dx <= 1; ++dx) {
          for (int dy = -1; dy <= 1; ++dy) {
            for (int dz = -1; dz <= 1; ++dz) {
              const VoxelIndex n = v + VoxelIndex(dx, dy, dz);
              if (!open(n)) continue;
              steps[grid.index(n)] = steps[grid.index(v)] + 1;
              queue.push_back(n);
            }
          }
        }
      }
      StopCondition never(Budget{});
      const auto heuristic =
          heuristicForQuery(geodesicSteps(tau, robot_radius, goal_radius), *world, goal, never);
      int reached = 0;
      int mismatches = 0;
      for (int x = 0; x < dims.x(); ++x) {
        for (int y = 0; y < dims.y(); ++y) {
          for (int z = 0; z < dims.z(); ++z) {
            ChainState state = ChainState::Zero();
            state.col(0) = grid.center(VoxelIndex(x, y, z));
            const double h = heuristic->estimate(state, goal);
            const int expected = steps[grid.index(x, y, z)];
            reached += expected > 0;
            mismatches +=
                expected == kUnreached ? h != INFINITY : std::abs(h - tau * expected) > 1e-9;
          }
        }
      }
      EXPECT_EQ(mismatches, 0) << dims.transpose() << ", radius " << robot_radius;
      EXPECT_GT(reached, 50) << "the goal's component is not trivial";
      VoxelGrid bricked(grid.bounds(), 0.1, GridLayout::kBricked);
      for (std::size_t i = 0; i < grid.size(); ++i) bricked.setOccupied(i, grid.occupied(i));
      // Truncated just past the node test's value: voxels reading +T pass it, those reading -T
      // fail it, as on the dense field.
      const double truncation = std::abs(threshold) + 0.005;
      const auto sparse =
          std::make_shared<World>("random", 0, bricked, Esdf::truncated(bricked, truncation));
      const auto on_sparse =
          heuristicForQuery(geodesicSteps(tau, robot_radius, goal_radius), *sparse, goal, never);
      int sparse_mismatches = 0;
      for (std::size_t i = 0; i < grid.size(); ++i) {
        ChainState state = ChainState::Zero();
        state.col(0) = grid.center(grid.voxel(i));
        sparse_mismatches += on_sparse->estimate(state, goal) != heuristic->estimate(state, goal);
      }
      EXPECT_EQ(sparse_mismatches, 0) << dims.transpose() << ", radius " << robot_radius;
      // The field grows as it is asked: asked in a random order, it gives the same counts.
      const auto asked_otherwise =
          heuristicForQuery(geodesicSteps(tau, robot_radius, goal_radius), *world, goal, never);
      std::vector<std::size_t> order(grid.size());
      std::iota(order.begin(), order.end(), std::size_t{0});
      for (std::size_t i = 0; i + 1 < order.size(); ++i) {
        const auto j = rng.uniformInt(static_cast<std::int64_t>(i),
                                      static_cast<std::int64_t>(order.size()) - 1);
        std::swap(order[i], order[static_cast<std::size_t>(j)]);
      }
      int differ = 0;
      for (const std::size_t i : order) {
        const VoxelIndex v(static_cast<int>(i / (dims.y() * dims.z())),
                           static_cast<int>(i / dims.z() % dims.y()),
                           static_cast<int>(i % dims.z()));
        ChainState state = ChainState::Zero();
        state.col(0) = grid.center(v);
        const int expected = steps[i];
        const double h = asked_otherwise->estimate(state, goal);
        differ += expected == kUnreached ? h != INFINITY : std::abs(h - tau * expected) > 1e-9;
      }
      EXPECT_EQ(differ, 0) << dims.transpose() << ", radius " << robot_radius;
    }
  }
}

TEST(GeodesicHeuristic, AnEnclosedGoalEndsTheSearchAtItsStart) {
  test::loadTestPlugins();
  // As AnEnclosedGoalExhaustsTheSearch, with the geodesic heuristic: the start's estimate is
  // infinite (no chain of free voxels reaches the goal), so no edge is queued.
  const auto world = enclosedCornerWorld();
  // Eager, LWA* and LazySP (LRA* keeps such states, at the end of its queue).
  for (const auto& [planner, lookahead] :
       {std::pair("eager_mp_astar", ""), std::pair("lazy_mp_astar", "1"),
        std::pair("lazy_mp_astar", "inf")}) {
    std::vector<std::string> items = {"sampler.samples_per_axis=3", "time_limit=0",
                                      "max_velocity=1", "tau=0.3", "heuristic=geodesic"};
    if (*lookahead) items.push_back(std::string("lookahead=") + lookahead);
    ConfiguredPlanner configured = configurePlanner(planner, test::assignments(items));
    configured.planner->setup({world, 1});
    PlanningQuery query;
    query.start.col(0) = Eigen::Vector3d(0.8, 0.8, 1.0);
    query.goal = Eigen::Vector3d(3.2, 3.2, 1.0);
    const PlanResult result = configured.planner->plan(query, Budget{});
    EXPECT_EQ(result.status, PlanStatus::kNoSolution) << planner << lookahead << result.message;
    EXPECT_LE(test::statistic(result.statistics, "expansions"), 1.0) << planner << lookahead;
  }
}

TEST(GeodesicHeuristic, AMemoryBudgetEndsTheSearchAtALowerBoundThatStaysConsistent) {
  // 300 x 300 x 10 voxels: the per-column tables take 0.69 MB, so 1 MB holds about 4,800 of
  // the 90,000 columns (68 bytes each). The budgeted field stops growing there: every voxel reads
  // at most the unbudgeted count (the far ones less), and neighbours still differ by at most one
  // step, so the estimate stays consistent (one step a primitive here).
  Rng rng(47);
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(30.0, 30.0, 1.0)}, 0.1);
  for (std::size_t i = 0; i < grid.size(); ++i) grid.setOccupied(i, rng.uniform01() < 0.05);
  const World world("random", 0, grid, Esdf(grid));
  const double tau = 0.04;
  const Eigen::Vector3d goal(1.0, 1.0, 0.5);
  StopCondition never(Budget{});
  const auto full = heuristicForQuery(geodesicSteps(tau, 0.0, 0.15), world, goal, never);
  const auto cut = heuristicForQuery(geodesicSteps(tau, 0.0, 0.15, "1"), world, goal, never);
  std::vector<double> estimates(grid.size());
  int above = 0;
  int lower = 0;
  int equal = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    ChainState state = ChainState::Zero();
    state.col(0) = grid.center(grid.voxel(i));
    estimates[i] = cut->estimate(state, goal);
    const double reference = full->estimate(state, goal);
    above += estimates[i] > reference;
    lower += estimates[i] < reference;
    equal += estimates[i] == reference && reference > 0.0 && reference < INFINITY;
  }
  EXPECT_EQ(above, 0);
  EXPECT_GT(lower, 100000) << "the budget did not cut the search short";
  EXPECT_GT(equal, 1000) << "the budgeted search reached too little";
  int steeper = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    if (estimates[i] == INFINITY) continue;  // not a node
    const VoxelIndex v = grid.voxel(i);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const VoxelIndex n = v + VoxelIndex(dx, dy, dz);
          if (!grid.inside(n) || estimates[grid.index(n)] == INFINITY) continue;
          steeper += std::abs(estimates[i] - estimates[grid.index(n)]) > tau * (1.0 + 1e-9);
        }
      }
    }
  }
  EXPECT_EQ(steeper, 0);
  // A budget below the per-column tables (160,000 columns: 1.22 MB) is refused, naming both.
  VoxelGrid wide(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(40.0, 40.0, 0.2)}, 0.1);
  const World large("wide", 0, wide, Esdf(wide));
  const std::string refused = test::errorOf<InvalidArgument>(
      [&] { heuristicForQuery(geodesicSteps(tau, 0.0, 0.15, "1"), large, goal, never); });
  EXPECT_NE(refused.find("memory_limit_mb 1 is below the 1.23 MB"), std::string::npos) << refused;
}

TEST(GeodesicHeuristic, ASparseWorldTruncatedShortOfItsFreeSpaceTestIsRefused) {
  // On 0.1 m voxels a 0.5 m body's free space needs distances to 0.49 - 0.087 = 0.40 m; a field
  // truncated at 0.3 m cannot tell those voxels (it reads 0.3 beyond), at 0.5 m it can.
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(3.0, 3.0, 2.0)}, 0.1,
                 GridLayout::kBricked);
  grid.setOccupied(grid.index(VoxelIndex(15, 15, 10)), true);
  const Eigen::Vector3d goal(0.6, 0.6, 1.0);
  StopCondition never(Budget{});
  const World short_field("short", 0, grid, Esdf::truncated(grid, 0.3));
  const std::string refused = test::errorOf<InvalidArgument>(
      [&] { heuristicForQuery(geodesicSteps(0.04, 0.5, 0.15), short_field, goal, never); });
  EXPECT_NE(refused.find("exact to 0.3 m"), std::string::npos) << refused;
  EXPECT_NE(refused.find("larger truncation"), std::string::npos) << refused;
  const World long_field("long", 0, grid, Esdf::truncated(grid, 0.5));
  EXPECT_NO_THROW(heuristicForQuery(geodesicSteps(0.04, 0.5, 0.15), long_field, goal, never));
}

/// Eager and lazy MP-A* with the heuristic `settings` choose (`heuristic=...` and its own)
/// return the default heuristic's optimal cost on every query of the small walls and forest
/// worlds (lazy = eager), with fewer expansions in all.
void expectTimeOptimalsCostsWithFewerExpansions(const std::vector<std::string>& settings) {
  test::loadTestPlugins();
  for (const std::string kind : {"walls", "forest"}) {
    const auto world = test::smallWorld(kind);
    const auto queries = test::randomQueries(*world, 6, 8, 3.0, 9.0, 0.6);
    const auto planner = [&](const std::string& type, const std::vector<std::string>& chosen) {
      std::vector<std::string> items = {"sampler.samples_per_axis=3", "time_limit=0",
                                        "max_expansions=200000"};
      items.insert(items.end(), chosen.begin(), chosen.end());
      ConfiguredPlanner configured = configurePlanner(type, test::assignments(items));
      configured.planner->setup({world, 1});
      return configured;
    };
    ConfiguredPlanner reference = planner("eager_mp_astar", {"heuristic=time_optimal"});
    ConfiguredPlanner eager = planner("eager_mp_astar", settings);
    ConfiguredPlanner lazy = planner("lazy_mp_astar", settings);
    double before = 0.0;
    double after = 0.0;
    int solved = 0;
    for (const PlanningQuery& query : queries) {
      const PlanResult expected = reference.planner->plan(query, Budget{});
      const PlanResult e = eager.planner->plan(query, Budget{});
      const PlanResult l = lazy.planner->plan(query, Budget{});
      EXPECT_EQ(e.status, expected.status) << kind;
      EXPECT_EQ(l.status, expected.status) << kind;
      if (expected.status != PlanStatus::kExact) continue;  // a lattice that cannot reach it
      ++solved;
      ASSERT_EQ(e.status, PlanStatus::kExact) << kind;
      ASSERT_EQ(l.status, PlanStatus::kExact) << kind;
      EXPECT_NEAR(e.cost, expected.cost, 1e-9 * expected.cost) << kind;
      EXPECT_NEAR(l.cost, expected.cost, 1e-9 * expected.cost) << kind;
      EXPECT_TRUE(e.check.valid && l.check.valid) << kind;
      before += test::statistic(expected.statistics, "expansions");
      after += test::statistic(e.statistics, "expansions");
    }
    EXPECT_GE(solved, 4) << kind;
    EXPECT_LT(after, before) << kind;
  }
}

TEST(GeodesicHeuristic, LazyAndEagerReturnTimeOptimalsCostsWithFewerExpansions) {
  // The estimate is at least time_optimal's everywhere (so only ties can make one query
  // expand more).
  expectTimeOptimalsCostsWithFewerExpansions({"heuristic=geodesic"});
}

TEST(LatticeHeuristic, IsTheOptimalCostInFreeSpace) {
  // With no obstacles the heuristic is the exact cost of the lattice's relaxed problem, whose
  // goal is the cube around the goal ball: the optimal cost itself when the cube holds no
  // other lattice state than the ball does (the goal straight along x, or a goal on the
  // lattice, 0.375 m apart here, with a radius of 1 cm). So the start's estimate is the optimal
  // cost, to rounding, and the search expands a few states a primitive (time_optimal floods).
  const auto world = test::smallWorld("empty");
  const auto controls = controlGrid({-1.0, 0.0, 1.0}, Eigen::Vector3d(3, 3, 3));
  ChainState start = ChainState::Zero();
  start.col(0) = Eigen::Vector3d(1.0, 1.7, 1.0);
  const double w = 0.5 * 3.0 * 0.5 * 0.5;  // the lattice's step: u tau^2 / 2
  for (const auto& [offset, goal_radius] :
       {std::pair(Eigen::Vector3d(2.3, 0, 0), 0.5), std::pair(Eigen::Vector3d(9.7, 0, 0), 0.5),
        std::pair(Eigen::Vector3d(8 * w, 4 * w, 2 * w), 0.01),
        std::pair(Eigen::Vector3d(24 * w, 20 * w, 3 * w), 0.01),
        std::pair(Eigen::Vector3d(-2 * w, 25 * w, -w), 0.01)}) {
    const Eigen::Vector3d goal = start.col(0) + offset;
    SearchSettings settings;
    settings.goal_radius = goal_radius;
    const auto solve = [&](const std::string& name) {
      SearchPolicies policies;
      policies.edges = std::make_shared<FullEvaluationPolicy>();
      policies.heuristic = heuristicFor(name, settings.edges, goal_radius);
      policies.space = std::make_shared<LatticeSpace>(LatticeSpace::Resolution());
      auto search =
          std::make_unique<MotionPrimitiveSearch>(world, controls, settings, std::move(policies));
      StopCondition stop(Budget{});
      EXPECT_EQ(search->search(start, goal, stop), MotionPrimitiveSearch::Outcome::kGoal);
      return search;
    };
    const auto lattice = solve("lattice");
    const auto reference = solve("time_optimal");
    const double optimum = reference->cost();
    EXPECT_NEAR(lattice->cost(), optimum, 1e-9 * optimum) << offset.transpose();
    StopCondition stop(Budget{});
    const auto heuristic = heuristicForQuery(
        heuristicForControls(heuristicFor("lattice", settings.edges, goal_radius), controls),
        *world, goal, stop);
    EXPECT_NEAR(heuristic->estimate(start, goal), optimum, 1e-9 * optimum) << offset.transpose();
    const auto primitives = static_cast<double>(lattice->trajectory().segments().size());
    EXPECT_LE(lattice->counters().expansions, 4 * (primitives + 1)) << offset.transpose();
    EXPECT_LE(lattice->counters().expansions, reference->counters().expansions);
    if (offset.norm() > 5.0) {
      EXPECT_LT(3 * lattice->counters().expansions, reference->counters().expansions)
          << offset.transpose();
    }
  }
}

TEST(LatticeHeuristic, FromAMovingStartItIsALowerBoundCloseToTheOptimum) {
  // A start moving at 1.1 m/s along x and -0.7 m/s along y (the 3-control grid's velocity step
  // is 1.5 m/s: off its lattice), no obstacles: the relaxation on finer cells is at most the
  // optimal cost, and closes most of the gap time_optimal in whole primitives leaves.
  const auto world = test::smallWorld("empty");
  const auto controls = controlGrid({-1.0, 0.0, 1.0}, Eigen::Vector3d(3, 3, 3));
  SearchSettings settings;
  ChainState start = ChainState::Zero();
  start.col(0) = Eigen::Vector3d(1.5, 6.0, 1.5);
  start.col(1) = Eigen::Vector3d(1.1, -0.7, 0.0);
  for (const Eigen::Vector3d& goal :
       {Eigen::Vector3d(9.0, 6.0, 1.5), Eigen::Vector3d(4.0, 10.5, 1.5),
        Eigen::Vector3d(10.0, 2.0, 2.0)}) {
    SearchPolicies policies;
    policies.edges = std::make_shared<FullEvaluationPolicy>();
    policies.heuristic = heuristicFor("lattice", settings.edges, settings.goal_radius);
    policies.space = std::make_shared<LatticeSpace>(LatticeSpace::Resolution());
    MotionPrimitiveSearch search(world, controls, settings, std::move(policies));
    StopCondition stop(Budget{});
    ASSERT_EQ(search.search(start, goal, stop), MotionPrimitiveSearch::Outcome::kGoal);
    const auto heuristic = heuristicForQuery(
        heuristicForControls(heuristicFor("lattice", settings.edges, settings.goal_radius),
                             controls),
        *world, goal, stop);
    const double h = heuristic->estimate(start, goal);
    const double whole =
        TimeOptimalHeuristic(settings.edges, settings.goal_radius, true).estimate(start, goal);
    EXPECT_LE(h, search.cost() * (1.0 + 1e-9)) << goal.transpose();
    // (0.83-0.93 of the optimum here, time_optimal 0.43-0.58: the cube around the goal ball
    // and the finer cells' slack are the rest.)
    EXPECT_GE(h, 0.75 * search.cost()) << goal.transpose();
    EXPECT_GE(h - whole, 0.5 * (search.cost() - whole)) << goal.transpose();
  }
}

TEST(LatticeHeuristic, ALatticeTooFineForItsTablesKeepsTimeOptimal) {
  // tau 0.01 s and 64 controls per axis: a lattice step of 5 micrometres and 4,000 velocities
  // an axis, 10^10 states in a 12 m world: past the tables' budget, the query is time_optimal
  // in whole primitives (no tables are made).
  EdgeEvaluatorSettings edges;
  edges.duration = 0.01;
  std::vector<double> values;
  for (int k = 0; k < 64; ++k) values.push_back(-1.0 + 2.0 * k / 63.0);
  const auto controls = controlGrid(values, Eigen::Vector3d(3, 3, 3));
  const auto world = test::smallWorld("empty");
  ChainState start = ChainState::Zero();
  start.col(0) = Eigen::Vector3d(1.0, 1.7, 1.0);
  const Eigen::Vector3d goal(9.0, 8.0, 2.0);
  StopCondition stop(Budget{});
  const auto lattice = heuristicForQuery(
      heuristicForControls(heuristicFor("lattice", edges, 0.5), controls), *world, goal, stop);
  const TimeOptimalHeuristic whole(edges, 0.5, true);
  EXPECT_EQ(lattice->estimate(start, goal), whole.estimate(start, goal));
}

TEST(LatticeHeuristic, RefusesControlsOffAGridAndOrdersAboveTwoWithoutItsFallback) {
  test::loadTestPlugins();
  const auto strict = pluginRegistry<HeuristicBuilder>()
                          .create("lattice", test::assignments({"fallback=false"}))
                          ->build({SearchSettings().edges, SearchSettings().goal_radius});
  try {
    strict->forControls({Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector3d(std::sqrt(2.0), 0, 0)});
    FAIL() << "no error";
  } catch (const InvalidArgument& error) {
    EXPECT_NE(std::string(error.what()).find("controls' x values are not whole multiples"),
              std::string::npos)
        << error.what();
  }
  // Named where the configuration is read: the random sampler's set is no grid.
  const std::string random =
      configErrorOf({"sampler=random", "heuristic=lattice", "heuristic.fallback=false"});
  EXPECT_NE(random.find("parameter 'heuristic': lattice needs a control grid"), std::string::npos)
      << random;
  const std::string order =
      configErrorOf({"order=3", "heuristic=lattice", "heuristic.fallback=false"});
  EXPECT_NE(order.find("parameter 'heuristic': lattice needs order 2"), std::string::npos) << order;
}

TEST(LatticeHeuristic, FallsBackToWholePrimitiveTimeWhereItsLatticeDoesNotApply) {
  // With its fallback (the default): a random control set and order 3 plan exactly as
  // time_optimal in whole primitives does, expansion for expansion.
  test::loadTestPlugins();
  const auto world = test::smallWorld("forest");
  const auto queries = test::randomQueries(*world, 5, 8, 3.0, 9.0, 0.6);
  const auto plan = [&](std::vector<std::string> items, const PlanningQuery& query) {
    items.insert(items.end(), {"time_limit=0", "max_expansions=200000"});
    ConfiguredPlanner configured = configurePlanner("lazy_mp_astar", test::assignments(items));
    configured.planner->setup({world, 1});
    return configured.planner->plan(query, Budget{});
  };
  for (const std::string setting : {"sampler=random", "order=3"}) {
    int exact = 0;
    for (const PlanningQuery& query : queries) {
      const PlanResult lattice = plan({setting, "heuristic=lattice"}, query);
      const PlanResult whole =
          plan({setting, "heuristic=time_optimal", "heuristic.whole_primitives=true"}, query);
      EXPECT_EQ(lattice.status, whole.status) << setting;
      EXPECT_EQ(lattice.cost, whole.cost) << setting;
      EXPECT_EQ(test::statistic(lattice.statistics, "expansions"),
                test::statistic(whole.statistics, "expansions"))
          << setting;
      exact += lattice.status == PlanStatus::kExact;
    }
    EXPECT_GE(exact, 3) << setting;
  }
}

TEST(LatticeHeuristic, LazyAndEagerReturnTimeOptimalsCostsWithFewerExpansions) {
  expectTimeOptimalsCostsWithFewerExpansions({"heuristic=lattice"});
}

TEST(MaxHeuristic, CombinesAnyTwoPreparedForTheirControlsAndQueries) {
  // The lattice bound (prepared for the controls) and the geodesic one (for each query).
  expectTimeOptimalsCostsWithFewerExpansions({"heuristic=max", "heuristic.first=lattice",
                                              "heuristic.second=geodesic",
                                              "heuristic.second.time_optimal=off"});
  // Directly: the lattice part is prepared for the controls (else it would read time_optimal).
  EdgeEvaluatorSettings edges;
  const auto controls = controlGrid({-1.0, 0.0, 1.0}, Eigen::Vector3d(3, 3, 3));
  const auto world = test::smallWorld("empty");
  ChainState start = ChainState::Zero();
  start.col(0) = Eigen::Vector3d(1.0, 1.7, 1.0);
  const Eigen::Vector3d goal(10.0, 9.0, 2.0);
  const auto prepared = [&](const std::shared_ptr<const SearchHeuristic>& heuristic) {
    StopCondition stop(Budget{});
    return heuristicForQuery(heuristicForControls(heuristic, controls), *world, goal, stop)
        ->estimate(start, goal);
  };
  const double both =
      prepared(pluginRegistry<HeuristicBuilder>()
                   .create("max", test::assignments({"first=lattice", "second=geodesic"}))
                   ->build({edges, 0.5}));
  EXPECT_EQ(both, prepared(heuristicFor("lattice", edges, 0.5)));
  EXPECT_GT(both, TimeOptimalHeuristic(edges, 0.5, true).estimate(start, goal));
  // A part that does not serve the order is left out; when neither does, the first's reason.
  EXPECT_NO_THROW(configurePlanner(
      "lazy_mp_astar",
      test::assignments({"order=3", "heuristic=max", "heuristic.first=geodesic"})));
  const std::string neither = configErrorOf(
      {"order=3", "heuristic=max", "heuristic.first=lattice", "heuristic.first.fallback=false"});
  EXPECT_NE(neither.find("lattice needs order 2"), std::string::npos) << neither;
}

TEST(ParallelEvaluation, EveryThreadCountSearchesTheSameAndAnswersTheSame) {
  // A state's edges (eager) or the popped edge with the open list's next ones (lazy)
  // evaluated on 1, 2 and 4 threads: the same expansions, evaluations used, ESDF queries, cost
  // and trajectory, bit for bit (each edge lands in its own slot).
  test::loadTestPlugins();
  const auto world = test::smallWorld("forest");
  const auto queries = test::randomQueries(*world, 4, 21, 3.0, 9.0, 0.6);
  for (const std::string type : {"eager_mp_astar", "lazy_mp_astar"}) {
    std::vector<std::vector<PlanResult>> results;
    for (const int threads : {1, 2, 4}) {
      ConfiguredPlanner configured =
          configurePlanner(type, test::assignments({"time_limit=0", "edge_samples=40",
                                                    "threads=" + std::to_string(threads)}));
      configured.planner->setup({world, 1});
      results.emplace_back();
      for (const PlanningQuery& query : queries) {
        results.back().push_back(configured.planner->plan(query, Budget{}));
      }
    }
    int exact = 0;
    for (std::size_t q = 0; q < queries.size(); ++q) {
      const PlanResult& one = results[0][q];
      exact += one.status == PlanStatus::kExact;
      for (std::size_t t = 1; t < results.size(); ++t) {
        const PlanResult& other = results[t][q];
        EXPECT_EQ(other.status, one.status) << type << " query " << q;
        EXPECT_EQ(other.cost, one.cost) << type << " query " << q;
        for (const char* counter :
             {"expansions", "full_evaluations", "partial_evaluations", "esdf_queries"}) {
          EXPECT_EQ(test::statistic(other.statistics, counter),
                    test::statistic(one.statistics, counter))
              << type << " query " << q << " " << counter;
        }
        ASSERT_EQ(other.trajectory.segments().size(), one.trajectory.segments().size());
        for (std::size_t i = 0; i < one.trajectory.segments().size(); ++i) {
          EXPECT_EQ(other.trajectory.segments()[i].coefficients,
                    one.trajectory.segments()[i].coefficients);
        }
      }
    }
    EXPECT_GE(exact, 3) << type;
    // Lazy search evaluates the open list's next edges ahead on the other threads: none at one
    // thread, some at two and four, and never more wasted than made.
    for (std::size_t t = 0; t < results.size(); ++t) {
      double ahead = 0.0;
      double wasted = 0.0;
      for (const PlanResult& result : results[t]) {
        ahead += test::statistic(result.statistics, "ahead_evaluations");
        wasted += test::statistic(result.statistics, "wasted_evaluations");
      }
      EXPECT_LE(wasted, ahead) << type << " " << t;
      if (t == 0 || type == "eager_mp_astar") {
        EXPECT_EQ(ahead, 0.0) << type << " " << t;
      } else {
        EXPECT_GT(ahead, 0.0) << type << " " << t;
      }
    }
  }
}

TEST(EdgeWorkers, RunEveryIndexOnceOnTheTeamAndRethrowAJobsException) {
  EdgeWorkers workers(2);
  ASSERT_EQ(workers.threads(), 2);
  std::vector<std::atomic<int>> runs(64);
  for (int round = 0; round < 200; ++round) {
    workers.run(runs.size(), [&](std::size_t i) { ++runs[i]; });
  }
  for (const auto& count : runs) EXPECT_EQ(count.load(), 200);
  // Runs of changing sizes: each index of each run once, none past its count (a worker's stale
  // look at a finished run once took the index past its count when the next run was larger).
  for (int round = 0; round < 4000; ++round) {
    const std::size_t count = 1 + static_cast<std::size_t>(round) % runs.size();
    for (auto& ran : runs) ran = 0;
    workers.run(count, [&](std::size_t i) { ++runs[i]; });
    for (std::size_t i = 0; i < runs.size(); ++i) ASSERT_EQ(runs[i].load(), i < count) << round;
  }
  // Index 0 waits (counted yields, never a clock) until another index has started: only a
  // second thread can start one meanwhile, so this ends early only if the team shares the
  // work.
  std::atomic<int> started{0};
  std::vector<std::thread::id> who(8);
  long waited = 0;
  workers.run(who.size(), [&](std::size_t i) {
    ++started;
    who[i] = std::this_thread::get_id();
    while (i == 0 && started.load() < 2 && waited < 100000000) {
      ++waited;
      std::this_thread::yield();
    }
  });
  EXPECT_LT(waited, 100000000);
  EXPECT_GT(std::set<std::thread::id>(who.begin(), who.end()).size(), 1u);
  const auto failing = [](std::size_t i) {
    if (i == 7) throw InvalidArgument("edge 7");
  };
  EXPECT_THROW(workers.run(16, failing), InvalidArgument);
  std::atomic<int> after{0};
  workers.run(16, [&](std::size_t) { ++after; });  // the team still works
  EXPECT_EQ(after.load(), 16);
}

}  // namespace
}  // namespace kinolab
