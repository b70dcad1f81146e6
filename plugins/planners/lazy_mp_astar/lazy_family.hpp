#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <queue>
#include <unordered_map>
#include <vector>

#include "kinolab/search/motion_primitive_search.hpp"
#include "kinolab/search/primitive_graph.hpp"

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

/// One edge of a lazy path, by value (it outlives the search that found it).
struct LazyPathStep {
  ChainState parent;
  int control = -1;
  double cost = 0.0;
};

/// Hash of a search-space key.
struct LatticeKeyHash {
  std::size_t operator()(const SearchSpace::Key& key) const;
};

/// What the lazy-search family's searches above lookahead 1 share: the primitive graph they
/// run on (PrimitiveGraph: successors, keys, heuristic, counters, memory budget), the
/// selector and the path a search returns.
class LazyFamilySearch {
 public:
  virtual ~LazyFamilySearch() = default;
  LazyFamilySearch(const LazyFamilySearch&) = delete;
  LazyFamilySearch& operator=(const LazyFamilySearch&) = delete;

  /// One search from `start` to the goal region around `goal`.
  virtual MotionPrimitiveSearch::Outcome search(const ChainState& start,
                                                const Eigen::Vector3d& goal,
                                                StopCondition& stop) = 0;
  /// After search(): the path (every edge fully evaluated, kGoal) or else, as eager MP-A*
  /// answers, the path to the state nearest the goal that the search reached through fully
  /// evaluated, valid edges (empty when that is the start).
  Trajectory trajectory() const;
  double cost() const;
  /// The last search stopped at memory_limit_mb.
  bool memoryLimited() const { return graph_.counters().memory_limited; }
  const PrimitiveGraph& graph() const { return graph_; }
  /// The graph's counters (PrimitiveGraph::statistics(): expansions, the evaluations by kind,
  /// Dellin's time breakdown, start_heuristic), then the member's own.
  Statistics statistics() const;

 protected:
  /// Checks the arguments (`name` heads the messages).
  LazyFamilySearch(const char* name, std::shared_ptr<const World> world,
                   std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                   SearchPolicies policies, EdgeSelector selector);
  /// Starts a query (the graph's: counters, the query's heuristic) and forgets the last
  /// one's path and flags.
  void reset(const ChainState& start, const Eigen::Vector3d& goal, StopCondition& stop);
  /// The member's own counters, after expansions.
  virtual Statistics ownStatistics() const = 0;
  /// The order in which the selector evaluates the unevaluated edges `band` (in path order)
  /// of a lazy path; `clearance(edge)` is failfast's key.
  std::vector<int> selectorOrder(std::vector<int> band,
                                 const std::function<double(int)>& clearance);

  PrimitiveGraph graph_;
  EdgeSelector selector_;

  std::vector<LazyPathStep> path_;  ///< the final path, or the one to the nearest state reached
  bool solved_ = false;

 private:
  bool reverse_next_ = false;  ///< alternate's turn
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
class LazySpSearch final : public LazyFamilySearch {
 public:
  LazySpSearch(std::shared_ptr<const World> world, std::vector<Eigen::Vector3d> controls,
               SearchSettings settings, SearchPolicies policies, EdgeSelector selector);

  MotionPrimitiveSearch::Outcome search(const ChainState& start, const Eigen::Vector3d& goal,
                                        StopCondition& stop) override;

 protected:
  /// lazy_searches (expansions count those of every lazy search).
  Statistics ownStatistics() const override;

 private:
  /// One lattice edge: the policy's estimate at first use (a lower bound, or exact when the
  /// policy certified it) and the full evaluation once asked for.
  struct Edge {
    ChainState parent;  ///< the continuous state the records below are of
    EdgeEvaluation bound;
    EdgeEvaluation full;
    bool evaluated = false;

    /// What the search knows of the edge: the full evaluation, else the bound.
    const EdgeEvaluation& known() const { return evaluated ? full : bound; }
  };
  struct Node {
    ChainState state;
    double g = 0.0;
    int parent = -1;
    int control = -1;
    Edge* edge = nullptr;
  };
  using Key = SearchSpace::Key;

  /// One lazy search from the start; returns the goal node or -1 (none, or the budget).
  int lazySearch(StopCondition& stop, bool& stopped);
  using Slot = std::vector<std::unique_ptr<Edge>>;  ///< a parent key's records, by control
  /// The record of the edge `control` from `parent` in its key's `slot`, its lower bound
  /// computed on first use (and the parent's `clearance` then, when it is still NaN).
  Edge& edgeOf(Slot& slot, const ChainState& parent, double& clearance, int control);
  /// Bytes the search holds (nodes and edge records), against memory_limit_mb.
  double memoryBytes() const;
  /// Fully evaluates the edge the selector picks on the path to `goal_node` (`whole`: every
  /// unevaluated edge in the selector's order, up to the first invalid one); false when the
  /// path was already fully evaluated (then it is path_).
  bool evaluateOnPath(int goal_node, bool whole);
  /// The last lazy search's node nearest `goal` (through evaluated, valid edges only, when
  /// `evaluated`); the start when none is nearer.
  int nearestNode(const Eigen::Vector3d& goal, bool evaluated) const;

