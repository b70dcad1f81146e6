#include "kinolab/flight/difficulty.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "kinolab/flight/vehicle_map.hpp"

namespace kinolab {
namespace {

constexpr double kSensingRange = 4.0;  // m, FlightBench's R

/// The polyline with every corner cut whose shortcut the body clears (greedy: from each
/// kept point, the farthest later point in sight).
std::vector<Eigen::Vector3d> shortened(const World& truth, const std::vector<Eigen::Vector3d>& path,
                                       double radius) {
  if (path.size() < 3) return path;
  std::vector<Eigen::Vector3d> kept{path.front()};
  std::size_t at = 0;
  while (at + 1 < path.size()) {
    std::size_t next = at + 1;
    for (std::size_t j = path.size() - 1; j > at + 1; --j) {
      if (truth.segmentFree(path[at], path[j], radius)) {
        next = j;
        break;
      }
    }
    kept.push_back(path[next]);
    at = next;
  }
  return kept;
}

double lengthOf(const std::vector<Eigen::Vector3d>& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

/// Points every `step` along the path (from its start), each with the direction of its leg.
std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> along(
    const std::vector<Eigen::Vector3d>& path, double step) {
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> points;
  double offset = 0.0;  // where the next point lies on the current leg
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Eigen::Vector3d leg = path[i] - path[i - 1];
    const double length = leg.norm();
    if (length <= 0.0) continue;
    for (; offset <= length; offset += step) {
      points.emplace_back(path[i - 1] + offset / length * leg, leg / length);
    }
    offset -= length;
  }
  return points;
}

double traversabilityObstruction(const World& truth, const std::vector<Eigen::Vector3d>& guide,
                                 double radius) {
  // FlightBench grows a corridor of spheres along the guide, sampling each centre near the
  // path for the largest sphere; here each sphere is the largest centred on a 5 x 5 grid
  // across the path, up to 0.5 m either way (in the plane normal to it).
  constexpr double kAcross = 0.5;
  std::vector<double> radii;
  for (const auto& [point, direction] : along(guide, 0.3)) {
    const Eigen::Vector3d side = direction.cross(Eigen::Vector3d::UnitZ()).norm() > 1e-6
                                     ? direction.cross(Eigen::Vector3d::UnitZ()).normalized()
                                     : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d up = side.cross(direction).normalized();
    double best = 0.0;
    for (int i = -2; i <= 2; ++i) {
      for (int j = -2; j <= 2; ++j) {
        const Eigen::Vector3d centre = point + 0.5 * kAcross * (i * side + j * up);
        if (!truth.isFree(centre, radius)) continue;
        best = std::max(best, truth.esdf().exactDistance(centre, kSensingRange + radius) - radius);
      }
    }
    radii.push_back(std::clamp(best, 0.01, kSensingRange));
  }
  std::sort(radii.begin(), radii.end());
  const std::size_t n = std::max<std::size_t>(1, radii.size() / 2);
  double sum = 0.0;
  for (std::size_t i = 0; i < n && i < radii.size(); ++i) sum += 1.0 / radii[i];
  return kSensingRange / (2.0 * static_cast<double>(n)) * sum;
}

double viewOcclusion(const World& truth, const std::vector<Eigen::Vector3d>& guide) {
  const VoxelGrid& grid = truth.grid();
  // The cones' half-angles' cosines, widest first, and their weights.
  const double cosines[4] = {std::cos(M_PI / 5), std::cos(M_PI / 6), std::cos(M_PI / 8),
                             std::cos(M_PI / 12)};
  const double weights[4] = {0.05, 0.1, 0.3, 0.55};
  double total = 0.0;
  int samples = 0;
  for (const auto& [point, direction] : along(guide, kSensingRange / 10.0)) {
    double nearest[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
    Eigen::Vector3i low;
    Eigen::Vector3i high;
    if (grid.voxelRange(point.array() - kSensingRange, point.array() + kSensingRange, low, high)) {
      for (int x = low.x(); x <= high.x(); ++x) {
        for (int y = low.y(); y <= high.y(); ++y) {
          for (int z = low.z(); z <= high.z(); ++z) {
            if (!grid.occupied(VoxelIndex(x, y, z))) continue;
            const Eigen::Vector3d offset = grid.center(VoxelIndex(x, y, z)) - point;
            const double distance = offset.norm();
            if (distance > kSensingRange || distance <= 0.0) continue;
            const double cosine = offset.dot(direction) / distance;
            // The narrowest cone that holds it (FlightBench's bins).
            int bin = -1;
            for (int k = 0; k < 4; ++k) {
              if (cosine >= cosines[k]) bin = k;
            }
            if (bin >= 0) nearest[bin] = std::min(nearest[bin], distance);
          }
        }
      }
    }
    double sight = 0.0;
    for (int k = 0; k < 4; ++k) sight += weights[k] * kSensingRange / nearest[k];
    total += sight;
    ++samples;
  }
  return samples > 0 ? total / samples : NAN;
}

double angleOverLength(const std::vector<Eigen::Vector3d>& guide, double length) {
  double sum = 0.0;
  for (std::size_t i = 1; i + 1 < guide.size(); ++i) {
    const Eigen::Vector3d a = (guide[i] - guide[i - 1]).normalized();
    const Eigen::Vector3d b = (guide[i + 1] - guide[i]).normalized();
    sum += std::exp(2.0 * std::acos(std::clamp(a.dot(b), -1.0, 1.0)) / M_PI) - 1.0;
  }
  return length > 0.0 ? sum / length : NAN;
}

double obstaclesPerHectare(const World& truth, double height) {
  const VoxelGrid& grid = truth.grid();
  const Eigen::Vector3i& n = grid.dims();
  const int z = static_cast<int>(std::floor((height - grid.origin().z()) / grid.resolution()));
  if (z < 0 || z >= n.z()) return NAN;
  // 8-connected areas of the slice, by flood fill.
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(n.x()) * n.y(), 0);
  std::vector<Eigen::Vector2i> stack;
  int areas = 0;
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      if (seen[static_cast<std::size_t>(x) * n.y() + y] || !grid.occupied(VoxelIndex(x, y, z))) {
        continue;
      }
      ++areas;
      stack.emplace_back(x, y);
      seen[static_cast<std::size_t>(x) * n.y() + y] = 1;
      while (!stack.empty()) {
        const Eigen::Vector2i c = stack.back();
        stack.pop_back();
        for (int dx = -1; dx <= 1; ++dx) {
          for (int dy = -1; dy <= 1; ++dy) {
            const int cx = c.x() + dx;
            const int cy = c.y() + dy;
            if (cx < 0 || cy < 0 || cx >= n.x() || cy >= n.y()) continue;
            std::uint8_t& mark = seen[static_cast<std::size_t>(cx) * n.y() + cy];
            if (mark || !grid.occupied(VoxelIndex(cx, cy, z))) continue;
            mark = 1;
            stack.emplace_back(cx, cy);
          }
        }
      }
    }
  }
  const Eigen::Vector3d extent = grid.bounds().max - grid.bounds().min;
  return areas / (extent.x() * extent.y() / 1e4);
}

}  // namespace

