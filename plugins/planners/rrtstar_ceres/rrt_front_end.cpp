#include "rrt_front_end.hpp"

#include <ompl/base/PlannerData.h>
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/goals/GoalRegion.h>
#include <ompl/base/goals/GoalState.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/config.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/informedtrees/ABITstar.h>
#include <ompl/geometric/planners/informedtrees/AITstar.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/prm/LazyPRMstar.h>
#include <ompl/geometric/planners/rrt/InformedRRTstar.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "ompl_common.hpp"
#include "plan_seeds.hpp"

namespace kinolab::rrt {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;

Eigen::Vector3d toVector(const ob::State* state) {
  const double* values = state->as<ob::RealVectorStateSpace::StateType>()->values;
  return {values[0], values[1], values[2]};
}

void fromVector(const Eigen::Vector3d& point, ob::State* state) {
  double* values = state->as<ob::RealVectorStateSpace::StateType>()->values;
  for (int axis = 0; axis < 3; ++axis) values[axis] = point[axis];
}

/// RRT* with its tree's size visible (the vertex cap).
class SeededRrtStar final : public Seeded<og::RRTstar> {
 public:
  using Seeded<og::RRTstar>::Seeded;
  std::size_t treeSize() const { return nn_ ? nn_->size() : 0; }
};

std::vector<Eigen::Vector3d> waypoints(const og::PathGeometric& path) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(path.getStateCount());
  for (std::size_t i = 0; i < path.getStateCount(); ++i)
    points.push_back(toVector(path.getState(i)));
  return points;
}

}  // namespace

struct RrtFrontEnd::Ompl {
  std::shared_ptr<const World> world;
  FrontEndSettings settings;
  std::shared_ptr<PlanSeeds> seeds = std::make_shared<PlanSeeds>();  // of the current plan
  std::shared_ptr<ob::RealVectorStateSpace> space;
  ob::SpaceInformationPtr si;
  long long validity_checks = 0;
  ob::PlannerPtr last_planner;  // kept for tree() after the clock stopped
};

RrtFrontEnd::RrtFrontEnd(std::shared_ptr<const World> world, const FrontEndSettings& settings)
    : ompl_(std::make_unique<Ompl>()) {
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  Ompl& o = *ompl_;
  o.world = std::move(world);
  o.settings = settings;
  o.space = std::make_shared<SeededRealVectorStateSpace>(3, o.seeds);
  ob::RealVectorBounds bounds(3);
  const Box& box = o.world->bounds();
  for (int axis = 0; axis < 3; ++axis) {
    bounds.setLow(axis, box.min[axis]);
    bounds.setHigh(axis, box.max[axis]);
  }
  o.space->setBounds(bounds);
  Ompl* shared = ompl_.get();
  o.si = std::make_shared<ob::SpaceInformation>(o.space);
  o.si->setStateValidityChecker([shared](const ob::State* state) {
    ++shared->validity_checks;
    return shared->world->isFree(toVector(state), shared->settings.clearance);
  });
  o.si->setStateValidityCheckingResolution(settings.motion_resolution /
                                           o.space->getMaximumExtent());
  o.si->setup();
}

RrtFrontEnd::~RrtFrontEnd() = default;

SearchTree RrtFrontEnd::tree(std::size_t max_edges) const {
  const Ompl& o = *ompl_;
  return o.last_planner ? plannerTree(*o.last_planner, o.si, max_edges) : SearchTree{};
}

std::shared_ptr<ob::ProblemDefinition> RrtFrontEnd::problem(const Eigen::Vector3d& start,
                                                            const Eigen::Vector3d& goal) const {
  const Ompl& o = *ompl_;
  auto problem = std::make_shared<ob::ProblemDefinition>(o.si);
  ob::ScopedState<> start_state(o.space);
  fromVector(start, start_state.get());
  problem->addStartState(start_state);
  auto goal_region = std::make_shared<ob::GoalState>(o.si);
  ob::ScopedState<> goal_state(o.space);
  fromVector(goal, goal_state.get());
  goal_region->setState(goal_state);
  goal_region->setThreshold(o.settings.goal_radius);
  problem->setGoal(goal_region);
  problem->setOptimizationObjective(std::make_shared<ob::PathLengthOptimizationObjective>(o.si));
  return problem;
}

namespace {

/// The termination condition, run once per RRT* iteration: it applies the budget, stops
/// after the refinement iterations or at the vertex cap, and records the anytime progress
/// (every improvement of the best cost, as the `anytime_cost` series) and the first solution.
class Monitor {
 public:
  Monitor(const SeededRrtStar& planner, const FrontEndSettings& settings, StopCondition& stop)
      : planner_(planner), settings_(settings), stop_(stop), watch_(stop.budget().clock) {}

