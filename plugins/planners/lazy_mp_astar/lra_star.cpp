// LRA* on the motion-primitive lattice (LraStarSearch, lazy_family.hpp): one search tree with
// a lazy band of at most `lookahead` unevaluated edges, rewired below the best remaining
// parents when an evaluated edge is invalid or dearer than its bound.
#include <algorithm>
#include <cmath>
#include <queue>

#include "kinolab/core/error.hpp"
#include "lazy_family.hpp"

namespace kinolab {

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
  const Key key = graph_.key(state);
  const auto [found, inserted] = index_.emplace(key, static_cast<int>(vertices_.size()));
  if (inserted) {
    // A key's state is fixed when it is first reached (routes to one lattice key agree up to
    // rounding), so its edge records hold for every later parent.
    Vertex vertex;
    vertex.state = state;
    vertex.h = graph_.settings().heuristic_weight * graph_.h(state);
    vertex.goal = graph_.inGoal(state);
    vertices_.push_back(std::move(vertex));
  }
  return found->second;
}

LraStarSearch::Arc& LraStarSearch::arcOf(int vertex, int control) {
  if (vertices_[vertex].first_arc < 0) {
    const ChainState parent = vertices_[vertex].state;  // vertexOf below may move vertices_
    const double clearance = graph_.clearance(parent.col(0));
    const int first = static_cast<int>(arcs_.size());
    vertices_[vertex].first_arc = first;
    graph_.estimateAll(parent, clearance, evaluations_, estimates_);
    arcs_.resize(arcs_.size() + evaluations_.size());
    for (std::size_t c = 0; c < evaluations_.size(); ++c) {
      const EdgeEvaluation& estimate = evaluations_[c];
      Arc& arc = arcs_[first + c];
      arc.evaluated = estimates_[c] != EdgeEstimate::kLowerBound;
      arc.valid = estimate.valid();
      arc.bound_cost = arc.cost = estimate.cost;
      if (!arc.valid) continue;
      arc.child = vertexOf(estimate.end);
      // failfast's order: the bound's clearance at the end, else the map's.
      if (selector_ == EdgeSelector::kFailFast) {
        arc.end_clearance = static_cast<float>(std::isfinite(estimate.end_clearance)
                                                   ? estimate.end_clearance
                                                   : graph_.world().clearance(estimate.end.col(0)));
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
      .push({graph_.settings().cost_weight * v.g + v.h, v.g, vertex, v.stamp});
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
  ++graph_.counters().expansions;
  for (int control = 0; control < static_cast<int>(graph_.controls().size()); ++control) {
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
    for (int control = 0; control < static_cast<int>(graph_.controls().size()); ++control) {
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
        graph_.evaluate(vertices_[vertices_[v].parent].state, vertices_[v].control);
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

bool LraStarSearch::evaluatedPath(int vertex) {
  for (int v = vertex; vertices_[v].parent >= 0; v = vertices_[v].parent) {
    if (!treeArc(v).evaluated) return false;  // an evaluated tree arc is valid
  }
  return true;
}

int LraStarSearch::nearestVertex(const Eigen::Vector3d& goal, bool evaluated) {
  int nearest = 0;  // the root
  double nearest_distance = INFINITY;
  for (int v = 0; v < static_cast<int>(vertices_.size()); ++v) {
    if (!vertices_[v].in_tree) continue;
    const double distance = (vertices_[v].state.col(0) - goal).norm();
    if (distance < nearest_distance && (!evaluated || evaluatedPath(v))) {
      nearest_distance = distance;
      nearest = v;
    }
  }
  return nearest;
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
  auto outcome = MotionPrimitiveSearch::Outcome::kExhausted;
  int best = root;  // the vertex whose path is the answer
  for (;;) {
    if (graph_.stopHere(stop, graph_.counters().expansions, memoryBytes())) {
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
      // Exhausted: no path even at the lower bounds. The answer is then eager's, the path to
      // the state nearest the goal that is reached: the path to the nearest vertex is
      // evaluated (and the tree rewired) until it is evaluated whole.
      const int nearest = nearestVertex(goal, false);
      if (evaluatedPath(nearest)) {
        best = nearest;
        break;
      }
      evaluateBand(nearest);
      continue;
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
  // The path to the goal, to the nearest state reached (exhausted), or on a budget stop to the
  // vertex nearest the goal whose tree path is evaluated whole.
  if (outcome == MotionPrimitiveSearch::Outcome::kBudget) best = nearestVertex(goal, true);
  for (const int v : pathTo(best)) {
    path_.push_back({vertices_[vertices_[v].parent].state, vertices_[v].control, treeArc(v).cost});
  }
  graph_.endQuery();
  return outcome;
}

Statistics LraStarSearch::ownStatistics() const {
  return {{"rewired_vertices", static_cast<double>(rewired_)}};
}

}  // namespace kinolab