  std::vector<Node> nodes_;
  /// Edge records by parent key, then control.
  std::unordered_map<Key, Slot, LatticeKeyHash> edges_;
  std::size_t edge_records_ = 0;
  long long lazy_searches_ = 0;
};

/// LRA* on the motion-primitive lattice (Mandalika, Salzman and Srinivasa, "Lazy Receding
/// Horizon A* for Efficient Path Planning in Graphs with Expensive-to-Evaluate Edges", ICAPS
/// 2018), with GLS's edge selectors on the path it evaluates (Mandalika, Choudhury, Salzman and
/// Srinivasa, "Generalized Lazy Search for Robot Motion Planning", ICAPS 2019). One search tree
/// over lattice keys: its evaluated part (every edge from the start fully evaluated) carries a
/// lazy band of at most `lookahead` unevaluated edges, extended best-first at the lower bounds
/// while a band vertex is cheaper than the best frontier vertex (`lookahead` unevaluated edges
/// deep, or at the goal). The best frontier vertex's unevaluated edges are then evaluated in the
/// selector's order until one is invalid or costs more than its bound; that edge's subtree
/// leaves the tree and returns below its best remaining parents (LRA*'s rewiring). The
/// search ends when the best frontier vertex
/// is a fully evaluated goal: with a consistent heuristic, lower bounds and weight 1, eager's
/// cost. Lookahead 1 evaluates edges as LWA* does; a larger lookahead evaluates fewer edges
/// (only those on paths that stay best `lookahead` edges ahead) for more search.
class LraStarSearch final : public LazyFamilySearch {
 public:
  LraStarSearch(std::shared_ptr<const World> world, std::vector<Eigen::Vector3d> controls,
                SearchSettings settings, SearchPolicies policies, int lookahead,
                EdgeSelector selector);

  MotionPrimitiveSearch::Outcome search(const ChainState& start, const Eigen::Vector3d& goal,
                                        StopCondition& stop) override;

 protected:
  /// rewired_vertices (expansions count the extensions again after a rewire too).
  Statistics ownStatistics() const override;

 private:
  enum class Queue : std::uint8_t { kNone, kExtend, kFrontier };
  /// One lattice edge from a vertex, as the search knows it: the bound until evaluated.
  struct Arc {
    int child = -1;           ///< the vertex at its end (-1 when the bound already refused it)
    float end_clearance = 0;  ///< the bound's clearance at the end (failfast's order)
    bool evaluated = false;
    bool valid = false;
    double bound_cost = INFINITY;
    double cost = INFINITY;  ///< the full cost when evaluated, else the bound's
  };
  struct Vertex {
    ChainState state;
    double g = INFINITY;
    double h = 0.0;
    int parent = -1;
    int control = -1;
    int budget = 0;      ///< unevaluated edges on the tree path from the start
    int first_arc = -1;  ///< its arcs (one per control) in arcs_, once extended
    bool in_tree = false;
    bool goal = false;
    Queue queue = Queue::kNone;
    std::uint32_t stamp = 0;                        ///< the valid queue entry's
    std::vector<int> children;                      ///< in the tree
    std::vector<std::pair<int, int>> predecessors;  ///< (vertex, control) that reached it
  };
  struct Entry {
    double f;
    double g;
    int vertex;
    std::uint32_t stamp;
    bool operator>(const Entry& other) const;
  };
  using Heap = std::priority_queue<Entry, std::vector<Entry>, std::greater<>>;
  using Key = SearchSpace::Key;

  /// The arc `control` from `vertex` (every arc of the vertex estimated at first use).
  Arc& arcOf(int vertex, int control);
  /// The arc from `vertex`'s parent to it.
  Arc& treeArc(int vertex) { return arcOf(vertices_[vertex].parent, vertices_[vertex].control); }
  int vertexOf(const ChainState& state);
  void enqueue(int vertex);
  /// The valid entry on top of `heap` (stale ones dropped), or nullptr.
  const Entry* top(Heap& heap, Queue queue);
  void extend(int vertex);
  /// Takes `vertex`'s descendants (and `vertex` itself when `inclusive`) out of the tree.
  void discardBelow(int vertex, bool inclusive, std::vector<int>* removed);
  void detach(int vertex);
  /// `vertex`'s edge was found invalid or dearer than its bound: its subtree leaves the tree,
  /// and each of them returns below its best remaining parent (the tree vertices that reached
  /// it, then each other in cost order, as LRA*'s rewiring) and is extended again.
  void rewire(int vertex);
  /// Recomputes the budgets below `vertex`; frontier vertices whose band shrank are extended.
  void updateBudgets(int vertex);
  /// Evaluates the unevaluated edges on the path to `vertex` in the selector's order, until one
  /// is invalid or dearer than its bound.
  void evaluateBand(int vertex);
  std::vector<int> pathTo(int vertex) const;
  /// Every arc of the tree path to `vertex` is evaluated (so valid).
  bool evaluatedPath(int vertex);
  /// The tree vertex nearest `goal` (with an evaluated path, when `evaluated`); the root when
  /// none is nearer.
  int nearestVertex(const Eigen::Vector3d& goal, bool evaluated);
  double memoryBytes() const;

  int lookahead_;
  std::vector<Vertex> vertices_;
  std::vector<Arc> arcs_;
  std::vector<EdgeEvaluation> evaluations_;  // scratch: a vertex's arcs, one per control
  std::vector<EdgeEstimate> estimates_;
  std::unordered_map<Key, int, LatticeKeyHash> index_;
  Heap extend_;
  Heap frontier_;
  long long rewired_ = 0;
  long long predecessor_entries_ = 0;  ///< over every vertex, for memoryBytes()
};

}  // namespace kinolab
