// `ompl_control`: OMPL's control-based (kinodynamic) planners by name - SST, KPIECE1, RRT, EST,
// PDST - over kinolab's integrator chain: states are position and velocity (and acceleration
// at order 3), controls the highest derivative boxed by its limit, propagation exact. A state
// is valid within the map and the limits and with the body's clearance plus half the longest
// step's travel, so that the motion between two valid states is clear too (the independent
// checker confirms it). docs/ompl_control.md.
#include "ompl_control.hpp"

#include <ompl/base/Goal.h>
#include <ompl/base/OptimizationObjective.h>
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/goals/GoalRegion.h>
#include <ompl/base/spaces/RealVectorStateProjections.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/control/PathControl.h>
#include <ompl/control/SpaceInformation.h>
#include <ompl/control/planners/est/EST.h>
#include <ompl/control/planners/kpiece/KPIECE1.h>
#include <ompl/control/planners/pdst/PDST.h>
#include <ompl/control/planners/rrt/RRT.h>
#include <ompl/control/planners/sst/SST.h>
#include <ompl/control/spaces/RealVectorControlSpace.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "ompl_common.hpp"
#include "plan_seeds.hpp"
#include "rrt_front_end.hpp"

namespace kinolab::rrt {
namespace {

namespace ob = ompl::base;
namespace oc = ompl::control;

enum class ControlPlanner { kSst, kKpiece1, kRrt, kEst, kPdst };

/// ompl_control's own parameters (the body, limits, goal and time limit: motionParameters()).
struct ControlSettings {
  ControlPlanner planner = ControlPlanner::kSst;
  long long order = 2;
  double max_jerk = 5.0;
  double step = 0.05;
  long long min_steps = 1;
  long long max_steps = 10;
  double goal_bias = 0.05;
  double selection_radius = 0.2;
  double pruning_radius = 0.1;
  bool stop_at_first = false;
  long long max_iterations = 0;

  template <typename Fields>
  void fields(Fields& f) {
    f.choice("planner", planner,
             {{"sst", ControlPlanner::kSst},
              {"kpiece1", ControlPlanner::kKpiece1},
              {"rrt", ControlPlanner::kRrt},
              {"est", ControlPlanner::kEst},
              {"pdst", ControlPlanner::kPdst}},
             "OMPL's control-based planner");
    f.integer("order", order, 2, 3,
              "integrator chain: 2 acceleration control (states p, v), 3 jerk (p, v, a)");
    f.real("max_jerk", max_jerk, 0.01, 10000.0, "per-axis jerk limit (order 3), m/s^3");
    f.real("step", step, 0.001, 1.0, "propagation step, s (OMPL's propagation step size)");
    f.integer("min_steps", min_steps, 1, 1000, "a control is applied for at least this many steps");
    f.integer("max_steps", max_steps, 1, 1000, "... and at most this many");
    f.real("goal_bias", goal_bias, 0.0, 1.0, "probability of sampling towards the goal");
    f.real("selection_radius", selection_radius, 0.0, 1000.0, "SST's selection radius (delta_s)");
    f.real("pruning_radius", pruning_radius, 0.0, 1000.0, "SST's pruning radius (delta_bn)");
    f.boolean("stop_at_first", stop_at_first,
              "stop at the first exact solution (SST refines to the budget otherwise)");
    f.integer("max_iterations", max_iterations, 0, 1000000000,
              "budget in calls of the termination condition (0: none)");
  }
};

/// A control planner with its own stream seeded (every stream of a plan comes from the run's
/// seed and the query: plan_seeds.hpp), and SST's best cost visible.
template <typename Base>
class SeededControlPlanner final : public Seeded<Base> {
 public:
  using Seeded<Base>::Seeded;
  /// SST's best solution cost so far (infinite before the first), for the anytime series.
  double bestCost() const {
    if constexpr (std::is_same_v<Base, oc::SST>) return this->prevSolutionCost_.value();
    return INFINITY;
  }
};

class SeededControlSampler final : public oc::RealVectorControlUniformSampler {
 public:
  SeededControlSampler(const oc::ControlSpace* space, std::uint32_t seed)
      : oc::RealVectorControlUniformSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

/// A box of controls whose every sampler (OMPL's default, which every planner here reaches
/// through allocControlSampler()) draws from the plan's seeds.
class SeededRealVectorControlSpace final : public oc::RealVectorControlSpace {
 public:
  SeededRealVectorControlSpace(const ob::StateSpacePtr& states, unsigned int dimension,
                               std::shared_ptr<PlanSeeds> seeds)
      : oc::RealVectorControlSpace(states, dimension), seeds_(std::move(seeds)) {}

