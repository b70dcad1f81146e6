#include "kinolab/search/lazy_family.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

#include "kinolab/core/error.hpp"

namespace kinolab {
namespace {

double secondsSince(std::chrono::steady_clock::time_point begin) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
}

}  // namespace

std::size_t LatticeKeyHash::operator()(const SearchSpace::Key& key) const {
  std::uint64_t hash = 1469598103934665603ull;
  for (const std::int32_t value : key) {
    hash ^= static_cast<std::uint32_t>(value);
    hash *= 1099511628211ull;
  }
  return static_cast<std::size_t>(hash ^ (hash >> 29));
}

LazyEdgeWork::LazyEdgeWork(std::shared_ptr<const World> world, const SearchSettings& settings,
                           std::shared_ptr<const EdgeEvaluationPolicy> policy)
    : world_(std::move(world)), policy_(std::move(policy)), evaluator_(world_, settings.edges) {}

void LazyEdgeWork::reset() {
  partial_evaluations_ = full_evaluations_ = rejected_edges_ = esdf_queries_ = 0;
  evaluation_seconds_ = 0.0;
}

double LazyEdgeWork::clearance(const Eigen::Vector3d& position) {
  ++esdf_queries_;
  return world_->clearance(position);
}

bool LazyEdgeWork::estimate(const ChainState& parent, double parent_clearance,
                            const Eigen::Vector3d& control, EdgeEvaluation& estimate) {
  const auto begin = std::chrono::steady_clock::now();
  const bool exact = policy_->evaluate(evaluator_, parent, parent_clearance, control, estimate) !=
                     EdgeEstimate::kLowerBound;
  evaluation_seconds_ += secondsSince(begin);
  esdf_queries_ += estimate.esdf_queries;
  if (exact) {  // the policy evaluated it exactly (full, or a certified bound)
    ++full_evaluations_;
    rejected_edges_ += !estimate.valid();
  } else {
    ++partial_evaluations_;
  }
  return exact;
}

EdgeEvaluation LazyEdgeWork::evaluate(const ChainState& parent, const Eigen::Vector3d& control) {
  const auto begin = std::chrono::steady_clock::now();
  EdgeEvaluation full = evaluator_.full(parent, control, world_->clearance(parent.col(0)));
  evaluation_seconds_ += secondsSince(begin);
  ++full_evaluations_;
  esdf_queries_ += full.esdf_queries + 1;  // and the parent's clearance
  rejected_edges_ += !full.valid();
  return full;
}

void LazyEdgeWork::addStatistics(Statistics& statistics, double total_seconds) const {
  const auto value = [](long long count) { return static_cast<double>(count); };
  statistics.emplace_back("partial_evaluations", value(partial_evaluations_));
  statistics.emplace_back("full_evaluations", value(full_evaluations_));
  statistics.emplace_back("rejected_edges", value(rejected_edges_));
  statistics.emplace_back("esdf_queries", value(esdf_queries_));
  statistics.emplace_back("time_evaluation_ms", 1e3 * evaluation_seconds_);
  statistics.emplace_back("time_search_ms", 1e3 * (total_seconds - evaluation_seconds_));
}

LazyFamilySearch::LazyFamilySearch(const char* name, std::shared_ptr<const World> world,
                                   std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                                   SearchPolicies policies, EdgeSelector selector)
    : world_(std::move(world)),
      controls_(std::move(controls)),
      settings_(settings),
      policies_(std::move(policies)),
      selector_(selector),
      work_(world_, settings_, policies_.edges) {
  const std::string who(name);
  if (controls_.empty()) throw InvalidArgument(who + ": no controls");
  if (!policies_.edges || !policies_.heuristic || !policies_.space) {
    throw InvalidArgument(who + ": an edge policy, a heuristic and a search space are needed");
  }
  if (!(settings_.heuristic_weight >= 1.0)) {
    throw InvalidArgument(who + ": heuristic_weight must be >= 1");
  }
  policies_.heuristic = heuristicForControls(policies_.heuristic, controls_);
}

