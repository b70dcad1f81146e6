#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/world/esdf.hpp"

namespace kinolab {

// The tree holds positions relative to the map's origin (the ground truth's minimum corner),
// so that its voxels [k r, (k + 1) r) are exactly the ground truth's voxels.
struct KnownMap::Tree {
  explicit Tree(double resolution) : tree(resolution) {}
  octomap::OcTree tree;
};

namespace {

octomap::point3d toTree(const Eigen::Vector3d& p, const Eigen::Vector3d& origin) {
  const Eigen::Vector3d q = p - origin;
  return {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
}

}  // namespace

KnownMap::KnownMap(const Box& bounds, const MapModel& model)
    : tree_(std::make_unique<Tree>(model.resolution)), bounds_(bounds), model_(model) {
  tree_->tree.setProbHit(model.probability_hit);
  tree_->tree.setProbMiss(model.probability_miss);
}

KnownMap::~KnownMap() = default;
KnownMap::KnownMap(KnownMap&&) noexcept = default;
KnownMap& KnownMap::operator=(KnownMap&&) noexcept = default;

void KnownMap::insert(const SensorFrame& frame, double max_range) {
  octomap::Pointcloud cloud;
  cloud.reserve(frame.hits.size() + frame.misses.size());
  for (const auto& p : frame.hits) cloud.push_back(toTree(p, bounds_.min));
  for (const auto& p : frame.misses) cloud.push_back(toTree(p, bounds_.min));
  // Rays are cut at max_range: the misses (placed beyond it) insert free space only. Inner
  // nodes are not updated (lazy): the window reads leaves only; write() updates them.
  tree_->tree.insertPointCloud(cloud, toTree(frame.origin, bounds_.min), max_range,
                               /*lazy_eval=*/true, /*discretize=*/true);
}

std::shared_ptr<const World> KnownMap::window(const Eigen::Vector3d& center) const {
  const double r = model_.resolution;
  // The window's box on the map's lattice, within the map.
  Box box;
  for (int axis = 0; axis < 3; ++axis) {
    const double half = 0.5 * (axis < 2 ? model_.window : model_.window_height);
    const double low = std::max(bounds_.min[axis], center[axis] - half);
    const double high = std::min(bounds_.max[axis], center[axis] + half);
    box.min[axis] = bounds_.min[axis] + std::floor((low - bounds_.min[axis]) / r + 1e-9) * r;
    box.max[axis] = bounds_.min[axis] + std::ceil((high - bounds_.min[axis]) / r - 1e-9) * r;
    box.max[axis] = std::max(box.max[axis], box.min[axis] + r);
  }
  VoxelGrid grid(box, r);
  const Eigen::Vector3i& n = grid.dims();
  // 0 unknown, 1 known free, 2 known occupied.
  std::vector<std::uint8_t> state(grid.size(), 0);
  const Eigen::Vector3d offset = grid.origin() - bounds_.min;  // window origin in tree frame
  const octomap::point3d low(static_cast<float>(offset.x() + 0.5 * r),
                             static_cast<float>(offset.y() + 0.5 * r),
                             static_cast<float>(offset.z() + 0.5 * r));
  const octomap::point3d high(static_cast<float>(offset.x() + (n.x() - 0.5) * r),
                              static_cast<float>(offset.y() + (n.y() - 0.5) * r),
                              static_cast<float>(offset.z() + (n.z() - 0.5) * r));
  const octomap::OcTree& tree = tree_->tree;
  for (auto it = tree.begin_leafs_bbx(low, high), end = tree.end_leafs_bbx(); it != end; ++it) {
    const std::uint8_t value = tree.isNodeOccupied(*it) ? 2 : 1;
    // A leaf may be a pruned block of 2^k voxels: mark every window voxel it covers.
    const double size = it.getSize();
    const octomap::point3d c = it.getCoordinate();
    Eigen::Vector3i first;
    Eigen::Vector3i last;
    for (int axis = 0; axis < 3; ++axis) {
      const double lo = (c(axis) - 0.5 * size - offset[axis]) / r;
      first[axis] = std::max(0, static_cast<int>(std::lround(lo)));
      last[axis] = std::min(n[axis] - 1, static_cast<int>(std::lround(lo + size / r)) - 1);
    }
    for (int x = first.x(); x <= last.x(); ++x) {
      for (int y = first.y(); y <= last.y(); ++y) {
        for (int z = first.z(); z <= last.z(); ++z) state[grid.index(x, y, z)] = value;
      }
    }
  }
  const double near2 = model_.free_beyond * model_.free_beyond;
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      for (int z = 0; z < n.z(); ++z) {
        const std::size_t i = grid.index(x, y, z);
        bool occupied = state[i] == 2;
        if (state[i] == 0) {
          switch (model_.unknown) {
            case UnknownSpace::kFree:
              break;
            case UnknownSpace::kOccupied:
              occupied = true;
              break;
            case UnknownSpace::kFreeBeyond:
              occupied = (grid.center(VoxelIndex(x, y, z)) - center).squaredNorm() < near2;
              break;
          }
        }
        if (occupied) grid.setOccupied(i, true);
      }
    }
  }
  Esdf esdf(grid);
  return std::make_shared<const World>("known_window", 0, std::move(grid), std::move(esdf));
}