  oc::ControlSamplerPtr allocDefaultControlSampler() const override {
    return std::make_shared<SeededControlSampler>(this, seeds_->next());
  }

 private:
  std::shared_ptr<PlanSeeds> seeds_;
};

/// The goal region: positions within the goal radius (any velocity).
class PositionGoal final : public ob::GoalRegion {
 public:
  PositionGoal(const ob::SpaceInformationPtr& si, const Eigen::Vector3d& goal, double radius)
      : ob::GoalRegion(si), goal_(goal) {
    setThreshold(radius);
  }
  double distanceGoal(const ob::State* state) const override {
    const double* x = state->as<ob::RealVectorStateSpace::StateType>()->values;
    return (Eigen::Vector3d(x[0], x[1], x[2]) - goal_).norm();
  }

 private:
  Eigen::Vector3d goal_;
};

/// Path length in position (SST's cost; the other planners ignore it).
class PositionLength final : public ob::OptimizationObjective {
 public:
  explicit PositionLength(const ob::SpaceInformationPtr& si) : ob::OptimizationObjective(si) {}
  ob::Cost stateCost(const ob::State*) const override { return identityCost(); }
  ob::Cost motionCost(const ob::State* a, const ob::State* b) const override {
    const double* x = a->as<ob::RealVectorStateSpace::StateType>()->values;
    const double* y = b->as<ob::RealVectorStateSpace::StateType>()->values;
    return ob::Cost(std::sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) +
                              (x[2] - y[2]) * (x[2] - y[2])));
  }
};

ChainState chainOf(const ob::State* state, int order) {
  const double* x = state->as<ob::RealVectorStateSpace::StateType>()->values;
  ChainState chain = ChainState::Zero();
  for (int k = 0; k < order; ++k)
    chain.col(k) = Eigen::Vector3d(x[3 * k], x[3 * k + 1], x[3 * k + 2]);
  return chain;
}

void setChain(const ChainState& chain, int order, ob::State* state) {
  double* x = state->as<ob::RealVectorStateSpace::StateType>()->values;
  for (int k = 0; k < order; ++k) {
    for (int axis = 0; axis < 3; ++axis) x[3 * k + axis] = chain(axis, k);
  }
}

Eigen::Vector3d controlOf(const oc::Control* control) {
  const double* u = control->as<oc::RealVectorControlSpace::ControlType>()->values;
  return {u[0], u[1], u[2]};
}

/// The OMPL problem of one world: spaces, propagation and validity.
struct ControlProblem {
  std::shared_ptr<const World> world;
  ControlSettings settings;
  PlannerLimits limits;
  Body body;
  std::shared_ptr<PlanSeeds> seeds = std::make_shared<PlanSeeds>();  // of the current plan
  std::shared_ptr<ob::RealVectorStateSpace> space;
  oc::SpaceInformationPtr si;
  long long validity_checks = 0;
  long long propagations = 0;
  /// m every state keeps beyond the body's radius and inside the map's box: half the longest
  /// step's travel (setUpPropagation()).
  double margin = 0.0;
  ob::PlannerPtr last_planner;
};

void buildSpaces(ControlProblem& p) {
  const int order = static_cast<int>(p.settings.order);
  p.space = std::make_shared<SeededRealVectorStateSpace>(3 * order, p.seeds);
  ob::RealVectorBounds bounds(3 * order);
  const Box& box = p.world->bounds();
  for (int axis = 0; axis < 3; ++axis) {
    bounds.setLow(axis, box.min[axis]);
    bounds.setHigh(axis, box.max[axis]);
    for (int k = 1; k < order; ++k) {
      bounds.setLow(3 * k + axis, -p.limits.limits.bound[k][axis]);
      bounds.setHigh(3 * k + axis, p.limits.limits.bound[k][axis]);
    }
  }
  p.space->setBounds(bounds);
  // KPIECE1 and PDST grow over a projection: the position, in 0.5 m cells.
  p.space->registerDefaultProjection(std::make_shared<ob::RealVectorOrthogonalProjectionEvaluator>(
      p.space.get(), std::vector<double>{0.5, 0.5, 0.5}, std::vector<unsigned int>{0, 1, 2}));
  auto controls = std::make_shared<SeededRealVectorControlSpace>(p.space, 3, p.seeds);
  ob::RealVectorBounds control_bounds(3);
  for (int axis = 0; axis < 3; ++axis) {
    control_bounds.setLow(axis, -p.limits.limits.bound[order][axis]);
    control_bounds.setHigh(axis, p.limits.limits.bound[order][axis]);
  }
  controls->setBounds(control_bounds);
  p.si = std::make_shared<oc::SpaceInformation>(p.space, controls);
}

void setUpPropagation(ControlProblem& p) {
  const int order = static_cast<int>(p.settings.order);
  ControlProblem* shared = &p;
  p.si->setStatePropagator([shared, order](const ob::State* from, const oc::Control* control,
                                           double duration, ob::State* result) {
    ++shared->propagations;
    const TrajectorySegment segment =
        TrajectorySegment::primitive(chainOf(from, order), controlOf(control), order, duration);
    ChainState end = ChainState::Zero();
    for (int k = 0; k < order; ++k) end.col(k) = segment.evaluate(duration, k);
    setChain(end, order, result);
  });
  // Between two states one step apart the body travels at most sqrt(3) v_max step (the speed
  // bound of per-axis limits): clearance of half that beyond the radius at both keeps the
  // motion clear, and as far inside the map's box keeps it in the map. At order 3 the velocity is
  // quadratic within a step and can exceed its endpoints' by j_max step^2 / 8: the states keep that
  // much below the limit.
  const double step = p.settings.step;
  const double margin = 0.5 * std::sqrt(3.0) * p.limits.limits.bound[1].maxCoeff() * step;
  p.margin = margin;
  const double velocity_slack = order == 3 ? p.settings.max_jerk * step * step / 8.0 : 0.0;
  // A sparse world's truncated distances would read as the clearance: refused at setup.
  p.world->requireExactDistancesTo(p.body.radius + margin,
                                   "ompl_control (its states keep the robot radius plus half a "
                                   "propagation step's travel clear)");
  // The same margin inside the map's box keeps the motion inside it.
  const Box& box = p.world->bounds();
  const Eigen::Vector3d low = box.min.array() + margin;
  const Eigen::Vector3d high = box.max.array() - margin;
  p.si->setStateValidityChecker(
      [shared, order, margin, velocity_slack, low, high](const ob::State* state) {
        ++shared->validity_checks;
        const ChainState chain = chainOf(state, order);
        const Eigen::Vector3d& bound = shared->limits.limits.bound[1];
        if ((chain.col(1).cwiseAbs() - bound).maxCoeff() > -velocity_slack) return false;
        if ((chain.col(0) - low).minCoeff() < 0.0 || (high - chain.col(0)).minCoeff() < 0.0) {
          return false;
        }
        return shared->si->satisfiesBounds(state) &&
               shared->world->isFree(chain.col(0), shared->body.radius + margin);
      });
  p.si->setPropagationStepSize(step);
  p.si->setMinMaxControlDuration(static_cast<unsigned>(p.settings.min_steps),
                                 static_cast<unsigned>(p.settings.max_steps));
  p.si->setup();
}

ob::PlannerPtr allocate(const ControlProblem& p) {
  const std::uint32_t seed = p.seeds->next();
  const ControlSettings& s = p.settings;
  switch (s.planner) {
    case ControlPlanner::kSst: {
      auto planner = std::make_shared<SeededControlPlanner<oc::SST>>(seed, p.si);
      planner->setGoalBias(s.goal_bias);
      planner->setSelectionRadius(s.selection_radius);
      planner->setPruningRadius(s.pruning_radius);
      return planner;
    }
    case ControlPlanner::kKpiece1: {
      auto planner = std::make_shared<SeededControlPlanner<oc::KPIECE1>>(seed, p.si);
      planner->setGoalBias(s.goal_bias);
      return planner;
    }
    case ControlPlanner::kRrt: {
      auto planner = std::make_shared<SeededControlPlanner<oc::RRT>>(seed, p.si);
      planner->setGoalBias(s.goal_bias);
      return planner;
    }
    case ControlPlanner::kEst: {
      auto planner = std::make_shared<SeededControlPlanner<oc::EST>>(seed, p.si);
      planner->setGoalBias(s.goal_bias);
      return planner;
    }
    case ControlPlanner::kPdst: {
      auto planner = std::make_shared<SeededControlPlanner<oc::PDST>>(seed, p.si);
      planner->setGoalBias(s.goal_bias);
      return planner;
    }
  }
  return nullptr;
}

class OmplControlPlanner final : public Planner {
 public:
  explicit OmplControlPlanner(const ParameterSet& parameters)
      : settings_(readFields<ControlSettings>(parameters)),
        limits_(plannerLimitsFrom(parameters)),
        budget_(timeBudgetFrom(parameters)) {
    if (settings_.max_steps < settings_.min_steps) {
      throw ConfigError("ompl_control: max_steps " + std::to_string(settings_.max_steps) +
                        " is below min_steps " + std::to_string(settings_.min_steps));
    }
    if (settings_.max_iterations > 0) budget_.max_iterations = settings_.max_iterations;
    if (!std::isfinite(budget_.time_limit) && settings_.max_iterations <= 0) {
      throw ConfigError(
          "ompl_control: time_limit 0 (none) needs max_iterations > 0: the planners stop only "
          "at their budget");
    }
    const Eigen::Vector3d& v = limits_.limits.bound[1];
    const Eigen::Vector3d& a = limits_.limits.bound[2];
    limits_.limits = DynamicLimits::uniform(v.x(), a.x(), settings_.max_jerk);
    limits_.limited_derivatives = static_cast<int>(settings_.order);
  }