void LazyFamilySearch::reset(const ChainState& start, const Eigen::Vector3d& goal,
                             StopCondition& stop) {
  start_ = start;
  goal_ = goal;
  heuristic_ = heuristicForQuery(policies_.heuristic, *world_, goal, stop);
  start_heuristic_ = heuristic_->estimate(start, goal);
  path_.clear();
  solved_ = memory_limited_ = reverse_next_ = false;
  expansions_ = 0;
  work_.reset();
}

Trajectory LazyFamilySearch::trajectory() const {
  Trajectory trajectory;
  for (const LazyPathStep& step : path_) {
    trajectory.append(TrajectorySegment::primitive(
        step.parent, controls_[step.control], settings_.edges.order, settings_.edges.duration));
  }
  return trajectory;
}

double LazyFamilySearch::cost() const {
  if (path_.empty()) return solved_ ? 0.0 : INFINITY;
  double total = 0.0;
  for (const LazyPathStep& step : path_) total += step.cost;
  return total;
}

Statistics LazyFamilySearch::statistics() const {
  Statistics statistics{{"expansions", static_cast<double>(expansions_)},
                        {"start_heuristic", start_heuristic_}};
  for (auto& entry : ownStatistics()) statistics.push_back(std::move(entry));
  work_.addStatistics(statistics, total_seconds_);
  return statistics;
}

