#include <algorithm>
#include <cmath>
#include <queue>

#include "column_cells.hpp"
#include "kinolab/flight/vehicle_map.hpp"

namespace kinolab {

using namespace column_cells;

namespace {

/// A shortest path of nodes (level * nx * ny + x * ny + y) over the nodes not `blocked`, from
/// `start` at `start_level` to `goal` at any level: 8-connected within a level, and up or down
/// one level at a cell open in both at the cost `rises` (rises[k]: from level k - 1 to k, in
/// cells). A* with the octile distance in x and y. Empty when there is none.
std::vector<std::size_t> levelPath(const std::vector<std::uint8_t>& blocked, int nx, int ny,
                                   const std::vector<double>& rises, std::size_t start_level,
                                   const Eigen::Vector2i& start, const Eigen::Vector2i& goal) {
  const std::size_t cells = static_cast<std::size_t>(nx) * ny;
  const auto octile = [&](std::size_t cell) {
    const int dx = std::abs(static_cast<int>(cell / ny) - goal.x());
    const int dy = std::abs(static_cast<int>(cell % ny) - goal.y());
    return static_cast<double>(std::max(dx, dy)) + (M_SQRT2 - 1.0) * std::min(dx, dy);
  };
  std::vector<double> cost(blocked.size(), INFINITY);
  std::vector<std::int64_t> parent(blocked.size(), -1);
  using Entry = std::pair<double, std::size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const std::size_t first =
      start_level * cells + static_cast<std::size_t>(start.x()) * ny + start.y();
  const std::size_t goal_cell = static_cast<std::size_t>(goal.x()) * ny + goal.y();
  cost[first] = 0.0;
  open.emplace(octile(first % cells), first);
  const auto relax = [&](std::size_t at, std::size_t next, double step) {
    if (blocked[next] || cost[at] + step >= cost[next]) return;
    cost[next] = cost[at] + step;
    parent[next] = static_cast<std::int64_t>(at);
    open.emplace(cost[next] + octile(next % cells), next);
  };
  while (!open.empty()) {
    const auto [f, at] = open.top();
    open.pop();
    const std::size_t level = at / cells;
    const std::size_t cell = at % cells;
    if (f > cost[at] + octile(cell) + 1e-9) continue;  // stale
    if (cell == goal_cell) {
      return wayTo(parent, at);
    }
    const int x = static_cast<int>(cell / ny);
    const int y = static_cast<int>(cell % ny);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        if ((dx == 0 && dy == 0) || x + dx < 0 || y + dy < 0 || x + dx >= nx || y + dy >= ny) {
          continue;
        }
        const auto next = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(at) + dx * ny + dy);
        relax(at, next, dx != 0 && dy != 0 ? M_SQRT2 : 1.0);
      }
    }
    if (level > 0) relax(at, at - cells, rises[level]);
    if (level + 1 < rises.size()) relax(at, at + cells, rises[level + 1]);
  }
  return {};
}

}  // namespace

std::vector<std::vector<Eigen::Vector3d>> levelColumnGuides(
    const VoxelGrid& lattice, const ObstacleColumns& obstacles,
    std::span<const Eigen::Vector3d> froms, const Eigen::Vector3d& to, double radius,
    std::span<const double> levels, double room, double inset,
    std::span<const Eigen::Vector3d> trail) {
  std::vector<std::vector<Eigen::Vector3d>> paths(froms.size());
  if (levels.empty()) return paths;
  const Eigen::Vector3i& n = lattice.dims();
  const std::size_t cells = static_cast<std::size_t>(n.x()) * n.y();
  const auto nearest = [&](double z) {
    std::size_t best = 0;
    for (std::size_t k = 1; k < levels.size(); ++k) {
      if (std::abs(levels[k] - z) < std::abs(levels[best] - z)) best = k;
    }
    return best;
  };
  // Node level * cells + x * ny + y; closed as columnGuides() closes a cell of each level.
  std::vector<std::uint8_t> blocked(levels.size() * cells);
  for (std::size_t k = 0; k < levels.size(); ++k) {
    std::vector<std::uint8_t> level =
        closedCells(lattice, obstacles, radius, levels[k] - radius, levels[k] + radius, inset);
    if (room > 0.0) openRound(lattice, level, to, room);
    openTrail(lattice, level, trail, levels[k] - radius, levels[k] + radius);
    std::copy(level.begin(), level.end(), blocked.begin() + static_cast<std::ptrdiff_t>(k * cells));
  }
  const Eigen::Vector2i goal = cellOf(lattice, to);
  // A climb or descent of one level costs its height, in cells.
  std::vector<double> rises(levels.size(), 0.0);
  for (std::size_t k = 1; k < levels.size(); ++k) {
    rises[k] = (levels[k] - levels[k - 1]) / lattice.resolution();
  }
  for (std::size_t i = 0; i < froms.size(); ++i) {
    const Eigen::Vector3d& from = froms[i];
    std::vector<std::uint8_t> open = blocked;
    const std::size_t start_level = nearest(from.z());
    openRound(lattice, std::span(open).subspan(start_level * cells, cells), from,
              room);  // the vehicle is here
    const std::vector<std::size_t> nodes =
        levelPath(open, n.x(), n.y(), rises, start_level, cellOf(lattice, from), goal);
    std::vector<Eigen::Vector3d>& path = paths[i];
    for (const std::size_t node : nodes) {
      const std::size_t cell = node % cells;
      const Eigen::Vector3d centre = lattice.center(
          VoxelIndex(static_cast<int>(cell / n.y()), static_cast<int>(cell % n.y()), 0));
      path.emplace_back(centre.x(), centre.y(), levels[node / cells]);
    }
    if (path.empty()) continue;
    path.front() = from;
    path.back() = to;
  }
  return paths;
}

}  // namespace kinolab
