#include "kinolab/search/motion_primitive_planner.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {
namespace {

/// The limit parameters by derivative (1 = velocity ... 4 = snap).
constexpr const char* kLimitNames[] = {"", "max_velocity", "max_acceleration", "max_jerk",
                                       "max_snap"};
constexpr const char* kDerivativeNames[] = {"", "velocity", "acceleration", "jerk", "snap"};

/// Refuses a control set none of whose controls moves the vehicle from rest within the limits
/// over one primitive: such a lattice can never leave its start, and every query would end
/// `no_solution`. The message names the gentlest control, the limit it breaks and the fixes,
/// the first being the longest primitive duration at which that control fits.
void requireAMovingControl(const std::vector<Eigen::Vector3d>& controls,
                           const EdgeEvaluatorSettings& edges) {
  const IntegratorChain chain(edges.order);
  const ChainState rest = ChainState::Zero();
  const Eigen::Vector3d* gentlest = nullptr;
  for (const Eigen::Vector3d& control : controls) {
    if (control.cwiseAbs().maxCoeff() == 0.0) continue;
    if (chain.withinLimits(rest, control, edges.duration, edges.limits)) return;
    // The smallest by its largest component, then by its length: (0, 0, 3) before (3, 3, 3).
    const auto size = [](const Eigen::Vector3d& u) {
      return std::pair(u.cwiseAbs().maxCoeff(), u.norm());
    };
    if (!gentlest || size(control) < size(*gentlest)) gentlest = &control;
  }
  if (!gentlest) return;  // only the zero control: a sampler's choice, not a mismatch
  const auto broken = chain.checkLimits(rest, *gentlest, edges.duration, edges.limits);
  // The longest duration at which the gentlest control stays within the limits (bisection;
  // the limits of a primitive from rest only tighten with its duration).
  double fits = 0.0;
  double breaks = edges.duration;
  for (int i = 0; i < 60; ++i) {
    const double middle = 0.5 * (fits + breaks);
    (chain.withinLimits(rest, *gentlest, middle, edges.limits) ? fits : breaks) = middle;
  }
  const double shown = std::floor(fits * 1000.0) / 1000.0;  // rounded down: it still fits
  const int k = broken ? broken->derivative : 1;
  const char axis = broken ? "xyz"[broken->axis] : 'x';
  throw ParameterConflict(
      "tau",
      "no control of the " + std::to_string(controls.size()) +
          " moves the vehicle from rest within the limits, so the lattice can never "
          "leave its start: the gentlest, " +
          formatPoint(*gentlest) + " for tau = " + formatNumber(edges.duration) + " s, reaches a " +
          kDerivativeNames[k] + " of " +
          formatNumber(std::round(std::abs(broken ? broken->value : 0.0) * 1e6) / 1e6) + " along " +
          axis + ", above " + kLimitNames[k] + " = " + formatNumber(edges.limits.bound[k][0]) +
          ". Set tau <= " + formatNumber(shown) +
          ", a finer control set (sampler.samples_per_axis), or a larger " + kLimitNames[k],
      {kLimitNames[k], "max_acceleration", "sampler.samples_per_axis"});
}

}  // namespace