  bool operator()() {
    const long long iterations = planner_.numIterations();
    const double cost = planner_.bestCost().value();
    const double now_ms = watch_.milliseconds();
    if (std::isfinite(cost) && (progress.empty() || cost < progress.back().value)) {
      progress.push_back({"anytime_cost", now_ms, cost});
    }
    if (first_iteration < 0 && std::isfinite(cost)) {
      first_iteration = iterations;
      first_ms = now_ms;
      first_cost = cost;
    }
    if (first_iteration >= 0 && iterations - first_iteration >= settings_.refine_iterations) {
      return true;
    }
    if (static_cast<long long>(planner_.treeSize()) >= settings_.max_vertices) return true;
    return stop_.expiredNow(iterations);
  }

  double elapsedMs() const { return watch_.milliseconds(); }

  Progress progress;
  long long first_iteration = -1;
  double first_ms = NAN;
  double first_cost = NAN;

 private:
  const SeededRrtStar& planner_;
  const FrontEndSettings& settings_;
  StopCondition& stop_;
  Stopwatch watch_;  // the budget's clock, from the search's start
};

}  // namespace

FrontEndResult RrtFrontEnd::plan(const Eigen::Vector3d& start, const Eigen::Vector3d& goal,
                                 std::uint64_t seed, StopCondition& stop) {
  Ompl& o = *ompl_;
  const FrontEndSettings& settings = o.settings;
  o.seeds->begin(seed);
  o.validity_checks = 0;
  o.si->getMotionValidator()->resetMotionCounter();

  const auto problem = this->problem(start, goal);
  if (settings.planner != OmplPlanner::kRrtStar) return planOther(problem, stop);
  auto planner = std::make_shared<SeededRrtStar>(o.seeds->next(), o.si);
  if (settings.range > 0.0) planner->setRange(settings.range);
  planner->setGoalBias(settings.goal_bias);
  planner->setRewireFactor(settings.rewire_factor);
  planner->setKNearest(settings.k_nearest);
  planner->setDelayCC(settings.delay_collision_checking);
  planner->setProblemDefinition(problem);
  planner->setup();
  o.last_planner = planner;

  FrontEndResult result;
  Monitor monitor(*planner, settings, stop);
  const ob::PlannerStatus status =
      planner->solve(ob::PlannerTerminationCondition([&monitor] { return monitor(); }));
  const double rrt_ms = monitor.elapsedMs();
  result.iterations = planner->numIterations();
  if (status == ob::PlannerStatus::EXACT_SOLUTION ||
      status == ob::PlannerStatus::APPROXIMATE_SOLUTION) {
    result.outcome = problem->hasApproximateSolution() ? FrontEndResult::Outcome::kApproximate
                                                       : FrontEndResult::Outcome::kExact;
    simplify(static_cast<og::PathGeometric&>(*problem->getSolutionPath()), result);
  }

  Statistics& stats = result.statistics;
  stats.emplace_back("iterations", static_cast<double>(result.iterations));
  stats.emplace_back("tree_size", static_cast<double>(planner->treeSize()));
  countChecks(result);
  stats.emplace_back(
      "first_solution_iteration",
      monitor.first_iteration < 0 ? NAN : static_cast<double>(monitor.first_iteration));
  stats.emplace_back("first_solution_ms", monitor.first_ms);
  stats.emplace_back("first_solution_cost", monitor.first_cost);
  stats.emplace_back("best_cost", planner->bestCost().value());
  stats.emplace_back("time_rrt_ms", rrt_ms);
  result.progress = std::move(monitor.progress);
  return result;
}

void RrtFrontEnd::countChecks(FrontEndResult& result) const {
  const ob::MotionValidatorPtr& motions = ompl_->si->getMotionValidator();
  Statistics& stats = result.statistics;
  stats.emplace_back("collision_checks", static_cast<double>(ompl_->validity_checks));
  stats.emplace_back("motion_checks", static_cast<double>(motions->getValidMotionCount() +
                                                          motions->getInvalidMotionCount()));
  stats.emplace_back("motion_checks_invalid",
                     static_cast<double>(motions->getInvalidMotionCount()));
}

