#include "grid_path.hpp"

#include <cmath>

namespace kinolab::grid {
namespace {

/// Drops a point equal to the one before it.
void appendDistinct(std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& point) {
  if (points.empty() || points.back() != point) points.push_back(point);
}

/// From each kept point, the farthest later point seen along a free straight line; the next
/// point is always kept (its piece is free: a voxel move or a checked connection).
std::vector<Eigen::Vector3d> shortcut(const World& world, const Body& body,
                                      const std::vector<Eigen::Vector3d>& points,
                                      long long& checks) {
  std::vector<Eigen::Vector3d> kept{points.front()};
  std::size_t anchor = 0;
  while (anchor + 1 < points.size()) {
    std::size_t reach = anchor + 1;
    for (std::size_t next = points.size() - 1; next > anchor + 1; --next) {
      ++checks;
      if (segmentFree(world, points[anchor], points[next], body)) {
        reach = next;
        break;
      }
    }
    kept.push_back(points[reach]);
    anchor = reach;
  }
  return kept;
}

}  // namespace

bool segmentFree(const World& world, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 const Body& body) {
  return world.segmentFree(a, b, body.verdictRadius(), body.tolerance);
}

std::optional<VoxelIndex> connectedVoxel(const FreeVoxels& voxels, const Eigen::Vector3d& position,
                                         const Body& body) {
  const VoxelGrid& grid = voxels.grid();
  const VoxelIndex own =
      ((position - grid.origin()) / grid.resolution()).array().floor().cast<int>();
  std::optional<VoxelIndex> best;
  double best_distance = INFINITY;
  for (int move = 0; move < 27; ++move) {
    const VoxelIndex voxel = own + VoxelIndex(move / 9 - 1, move / 3 % 3 - 1, move % 3 - 1);
    if (!grid.inside(voxel) || !voxels.free(voxel)) continue;
    const double distance = (grid.center(voxel) - position).norm();
    if (distance < best_distance &&
        segmentFree(voxels.world(), position, grid.center(voxel), body)) {
      best = voxel;
      best_distance = distance;
    }
  }
  return best;
}

GridPath findGridPath(const World& world, const Body& body, const Eigen::Vector3d& start,
                      const Eigen::Vector3d& goal, GridAlgorithm algorithm, StopCondition& stop) {
  GridPath result;
  const FreeVoxels voxels(world, body.keptRadius());
  const std::optional<VoxelIndex> first = connectedVoxel(voxels, start, body);
  const std::optional<VoxelIndex> last = connectedVoxel(voxels, goal, body);
  if (!first || !last) {
    result.outcome =
        first ? GridPath::Outcome::kGoalUnconnected : GridPath::Outcome::kStartUnconnected;
    result.message = std::string("no free voxel next to the ") + (first ? "goal" : "start") +
                     " is joined to it by a free straight segment";
    return result;
  }
  result.search = searchGrid(voxels, *first, *last, algorithm, stop);
  result.voxel_evaluations = voxels.evaluations();
  if (!result.search.found) {
    result.outcome =
        result.search.stopped ? GridPath::Outcome::kStopped : GridPath::Outcome::kNoPath;
    result.message =
        result.search.stopped
            ? "budget spent after " + std::to_string(result.search.expansions) + " expansions"
            : "no voxel path: the goal's free space is not connected to the start's";
    return result;
  }
  result.outcome = GridPath::Outcome::kFound;
  appendDistinct(result.grid_path, start);
  for (const Eigen::Vector3d& centre : voxelCentres(world.grid(), result.search.voxels)) {
    appendDistinct(result.grid_path, centre);
  }
  appendDistinct(result.grid_path, goal);
  result.grid_length = polylineLength(result.grid_path);
  result.path = shortcut(world, body, result.grid_path, result.line_of_sight_checks);
  result.length = polylineLength(result.path);
  return result;
}

double polylineLength(const std::vector<Eigen::Vector3d>& points) {
  double length = 0.0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  return length;
}

}  // namespace kinolab::grid