 protected:
  void doSetup(const PlannerContext& context) override {
    ompl::msg::setLogLevel(ompl::msg::LOG_WARN);  // no "Info:" line per plan
    problem_ = std::make_unique<ControlProblem>();
    problem_->world = context.world;
    problem_->settings = settings_;
    problem_->limits = limits_;
    problem_->body = body();
    buildSpaces(*problem_);
    setUpPropagation(*problem_);
    seed_ = context.seed;
  }

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override;

  SearchTree doTree(std::size_t max_edges) const override;
  PlannerLimits plannerLimits() const override { return limits_; }
  Budget ownBudget() const override { return budget_; }
  std::string stateProblem(const Eigen::Vector3d& position) const override {
    const ControlProblem& p = *problem_;
    const Box& box = p.world->bounds();
    const double inset = std::min((position - box.min).minCoeff(), (box.max - position).minCoeff());
    if (inset < p.margin) {
      return "it is " + formatNumber(inset) + " m inside the map's box, less than the " +
             formatNumber(p.margin) + " m (half a propagation step's travel) every state keeps";
    }
    const double clearance = p.world->clearance(position);
    if (clearance >= p.body.radius + p.margin) return "";
    return "clearance " + formatNumber(clearance) +
           " m is below the robot radius plus half a propagation step's travel = " +
           formatNumber(p.body.radius + p.margin) + " m, which every state keeps";
  }
  std::string costObjective() const override { return "trajectory length"; }