namespace {

/// The planner of `s`, its own stream (where OMPL lets it be reached) seeded from `seeds`.
ob::PlannerPtr allocatePlanner(const ob::SpaceInformationPtr& si, const FrontEndSettings& s,
                               PlanSeeds& seeds) {
  switch (s.planner) {
    case OmplPlanner::kRrtConnect: {
      auto planner = std::make_shared<Seeded<og::RRTConnect>>(seeds.next(), si);
      if (s.range > 0.0) planner->setRange(s.range);
      return planner;
    }
    case OmplPlanner::kInformedRrtStar: {
      auto planner = std::make_shared<Seeded<og::InformedRRTstar>>(seeds.next(), si);
      if (s.range > 0.0) planner->setRange(s.range);
      planner->setGoalBias(s.goal_bias);
      planner->setRewireFactor(s.rewire_factor);
      planner->setKNearest(s.k_nearest);
      planner->setDelayCC(s.delay_collision_checking);
      return planner;
    }
    // Named for their default k-nearest variant (else OMPL warns on every allocation).
    case OmplPlanner::kBitStar:
      return std::make_shared<og::BITstar>(si, "kBITstar");
    case OmplPlanner::kAbitStar:
      return std::make_shared<og::ABITstar>(si, "kABITstar");
    case OmplPlanner::kAitStar:
      return std::make_shared<og::AITstar>(si);
    case OmplPlanner::kLazyPrmStar:
      return std::make_shared<og::LazyPRMstar>(si);
    case OmplPlanner::kRrtStar:
      break;
  }
  throw InvalidArgument("ompl_geometric: RRT* runs its own loop");
}

/// The termination condition of any planner but RRT*: the budget (its iterations are calls of
/// the condition), the first exact solution with stop_at_first; records the first solution
/// and the anytime progress (OMPL's "best cost" progress property, at every improvement).
class AnyPlannerMonitor {
 public:
  AnyPlannerMonitor(const ob::Planner& planner, const ob::ProblemDefinition& problem,
                    bool stop_at_first, StopCondition& stop)
      : problem_(problem), stop_at_first_(stop_at_first), stop_(stop), watch_(stop.budget().clock) {
    // OMPL names it "best cost REAL" or "best cost DOUBLE" (BIT*, ABIT*, AIT*).
    for (const auto& [name, read] : planner.getPlannerProgressProperties()) {
      if (name.rfind("best cost ", 0) == 0) best_cost_ = read;
    }
  }

  bool operator()() {
    ++calls;
    const double now_ms = watch_.milliseconds();
    double cost = INFINITY;
    if (best_cost_) cost = std::strtod(best_cost_().c_str(), nullptr);
    if (std::isfinite(cost) && (progress.empty() || cost < progress.back().value)) {
      progress.push_back({"anytime_cost", now_ms, cost});
    }
    // The first solution: the first finite best cost (planners add their solution to the
    // problem only when they return).
    if (stop_at_first_ && (!progress.empty() || problem_.hasExactSolution())) return true;
    return stop_.expiredNow(calls);
  }

  double elapsedMs() const { return watch_.milliseconds(); }

  Progress progress;
  long long calls = 0;

 private:
  const ob::ProblemDefinition& problem_;
  bool stop_at_first_;
  StopCondition& stop_;
  std::function<std::string()> best_cost_;
  Stopwatch watch_;  // the budget's clock, from the search's start
};

/// An approximate answer runs from the start: `path` when it does, else the path through
/// `planner`'s graph from the start to the vertex it reached nearest the goal (nullptr when it
/// reached none but the start). A bidirectional planner may offer a branch of its goal tree:
/// OMPL 1.5.2's RRT-Connect takes its approximate solution from the motion last added, which
/// after a connection attempt is in the goal tree, so its path began at the goal.
std::shared_ptr<og::PathGeometric> approximateFromStart(const ob::Planner& planner,
                                                        const ob::ProblemDefinition& problem,
                                                        std::shared_ptr<og::PathGeometric> path) {
  const ob::SpaceInformationPtr& si = problem.getSpaceInformation();
  for (unsigned int i = 0; i < problem.getStartStateCount(); ++i) {
    if (path->getStateCount() > 0 && si->equalStates(path->getState(0), problem.getStartState(i))) {
      return path;
    }
  }
  // Breadth first along the graph's edges (a goal tree's point towards its root, so they are
  // entered only through a connection) from the start vertices.
  ob::PlannerData data(si);
  planner.getPlannerData(data);
  const unsigned int kNone = ob::PlannerData::INVALID_INDEX;
  std::vector<unsigned int> parent(data.numVertices(), kNone);
  std::vector<unsigned int> queue;
  for (unsigned int i = 0; i < data.numStartVertices(); ++i) {
    const unsigned int start = data.getStartIndex(i);
    parent[start] = start;
    queue.push_back(start);
  }
  const auto& goal = *problem.getGoal()->as<ob::GoalRegion>();
  unsigned int nearest = kNone;
  double nearest_distance = INFINITY;
  std::vector<unsigned int> children;
  for (std::size_t next = 0; next < queue.size(); ++next) {
    const unsigned int vertex = queue[next];
    if (parent[vertex] != vertex) {  // the start itself is no answer
      const double distance = goal.distanceGoal(data.getVertex(vertex).getState());
      if (distance < nearest_distance) {
        nearest_distance = distance;
        nearest = vertex;
      }
    }
    data.getEdges(vertex, children);
    for (const unsigned int child : children) {
      if (parent[child] != kNone) continue;
      parent[child] = vertex;
      queue.push_back(child);
    }
  }
  if (nearest == kNone) return nullptr;
  std::vector<unsigned int> chain{nearest};  // back to its start
  while (parent[chain.back()] != chain.back()) chain.push_back(parent[chain.back()]);
  auto rebuilt = std::make_shared<og::PathGeometric>(si);
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
    rebuilt->append(data.getVertex(*it).getState());
  }
  return rebuilt;
}

}  // namespace

