#include "kinolab/search/motion_primitive_search.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

#include "kinolab/core/error.hpp"

namespace kinolab {

std::uint64_t MotionPrimitiveSearch::hashOf(const Key& key) const {
  // SplitMix64-style mixing of the packed components the order uses (3 per derivative).
  std::uint64_t hash = 0x9E3779B97F4A7C15ull;
  const std::size_t used = 3 * static_cast<std::size_t>(graph_.settings().edges.order);
  for (std::size_t i = 0; i < used; i += 2) {
    std::uint64_t word = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(key[i])) << 32) |
                         static_cast<std::uint32_t>(key[i + 1]);
    word ^= hash;
    word = (word ^ (word >> 30)) * 0xBF58476D1CE4E5B9ull;
    word = (word ^ (word >> 27)) * 0x94D049BB133111EBull;
    hash = word ^ (word >> 31);
  }
  return hash;
}

MotionPrimitiveSearch::MotionPrimitiveSearch(std::shared_ptr<const World> world,
                                             std::vector<Eigen::Vector3d> controls,
                                             SearchSettings settings, SearchPolicies policies)
    : graph_("motion-primitive search", std::move(world), std::move(controls), std::move(settings),
             std::move(policies)) {
  evaluations_.resize(graph_.controls().size());
  estimates_.resize(graph_.controls().size());
  if (graph_.policies().shot) {
    // A shot is held to what the search's edges are: its limits, body and tolerance.
    const EdgeEvaluatorSettings& edges = graph_.settings().edges;
    CheckerSettings check;
    check.body = edges.body;
    check.limits = edges.limits;
    check.max_derivative = edges.order;
    shot_checker_ = std::make_unique<TrajectoryChecker>(graph_.sharedWorld(), check);
  }
}

MotionPrimitiveSearch::~MotionPrimitiveSearch() = default;

bool MotionPrimitiveSearch::tryShot(int node) {
  const ChainState& state = candidates_[node].state;
  const GoalShot& policy = *graph_.policies().shot;
  Trajectory shot = policy.shoot(state, graph_.goal());
  if (shot.empty()) return false;
  SearchCounters& counters = graph_.counters();
  ++counters.shots;
  CheckQuery query;
  query.start = state;
  query.goal = graph_.goal();
  query.goal_radius = graph_.settings().goal_radius;
  if (!shot_checker_->check(shot, query).valid) {
    ++counters.shots_rejected;
    return false;
  }
  shot_cost_ = policy.cost(shot);
  shot_ = std::move(shot);
  return true;
}

int MotionPrimitiveSearch::slotOf(const ChainState& state) {
  if (2 * (slots_.size() + 1) > table_.size()) {
    // Grow and re-insert every slot.
    table_.assign(std::max<std::size_t>(1024, 2 * table_.size()), -1);
    const std::size_t mask = table_.size() - 1;
    for (std::size_t i = 0; i < slots_.size(); ++i) {
      std::size_t position = slots_[i].hash & mask;
      while (table_[position] >= 0) position = (position + 1) & mask;
      table_[position] = static_cast<int>(i);
    }
  }
  const Key key = graph_.key(state);
  const std::uint64_t hash = hashOf(key);
  const std::size_t position = probe(key, hash);
  if (table_[position] < 0) {
    table_[position] = static_cast<int>(slots_.size());
    slots_.push_back(Slot{key, hash});
  }
  return table_[position];
}

int MotionPrimitiveSearch::findSlot(const ChainState& state) const {
  if (table_.empty()) return -1;
  const Key key = graph_.key(state);
  return table_[probe(key, hashOf(key))];
}

std::size_t MotionPrimitiveSearch::probe(const Key& key, std::uint64_t hash) const {
  const std::size_t mask = table_.size() - 1;
  for (std::size_t position = hash & mask;; position = (position + 1) & mask) {
    const int index = table_[position];
    // The hash first: keys are compared only when it matches.
    if (index < 0 || (slots_[index].hash == hash && slots_[index].key == key)) return position;
  }
}

void MotionPrimitiveSearch::push(const HeapEntry& entry) {
  heap_.push_back(entry);
  std::push_heap(heap_.begin(), heap_.end(), HeapEntry::Later{});
  SearchCounters& counters = graph_.counters();
  counters.open_peak =
      std::max<long long>(counters.open_peak, static_cast<long long>(heap_.size()));
}

