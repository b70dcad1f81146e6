#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "kinolab/core/stop_condition.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/search/primitive_graph.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab {

/// The motion-primitive A* core shared by the lazy and eager planners and by any new
/// search-based plugin, on a PrimitiveGraph (successors, keys, heuristic, counters, memory
/// budget). The open list holds edges: an evaluated edge is a candidate (state,
/// parent, control, cost) in one array addressed by index; an edge queued with a lower bound
/// (lazy) is only its heap entry (parent, control, lower-bound cost: 24 bytes), and its end
/// state, key and table probe are computed when it is popped. A state is closed only when an
/// evaluated candidate for it is popped; a popped lower-bound edge is dropped if its state is
/// closed, else fully evaluated and re-queued with its true cost (or dropped when invalid);
/// the goal test happens on an evaluated pop inside the goal region. The open list is a
/// binary heap with lazy deletion (stale entries are skipped when popped).
///
/// With a consistent heuristic and weight 1, lazy (a lower-bound edge policy) with the `lwa`
/// rule and eager (full evaluation) return the same cost. States are keyed by the search space
/// (SearchPolicies::space): the lattice's keys are exact on the lattice a control grid spans;
/// with sampled controls optimality is with respect to that discretisation, and with hybrid
/// A*'s cells there is none.
class MotionPrimitiveSearch {
 public:
  enum class Outcome { kGoal, kExhausted, kBudget };

  MotionPrimitiveSearch(std::shared_ptr<const World> world, std::vector<Eigen::Vector3d> controls,
                        SearchSettings settings, SearchPolicies policies);
  ~MotionPrimitiveSearch();
  MotionPrimitiveSearch(const MotionPrimitiveSearch&) = delete;
  MotionPrimitiveSearch& operator=(const MotionPrimitiveSearch&) = delete;

  const SearchSettings& settings() const { return graph_.settings(); }
  /// The policies it runs with (the heuristic as given, before its control set's).
  const SearchPolicies& policies() const { return graph_.givenPolicies(); }
  const EdgeEvaluator& evaluator() const { return graph_.evaluator(); }
  const std::vector<Eigen::Vector3d>& controls() const { return graph_.controls(); }

  /// Searches from `start` (assumed valid) towards `goal`.
  Outcome search(const ChainState& start, const Eigen::Vector3d& goal, StopCondition& stop);

  /// After search(): the path to the goal (kGoal: ending with the accepted shot, if any) or
  /// to the closed state nearest the goal.
  Trajectory trajectory() const;
  /// Cost of that path (sum of its edges' full costs, and the shot's).
  double cost() const;
  const SearchCounters& counters() const { return graph_.counters(); }
  /// The counters by name, for results: the graph's (PrimitiveGraph::statistics()), then
  /// pops, open_peak, candidates, closed_states (and shots, shots_rejected with a shot
  /// policy).
  Statistics statistics() const;
  /// The edges of the last search for figures: every evaluated, certified or rejected edge,
  /// then the lower-bound edges still queued (lower-bound edges popped after their state was
  /// closed are not kept). At most `max_edges` edges: beyond that every k-th, evenly, so a
  /// large search gives a figure of bounded size.
  SearchTree tree(std::size_t max_edges, int points_per_edge = 6) const;

  /// Frees the memory of the last search (search() reuses it otherwise).
  void clear();
  /// Bytes the search's containers hold now.
  double memoryBytes() const;

 private:
  using Key = SearchSpace::Key;
  struct Slot {
    Key key;
    std::uint64_t hash = 0;    ///< hashOf(key)
    double best_f = INFINITY;  ///< lowest priority of an evaluated candidate queued (lwa, eager)
    int closed = -1;           ///< the candidate that closed the state
    bool seen = false;         ///< an edge was queued (seed rule)
  };
  enum class Evaluation : std::uint8_t { kFull, kCertified, kRejected };
  struct Candidate {
    ChainState state;
    double g = 0.0;
    double clearance = INFINITY;  ///< Esdf::clearance at the state, set when expanded
    int parent = -1;
    int control = -1;
    int slot = -1;
    Evaluation evaluation = Evaluation::kFull;
  };
  /// What a heap entry holds: an evaluated candidate, or a parent and control whose edge was
  /// queued with a lower bound (or certified exact) and not yet materialised.
  enum EntryKind : std::uint32_t { kCandidate, kLowerBound, kCertified };
  struct HeapEntry {
    double f;
    double g;
    std::int32_t node;           ///< the candidate (kCandidate) or the edge's parent
    std::uint32_t control : 30;  ///< the edge's control (lower-bound and certified entries)
    std::uint32_t kind : 2;      ///< an EntryKind
    /// Heap order: smallest f first; among equal f the deeper (larger g), then evaluated
    /// candidates before queued edges, then by node and control.
    struct Later {
      bool operator()(const HeapEntry& a, const HeapEntry& b) const {
        if (a.f != b.f) return a.f > b.f;
        if (a.g != b.g) return a.g < b.g;
        if (a.kind != b.kind) return a.kind > b.kind;
        if (a.node != b.node) return a.node > b.node;
        return a.control > b.control;
      }
    };
  };

