#include "lazy_family.hpp"

#include <algorithm>
#include <cmath>
#include <queue>

#include "kinolab/core/error.hpp"

namespace kinolab {

std::size_t LatticeKeyHash::operator()(const SearchSpace::Key& key) const {
  std::uint64_t hash = 1469598103934665603ull;
  for (const std::int32_t value : key) {
    hash ^= static_cast<std::uint32_t>(value);
    hash *= 1099511628211ull;
  }
  return static_cast<std::size_t>(hash ^ (hash >> 29));
}

LazyFamilySearch::LazyFamilySearch(const char* name, std::shared_ptr<const World> world,
                                   std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                                   SearchPolicies policies, EdgeSelector selector)
    : graph_(name, std::move(world), std::move(controls), std::move(settings), std::move(policies)),
      selector_(selector) {}

void LazyFamilySearch::reset(const ChainState& start, const Eigen::Vector3d& goal,
                             StopCondition& stop) {
  graph_.beginQuery(start, goal, stop);
  path_.clear();
  solved_ = reverse_next_ = false;
}

Trajectory LazyFamilySearch::trajectory() const {
  Trajectory trajectory;
  for (const LazyPathStep& step : path_) {
    const EdgeEvaluatorSettings& edges = graph_.settings().edges;
    trajectory.append(TrajectorySegment::primitive(step.parent, graph_.controls()[step.control],
                                                   edges.order, edges.duration));
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
  Statistics statistics = graph_.statistics();
  for (auto& entry : ownStatistics()) statistics.push_back(std::move(entry));
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
  if (slot.empty()) slot.resize(graph_.controls().size());
  std::unique_ptr<Edge>& edge = slot[control];
  // An edge's records hold for its continuous parent: routes to one lattice key agree up to
  // rounding, and another parent of the key is evaluated afresh.
  if (!edge || (edge->parent - parent).cwiseAbs().maxCoeff() > 1e-9) {
    if (!edge) ++edge_records_;
    edge = std::make_unique<Edge>();
    edge->parent = parent;
    // The parent's clearance once per expansion, and only when an edge is new.
    if (std::isnan(clearance)) clearance = graph_.clearance(parent.col(0));
    edge->evaluated =
        graph_.estimate(parent, clearance, control, edge->bound) != EdgeEstimate::kLowerBound;
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
  nodes_.push_back({graph_.start(), 0.0, -1, -1, nullptr});
  std::unordered_map<Key, int, LatticeKeyHash> closed;
  std::unordered_map<Key, double, LatticeKeyHash> best_g;
  using Entry = std::tuple<double, double, int>;  // f, -g (deeper first among equal f), node
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const auto h = [&](const ChainState& state) {
    return graph_.settings().heuristic_weight * graph_.h(state);
  };
  open.emplace(h(graph_.start()), 0.0, 0);
  SearchCounters& counters = graph_.counters();
  while (!open.empty()) {
    if (graph_.stopHere(stop, counters.expansions, memoryBytes())) {
      stopped = true;
      return -1;
    }
    const int node = std::get<2>(open.top());
    open.pop();
    const Key key = graph_.key(nodes_[node].state);
    if (!closed.emplace(key, node).second) continue;
    if (graph_.inGoal(nodes_[node].state)) return node;
    ++counters.expansions;
    // The node's edge records, by its key (the closed-set key): one look-up per expansion.
    Slot& slot = edges_[key];
    double clearance = NAN;
    for (int control = 0; control < static_cast<int>(graph_.controls().size()); ++control) {
      Edge& edge = edgeOf(slot, nodes_[node].state, clearance, control);
      const EdgeEvaluation& known = edge.known();
      if (!known.valid()) continue;
      const Key child_key = graph_.key(known.end);
      if (closed.count(child_key)) continue;
      const double g = nodes_[node].g + known.cost;
      const auto [best, inserted] = best_g.emplace(child_key, g);
      if (!inserted && g >= best->second) continue;
      best->second = g;
      const double estimate = h(known.end);
      if (estimate == INFINITY) continue;  // the goal is out of its reach
      nodes_.push_back({known.end, g, node, control, &edge});
      const int child = static_cast<int>(nodes_.size()) - 1;
      open.emplace(graph_.settings().cost_weight * g + estimate, -g, child);
    }
  }
  return -1;
}

bool LazySpSearch::evaluateOnPath(int goal_node, bool whole) {
  std::vector<int> nodes;
  for (int node = goal_node; node > 0; node = nodes_[node].parent) nodes.push_back(node);
  std::reverse(nodes.begin(), nodes.end());
  std::vector<int> unevaluated;
  for (const int node : nodes) {
    if (!nodes_[node].edge->evaluated) unevaluated.push_back(node);
  }
  if (unevaluated.empty()) {  // the answer, by value: the next lazy search rebuilds nodes_
    path_.clear();
    for (const int node : nodes) {
      path_.push_back(
          {nodes_[node].edge->parent, nodes_[node].control, nodes_[node].edge->full.cost});
    }
    return false;
  }
  const auto clearance = [&](int node) {
    const EdgeEvaluation& bound = nodes_[node].edge->bound;
    return std::isfinite(bound.end_clearance) ? bound.end_clearance
                                              : graph_.world().clearance(bound.end.col(0));
  };
  for (const int chosen : selectorOrder(unevaluated, clearance)) {
    Edge& edge = *nodes_[chosen].edge;
    edge.full = graph_.evaluate(edge.parent, nodes_[chosen].control);
    edge.evaluated = true;
    if (!whole || !edge.full.valid()) break;
  }
  return true;
}

MotionPrimitiveSearch::Outcome LazySpSearch::search(const ChainState& start,
                                                    const Eigen::Vector3d& goal,
                                                    StopCondition& stop) {
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
    if (goal_node < 0) {
      // Exhausted: no path even at the lower bounds. The answer is then eager's, the path to
      // the state nearest the goal that is reached: the lazy path to the nearest node is
      // evaluated (whole, up to an invalid edge: one lazy search an edge would be dear) until
      // it is evaluated whole (path_).
      if (!evaluateOnPath(nearestNode(goal, false), true)) break;
      continue;
    }
    if (!evaluateOnPath(goal_node, false)) {
      solved_ = true;
      outcome = MotionPrimitiveSearch::Outcome::kGoal;
      break;
    }
  }
  if (outcome == MotionPrimitiveSearch::Outcome::kBudget) {
    // The path to the node nearest the goal through evaluated edges (nodes_ by value).
    std::vector<int> chain;
    for (int node = nearestNode(goal, true); node > 0; node = nodes_[node].parent) {
      chain.push_back(node);
    }
    path_.clear();
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const Edge& edge = *nodes_[*it].edge;
      path_.push_back({edge.parent, nodes_[*it].control, edge.full.cost});
    }
  }
  graph_.endQuery();
  return outcome;
}

int LazySpSearch::nearestNode(const Eigen::Vector3d& goal, bool evaluated) const {
  // A node's parent comes before it: one pass marks the nodes whose every edge is evaluated.
  std::vector<char> whole(nodes_.size(), 1);
  int nearest = 0;
  double nearest_distance = INFINITY;
  for (std::size_t node = 0; node < nodes_.size(); ++node) {
    const Node& n = nodes_[node];
    if (node > 0) whole[node] = whole[n.parent] && n.edge->evaluated;  // evaluated: valid
    if (evaluated && !whole[node]) continue;
    const double distance = (n.state.col(0) - goal).norm();
    if (distance < nearest_distance) {
      nearest_distance = distance;
      nearest = static_cast<int>(node);
    }
  }
  return nearest;
}

Statistics LazySpSearch::ownStatistics() const {
  return {{"lazy_searches", static_cast<double>(lazy_searches_)}};
}

}  // namespace kinolab