ParameterSpecs motionPrimitiveParameters() {
  return ParameterSpecs()
      .plugin("sampler", "sampler", "uniform",
              "control sampler (kinolab list samplers); set its parameters as sampler.NAME")
      .integer("order", 2, 2, 4, "integrator chain order: 2 acceleration, 3 jerk, 4 snap control")
      .real("tau", 0.6, 0.01, 5.0, "primitive duration, s")
      .include(motionParameters(10.0))
      .real("max_jerk", 5.0, 0.01, 10000.0,
            "per-axis jerk limit (order >= 3), m/s^3 (the default keeps max_jerk tau within "
            "max_acceleration at the default tau, so the full-jerk primitives are feasible)")
      .real("max_snap", 4.0, 0.01, 100000.0,
            "per-axis snap limit (order 4), m/s^4 (the default keeps max_snap tau within "
            "half of max_jerk: a finer lattice of jerks)")
      .real("weight_duration", 1.0, 0.0, 1e6, "cost per second of flight")
      .real("weight_length", 0.0, 0.0, 1e6, "cost per metre travelled")
      .real("weight_control", 0.1, 0.0, 1e6, "cost per |u|^2 s of control effort")
      .real("weight_obstacle", 1.0, 0.0, 1e6, "cost per second inside the safety band (squared)")
      .integer("edge_samples", 10, 1, 10000,
               "K: quadrature samples of the obstacle cost per edge (not of the collision "
               "verdict, which sphere tracing makes exact to collision_tolerance)")
      .real("edge_spacing", 0.0, 0.0, 10.0,
            "> 0: quadrature samples this far apart along the edge instead of K, m")
      .real("safety_distance", 0.5, 0.001, 100.0, "obstacle penalty band beyond the radius, m")
      .plugin("heuristic", "heuristic", "lattice",
              "the search's heuristic (kinolab list heuristics); set its parameters as "
              "heuristic.NAME; the default, lattice, is the fastest exact one measured "
              "(docs/planning.md); the paper's is time_optimal")
      .real("heuristic_weight", 1.0, 1.0, 100.0,
            "epsilon: f = g + epsilon h; > 1 is bounded suboptimal (cost <= epsilon optimum)")
      .plugin("search_space", "search_space", "lattice",
              "how states are told apart (kinolab list search_spaces): lattice (exact, "
              "optimal) or cells (hybrid A*'s); set its parameters as search_space.NAME")
      .integer("max_expansions", 0, 0, 1000000000, "expansion budget (0: none)")
      .real("memory_limit_mb", 2048.0, 1.0, 1e6,
            "memory budget of the search, MB: past it the search stops as on any budget")
      .integer("threads", 1, 1, 256,
               "threads fully evaluating edges at once: eager's successors of a state; lazy's "
               "popped edge with the next lower-bound edges of the open list, evaluated ahead "
               "(a lazy search's lower bounds are too cheap to hand over); the search, its "
               "counters and its answer are the same at every count (wasted_evaluations aside)");
}

MetricSpecs motionPrimitiveStatistics() {
  return MetricSpecs()
      .counter("expansions", "states expanded (N)")
      .counter("pops", "open-list entries popped, stale ones included")
      .counter("partial_evaluations", "edges queued with a lower bound (lazy)")
      .counter("full_evaluations",
               "edges fully evaluated (those the search used: the same at every "
               "thread count)")
      .counter("ahead_evaluations",
               "full evaluations made ahead of their pops beside the popped edge's (lazy, "
               "threads > 1)")
      .counter("wasted_evaluations", "of those, the ones the search never used")
      .counter("certified_edges", "lower-bound edges proved exact without full evaluation")
      .counter("rejected_edges", "full evaluations that found a collision")
      .counter("esdf_queries", "ESDF look-ups by edge evaluation")
      .counter("open_peak", "largest open list")
      .counter("candidates", "candidate edges created")
      .counter("closed_states", "states closed")
      .clock("time_evaluation_ms", "time spent evaluating edges (within planning_time_ms)")
      .clock("time_search_ms", "time in the search besides edge evaluation (Dellin's breakdown)")
      .counter("controls", "size of the control set")
      .real("heuristic_weight", "", "epsilon: the heuristic's weight")
      .real("start_heuristic", "",
            "the heuristic's estimate at the start, unweighted (with an admissible heuristic, as "
            "every built-in one is, a lower bound of the optimal cost: start_heuristic / cost "
            "is how tight it is)");
}

std::shared_ptr<const SearchHeuristic> heuristicFor(const std::string& key,
                                                    const EdgeEvaluatorSettings& edges,
                                                    double goal_radius) {
  return pluginRegistry<HeuristicBuilder>().create(key, {})->build({edges, goal_radius});
}

