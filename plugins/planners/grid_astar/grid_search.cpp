#include "grid_search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <queue>
#include <unordered_map>

namespace kinolab::grid {
namespace {

/// The largest window whose voxels' verdicts are kept a byte each (64 MB).
constexpr std::size_t kDenseWindow = std::size_t{1} << 26;

/// A move's number: (dx + 1) * 9 + (dy + 1) * 3 + (dz + 1); 13 is no move (the start).
constexpr int kNoMove = 13;

VoxelIndex moveStep(int move) { return {move / 9 - 1, move / 3 % 3 - 1, move % 3 - 1}; }
int moveOf(const VoxelIndex& step) {
  return (step.x() + 1) * 9 + (step.y() + 1) * 3 + step.z() + 1;
}
double stepLength(const VoxelIndex& step) { return std::sqrt(step.squaredNorm()); }
/// The unit move of a straight or diagonal line of moves.
VoxelIndex direction(const VoxelIndex& offset) {
  const int steps = offset.cwiseAbs().maxCoeff();
  return steps == 0 ? offset : VoxelIndex(offset / steps);
}

/// The voxels (offsets from `from`) of the cube a move spans, `from` and the target excluded.
std::vector<VoxelIndex> spannedVoxels(const VoxelIndex& from, const VoxelIndex& step) {
  std::vector<VoxelIndex> voxels;
  for (int mask = 1; mask < 7; ++mask) {
    VoxelIndex offset = VoxelIndex::Zero();
    for (int axis = 0; axis < 3; ++axis) {
      if ((mask >> axis) & 1) offset[axis] = step[axis];
    }
    if (offset != VoxelIndex::Zero() && offset != step &&
        std::find(voxels.begin(), voxels.end(), from + offset) == voxels.end()) {
      voxels.push_back(from + offset);
    }
  }
  return voxels;
}

/// JPS's pruning of the neighbours of a node n reached by move d from its parent p = n - d
/// (Harabor and Grastien's rule, derived here for 26 neighbours and no corner cutting): a
/// neighbour x is pruned when, in the free 3 x 3 x 3 block around n, a path p .. x avoiding n
/// is no longer (d straight) or shorter (d diagonal) than p, n, x. It is forced when a voxel
/// that path needs (its `witnesses`) is blocked; natural when no such path exists.
struct Pruning {
  std::array<bool, 27> natural{};
  std::array<std::vector<VoxelIndex>, 27> witnesses;  // empty: never forced
};

Pruning derivePruning(int move) {
  Pruning pruning;
  const VoxelIndex d = moveStep(move);
  const VoxelIndex parent = -d;
  auto cellOf = [](const VoxelIndex& v) { return moveOf(v); };
  // Dijkstra from p over the block without n (27 cells: brute force is enough).
  std::array<double, 27> cost;
  std::array<int, 27> previous;
  cost.fill(INFINITY);
  previous.fill(-1);
  std::array<bool, 27> done{};
  cost[cellOf(parent)] = 0.0;
  for (int round = 0; round < 27; ++round) {
    int best = -1;
    for (int c = 0; c < 27; ++c) {
      if (c != kNoMove && !done[c] && (best < 0 || cost[c] < cost[best])) best = c;
    }
    if (best < 0 || !std::isfinite(cost[best])) break;
    done[best] = true;
    for (int m = 0; m < 27; ++m) {
      const VoxelIndex next = moveStep(best) + moveStep(m);
      if (m == kNoMove || next.cwiseAbs().maxCoeff() > 1 || next == VoxelIndex::Zero()) continue;
      const double through = cost[best] + stepLength(moveStep(m));
      if (through < cost[cellOf(next)] - 1e-12) {
        cost[cellOf(next)] = through;
        previous[cellOf(next)] = best;
      }
    }
  }
  const bool straight = d.cwiseAbs().sum() == 1;
  for (int x = 0; x < 27; ++x) {
    if (x == kNoMove || moveStep(x) == parent) continue;
    const double via = stepLength(d) + stepLength(moveStep(x));
    const bool pruned = straight ? cost[x] <= via + 1e-9 : cost[x] < via - 1e-9;
    if (!pruned) {
      pruning.natural[x] = true;
      continue;
    }
    std::vector<VoxelIndex>& witnesses = pruning.witnesses[x];
    for (int c = x; previous[c] >= 0; c = previous[c]) {
      const VoxelIndex from = moveStep(previous[c]);
      for (const VoxelIndex& v : spannedVoxels(from, moveStep(c) - from)) witnesses.push_back(v);
      if (previous[c] != cellOf(parent)) witnesses.push_back(from);
    }
    std::erase_if(witnesses, [&](const VoxelIndex& v) {
      return v == VoxelIndex::Zero() || v == parent || v == moveStep(x);
    });
  }
  return pruning;
}

const std::array<Pruning, 27>& prunings() {
  static const std::array<Pruning, 27> table = [] {
    std::array<Pruning, 27> all;
    for (int move = 0; move < 27; ++move) {
      if (move != kNoMove) all[move] = derivePruning(move);
    }
    return all;
  }();
  return table;
}

struct Node {
  VoxelIndex voxel;
  double cost = 0.0;  // voxels
  int parent = -1;
  int move = kNoMove;  // the move that reached it (JPS: the jump's direction)
  bool closed = false;
};

struct Open {
  double estimate;
  double cost;
  int node;
  bool operator<(const Open& other) const {  // the priority queue's top is the largest
    if (estimate != other.estimate) return estimate > other.estimate;
    if (cost != other.cost) return cost < other.cost;  // ties: the deeper node first
    return node > other.node;
  }
};

class Search {
 public:
  Search(const FreeVoxels& voxels, const VoxelIndex& goal, StopCondition& stop)
      : voxels_(voxels), goal_(goal), stop_(stop) {}

