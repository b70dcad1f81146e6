#pragma once

#include <Eigen/Core>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/stop_condition.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/primitives/edge_evaluator.hpp"
#include "kinolab/search/search_policies.hpp"

namespace kinolab {

/// Which candidates of the same state the search keeps.
enum class DuplicateRule {
  kLwa,   ///< every candidate cheaper than the state's best evaluated one (optimal)
  kSeed,  ///< the paper's Algorithm 1 read literally: the first candidate only (lazy)
};

struct SearchSettings {
  EdgeEvaluatorSettings edges;
  DuplicateRule duplicate_rule = DuplicateRule::kLwa;
  double heuristic_weight = 1.0;  ///< epsilon >= 1: cost within epsilon times the optimum
  double cost_weight = 1.0;       ///< weight of g in the priority; 0 = greedy best-first
  double goal_radius = MotionDefaults::kGoalRadius;
  /// The search's memory (candidates, states, open list): once past this it stops as on any
  /// budget, so that no search, not even one without a time limit, exhausts the machine (a
  /// container that has just doubled may hold up to twice the limit).
  double memory_limit_mb = 2048.0;
  /// Threads fully evaluating a state's edges at once (PrimitiveGraph::estimateAll, when the
  /// edge policy evaluatesFully()): each edge's evaluation is independent and lands in its own
  /// slot, so the search, its counters and its answer are the same at every count; only the
  /// time changes.
  int threads = 1;
};

/// The policies a plugin gives the search (kinolab/search/search_policies.hpp).
struct SearchPolicies {
  /// How edges are evaluated at expansion: full (eager) or a lower bound (lazy).
  std::shared_ptr<const EdgeEvaluationPolicy> edges;
  std::shared_ptr<const SearchHeuristic> heuristic;
  /// How states are told apart (LatticeSpace: exact on a control grid's lattice).
  std::shared_ptr<const SearchSpace> space;
  /// An analytic expansion to the goal from each closed state (hybrid A*), or none.
  std::shared_ptr<const GoalShot> shot;
};

/// Counters of one search; see PrimitiveGraph::statistics() for their names.
struct SearchCounters {
  long long expansions = 0;
  long long pops = 0;
  long long partial_evaluations = 0;
  long long full_evaluations = 0;
  /// Full evaluations made ahead of their pops, beside the popped edge's (a lazy search with
  /// threads > 1; 0 at one thread), and of those the ones the search never used: the edge's
  /// state was closed first, or the search ended before its pop.
  long long ahead_evaluations = 0;
  long long wasted_evaluations = 0;
  long long certified_edges = 0;
  long long rejected_edges = 0;  ///< full evaluations that found a collision or limit breach
  long long esdf_queries = 0;
  long long open_peak = 0;
  long long candidates = 0;
  double evaluation_seconds = 0.0;
  double search_seconds = 0.0;   ///< the whole search (evaluation included)
  bool memory_limited = false;   ///< stopped by memory_limit_mb
  long long shots = 0;           ///< analytic expansions tried (SearchPolicies::shot)
  long long shots_rejected = 0;  ///< of those, refused by the checker
  double start_heuristic = 0.0;  ///< the heuristic's estimate at the start (unweighted)
};

/// The motion-primitive graph every search of kinolab runs on: the controls and the edge
/// evaluator (successors), the search space (state keys), the query's heuristic and its
/// estimate at the start, the counters of one search and its memory budget. Eager, lazy and
/// greedy MP-A* and hybrid A* (MotionPrimitiveSearch) and the lazy family (LazySP, LRA*) reach
/// the world only through it, so a feature of the search (a counter, a budget, a heuristic
/// hook) is written once, here.
class EdgeWorkers;

class PrimitiveGraph {
 public:
  using Key = SearchSpace::Key;
  using Clock = std::chrono::steady_clock;

  /// Checks the arguments (`who` heads the messages) and specialises the heuristic to the
  /// controls (SearchHeuristic::forControls).
  PrimitiveGraph(const std::string& who, std::shared_ptr<const World> world,
                 std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                 SearchPolicies policies);
  ~PrimitiveGraph();
  PrimitiveGraph(PrimitiveGraph&&) noexcept;
  PrimitiveGraph& operator=(PrimitiveGraph&&) noexcept;

  const World& world() const { return *world_; }
  const std::shared_ptr<const World>& sharedWorld() const { return world_; }
  const std::vector<Eigen::Vector3d>& controls() const { return controls_; }
  const SearchSettings& settings() const { return settings_; }
  /// The policies as given (the heuristic before its control set's).
  const SearchPolicies& givenPolicies() const { return given_policies_; }
  const SearchPolicies& policies() const { return policies_; }
  const EdgeEvaluator& evaluator() const { return evaluator_; }