MotionPrimitiveConfig MotionPrimitiveConfig::fromParameters(const ParameterSet& parameters) {
  MotionPrimitiveConfig config;
  SearchSettings& settings = config.settings;
  const PlannerLimits limits = plannerLimitsFrom(parameters);
  EdgeEvaluatorSettings& edges = settings.edges;
  edges.order = static_cast<int>(parameters.integer("order"));
  edges.duration = parameters.real("tau");
  edges.limits = DynamicLimits::uniform(limits.limits.bound[1].x(), limits.limits.bound[2].x(),
                                        parameters.real("max_jerk"), parameters.real("max_snap"));
  edges.weights.duration = parameters.real("weight_duration");
  edges.weights.length = parameters.real("weight_length");
  edges.weights.control_effort = parameters.real("weight_control");
  edges.weights.obstacle = parameters.real("weight_obstacle");
  const double spacing = parameters.real("edge_spacing");
  edges.sampling.mode = spacing > 0.0 ? EdgeSampling::Mode::kSpacing : EdgeSampling::Mode::kCount;
  edges.sampling.samples = static_cast<int>(parameters.integer("edge_samples"));
  if (spacing > 0.0) edges.sampling.spacing = spacing;
  settings.heuristic_weight = parameters.real("heuristic_weight");
  settings.goal_radius = limits.goal_radius;
  settings.memory_limit_mb = parameters.real("memory_limit_mb");
  settings.threads = static_cast<int>(parameters.integer("threads"));

  config.policies.edges = std::make_shared<FullEvaluationPolicy>();
  config.heuristic = pluginRegistry<HeuristicBuilder>().createChosen(parameters, "heuristic");
  config.policies.space = pluginRegistry<SearchSpace>().createChosen(parameters, "search_space");
  config.sampler = pluginRegistry<ControlSampler>().createChosen(parameters, "sampler");
  config.budget = timeBudgetFrom(parameters);
  if (const long long limit = parameters.integer("max_expansions"); limit > 0) {
    config.budget.max_iterations = limit;
  }
  return config;
}

MotionPrimitivePlanner::MotionPrimitivePlanner(MotionPrimitiveConfig config)
    : config_(std::move(config)) {
  if (!config_.policies.edges || !config_.heuristic || !config_.policies.space) {
    throw InvalidArgument(
        "motion-primitive planner: an edge policy, a heuristic and a search space are needed");
  }
  if (!config_.sampler && config_.controls.empty()) {
    throw InvalidArgument("motion-primitive planner: neither a control sampler nor controls");
  }
}

const MotionPrimitiveSearch& MotionPrimitivePlanner::search() const {
  if (!search_) throw InvalidArgument("motion-primitive planner: setup() was not called");
  return *search_;
}

SearchSettings MotionPrimitivePlanner::settingsFor(const Body& body) const {
  SearchSettings settings = config_.settings;
  settings.edges.body = body;
  return settings;
}

std::vector<Eigen::Vector3d> MotionPrimitivePlanner::controlsFor(std::uint64_t seed) const {
  const EdgeEvaluatorSettings& edges = config_.settings.edges;
  return config_.controls.empty() ? config_.sampler->sample(edges.limits.bound[edges.order], seed)
                                  : config_.controls;
}

MotionPrimitivePlanner::SearchParts MotionPrimitivePlanner::searchParts(
    const PlannerContext& context) const {
  SearchParts parts{controlsFor(context.seed), settingsFor(body()), config_.policies};
  requireAMovingControl(parts.controls, parts.settings.edges);
  parts.policies.heuristic =
      config_.heuristic->build({parts.settings.edges, parts.settings.goal_radius});
  return parts;
}

void MotionPrimitivePlanner::doSetup(const PlannerContext& context) {
  SearchParts parts = searchParts(context);
  search_ =
      std::make_unique<MotionPrimitiveSearch>(context.world, std::move(parts.controls),
                                              std::move(parts.settings), std::move(parts.policies));
}

