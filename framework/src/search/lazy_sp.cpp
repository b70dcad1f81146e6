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

LazySpSearch::Edge& LazySpSearch::edgeOf(int node, int control) {
  const ChainState& parent = nodes_[node].state;
  const Key key = policies_.space->key(parent, start_, settings_.edges.order);
  auto& slot = edges_[key];
  if (slot.empty()) slot.resize(controls_.size());
  std::unique_ptr<Edge>& edge = slot[control];
  // An edge's records hold for its continuous parent only: another parent of the same key
  // (not on a control grid's lattice) is evaluated afresh.
  if (!edge || edge->parent != parent) {
    edge = std::make_unique<Edge>();
    edge->parent = parent;
    const double clearance = world_->clearance(parent.col(0));
    policies_.edges->evaluate(evaluator_, parent, clearance, controls_[control], edge->bound);
    ++partial_evaluations_;
    esdf_queries_ += edge->bound.esdf_queries;
  }
  return *edge;
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
  while (!open.empty()) {
    if (stop.expired(expansions_)) {
      stopped = true;
      return -1;
    }
    const int node = std::get<2>(open.top());
    open.pop();
    const Key key = policies_.space->key(nodes_[node].state, start_, order);
    if (!closed.emplace(key, node).second) continue;
    if ((nodes_[node].state.col(0) - goal_).norm() <= settings_.goal_radius) return node;
    ++expansions_;
    for (int control = 0; control < static_cast<int>(controls_.size()); ++control) {
      Edge& edge = edgeOf(node, control);
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
  path_.clear();
  for (int node = goal_node; node > 0; node = nodes_[node].parent) path_.push_back(node);
  std::reverse(path_.begin(), path_.end());
  std::vector<int> unevaluated;
  for (const int node : path_) {
    if (!nodes_[node].edge->evaluated) unevaluated.push_back(node);
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
  esdf_queries_ += edge.full.esdf_queries;
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
  path_.clear();
  solved_ = false;
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
    if (goal_node < 0) break;  // no path even at the lower bounds: exhausted
    if (!evaluateOnPath(goal_node)) {
      solved_ = true;
      outcome = MotionPrimitiveSearch::Outcome::kGoal;
      break;
    }
  }
  if (!solved_) {
    // The evaluated, valid prefix of the last lazy path: a start towards the goal.
    const auto first_open = std::find_if(path_.begin(), path_.end(), [&](int node) {
      return !nodes_[node].edge->evaluated || !nodes_[node].edge->full.valid();
    });
    path_.erase(first_open, path_.end());
  }
  total_seconds_ = secondsSince(begin);
  return outcome;
}

Trajectory LazySpSearch::trajectory() const {
  Trajectory trajectory;
  for (const int node : path_) {
    trajectory.append(
        TrajectorySegment::primitive(nodes_[node].edge->parent, controls_[nodes_[node].control],
                                     settings_.edges.order, settings_.edges.duration));
  }
  return trajectory;
}

double LazySpSearch::cost() const {
  if (path_.empty()) return solved_ ? 0.0 : INFINITY;
  double total = 0.0;
  for (const int node : path_) total += nodes_[node].edge->full.cost;
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