bool MotionPrimitiveSearch::queueCandidate(const Candidate& candidate, double h) {
  if (h == INFINITY) return false;  // the goal is out of reach from this state
  const double f = graph_.priority(candidate.g, h);
  Slot& slot = slots_[candidate.slot];
  if (graph_.settings().duplicate_rule == DuplicateRule::kLwa) {
    // A candidate queued behind an evaluated one of the same state would be dropped when
    // popped, as that one closes the state first: it is not queued at all. Equal priorities
    // are kept: the tie-break decides.
    if (f > slot.best_f) return false;
    slot.best_f = f;
  }
  candidates_.push_back(candidate);
  push({f, candidate.g, static_cast<std::int32_t>(candidates_.size() - 1), 0, kCandidate});
  return true;
}

double MotionPrimitiveSearch::memoryBytes() const {
  return static_cast<double>(candidates_.capacity() * sizeof(Candidate) +
                             slots_.capacity() * sizeof(Slot) + table_.capacity() * sizeof(int) +
                             heap_.capacity() * sizeof(HeapEntry));
}

void MotionPrimitiveSearch::clear() {
  candidates_ = {};
  slots_ = {};
  table_ = {};
  heap_ = {};
  prepare();
}

void MotionPrimitiveSearch::prepare() {
  candidates_.clear();
  slots_.clear();
  std::fill(table_.begin(), table_.end(), -1);
  heap_.clear();
  ahead_.clear();
  ahead_used_ = 0;
  goal_candidate_ = -1;
  nearest_candidate_ = -1;
  shot_ = Trajectory();
  shot_cost_ = 0.0;
}

void MotionPrimitiveSearch::evaluatePopped(const HeapEntry& entry) {
  const ChainState& parent_state = candidates_[entry.node].state;
  const double parent_g = candidates_[entry.node].g;
  Candidate candidate;
  candidate.state = graph_.endState(parent_state, static_cast<int>(entry.control));
  candidate.slot = slotOf(candidate.state);
  if (slots_[candidate.slot].closed >= 0) {  // stale: closed by a cheaper candidate
    dropAhead(entry);
    return;
  }
  candidate.parent = entry.node;
  candidate.control = entry.control;
  if (entry.kind == kCertified) {
    candidate.g = entry.g;
    candidate.evaluation = Evaluation::kCertified;
  } else {
    const EdgeEvaluation full = fullEvaluation(entry);
    if (!full.valid()) {
      // Kept (never queued) so that figures show where lazy search found a collision.
      candidate.evaluation = Evaluation::kRejected;
      candidates_.push_back(candidate);
      return;
    }
    candidate.g = parent_g + full.cost;
    candidate.evaluation = Evaluation::kFull;
  }
  queueCandidate(candidate, graph_.h(candidate.state));
}

EdgeEvaluation MotionPrimitiveSearch::fullEvaluation(const HeapEntry& entry) {
  const Candidate& parent = candidates_[entry.node];
  if (!graph_.parallel()) {
    return graph_.evaluate(parent.state, static_cast<int>(entry.control), parent.clearance);
  }
  const std::uint64_t key = aheadKey(entry);
  if (const auto found = ahead_.find(key); found != ahead_.end()) {
    EdgeEvaluation full = std::move(found->second);
    ahead_.erase(found);
    ++ahead_used_;
    graph_.countFull(full);
    return full;
  }
  jobs_.assign(1, {&parent.state, static_cast<int>(entry.control), parent.clearance});
  job_keys_.assign(1, key);
  // A few edges a thread: a hand-over costs more than one edge of a point robot. Made ahead
  // only while at least half of what was made ahead has been used, after a first batch: with a
  // tight heuristic the search pops little besides its path, and the rest would be wasted.
  constexpr long long kEdgesPerThread = 4;
  const long long batch = kEdgesPerThread * graph_.settings().threads;
  if (graph_.counters().ahead_evaluations <= 2 * ahead_used_ + batch) {
    addNextEdges(static_cast<std::size_t>(batch - 1), key);
  }
  graph_.evaluateMany(jobs_, job_results_);
  graph_.counters().ahead_evaluations += static_cast<long long>(jobs_.size()) - 1;
  for (std::size_t i = 1; i < jobs_.size(); ++i) {
    ahead_.emplace(job_keys_[i], std::move(job_results_[i]));
  }
  graph_.countFull(job_results_[0]);
  return std::move(job_results_[0]);
}

void MotionPrimitiveSearch::addNextEdges(std::size_t count, std::uint64_t popped) {
  // Heap positions best first: a position's entry is no better than its parent's.
  const auto later = [this](std::size_t a, std::size_t b) {
    return HeapEntry::Later{}(heap_[a], heap_[b]);
  };
  std::priority_queue<std::size_t, std::vector<std::size_t>, decltype(later)> next(later);
  if (!heap_.empty()) next.push(0);
  const std::size_t examined_at_most = 4 * count + 8;
  for (std::size_t examined = 0; !next.empty() && count > 0 && examined < examined_at_most;
       ++examined) {
    const std::size_t position = next.top();
    next.pop();
    const HeapEntry& entry = heap_[position];
    const std::uint64_t key = aheadKey(entry);
    if (entry.kind == kLowerBound && key != popped && !ahead_.count(key) && !closedEnd(entry)) {
      const Candidate& parent = candidates_[entry.node];
      jobs_.push_back({&parent.state, static_cast<int>(entry.control), parent.clearance});
      job_keys_.push_back(key);
      --count;
    }
    for (const std::size_t child : {2 * position + 1, 2 * position + 2}) {
      if (child < heap_.size()) next.push(child);
    }
  }
}

