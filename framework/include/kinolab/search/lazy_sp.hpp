#pragma once

#include <memory>
#include <unordered_map>
#include <vector>

#include "kinolab/search/motion_primitive_search.hpp"

namespace kinolab {

/// Which edge of the lazy shortest path LazySP evaluates next (Dellin and Srinivasa, "A Unifying
/// Formalism for Shortest Path Problems with Expensive Edge Evaluations via Lazy Best-First
/// Search over Paths with Edge Selectors", ICAPS 2016).
enum class EdgeSelector {
  kForward,    ///< the first unevaluated edge from the start
  kReverse,    ///< the last one (nearest the goal)
  kAlternate,  ///< forward and reverse in turn
  kFailFast,   ///< the one most likely to collide: the least clearance at its end
};

/// LazySP on the motion-primitive lattice: repeatedly the shortest path to the goal region with
/// every edge not yet evaluated at its lower bound (the edge policy's) and every evaluated one
/// at its full cost (or removed when invalid), then full evaluation of the edge(s) the
/// selector picks on it, until a shortest path has every edge evaluated. With a consistent
/// heuristic, lower bounds and weight 1 its cost is eager MP-A*'s; it evaluates only edges on
/// candidate shortest paths. Each lazy search starts over (the evaluations are kept), so it
/// spends search time to save evaluations: it pays where an evaluation is dear. Lattice search
/// spaces only (a state is one continuous state per key); evaluations are reused only for the
/// same continuous parent.
class LazySpSearch {
 public:
  LazySpSearch(std::shared_ptr<const World> world, std::vector<Eigen::Vector3d> controls,
               SearchSettings settings, SearchPolicies policies, EdgeSelector selector);

  MotionPrimitiveSearch::Outcome search(const ChainState& start, const Eigen::Vector3d& goal,
                                        StopCondition& stop);
  /// After search(): the path (every edge fully evaluated, kGoal) or, on a budget stop, the
  /// evaluated, valid start of the last lazy path found (empty when exhausted).
  Trajectory trajectory() const;
  double cost() const;
  /// The last search stopped at memory_limit_mb.
  bool memoryLimited() const { return memory_limited_; }
  /// expansions (over every lazy search), lazy_searches, partial_evaluations (lower bounds),
  /// full_evaluations, rejected_edges, esdf_queries, time_evaluation_ms (lower bounds and full
  /// evaluations, as the core search counts them), time_search_ms (the rest).
  Statistics statistics() const;

 private:
  struct Edge {
    ChainState parent;  ///< the continuous state the records below are of
    EdgeEvaluation bound;
    EdgeEvaluation full;
    bool evaluated = false;
  };
  struct Node {
    ChainState state;
    double g = 0.0;
    int parent = -1;
    int control = -1;
    Edge* edge = nullptr;
  };
  /// One edge of a path, by value (it outlives the lazy search that found it).
  struct Step {
    ChainState parent;
    int control = -1;
    double cost = 0.0;
  };
  using Key = SearchSpace::Key;
  struct KeyHash {
    std::size_t operator()(const Key& key) const;
  };

  /// One lazy search from the start; returns the goal node or -1 (none, or the budget).
  int lazySearch(StopCondition& stop, bool& stopped);
  using Slot = std::vector<std::unique_ptr<Edge>>;  ///< a parent key's records, by control
  /// The record of the edge `control` from `parent` in its key's `slot`, its lower bound
  /// computed on first use (and the parent's `clearance` then, when it is still NaN).
  Edge& edgeOf(Slot& slot, const ChainState& parent, double& clearance, int control);
  /// Bytes the search holds (nodes and edge records), against memory_limit_mb.
  double memoryBytes() const;
  /// Fully evaluates the edges the selector picks on the path to `goal_node`; false when the
  /// path was already fully evaluated.
  bool evaluateOnPath(int goal_node);

  std::shared_ptr<const World> world_;
  std::vector<Eigen::Vector3d> controls_;
  SearchSettings settings_;
  SearchPolicies policies_;
  EdgeSelector selector_;
  EdgeEvaluator evaluator_;

  ChainState start_;
  Eigen::Vector3d goal_;
  std::vector<Node> nodes_;
  /// Edge records by parent key, then control.
  std::unordered_map<Key, Slot, KeyHash> edges_;
  std::vector<Step> path_;  ///< the final path, or the last one's evaluated valid start
  std::size_t edge_records_ = 0;
  bool solved_ = false;
  bool memory_limited_ = false;
  bool reverse_next_ = false;
  long long expansions_ = 0;
  long long lazy_searches_ = 0;
  long long partial_evaluations_ = 0;
  long long full_evaluations_ = 0;
  long long rejected_edges_ = 0;
  long long esdf_queries_ = 0;
  double evaluation_seconds_ = 0.0;
  double total_seconds_ = 0.0;
};

}  // namespace kinolab