  /// Starts a query: the counters from zero, the query's heuristic (forQuery, within `stop`)
  /// and its estimate at the start (SearchCounters::start_heuristic).
  void beginQuery(const ChainState& start, const Eigen::Vector3d& goal, StopCondition& stop);
  const ChainState& start() const { return start_; }
  const Eigen::Vector3d& goal() const { return goal_; }

  /// The search space's key of `state` (relative to the query's start).
  Key key(const ChainState& state) const {
    return policies_.space->key(state, start_, settings_.edges.order);
  }
  /// The query heuristic's estimate at `state` (unweighted; +infinity: the goal is out of
  /// its reach).
  double h(const ChainState& state) const { return heuristic_->estimate(state, goal_); }
  /// cost_weight g + heuristic_weight h.
  double priority(double g, double h) const {
    return settings_.cost_weight * g + settings_.heuristic_weight * h;
  }
  bool inGoal(const ChainState& state) const {
    return (state.col(0) - goal_).norm() <= settings_.goal_radius;
  }
  ChainState endState(const ChainState& parent, int control) const {
    return evaluator_.endState(parent, controls_[control]);
  }

  /// The map's clearance at `position`, counted as an ESDF query.
  double clearance(const Eigen::Vector3d& position) {
    ++counters_.esdf_queries;
    return world_->clearance(position);
  }
  /// The edge policy's estimate of every control from `parent` (whose clearance is
  /// `parent_clearance`) into `evaluations` and `estimates` (one per control), counted and
  /// timed as evaluation; full evaluations on SearchSettings::threads threads.
  void estimateAll(const ChainState& parent, double parent_clearance,
                   std::vector<EdgeEvaluation>& evaluations, std::vector<EdgeEstimate>& estimates);
  /// The edge policy's estimate of one control, counted and timed.
  EdgeEstimate estimate(const ChainState& parent, double parent_clearance, int control,
                        EdgeEvaluation& evaluation);
  /// The full evaluation of `control` from `parent`, counted and timed.
  EdgeEvaluation evaluate(const ChainState& parent, int control, double parent_clearance);
  /// One edge of evaluateMany(): its parent state (alive for the call), control and the
  /// parent's clearance.
  struct EdgeJob {
    const ChainState* parent;
    int control;
    double parent_clearance;
  };
  /// The full evaluations of `jobs` into `results`, on SearchSettings::threads threads, timed
  /// as evaluation and not counted: each is counted with countFull() when the search uses it.
  void evaluateMany(const std::vector<EdgeJob>& jobs, std::vector<EdgeEvaluation>& results);
  /// Counts one full evaluation the search uses.
  void countFull(const EdgeEvaluation& evaluation);
  /// Whether evaluateMany() runs on more than one thread.
  bool parallel() const { return workers_ != nullptr; }
  /// The same, the parent's clearance looked up (and counted) first.
  EdgeEvaluation evaluate(const ChainState& parent, int control);

  /// True when the search must stop: its budget is spent at `iterations`, or it holds more
  /// than memory_limit_mb (`bytes`; then SearchCounters::memory_limited is set).
  bool stopHere(StopCondition& stop, long long iterations, double bytes);

  SearchCounters& counters() { return counters_; }
  const SearchCounters& counters() const { return counters_; }
  /// Ends the query's clock: search_seconds from beginQuery().
  void endQuery() { counters_.search_seconds = secondsSince(query_begin_); }
  /// The counters every search reports: expansions, partial_evaluations, full_evaluations,
  /// certified_edges, rejected_edges, esdf_queries, time_evaluation_ms, time_search_ms (the
  /// rest of search_seconds: Dellin's breakdown) and start_heuristic.
  Statistics statistics() const;

  static double secondsSince(Clock::time_point begin) {
    return std::chrono::duration<double>(Clock::now() - begin).count();
  }

 private:
  /// Counts one policy estimate.
  void count(EdgeEstimate estimate, const EdgeEvaluation& evaluation);

  std::shared_ptr<const World> world_;
  std::vector<Eigen::Vector3d> controls_;
  SearchSettings settings_;
  SearchPolicies given_policies_;
  SearchPolicies policies_;
  EdgeEvaluator evaluator_;
  std::unique_ptr<EdgeWorkers> workers_;  ///< with threads > 1
  bool parallel_estimates_ = false;       ///< estimateAll() on the team (full evaluations)

  ChainState start_ = ChainState::Zero();
  Eigen::Vector3d goal_ = Eigen::Vector3d::Zero();
  std::shared_ptr<const SearchHeuristic> heuristic_;  ///< the query's (forQuery)
  Clock::time_point query_begin_;
  SearchCounters counters_;
};

}  // namespace kinolab