ScenarioDifficulty scenarioDifficulty(const World& truth, const PlanningQuery& query,
                                      double robot_radius) {
  ScenarioDifficulty difficulty;
  const Eigen::Vector3d start = query.start.col(0);
  difficulty.obstacles_per_hectare = obstaclesPerHectare(truth, start.z());
  const double z_low = std::min(start.z(), query.goal.z()) - 0.5;
  const double z_high = std::max(start.z(), query.goal.z()) + 0.5;
  const VoxelGrid& grid = truth.grid();
  // The grid's own occupancy, either layout (a sparse world is never copied out).
  const auto obstacles = [&grid](int x, int z0, int z1, std::uint8_t* row) {
    for (int y = 0; y < grid.dims().y(); ++y) {
      row[y] = 0;
      for (int z = z0; z <= z1 && row[y] == 0; ++z) row[y] = grid.occupied(VoxelIndex(x, y, z));
    }
  };
  const std::vector<Eigen::Vector3d> cells =
      columnGuide(grid, obstacles, start, query.goal, robot_radius, z_low, z_high);
  if (cells.empty()) return difficulty;
  difficulty.guide = shortened(truth, cells, robot_radius);
  difficulty.guide_length = lengthOf(difficulty.guide);
  difficulty.traversability_obstruction =
      traversabilityObstruction(truth, difficulty.guide, robot_radius);
  difficulty.view_occlusion = viewOcclusion(truth, difficulty.guide);
  difficulty.angle_over_length = angleOverLength(difficulty.guide, difficulty.guide_length);
  return difficulty;
}

}  // namespace kinolab