bool MotionPrimitiveSearch::closedEnd(const HeapEntry& entry) const {
  const int slot =
      findSlot(graph_.endState(candidates_[entry.node].state, static_cast<int>(entry.control)));
  return slot >= 0 && slots_[slot].closed >= 0;
}

void MotionPrimitiveSearch::dropAhead(const HeapEntry& entry) {
  if (entry.kind == kLowerBound && ahead_.erase(aheadKey(entry)) > 0) {
    ++graph_.counters().wasted_evaluations;
  }
}

void MotionPrimitiveSearch::expand(int node) {
  SearchCounters& counters = graph_.counters();
  ++counters.expansions;
  // Copies: candidates_ may grow (and move) while the node is expanded.
  const ChainState parent_state = candidates_[node].state;
  const double parent_g = candidates_[node].g;
  const double parent_clearance = graph_.clearance(parent_state.col(0));
  candidates_[node].clearance = parent_clearance;  // for its lazy edges, when popped
  const bool seed_rule = graph_.settings().duplicate_rule == DuplicateRule::kSeed;
  // Evaluate every primitive first (timed as evaluation), then queue them.
  graph_.estimateAll(parent_state, parent_clearance, evaluations_, estimates_);
  for (std::size_t i = 0; i < evaluations_.size(); ++i) {
    const EdgeEvaluation& evaluation = evaluations_[i];
    const EdgeEstimate estimate = estimates_[i];
    if (!evaluation.valid()) continue;
    const double g = parent_g + evaluation.cost;
    if (estimate == EdgeEstimate::kFull || seed_rule) {
      // The state's slot now: eager search drops what a closed or better state makes useless;
      // the seed rule queues only the first edge into a state.
      const int slot_index = slotOf(evaluation.end);
      Slot& slot = slots_[slot_index];
      if (slot.closed >= 0) continue;
      if (seed_rule) {
        if (slot.seen) continue;
        slot.seen = true;
      }
      if (estimate == EdgeEstimate::kFull) {
        Candidate candidate;
        candidate.state = evaluation.end;
        candidate.g = g;
        candidate.parent = node;
        candidate.control = static_cast<int>(i);
        candidate.slot = slot_index;
        counters.candidates += queueCandidate(candidate, graph_.h(evaluation.end));
        continue;
      }
    }
    // A lower bound (or a certified cost): queue the parent and control; the end state's key
    // and table probe wait until the edge is popped.
    const double h = graph_.h(evaluation.end);
    if (h == INFINITY) continue;  // the goal is out of reach from its end
    ++counters.candidates;
    push({graph_.priority(g, h), g, node, static_cast<std::uint32_t>(i),
          estimate == EdgeEstimate::kCertified ? kCertified : kLowerBound});
  }
}

MotionPrimitiveSearch::Outcome MotionPrimitiveSearch::search(const ChainState& start,
                                                             const Eigen::Vector3d& goal,
                                                             StopCondition& stop) {
  graph_.beginQuery(start, goal, stop);
  prepare();
  SearchCounters& counters = graph_.counters();
  Candidate root;
  root.state = start;
  root.slot = slotOf(start);
  candidates_.push_back(root);
  const double root_f = graph_.priority(0.0, counters.start_heuristic);
  slots_[root.slot].best_f = root_f;
  slots_[root.slot].seen = true;
  push({root_f, 0.0, 0, 0, kCandidate});

  double nearest = INFINITY;
  Outcome outcome = Outcome::kExhausted;
  while (!heap_.empty()) {
    if (graph_.stopHere(stop, counters.expansions, memoryBytes())) {
      outcome = Outcome::kBudget;
      break;
    }
    std::pop_heap(heap_.begin(), heap_.end(), HeapEntry::Later{});
    const HeapEntry entry = heap_.back();
    heap_.pop_back();
    ++counters.pops;
    if (entry.kind != kCandidate) {
      evaluatePopped(entry);
      continue;
    }
    const int index = entry.node;
    Candidate& candidate = candidates_[index];
    // Stale: the state was closed by a cheaper candidate.
    if (slots_[candidate.slot].closed >= 0) continue;
    slots_[candidate.slot].closed = index;
    const double distance = (candidate.state.col(0) - graph_.goal()).norm();
    if (distance < nearest) {
      nearest = distance;
      nearest_candidate_ = index;
    }
    if (distance <= graph_.settings().goal_radius || (graph_.policies().shot && tryShot(index))) {
      goal_candidate_ = index;
      outcome = Outcome::kGoal;
      break;
    }
    expand(index);
  }
  counters.wasted_evaluations += static_cast<long long>(ahead_.size());
  ahead_.clear();
  graph_.endQuery();
  return outcome;
}