FrontEndResult RrtFrontEnd::planOther(const std::shared_ptr<ob::ProblemDefinition>& problem,
                                      StopCondition& stop) {
  Ompl& o = *ompl_;
  const ob::PlannerPtr planner = allocatePlanner(o.si, o.settings, *o.seeds);
  planner->setProblemDefinition(problem);
  planner->setup();
  o.last_planner = planner;
  FrontEndResult result;
  AnyPlannerMonitor monitor(*planner, *problem, o.settings.stop_at_first, stop);
  const ob::PlannerStatus status =
      planner->solve(ob::PlannerTerminationCondition([&monitor] { return monitor(); }));
  const double planning_ms = monitor.elapsedMs();
  result.iterations = monitor.calls;
  double best = NAN;
  if (status == ob::PlannerStatus::EXACT_SOLUTION ||
      status == ob::PlannerStatus::APPROXIMATE_SOLUTION) {
    auto path = std::static_pointer_cast<og::PathGeometric>(problem->getSolutionPath());
    if (problem->hasApproximateSolution()) path = approximateFromStart(*planner, *problem, path);
    if (path) {
      result.outcome = problem->hasApproximateSolution() ? FrontEndResult::Outcome::kApproximate
                                                         : FrontEndResult::Outcome::kExact;
      best = path->length();
      simplify(*path, result);
    }
  }
  Statistics& stats = result.statistics;
  countChecks(result);
  // Without a best-cost property (RRT-Connect) a planner returns at its first solution.
  stats.emplace_back("first_solution_ms", !monitor.progress.empty()
                                              ? monitor.progress.front().time_ms
                                          : std::isfinite(best) ? planning_ms
                                                                : NAN);
  stats.emplace_back("best_cost", best);
  stats.emplace_back("time_ompl_ms", planning_ms);
  result.progress = std::move(monitor.progress);
  return result;
}

void RrtFrontEnd::simplify(og::PathGeometric& path, FrontEndResult& result) const {
  const Ompl& o = *ompl_;
  const std::size_t raw_vertices = path.getStateCount();
  const double raw_length = path.length();
  const auto simplify_begin = std::chrono::steady_clock::now();
  if (o.settings.simplify) {
    // Iteration-bounded (not timed) so that the result depends on the seed only.
    Seeded<og::PathSimplifier> simplifier(o.seeds->next(), o.si);
    for (int round = 0; round < 5 && simplifier.reduceVertices(path); ++round) {
    }
    for (int round = 0; round < 5 && simplifier.shortcutPath(path); ++round) {
    }
  }
  result.statistics.emplace_back("time_simplify_ms", millisecondsSince(simplify_begin));
  result.path = waypoints(path);
  result.path_length = path.length();
  result.statistics.emplace_back("path_vertices_raw", static_cast<double>(raw_vertices));
  result.statistics.emplace_back("path_length_raw", raw_length);
  result.statistics.emplace_back("path_vertices", static_cast<double>(path.getStateCount()));
  result.statistics.emplace_back("path_length", result.path_length);
}

std::string omplVersion() {
  // Debian's ompl/config.h leaves OMPL_VERSION empty; the numeric parts are set.
  return std::to_string(OMPL_MAJOR_VERSION) + "." + std::to_string(OMPL_MINOR_VERSION) + "." +
         std::to_string(OMPL_PATCH_VERSION);
}

}  // namespace kinolab::rrt