 private:
  ControlSettings settings_;
  PlannerLimits limits_;
  Budget budget_;
  std::uint64_t seed_ = 0;
  std::unique_ptr<ControlProblem> problem_;
};

PlanResult OmplControlPlanner::doPlan(const PlanningQuery& query, StopCondition& stop) {
  ControlProblem& p = *problem_;
  const int order = static_cast<int>(settings_.order);
  PlanResult result;
  std::uint64_t seed = hashBytes(query.goal.data(), 3 * sizeof(double), seed_);
  seed = hashBytes(query.start.data(), sizeof(ChainState), seed);
  p.seeds->begin(seed);
  p.validity_checks = 0;
  p.propagations = 0;
  auto definition = std::make_shared<ob::ProblemDefinition>(p.si);
  ob::ScopedState<> start(p.space);
  setChain(query.start, order, start.get());
  if (!p.si->isValid(start.get())) {
    result.status = PlanStatus::kInvalidStart;
    result.message =
        "the start is not a valid ompl_control state: within the limits, and with "
        "the robot radius plus half a propagation step's travel of clearance";
    return result;
  }
  definition->addStartState(start);
  definition->setGoal(std::make_shared<PositionGoal>(p.si, query.goal, limits_.goal_radius));
  definition->setOptimizationObjective(std::make_shared<PositionLength>(p.si));
  const ob::PlannerPtr planner = allocate(p);
  planner->setProblemDefinition(definition);
  planner->setup();
  p.last_planner = planner;

  const auto* sst = dynamic_cast<const SeededControlPlanner<oc::SST>*>(planner.get());
  const Stopwatch watch(stop.budget().clock);
  long long calls = 0;
  const ob::PlannerStatus status = planner->solve(ob::PlannerTerminationCondition([&] {
    ++calls;
    if (sst) {
      const double cost = sst->bestCost();
      if (std::isfinite(cost) && (result.progress.empty() || cost < result.progress.back().value))
        result.progress.push_back({"anytime_cost", watch.milliseconds(), cost});
    }
    if (settings_.stop_at_first && (!result.progress.empty() || definition->hasExactSolution()))
      return true;
    return stop.expiredNow(calls);
  }));
  const double planning_ms = watch.milliseconds();
  if (status == ob::PlannerStatus::EXACT_SOLUTION ||
      status == ob::PlannerStatus::APPROXIMATE_SOLUTION) {
    auto& path = static_cast<oc::PathControl&>(*definition->getSolutionPath());
    for (std::size_t i = 0; i < path.getControlCount(); ++i) {
      result.trajectory.append(TrajectorySegment::primitive(chainOf(path.getState(i), order),
                                                            controlOf(path.getControl(i)), order,
                                                            path.getControlDuration(i)));
    }
    result.status =
        definition->hasApproximateSolution() ? PlanStatus::kApproximate : PlanStatus::kExact;
    if (result.status == PlanStatus::kApproximate) {
      result.message = "budget spent: the path to the state nearest the goal";
    }
  } else {
    result.status = PlanStatus::kTimeout;
    result.message = "no path within the budget";
  }
  result.cost = result.trajectory.empty() ? INFINITY : result.trajectory.length();
  result.statistics = {{"propagations", static_cast<double>(p.propagations)},
                       {"validity_checks", static_cast<double>(p.validity_checks)},
                       {"termination_checks", static_cast<double>(calls)},
                       {"time_ompl_ms", planning_ms}};
  return result;
}

SearchTree OmplControlPlanner::doTree(std::size_t max_edges) const {
  if (!problem_ || !problem_->last_planner) return {};
  return plannerTree(*problem_->last_planner, problem_->si, max_edges);
}

}  // namespace

ParameterSpecs omplControlParameters() {
  return declareFields<ControlSettings>().include(motionParameters(1.0));
}

MetricSpecs omplControlStatistics() {
  return MetricSpecs()
      .counter("propagations", "exact propagations of a control")
      .counter("validity_checks", "state validity checks")
      .counter("termination_checks", "calls of the termination condition (the iteration budget)")
      .clock("time_ompl_ms", "the OMPL planner's own time")
      .series("anytime_cost", "m",
              "SST's best cost over its planning time: its own objective, the summed straight "
              "distances between the ends of its controls (at most the flown length)");
}

std::unique_ptr<Planner> makeOmplControl(const ParameterSet& parameters) {
  return std::make_unique<OmplControlPlanner>(parameters);
}

}  // namespace kinolab::rrt