Trajectory MotionPrimitiveSearch::trajectory() const {
  const int last = goal_candidate_ >= 0 ? goal_candidate_ : nearest_candidate_;
  std::vector<int> path;
  for (int i = last; i > 0; i = candidates_[i].parent) path.push_back(i);
  Trajectory trajectory;
  for (auto it = path.rbegin(); it != path.rend(); ++it) {
    const Candidate& candidate = candidates_[*it];
    const EdgeEvaluatorSettings& edges = graph_.settings().edges;
    trajectory.append(TrajectorySegment::primitive(candidates_[candidate.parent].state,
                                                   graph_.controls()[candidate.control],
                                                   edges.order, edges.duration));
  }
  if (goal_candidate_ >= 0) {
    for (const TrajectorySegment& segment : shot_.segments()) trajectory.append(segment);
  }
  return trajectory;
}

double MotionPrimitiveSearch::cost() const {
  const int last = goal_candidate_ >= 0 ? goal_candidate_ : nearest_candidate_;
  if (last < 0) return INFINITY;
  return candidates_[last].g + (goal_candidate_ >= 0 ? shot_cost_ : 0.0);
}

Statistics MotionPrimitiveSearch::statistics() const {
  const auto value = [](long long count) { return static_cast<double>(count); };
  const SearchCounters& counters = graph_.counters();
  Statistics statistics = graph_.statistics();
  statistics.emplace_back("pops", value(counters.pops));
  statistics.emplace_back("open_peak", value(counters.open_peak));
  statistics.emplace_back("candidates", value(counters.candidates));
  statistics.emplace_back(
      "closed_states",
      value(static_cast<long long>(std::count_if(
          slots_.begin(), slots_.end(), [](const Slot& slot) { return slot.closed >= 0; }))));
  if (graph_.policies().shot) {
    statistics.emplace_back("shots", value(counters.shots));
    statistics.emplace_back("shots_rejected", value(counters.shots_rejected));
  }
  return statistics;
}

SearchTree MotionPrimitiveSearch::tree(std::size_t max_edges, int points_per_edge) const {
  const IntegratorChain& chain = graph_.evaluator().chain();
  const double tau = graph_.settings().edges.duration;
  const auto edgeOf = [&](int parent, int control, SearchTreeEdge::State state, bool closed) {
    SearchTreeEdge edge;
    edge.points.reserve(static_cast<std::size_t>(points_per_edge));
    for (int p = 0; p < points_per_edge; ++p) {
      const double t = tau * p / (points_per_edge - 1);
      edge.points.push_back(
          chain.stateAt(candidates_[parent].state, graph_.controls()[control], t).col(0));
    }
    edge.state = state;
    edge.closed = closed;
    return edge;
  };
  std::vector<std::size_t> queued;  // heap entries that are edges not yet materialised
  for (std::size_t i = 0; i < heap_.size(); ++i) {
    if (heap_[i].kind != kCandidate) queued.push_back(i);
  }
  const std::size_t evaluated = candidates_.empty() ? 0 : candidates_.size() - 1;
  const std::size_t total = evaluated + queued.size();
  const std::size_t stride = treeStride(total, max_edges);
  SearchTree tree;
  tree.reserve(std::min(total, max_edges));
  for (std::size_t k = 0; k < total; k += stride) {
    if (k < evaluated) {
      const Candidate& candidate = candidates_[k + 1];
      const SearchTreeEdge::State state =
          candidate.evaluation == Evaluation::kFull        ? SearchTreeEdge::State::kFull
          : candidate.evaluation == Evaluation::kCertified ? SearchTreeEdge::State::kCertified
                                                           : SearchTreeEdge::State::kRejected;
      tree.push_back(edgeOf(candidate.parent, candidate.control, state,
                            slots_[candidate.slot].closed == static_cast<int>(k + 1)));
    } else {
      const HeapEntry& entry = heap_[queued[k - evaluated]];
      tree.push_back(edgeOf(entry.node, entry.control,
                            entry.kind == kCertified ? SearchTreeEdge::State::kCertified
                                                     : SearchTreeEdge::State::kPartial,
                            false));
    }
  }
  return tree;
}

}  // namespace kinolab