std::vector<int> LazyFamilySearch::selectorOrder(std::vector<int> band,
                                                 const std::function<double(int)>& clearance) {
  switch (selector_) {
    case EdgeSelector::kForward:
      break;
    case EdgeSelector::kReverse:
      std::reverse(band.begin(), band.end());
      break;
    case EdgeSelector::kAlternate: {
      std::vector<int> order;
      order.reserve(band.size());
      std::size_t front = 0, back = band.size();
      bool from_back = reverse_next_;
      while (front < back) {
        order.push_back(from_back ? band[--back] : band[front++]);
        from_back = !from_back;
      }
      reverse_next_ = !reverse_next_;
      return order;
    }
    case EdgeSelector::kFailFast: {
      // The least clearance at the end first: the likeliest to fail.
      std::vector<std::pair<double, int>> keyed;
      for (const int item : band) keyed.emplace_back(clearance(item), item);
      std::stable_sort(keyed.begin(), keyed.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      for (std::size_t i = 0; i < band.size(); ++i) band[i] = keyed[i].second;
      break;
    }
  }
  return band;
}

LazySpSearch::LazySpSearch(std::shared_ptr<const World> world,
                           std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                           SearchPolicies policies, EdgeSelector selector)
    : LazyFamilySearch("LazySP", std::move(world), std::move(controls), settings,
                       std::move(policies), selector) {}

LazySpSearch::Edge& LazySpSearch::edgeOf(Slot& slot, const ChainState& parent, double& clearance,
                                         int control) {
  if (slot.empty()) slot.resize(controls_.size());
  std::unique_ptr<Edge>& edge = slot[control];
  // An edge's records hold for its continuous parent: routes to one lattice key agree up to
  // rounding, and another parent of the key is evaluated afresh.
  if (!edge || (edge->parent - parent).cwiseAbs().maxCoeff() > 1e-9) {
    if (!edge) ++edge_records_;
    edge = std::make_unique<Edge>();
    edge->parent = parent;
    // The parent's clearance once per expansion, and only when an edge is new.
    if (std::isnan(clearance)) clearance = work_.clearance(parent.col(0));
    edge->evaluated = work_.estimate(parent, clearance, controls_[control], edge->bound);
    if (edge->evaluated) edge->full = edge->bound;
  }
  return *edge;
}

double LazySpSearch::memoryBytes() const {
  return static_cast<double>(nodes_.capacity() * sizeof(Node) +
                             edge_records_ * (sizeof(Edge) + sizeof(void*)) +
                             edges_.size() * (sizeof(Key) + 4 * sizeof(void*)));
}

int LazySpSearch::lazySearch(StopCondition& stop, bool& stopped) {
  ++lazy_searches_;
  nodes_.clear();
  nodes_.push_back({start_, 0.0, -1, -1, nullptr});
  std::unordered_map<Key, int, LatticeKeyHash> closed;
  std::unordered_map<Key, double, LatticeKeyHash> best_g;
  using Entry = std::tuple<double, double, int>;  // f, -g (deeper first among equal f), node
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const auto h = [&](const ChainState& state) {
    return settings_.heuristic_weight * heuristic_->estimate(state, goal_);
  };
  open.emplace(h(start_), 0.0, 0);
  const int order = settings_.edges.order;
  const double memory_limit = settings_.memory_limit_mb * 1024.0 * 1024.0;
  while (!open.empty()) {
    const double bytes = memoryBytes();
    if (stop.expired(expansions_) || bytes > memory_limit) {
      memory_limited_ = bytes > memory_limit;
      stopped = true;
      return -1;
    }
    const int node = std::get<2>(open.top());
    open.pop();
    const Key key = policies_.space->key(nodes_[node].state, start_, order);
    if (!closed.emplace(key, node).second) continue;
    if ((nodes_[node].state.col(0) - goal_).norm() <= settings_.goal_radius) return node;
    ++expansions_;
    // The node's edge records, by its key (the closed-set key): one look-up per expansion.
    Slot& slot = edges_[key];
    double clearance = NAN;
    for (int control = 0; control < static_cast<int>(controls_.size()); ++control) {
      Edge& edge = edgeOf(slot, nodes_[node].state, clearance, control);
      const EdgeEvaluation& known = edge.known();
      if (!known.valid()) continue;
      const Key child_key = policies_.space->key(known.end, start_, order);
      if (closed.count(child_key)) continue;
      const double g = nodes_[node].g + known.cost;
      const auto [best, inserted] = best_g.emplace(child_key, g);
      if (!inserted && g >= best->second) continue;
      best->second = g;
      const double estimate = h(known.end);
      if (estimate == INFINITY) continue;  // the goal is out of its reach
      nodes_.push_back({known.end, g, node, control, &edge});
      const int child = static_cast<int>(nodes_.size()) - 1;
      open.emplace(settings_.cost_weight * g + estimate, -g, child);
    }
  }
  return -1;
}

bool LazySpSearch::evaluateOnPath(int goal_node) {
  std::vector<int> nodes;
  for (int node = goal_node; node > 0; node = nodes_[node].parent) nodes.push_back(node);
  std::reverse(nodes.begin(), nodes.end());
  std::vector<int> unevaluated;
  for (const int node : nodes) {
    if (!nodes_[node].edge->evaluated) unevaluated.push_back(node);
  }
  // The path by value: whole when it is evaluated whole (the answer), else its evaluated
  // start (what a budget stop returns); the next lazy search rebuilds nodes_.
  path_.clear();
  for (const int node : nodes) {
    const Edge& edge = *nodes_[node].edge;
    if (!edge.evaluated || !edge.full.valid()) break;
    path_.push_back({edge.parent, nodes_[node].control, edge.full.cost});
  }
  if (unevaluated.empty()) return false;
  const auto clearance = [&](int node) {
    const EdgeEvaluation& bound = nodes_[node].edge->bound;
    return std::isfinite(bound.end_clearance) ? bound.end_clearance
                                              : world_->clearance(bound.end.col(0));
  };
  const int chosen = selectorOrder(unevaluated, clearance).front();
  Edge& edge = *nodes_[chosen].edge;
  edge.full = work_.evaluate(edge.parent, controls_[nodes_[chosen].control]);
  edge.evaluated = true;
  return true;
}

MotionPrimitiveSearch::Outcome LazySpSearch::search(const ChainState& start,
                                                    const Eigen::Vector3d& goal,
                                                    StopCondition& stop) {
  const auto begin = std::chrono::steady_clock::now();
  reset(start, goal, stop);
  edges_.clear();
  edge_records_ = 0;
  lazy_searches_ = 0;
  auto outcome = MotionPrimitiveSearch::Outcome::kExhausted;
  for (;;) {
    bool stopped = false;
    const int goal_node = lazySearch(stop, stopped);
    if (stopped) {
      outcome = MotionPrimitiveSearch::Outcome::kBudget;
      break;
    }
    if (goal_node < 0) {  // no path even at the lower bounds: exhausted
      path_.clear();
      break;
    }
    if (!evaluateOnPath(goal_node)) {
      solved_ = true;
      outcome = MotionPrimitiveSearch::Outcome::kGoal;
      break;
    }
  }
  total_seconds_ = secondsSince(begin);
  return outcome;
}

Statistics LazySpSearch::ownStatistics() const {
  return {{"lazy_searches", static_cast<double>(lazy_searches_)}};
}

bool LraStarSearch::Entry::operator>(const Entry& other) const {
  if (f != other.f) return f > other.f;
  if (g != other.g) return g < other.g;  // deeper first among equal f
  return vertex > other.vertex;
}

LraStarSearch::LraStarSearch(std::shared_ptr<const World> world,
                             std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                             SearchPolicies policies, int lookahead, EdgeSelector selector)
    : LazyFamilySearch("LRA*", std::move(world), std::move(controls), settings, std::move(policies),
                       selector),
      lookahead_(lookahead) {
  if (lookahead_ < 1) throw InvalidArgument("LRA*: lookahead must be >= 1");
}

int LraStarSearch::vertexOf(const ChainState& state) {
  const Key key = policies_.space->key(state, start_, settings_.edges.order);
  const auto [found, inserted] = index_.emplace(key, static_cast<int>(vertices_.size()));
  if (inserted) {
    // A key's state is fixed when it is first reached (routes to one lattice key agree up to
    // rounding), so its edge records hold for every later parent.
    Vertex vertex;
    vertex.state = state;
    vertex.h = settings_.heuristic_weight * heuristic_->estimate(state, goal_);
    vertex.goal = (state.col(0) - goal_).norm() <= settings_.goal_radius;
    vertices_.push_back(std::move(vertex));
  }
  return found->second;
}

LraStarSearch::Arc& LraStarSearch::arcOf(int vertex, int control) {
  if (vertices_[vertex].first_arc < 0) {
    const ChainState parent = vertices_[vertex].state;  // vertexOf below may move vertices_
    const double clearance = work_.clearance(parent.col(0));
    const int first = static_cast<int>(arcs_.size());
    vertices_[vertex].first_arc = first;
    arcs_.resize(arcs_.size() + controls_.size());
    EdgeEvaluation estimate;
    for (std::size_t c = 0; c < controls_.size(); ++c) {
      const bool exact = work_.estimate(parent, clearance, controls_[c], estimate);
      Arc& arc = arcs_[first + c];
      arc.evaluated = exact;
      arc.valid = estimate.valid();
      arc.bound_cost = arc.cost = estimate.cost;
      if (!arc.valid) continue;
      arc.child = vertexOf(estimate.end);
      // failfast's order: the bound's clearance at the end, else the map's.
      if (selector_ == EdgeSelector::kFailFast) {
        arc.end_clearance = static_cast<float>(std::isfinite(estimate.end_clearance)
                                                   ? estimate.end_clearance
                                                   : world_->clearance(estimate.end.col(0)));
      }
    }
  }
  return arcs_[vertices_[vertex].first_arc + control];
}

void LraStarSearch::enqueue(int vertex) {
  Vertex& v = vertices_[vertex];
  ++v.stamp;
  v.queue = v.goal || v.budget >= lookahead_ ? Queue::kFrontier : Queue::kExtend;
  (v.queue == Queue::kFrontier ? frontier_ : extend_)
      .push({settings_.cost_weight * v.g + v.h, v.g, vertex, v.stamp});
}

const LraStarSearch::Entry* LraStarSearch::top(Heap& heap, Queue queue) {
  while (!heap.empty()) {
    const Entry& entry = heap.top();
    const Vertex& v = vertices_[entry.vertex];
    if (v.in_tree && v.queue == queue && v.stamp == entry.stamp) return &entry;
    heap.pop();
  }
  return nullptr;
}

void LraStarSearch::detach(int vertex) {
  const int parent = vertices_[vertex].parent;
  if (parent < 0) return;
  std::vector<int>& siblings = vertices_[parent].children;
  const auto found = std::find(siblings.begin(), siblings.end(), vertex);
  if (found != siblings.end()) {
    *found = siblings.back();
    siblings.pop_back();
  }
}

void LraStarSearch::discardBelow(int vertex, bool inclusive, std::vector<int>* removed) {
  std::vector<int> stack;
  if (inclusive) {
    stack.push_back(vertex);
  } else {
    stack.swap(vertices_[vertex].children);
  }
  while (!stack.empty()) {
    const int current = stack.back();
    stack.pop_back();
    Vertex& v = vertices_[current];
    v.in_tree = false;
    v.queue = Queue::kNone;
    v.g = INFINITY;
    v.parent = -1;
    stack.insert(stack.end(), v.children.begin(), v.children.end());
    v.children.clear();
    if (removed) removed->push_back(current);
  }
}

void LraStarSearch::extend(int vertex) {
  ++expansions_;
  for (int control = 0; control < static_cast<int>(controls_.size()); ++control) {
    const Arc& arc = arcOf(vertex, control);
    if (!arc.valid) continue;
    const Vertex& u = vertices_[vertex];
    Vertex& v = vertices_[arc.child];
    const std::pair<int, int> predecessor{vertex, control};
    if (std::find(v.predecessors.begin(), v.predecessors.end(), predecessor) ==
        v.predecessors.end()) {
      v.predecessors.push_back(predecessor);
      ++predecessor_entries_;
    }
    const double g = u.g + arc.cost;
    if (v.in_tree && v.g <= g) continue;
    if (v.in_tree) {  // a cheaper route: its subtree is found again from it
      detach(arc.child);
      discardBelow(arc.child, false, nullptr);
    }
    v.in_tree = true;
    v.g = g;
    v.parent = vertex;
    v.control = control;
    v.budget = u.budget + (arc.evaluated ? 0 : 1);
    vertices_[vertex].children.push_back(arc.child);
    enqueue(arc.child);
  }
}

void LraStarSearch::rewire(int vertex) {
  detach(vertex);
  std::vector<int> removed;
  discardBelow(vertex, true, &removed);
  rewired_ += static_cast<long long>(removed.size());
  // Each removed vertex's best parent among the tree vertices that reached it...
  using Candidate = std::pair<double, int>;
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> candidates;
  const auto offer = [&](int parent, int control, int child) {
    const Vertex& u = vertices_[parent];
    const Arc& arc = arcs_[u.first_arc + control];
    Vertex& v = vertices_[child];
    if (!u.in_tree || u.goal || u.budget >= lookahead_ || !arc.valid || v.in_tree) return;
    const double g = u.g + arc.cost;
    if (g >= v.g) return;
    v.g = g;
    v.parent = parent;
    v.control = control;
    v.budget = u.budget + (arc.evaluated ? 0 : 1);
    candidates.emplace(g, child);
  };
  for (const int gone : removed) {
    for (const auto& [predecessor, control] : vertices_[gone].predecessors) {
      offer(predecessor, control, gone);
    }
  }
  // ...then each other's, in cost order (Dijkstra over the removed set); each returns to the
  // tree and is extended again (its other successors may have lost their parents earlier).
  while (!candidates.empty()) {
    const auto [g, child] = candidates.top();
    candidates.pop();
    Vertex& v = vertices_[child];
    if (v.in_tree || g > v.g) continue;
    v.in_tree = true;
    vertices_[v.parent].children.push_back(child);
    enqueue(child);
    if (v.first_arc < 0) continue;
    for (int control = 0; control < static_cast<int>(controls_.size()); ++control) {
      const Arc& arc = arcs_[vertices_[child].first_arc + control];
      if (arc.valid) offer(child, control, arc.child);
    }
  }
}

void LraStarSearch::updateBudgets(int vertex) {
  std::vector<int> stack{vertex};
  while (!stack.empty()) {
    const int current = stack.back();
    stack.pop_back();
    Vertex& v = vertices_[current];
    if (v.parent >= 0) v.budget = vertices_[v.parent].budget + (treeArc(current).evaluated ? 0 : 1);
    if (v.queue == Queue::kFrontier && !v.goal && v.budget < lookahead_) enqueue(current);
    stack.insert(stack.end(), v.children.begin(), v.children.end());
  }
}

std::vector<int> LraStarSearch::pathTo(int vertex) const {
  std::vector<int> path;
  for (int v = vertex; vertices_[v].parent >= 0; v = vertices_[v].parent) path.push_back(v);
  std::reverse(path.begin(), path.end());
  return path;
}

void LraStarSearch::evaluateBand(int vertex) {
  std::vector<int> band;
  for (const int v : pathTo(vertex)) {
    if (!treeArc(v).evaluated) band.push_back(v);
  }
  const auto clearance = [&](int v) { return treeArc(v).end_clearance; };
  const int top = band.front();  // the band's first vertex: every budget changes below it
  for (const int v : selectorOrder(band, clearance)) {
    Arc& arc = treeArc(v);
    const EdgeEvaluation full =
        work_.evaluate(vertices_[vertices_[v].parent].state, controls_[vertices_[v].control]);
    arc.evaluated = true;
    arc.valid = full.valid();
    arc.cost = full.cost;
    // Valid at its bound's cost: the tree stands. Invalid, or dearer (the bound's obstacle
    // share): its subtree is rewired, which ends this band.
    if (!arc.valid || arc.cost > arc.bound_cost) {
      rewire(v);
      break;
    }
  }
  if (vertices_[top].in_tree) updateBudgets(top);
}

double LraStarSearch::memoryBytes() const {
  return static_cast<double>(vertices_.capacity() * sizeof(Vertex) +
                             arcs_.capacity() * sizeof(Arc) +
                             index_.size() * (sizeof(Key) + 4 * sizeof(void*)) +
                             predecessor_entries_ * sizeof(std::pair<int, int>) +
                             vertices_.size() * sizeof(int));  // and one child entry each
}

MotionPrimitiveSearch::Outcome LraStarSearch::search(const ChainState& start,
                                                     const Eigen::Vector3d& goal,
                                                     StopCondition& stop) {
  const auto begin = std::chrono::steady_clock::now();
  reset(start, goal, stop);
  vertices_.clear();
  arcs_.clear();
  index_.clear();
  extend_ = Heap();
  frontier_ = Heap();
  rewired_ = predecessor_entries_ = 0;
  const int root = vertexOf(start);
  vertices_[root].g = 0.0;
  vertices_[root].in_tree = true;
  enqueue(root);
  const double memory_limit = settings_.memory_limit_mb * 1024.0 * 1024.0;
  auto outcome = MotionPrimitiveSearch::Outcome::kExhausted;
  int best = -1;  // the last frontier vertex taken
  for (;;) {
    const double bytes = memoryBytes();
    if (stop.expired(expansions_) || bytes > memory_limit) {
      memory_limited_ = bytes > memory_limit;
      outcome = MotionPrimitiveSearch::Outcome::kBudget;
      break;
    }
    const Entry* frontier = top(frontier_, Queue::kFrontier);
    const Entry* extendable = top(extend_, Queue::kExtend);
    // Extend the band while a band vertex is cheaper than the best frontier vertex.
    if (extendable && (!frontier || *frontier > *extendable)) {
      const int vertex = extendable->vertex;
      extend_.pop();
      vertices_[vertex].queue = Queue::kNone;
      extend(vertex);
      continue;
    }
    if (!frontier) {
      best = -1;
      break;  // exhausted: no path even at the lower bounds
    }
    best = frontier->vertex;
    frontier_.pop();
    Vertex& v = vertices_[best];
    v.queue = Queue::kNone;
    if (v.goal && v.budget == 0) {
      solved_ = true;
      outcome = MotionPrimitiveSearch::Outcome::kGoal;
      break;
    }
    evaluateBand(best);
    if (vertices_[best].in_tree) enqueue(best);
  }
  // The path to the goal, or the evaluated, valid start of the path to the last frontier vertex.
  if (best >= 0 && vertices_[best].in_tree) {
    for (const int v : pathTo(best)) {
      const Arc& arc = treeArc(v);
      if (!arc.evaluated || !arc.valid) break;
      path_.push_back({vertices_[vertices_[v].parent].state, vertices_[v].control, arc.cost});
    }
  }
  total_seconds_ = secondsSince(begin);
  return outcome;
}

Statistics LraStarSearch::ownStatistics() const {
  return {{"rewired_vertices", static_cast<double>(rewired_)}};
}

}  // namespace kinolab