  GridSearchResult run(const VoxelIndex& start, GridAlgorithm algorithm);

 private:
  void push(const VoxelIndex& voxel, double cost, int parent, int move);
  void expandAStar(int node);
  void expandJps(int node);
  /// JPS: the first jump point from `from` along `move`, or none.
  std::optional<VoxelIndex> jump(VoxelIndex from, int move);
  /// Whether a jump along a part of the diagonal `step` from `voxel` finds a jump point.
  bool subJumpFinds(const VoxelIndex& voxel, const VoxelIndex& step);
  bool hasForcedNeighbour(const VoxelIndex& voxel, int move) const;
  bool forced(const VoxelIndex& voxel, int move, int neighbour) const;

  const FreeVoxels& voxels_;
  VoxelIndex goal_;
  StopCondition& stop_;
  std::vector<Node> nodes_;
  std::unordered_map<std::size_t, int> ids_;
  /// JPS: the jump point (or none) of a jump from a voxel along a move (index * 27 + move).
  std::unordered_map<std::size_t, std::optional<VoxelIndex>> jumps_;
  std::priority_queue<Open> open_;
  GridSearchResult result_;
};

void Search::push(const VoxelIndex& voxel, double cost, int parent, int move) {
  const std::size_t key = voxels_.grid().index(voxel);
  auto [found, inserted] = ids_.try_emplace(key, static_cast<int>(nodes_.size()));
  if (inserted) {
    nodes_.push_back({voxel, cost, parent, move, false});
  } else {
    Node& node = nodes_[found->second];
    if (node.closed || cost >= node.cost - 1e-12) return;
    node.cost = cost;
    node.parent = parent;
    node.move = move;
  }
  ++result_.generated;
  open_.push({cost + octileDistance(voxel, goal_), cost, found->second});
}

void Search::expandAStar(int node) {
  const VoxelIndex voxel = nodes_[node].voxel;
  const double cost = nodes_[node].cost;
  for (int move = 0; move < 27; ++move) {
    const VoxelIndex step = moveStep(move);
    if (move == kNoMove || !voxels_.canMove(voxel, step)) continue;
    push(voxel + step, cost + stepLength(step), node, move);
  }
}

bool Search::forced(const VoxelIndex& voxel, int move, int neighbour) const {
  const std::vector<VoxelIndex>& witnesses = prunings()[move].witnesses[neighbour];
  return std::any_of(witnesses.begin(), witnesses.end(),
                     [&](const VoxelIndex& w) { return !voxels_.free(voxel + w); });
}

bool Search::hasForcedNeighbour(const VoxelIndex& voxel, int move) const {
  const Pruning& pruning = prunings()[move];
  for (int x = 0; x < 27; ++x) {
    if (pruning.natural[x] || pruning.witnesses[x].empty()) continue;
    if (forced(voxel, move, x) && voxels_.canMove(voxel, moveStep(x))) return true;
  }
  return false;
}

std::optional<VoxelIndex> Search::jump(VoxelIndex from, int move) {
  const VoxelIndex step = moveStep(move);
  const bool diagonal = step.cwiseAbs().sum() > 1;
  const auto key = [&](const VoxelIndex& voxel) {
    return voxels_.grid().index(voxel) * 27 + static_cast<std::size_t>(move);
  };
  // Every voxel walked over jumps to the same point along this move: remembered, a diagonal
  // jump's sub-jumps from the next voxels cost one look-up each, not a walk to the wall.
  std::vector<std::size_t> walked;
  std::optional<VoxelIndex> found;
  while (voxels_.canMove(from, step)) {
    walked.push_back(key(from));
    if (const auto known = jumps_.find(key(from)); known != jumps_.end()) {
      found = known->second;
      walked.pop_back();
      break;
    }
    from += step;
    ++result_.jump_steps;
    if (from == goal_ || hasForcedNeighbour(from, move) || (diagonal && subJumpFinds(from, step))) {
      found = from;
      break;
    }
  }
  for (const std::size_t start : walked) jumps_.emplace(start, found);
  return found;
}

bool Search::subJumpFinds(const VoxelIndex& voxel, const VoxelIndex& step) {
  // A jump point on a line along a part of the move makes this one a jump point.
  for (int part = 0; part < 27; ++part) {
    const VoxelIndex sub = moveStep(part);
    if (part == kNoMove || sub == step || (sub.array() * step.array() != sub.array().abs()).any()) {
      continue;
    }
    if (jump(voxel, part)) return true;
  }
  return false;
}

void Search::expandJps(int node) {
  const VoxelIndex voxel = nodes_[node].voxel;
  const double cost = nodes_[node].cost;
  const int incoming = nodes_[node].move;
  for (int move = 0; move < 27; ++move) {
    const bool successor =
        incoming == kNoMove || prunings()[incoming].natural[move] || forced(voxel, incoming, move);
    if (move == kNoMove || !successor) continue;
    const std::optional<VoxelIndex> point = jump(voxel, move);
    if (!point) continue;
    const double length = stepLength(moveStep(move)) * (*point - voxel).cwiseAbs().maxCoeff();
    push(*point, cost + length, node, move);
  }
}

GridSearchResult Search::run(const VoxelIndex& start, GridAlgorithm algorithm) {
  push(start, 0.0, -1, kNoMove);
  while (!open_.empty()) {
    const Open top = open_.top();
    open_.pop();
    Node& node = nodes_[top.node];
    if (node.closed || top.cost > node.cost + 1e-12) continue;
    node.closed = true;
    if (node.voxel == goal_) {
      result_.found = true;
      result_.length = node.cost * voxels_.grid().resolution();
      for (int n = top.node; n >= 0; n = nodes_[n].parent)
        result_.voxels.push_back(nodes_[n].voxel);
      std::reverse(result_.voxels.begin(), result_.voxels.end());
      return result_;
    }
    if (stop_.expired(result_.expansions)) {
      result_.stopped = true;
      return result_;
    }
    ++result_.expansions;
    if (algorithm == GridAlgorithm::kAStar) {
      expandAStar(top.node);
    } else {
      expandJps(top.node);
    }
  }
  return result_;
}

}  // namespace

FreeVoxels::FreeVoxels(const World& world, double radius)
    : FreeVoxels(world, radius, VoxelIndex::Zero(), world.grid().dims() - VoxelIndex::Ones()) {}

FreeVoxels::FreeVoxels(const World& world, double radius, const VoxelIndex& low,
                       const VoxelIndex& high)
    : world_(world),
      radius_(radius),
      low_(low.cwiseMax(VoxelIndex::Zero())),
      high_(high.cwiseMin(world.grid().dims() - VoxelIndex::Ones())) {
  const VoxelIndex size = (high_ - low_ + VoxelIndex::Ones()).cwiseMax(VoxelIndex::Zero());
  const auto voxels = static_cast<std::size_t>(size.x()) * size.y() * size.z();
  if (voxels <= kDenseWindow) known_.assign(voxels, 0);
}

std::size_t FreeVoxels::local(const VoxelIndex& voxel) const {
  const VoxelIndex offset = voxel - low_;
  const VoxelIndex size = high_ - low_ + VoxelIndex::Ones();
  return (static_cast<std::size_t>(offset.x()) * size.y() + offset.y()) * size.z() + offset.z();
}

bool FreeVoxels::free(const VoxelIndex& voxel) const {
  if ((voxel.array() < low_.array()).any() || (voxel.array() > high_.array()).any()) return false;
  std::uint8_t& known = known_.empty() ? sparse_known_[local(voxel)] : known_[local(voxel)];
  if (known == 0) {
    ++evaluations_;
    const Eigen::Vector3d centre = world_.grid().center(voxel);
    const bool is_free =
        world_.bounds().contains(centre) && world_.clearanceFor(centre, radius_) >= radius_;
    known = is_free ? 1 : 2;
  }
  return known == 1;
}

bool FreeVoxels::canMove(const VoxelIndex& voxel, const VoxelIndex& step) const {
  if (!free(voxel + step)) return false;
  for (int mask = 1; mask < 7; ++mask) {
    VoxelIndex offset = VoxelIndex::Zero();
    for (int axis = 0; axis < 3; ++axis) {
      if ((mask >> axis) & 1) offset[axis] = step[axis];
    }
    if (offset != step && offset != VoxelIndex::Zero() && !free(voxel + offset)) return false;
  }
  return true;
}

GridSearchResult searchGrid(const FreeVoxels& voxels, const VoxelIndex& start,
                            const VoxelIndex& goal, GridAlgorithm algorithm, StopCondition& stop) {
  if (!voxels.free(start) || !voxels.free(goal)) return {};
  return Search(voxels, goal, stop).run(start, algorithm);
}

double octileDistance(const VoxelIndex& a, const VoxelIndex& b) {
  std::array<int, 3> d{std::abs(a.x() - b.x()), std::abs(a.y() - b.y()), std::abs(a.z() - b.z())};
  std::sort(d.begin(), d.end());  // d[0] <= d[1] <= d[2]
  return (std::sqrt(3.0) - std::sqrt(2.0)) * d[0] + (std::sqrt(2.0) - 1.0) * d[1] + d[2];
}

std::vector<Eigen::Vector3d> voxelCentres(const VoxelGrid& grid,
                                          const std::vector<VoxelIndex>& voxels) {
  std::vector<Eigen::Vector3d> centres;
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const bool collinear =
        i > 0 && i + 1 < voxels.size() &&
        direction(voxels[i] - voxels[i - 1]) == direction(voxels[i + 1] - voxels[i]);
    if (!collinear) centres.push_back(grid.center(voxels[i]));
  }
  return centres;
}

}  // namespace kinolab::grid