void MotionPrimitivePlanner::doCheck() const {
  const SearchSettings settings = settingsFor(body());
  const std::vector<Eigen::Vector3d> controls = controlsFor(1);
  if (controls.empty()) return;
  requireAMovingControl(controls, settings.edges);
  // A heuristic that reads the control set (`lattice`) refuses one it cannot serve here, where
  // the configuration names the heuristic, not when a worker sets the planner up.
  try {
    heuristicForControls(config_.heuristic->build({settings.edges, settings.goal_radius}),
                         controls);
  } catch (const ParameterConflict&) {
    throw;
  } catch (const InvalidArgument& error) {
    throw ParameterConflict("heuristic", error.what(), {"sampler"});
  }
}

void MotionPrimitivePlanner::doReset() {
  if (search_) search_->clear();
}

std::string MotionPrimitivePlanner::costObjective() const {
  const EdgeEvaluatorSettings& edges = config_.settings.edges;
  const CostWeights& w = edges.weights;
  std::string text = "motion-primitive cost: order " + std::to_string(edges.order) + ", per s " +
                     formatNumber(w.duration) + ", control " + formatNumber(w.control_effort);
  if (w.length > 0.0) text += ", per m " + formatNumber(w.length);
  if (w.obstacle > 0.0) {
    text += ", obstacle " + formatNumber(w.obstacle) + " within " +
            formatNumber(body().safety_band) + " m of radius " + formatNumber(body().radius);
  }
  // The quadrature reads the length and obstacle terms only: without them the cost is exact.
  if (w.length > 0.0 || w.obstacle > 0.0) {
    text += edges.sampling.mode == EdgeSampling::Mode::kSpacing
                ? ", samples every " + formatNumber(edges.sampling.spacing) + " m"
                : ", " + std::to_string(edges.sampling.samples) + " samples an edge";
  }
  return text;
}

PlannerLimits MotionPrimitivePlanner::plannerLimits() const {
  PlannerLimits limits;
  limits.limits = config_.settings.edges.limits;
  limits.limited_derivatives = config_.settings.edges.order;
  limits.goal_radius = config_.settings.goal_radius;
  return limits;
}

PlanResult MotionPrimitivePlanner::resultOf(MotionPrimitiveSearch::Outcome outcome,
                                            Trajectory trajectory, double cost,
                                            const std::string& budget_spent) {
  PlanResult result;
  result.trajectory = std::move(trajectory);
  result.cost = result.trajectory.empty() ? INFINITY : cost;
  switch (outcome) {
    case MotionPrimitiveSearch::Outcome::kGoal:
      result.status = PlanStatus::kExact;
      break;
    case MotionPrimitiveSearch::Outcome::kExhausted:
      result.status = PlanStatus::kNoSolution;
      // True of the search space, not of the world: a lattice of these controls and this
      // duration, or (hybrid A*) one state per cell, may miss a way that exists.
      result.message =
          "every state of the search space was expanded without reaching the goal region: no "
          "way on this space (its controls, duration and state pruning), not proof that none "
          "exists";
      break;
    case MotionPrimitiveSearch::Outcome::kBudget:
      result.status = result.trajectory.empty() ? PlanStatus::kTimeout : PlanStatus::kApproximate;
      result.message = budget_spent;
      break;
  }
  return result;
}

PlanResult MotionPrimitivePlanner::doPlan(const PlanningQuery& query, StopCondition& stop) {
  MotionPrimitiveSearch& search = *search_;
  const auto outcome = search.search(query.start, query.goal, stop);
  PlanResult result =
      resultOf(outcome, search.trajectory(), search.cost(),
               std::string(search.counters().memory_limited ? "memory budget" : "budget") +
                   " spent after " + std::to_string(search.counters().expansions) + " expansions");
  result.statistics = search.statistics();
  result.statistics.emplace_back("controls", static_cast<double>(search.controls().size()));
  result.statistics.emplace_back("heuristic_weight", config_.settings.heuristic_weight);
  return result;
}

SearchTree MotionPrimitivePlanner::doTree(std::size_t max_edges) const {
  return search_ ? search_->tree(max_edges) : SearchTree{};
}

}  // namespace kinolab
