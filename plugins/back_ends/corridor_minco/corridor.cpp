#include "corridor.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace kinolab::minco {

void Polytope::add(const Eigen::Vector3d& normal, double offset) {
  const int count = size();
  normals.conservativeResize(3, count + 1);
  offsets.conservativeResize(count + 1);
  normals.col(count) = normal;
  offsets(count) = offset;
}

double Polytope::excess(const Eigen::Vector3d& point) const {
  if (size() == 0) return -INFINITY;
  return (normals.transpose() * point - offsets).maxCoeff();
}

std::vector<Eigen::Vector3d> shortcutPath(const World& world,
                                          const std::vector<Eigen::Vector3d>& path,
                                          const Body& body) {
  std::vector<Eigen::Vector3d> kept;
  if (path.empty()) return kept;
  kept.push_back(path.front());
  std::size_t from = 0;
  while (from + 1 < path.size()) {
    // The next point is kept even when the line to it is not open (a sampled trajectory's
    // chord may graze an obstacle): the corridor then excludes that part, soundly.
    std::size_t to = from + 1;
    while (to + 1 < path.size() &&
           world.segmentFree(path[from], path[to + 1], body.verdictRadius(), body.tolerance)) {
      ++to;
    }
    kept.push_back(path[to]);
    from = to;
  }
  return kept;
}

namespace {

/// An occupied voxel cube: its centre and half side.
struct Cube {
  Eigen::Vector3d centre;
  double half = 0.0;

  Eigen::Vector3d closest(const Eigen::Vector3d& point) const {
    return point.cwiseMax(centre - Eigen::Vector3d::Constant(half))
        .cwiseMin(centre + Eigen::Vector3d::Constant(half));
  }
  /// The least n . v over its corners.
  double lowest(const Eigen::Vector3d& normal) const {
    return normal.dot(centre) - half * normal.lpNorm<1>();
  }
};

/// The closest points of the segment and the cube: the squared distance from the segment's
/// point at t to the cube is convex in t, so a golden-section search finds its minimum.
std::pair<Eigen::Vector3d, Eigen::Vector3d> closestPoints(const Eigen::Vector3d& a,
                                                          const Eigen::Vector3d& b,
                                                          const Cube& cube) {
  const auto gap = [&](double t) {
    const Eigen::Vector3d point = a + t * (b - a);
    return (cube.closest(point) - point).squaredNorm();
  };
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double low = 0.0;
  double high = 1.0;
  for (int i = 0; i < 48; ++i) {
    const double left = high - ratio * (high - low);
    const double right = low + ratio * (high - low);
    if (gap(left) <= gap(right)) {
      high = right;
    } else {
      low = left;
    }
  }
  const Eigen::Vector3d point = a + 0.5 * (low + high) * (b - a);
  return {point, cube.closest(point)};
}

double segmentPointDistanceSquared(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& point) {
  const Eigen::Vector3d direction = b - a;
  const double length = direction.squaredNorm();
  const double t = length > 0.0 ? std::clamp((point - a).dot(direction) / length, 0.0, 1.0) : 0.0;
  return (a + t * direction - point).squaredNorm();
}

/// The occupied cubes with a free (or outside) face neighbour whose `radius` neighbourhood
/// meets `box`, nearest to the segment first.
std::vector<Cube> surfaceCubes(const VoxelGrid& grid, const Box& box, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, double radius) {
  const double resolution = grid.resolution();
  const auto voxelOf = [&](const Eigen::Vector3d& point) {
    const Eigen::Vector3d local = (point - grid.origin()) / resolution;
    return VoxelIndex(static_cast<int>(std::floor(local.x())),
                      static_cast<int>(std::floor(local.y())),
                      static_cast<int>(std::floor(local.z())));
  };
  const Eigen::Vector3d reach = Eigen::Vector3d::Constant(radius);
  const VoxelIndex low = voxelOf(box.min - reach).cwiseMax(VoxelIndex::Zero());
  const VoxelIndex high = voxelOf(box.max + reach).cwiseMin(grid.dims() - VoxelIndex::Ones());
  std::vector<std::pair<double, Cube>> found;
  const VoxelIndex steps[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int x = low.x(); x <= high.x(); ++x) {
    for (int y = low.y(); y <= high.y(); ++y) {
      for (int z = low.z(); z <= high.z(); ++z) {
        const VoxelIndex voxel(x, y, z);
        if (!grid.occupied(voxel)) continue;
        const bool surface = std::any_of(std::begin(steps), std::end(steps), [&](const auto& step) {
          const VoxelIndex next = voxel + step;
          return !grid.inside(next) || !grid.occupied(next);
        });
        if (!surface) continue;
        const Cube cube{grid.center(voxel), 0.5 * resolution};
        found.emplace_back(segmentPointDistanceSquared(a, b, cube.centre), cube);
      }
    }
  }
  // Ties broken by position, so that the order (and the polytope) never depends on the sort.
  std::sort(found.begin(), found.end(), [](const auto& left, const auto& right) {
    if (left.first != right.first) return left.first < right.first;
    return std::lexicographical_compare(left.second.centre.data(), left.second.centre.data() + 3,
                                        right.second.centre.data(), right.second.centre.data() + 3);
  });
  std::vector<Cube> cubes;
  cubes.reserve(found.size());
  for (const auto& [distance, cube] : found) cubes.push_back(cube);
  return cubes;
}

}  // namespace

Polytope corridorAround(const World& world, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        double box_half_size, double radius, CorridorTally* tally) {
  const Box& bounds = world.bounds();
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(box_half_size);
  const Box box{a.cwiseMin(b) - grow, a.cwiseMax(b) + grow};
  const Box clipped{box.min.cwiseMax(bounds.min), box.max.cwiseMin(bounds.max)};
  Polytope polytope;
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d unit = Eigen::Vector3d::Unit(axis);
    polytope.add(unit, clipped.max[axis]);
    polytope.add(-unit, -clipped.min[axis]);
  }
  const std::vector<Cube> cubes = surfaceCubes(world.grid(), clipped, a, b, radius);
  int cuts = 0;
  for (const Cube& cube : cubes) {
    // Cut off already: some plane has the whole cube, grown by the radius, beyond it.
    bool excluded = false;
    for (int i = 6; i < polytope.size() && !excluded; ++i) {
      excluded = cube.lowest(polytope.normals.col(i)) - radius >= polytope.offsets(i);
    }
    if (excluded) continue;
    const auto [on_segment, on_cube] = closestPoints(a, b, cube);
    Eigen::Vector3d normal = on_cube - on_segment;
    // A segment through the cube (a path that is not free): the plane faces the cube's centre.
    if (normal.norm() < 1e-9) normal = cube.centre - on_segment;
    if (normal.norm() < 1e-9) normal = Eigen::Vector3d::UnitZ();
    normal.normalize();
    // Sound whatever the normal: every corner of the cube is at least `radius` beyond it.
    polytope.add(normal, cube.lowest(normal) - radius);
    ++cuts;
  }
  if (tally != nullptr) {
    tally->obstacles += static_cast<int>(cubes.size());
    tally->halfspaces += cuts;
  }
  return polytope;
}

}  // namespace kinolab::minco
