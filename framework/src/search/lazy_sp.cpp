#include "kinolab/search/lazy_sp.hpp"

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

std::size_t LazySpSearch::KeyHash::operator()(const Key& key) const {
  std::uint64_t hash = 1469598103934665603ull;
  for (const std::int32_t value : key) {
    hash ^= static_cast<std::uint32_t>(value);
    hash *= 1099511628211ull;
  }
  return static_cast<std::size_t>(hash ^ (hash >> 29));
}

LazySpSearch::LazySpSearch(std::shared_ptr<const World> world,
                           std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                           SearchPolicies policies, EdgeSelector selector)
    : world_(std::move(world)),
      controls_(std::move(controls)),
      settings_(settings),
      policies_(std::move(policies)),
      selector_(selector),
      evaluator_(world_, settings_.edges) {
  if (controls_.empty()) throw InvalidArgument("LazySP: no controls");
  if (!policies_.edges || !policies_.heuristic || !policies_.space) {
    throw InvalidArgument("LazySP: an edge policy, a heuristic and a search space are needed");
  }
  if (!(settings_.heuristic_weight >= 1.0)) {
    throw InvalidArgument("LazySP: heuristic_weight must be >= 1");
  }
}

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
    if (std::isnan(clearance)) {  // once per expansion, and only when an edge is new
      clearance = world_->clearance(parent.col(0));
      ++esdf_queries_;
    }
    const auto begin = std::chrono::steady_clock::now();
    const EdgeEstimate estimate =
        policies_.edges->evaluate(evaluator_, parent, clearance, controls_[control], edge->bound);
    evaluation_seconds_ += secondsSince(begin);
    esdf_queries_ += edge->bound.esdf_queries;
    if (estimate == EdgeEstimate::kLowerBound) {
      ++partial_evaluations_;
    } else {  // the policy evaluated it exactly (full, or a certified bound)
      edge->full = edge->bound;
      edge->evaluated = true;
      ++full_evaluations_;
      rejected_edges_ += !edge->full.valid();
    }
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
  std::unordered_map<Key, int, KeyHash> closed;
  std::unordered_map<Key, double, KeyHash> best_g;
  using Entry = std::tuple<double, double, int>;  // f, -g (deeper first among equal f), node
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const auto h = [&](const ChainState& state) {
    return settings_.heuristic_weight * policies_.heuristic->estimate(state, goal_);
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
      const EdgeEvaluation& known = edge.evaluated ? edge.full : edge.bound;
      if (!known.valid()) continue;
      const Key child_key = policies_.space->key(known.end, start_, order);
      if (closed.count(child_key)) continue;
      const double g = nodes_[node].g + known.cost;
      const auto [best, inserted] = best_g.emplace(child_key, g);
      if (!inserted && g >= best->second) continue;
      best->second = g;
      nodes_.push_back({known.end, g, node, control, &edge});
      const int child = static_cast<int>(nodes_.size()) - 1;
      open.emplace(settings_.cost_weight * g + h(known.end), -g, child);
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
  int chosen = unevaluated.front();
  switch (selector_) {
    case EdgeSelector::kForward:
      break;
    case EdgeSelector::kReverse:
      chosen = unevaluated.back();
      break;
    case EdgeSelector::kAlternate:
      chosen = reverse_next_ ? unevaluated.back() : unevaluated.front();
      reverse_next_ = !reverse_next_;
      break;
    case EdgeSelector::kFailFast: {
      // The least clearance at the end (the bound's, else the map's): the likeliest to fail.
      double least = INFINITY;
      for (const int node : unevaluated) {
        const EdgeEvaluation& bound = nodes_[node].edge->bound;
        const double clearance = std::isfinite(bound.end_clearance)
                                     ? bound.end_clearance
                                     : world_->clearance(bound.end.col(0));
        if (clearance < least) {
          least = clearance;
          chosen = node;
        }
      }
      break;
    }
  }
  Edge& edge = *nodes_[chosen].edge;
  const auto begin = std::chrono::steady_clock::now();
  edge.full = evaluator_.full(edge.parent, controls_[nodes_[chosen].control],
                              world_->clearance(edge.parent.col(0)));
  evaluation_seconds_ += secondsSince(begin);
  edge.evaluated = true;
  ++full_evaluations_;
  esdf_queries_ += edge.full.esdf_queries + 1;  // and the parent's clearance
  rejected_edges_ += !edge.full.valid();
  return true;
}

MotionPrimitiveSearch::Outcome LazySpSearch::search(const ChainState& start,
                                                    const Eigen::Vector3d& goal,
                                                    StopCondition& stop) {
  const auto begin = std::chrono::steady_clock::now();
  start_ = start;
  goal_ = goal;
  edges_.clear();
  edge_records_ = 0;
  path_.clear();
  solved_ = false;
  memory_limited_ = false;
  reverse_next_ = false;
  expansions_ = lazy_searches_ = partial_evaluations_ = full_evaluations_ = 0;
  rejected_edges_ = esdf_queries_ = 0;
  evaluation_seconds_ = 0.0;
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

Trajectory LazySpSearch::trajectory() const {
  Trajectory trajectory;
  for (const Step& step : path_) {
    trajectory.append(TrajectorySegment::primitive(
        step.parent, controls_[step.control], settings_.edges.order, settings_.edges.duration));
  }
  return trajectory;
}

double LazySpSearch::cost() const {
  if (path_.empty()) return solved_ ? 0.0 : INFINITY;
  double total = 0.0;
  for (const Step& step : path_) total += step.cost;
  return total;
}

Statistics LazySpSearch::statistics() const {
  const auto value = [](long long count) { return static_cast<double>(count); };
  return {{"expansions", value(expansions_)},
          {"lazy_searches", value(lazy_searches_)},
          {"partial_evaluations", value(partial_evaluations_)},
          {"full_evaluations", value(full_evaluations_)},
          {"rejected_edges", value(rejected_edges_)},
          {"esdf_queries", value(esdf_queries_)},
          {"time_evaluation_ms", 1e3 * evaluation_seconds_},
          {"time_search_ms", 1e3 * (total_seconds_ - evaluation_seconds_)}};
}

}  // namespace kinolab