std::size_t KnownMap::knownFree() const {
  std::size_t count = 0;
  const octomap::OcTree& tree = tree_->tree;
  const double r3 = std::pow(model_.resolution, 3);
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it))
      count += static_cast<std::size_t>(std::lround(std::pow(it.getSize(), 3) / r3));
  }
  return count;
}

std::size_t KnownMap::knownOccupied() const { return occupiedCenters().size(); }

std::vector<Eigen::Vector3d> KnownMap::occupiedCenters() const {
  std::vector<Eigen::Vector3d> centers;
  const octomap::OcTree& tree = tree_->tree;
  const double r = model_.resolution;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const double size = it.getSize();
    const octomap::point3d c = it.getCoordinate();
    const int k = std::max(1, static_cast<int>(std::lround(size / r)));
    for (int x = 0; x < k; ++x) {
      for (int y = 0; y < k; ++y) {
        for (int z = 0; z < k; ++z) {
          centers.push_back(bounds_.min + Eigen::Vector3d(c.x() - 0.5 * size + (x + 0.5) * r,
                                                          c.y() - 0.5 * size + (y + 0.5) * r,
                                                          c.z() - 0.5 * size + (z + 0.5) * r));
        }
      }
    }
  }
  return centers;
}

void KnownMap::write(const std::string& path) const {
  tree_->tree.updateInnerOccupancy();  // insertions were lazy
  // OctoMap writes its own frame; the shift to the world frame goes into a copy's leaves.
  octomap::OcTree shifted(model_.resolution);
  const octomap::OcTree& tree = tree_->tree;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    const double size = it.getSize();
    const octomap::point3d c = it.getCoordinate();
    const int k = std::max(1, static_cast<int>(std::lround(size / model_.resolution)));
    const bool occupied = tree.isNodeOccupied(*it);
    for (int x = 0; x < k; ++x) {
      for (int y = 0; y < k; ++y) {
        for (int z = 0; z < k; ++z) {
          const Eigen::Vector3d p =
              bounds_.min + Eigen::Vector3d(c.x() - 0.5 * size + (x + 0.5) * model_.resolution,
                                            c.y() - 0.5 * size + (y + 0.5) * model_.resolution,
                                            c.z() - 0.5 * size + (z + 0.5) * model_.resolution);
          shifted.updateNode(toTree(p, Eigen::Vector3d::Zero()), occupied);
        }
      }
    }
  }
  shifted.updateInnerOccupancy();
  if (!shifted.writeBinary(path)) throw FileError(path + ": cannot write the known map");
}

}  // namespace kinolab