  std::uint64_t hashOf(const Key& key) const;
  int slotOf(const ChainState& state);
  /// The table position holding `key`'s slot, or the empty one where it would go.
  std::size_t probe(const Key& key, std::uint64_t hash) const;
  /// The state's slot, or -1 when it has none (nothing is added).
  int findSlot(const ChainState& state) const;
  /// Whether a queued edge's end state is closed already (its pop will find it stale).
  bool closedEnd(const HeapEntry& entry) const;
  /// Empties the containers of the last search, keeping their memory.
  void prepare();
  void push(const HeapEntry& entry);
  /// Appends an evaluated candidate and queues it unless the lwa rule drops it (a queued
  /// candidate of its state is at least as good) or `h` is infinite (the goal is out of its
  /// reach). Returns false when dropped.
  bool queueCandidate(const Candidate& candidate, double h);
  void expand(int node);
  /// Tries the shot policy from the closed candidate `node`; true when a shot was accepted.
  bool tryShot(int node);
  /// A popped lower-bound or certified edge: materialises it unless its state is closed
  /// (full evaluation for a lower bound) and queues the candidate.
  void evaluatePopped(const HeapEntry& entry);
  /// The full evaluation of a popped lower-bound edge: at one thread made now; on more, the one
  /// made ahead, or made now together with the open list's next lower-bound edges on the other
  /// threads (each is a pure function of its edge, so the search is the same whichever thread
  /// made it, and when).
  EdgeEvaluation fullEvaluation(const HeapEntry& entry);
  /// Adds to jobs_ up to `count` of the best lower-bound edges in the open list not yet
  /// evaluated ahead (the k best entries of a heap lie in its first k levels).
  void addNextEdges(std::size_t count, std::uint64_t popped);
  /// Forgets a popped edge's evaluation made ahead, if any, as wasted (its state was closed).
  void dropAhead(const HeapEntry& entry);
  static std::uint64_t aheadKey(const HeapEntry& entry) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(entry.node)) << 32) |
           entry.control;
  }

  PrimitiveGraph graph_;

  // The last search.
  std::vector<Candidate> candidates_;
  std::vector<Slot> slots_;
  /// Open addressing over slots_ (linear probing, power-of-two size, at most half full):
  /// -1 or a slot index. std::unordered_map allocates a node per state, which measured as a
  /// fifth of a lazy search's time.
  std::vector<int> table_;
  std::vector<HeapEntry> heap_;
  std::vector<EdgeEvaluation> evaluations_;  // scratch: one per control
  std::vector<EdgeEstimate> estimates_;      // scratch: one per control
  /// Full evaluations of lower-bound edges made ahead of their pops (threads > 1), by
  /// aheadKey(); with the scratch of one batch.
  std::unordered_map<std::uint64_t, EdgeEvaluation> ahead_;
  long long ahead_used_ = 0;  ///< of the last search's evaluations made ahead, those used
  std::vector<PrimitiveGraph::EdgeJob> jobs_;
  std::vector<std::uint64_t> job_keys_;
  std::vector<EdgeEvaluation> job_results_;
  int goal_candidate_ = -1;
  int nearest_candidate_ = -1;                       ///< closed, nearest the goal
  std::unique_ptr<TrajectoryChecker> shot_checker_;  ///< with a shot policy
  Trajectory shot_;                                  ///< the accepted shot
  double shot_cost_ = 0.0;
};

}  // namespace kinolab
