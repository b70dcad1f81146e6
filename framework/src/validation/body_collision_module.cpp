// The body's collision test with FCL, a module of its own (kinolab_modules/kinolab_fcl_body.so)
// that the framework loads when a checker first needs it (body_collision.hpp): a process that
// checks only point robots never loads FCL.
#include <fcl/fcl.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "body_collision.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab {
namespace {

/// Whether an occupied voxel has a free one among its 26 neighbours in the grid.
bool onSurface(const VoxelGrid& grid, const VoxelIndex& voxel) {
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        const VoxelIndex next = voxel + VoxelIndex(dx, dy, dz);
        if (grid.inside(next) && !grid.occupied(next)) return true;
      }
    }
  }
  return false;
}

/// The obstacles' surface voxels as OctoMap trees wrapped for FCL, one per tile of kTile x
/// kTile voxels in x and y (every height), each made when a check first reaches its tile: a
/// check costs the trees of the tiles its body reaches, not the world's (a city's surface is
/// tens of millions of voxels). The trees hold the occupied voxels with a free neighbour only
/// (a wall's skin, not its inside): a ball that meets an occupied cube while its centre lies in
/// none meets one of these, because the segment from its centre to the first point of an
/// occupied cube it reaches runs through free cubes, the last of which shares that point with
/// the cube. With the test of the centre (collides()) the verdicts are those of every cube.
/// Each tree is in its tile's coordinates (world minus the grid origin minus the tile's
/// corner), so its cubes are exactly the grid's voxels, and OctoMap's keys (2^15 voxels either
/// way) bound a tile, not the world.
class SurfaceTiles {
 public:
  static constexpr int kTile = TrajectoryChecker::kTileVoxels;

  explicit SurfaceTiles(const VoxelGrid& grid)
      : grid_(grid),
        tiles_x_((grid.dims().x() + kTile - 1) / kTile),
        tiles_y_((grid.dims().y() + kTile - 1) / kTile),
        trees_(static_cast<std::size_t>(tiles_x_) * tiles_y_),
        made_(trees_.size(), 0) {}

  int tilesX() const { return tiles_x_; }
  int tilesY() const { return tiles_y_; }

  /// Tile (tx, ty)'s tree, made on first use; null when the tile has no surface voxel.
  const fcl::CollisionObjectd* tile(int tx, int ty) {
    const std::size_t index = static_cast<std::size_t>(tx) * tiles_y_ + ty;
    const std::lock_guard<std::mutex> lock(mutex_);
    if (made_[index] == 0) {
      trees_[index] = make(tx, ty);
      made_[index] = 1;
    }
    return trees_[index].get();
  }

 private:
  std::unique_ptr<fcl::CollisionObjectd> make(int tx, int ty) const {
    const VoxelGrid& grid = grid_;
    const double r = grid.resolution();
    auto octree = std::make_shared<octomap::OcTree>(r);
    const Eigen::Vector3i low(tx * kTile, ty * kTile, 0);
    const Eigen::Vector3i high =
        (low + Eigen::Vector3i(kTile, kTile, grid.dims().z())).cwiseMin(grid.dims());
    const int b = VoxelGrid::kBrick;
    const bool bricked = grid.layout() == GridLayout::kBricked;
    bool any = false;
    // Brick by brick (a bricked grid skips its empty bricks, and the full ones inside others).
    for (int bx = low.x() / b; bx * b < high.x(); ++bx) {
      for (int by = low.y() / b; by * b < high.y(); ++by) {
        for (int bz = 0; bz * b < high.z(); ++bz) {
          if (bricked && (!grid.brickHasObstacle(bx, by, bz) || buried(bx, by, bz))) continue;
          const Eigen::Vector3i from = Eigen::Vector3i(bx, by, bz) * b;
          const Eigen::Vector3i to = (from.array() + b).matrix().cwiseMin(high);
          for (int x = from.x(); x < to.x(); ++x) {
            for (int y = from.y(); y < to.y(); ++y) {
              for (int z = from.z(); z < to.z(); ++z) {
                const VoxelIndex v(x, y, z);
                if (!grid.occupied(v) || !onSurface(grid, v)) continue;
                octree->updateNode(octomap::point3d(static_cast<float>((x - low.x() + 0.5) * r),
                                                    static_cast<float>((y - low.y() + 0.5) * r),
                                                    static_cast<float>((z + 0.5) * r)),
                                   true, /*lazy_eval=*/true);
                any = true;
              }
            }
          }
        }
      }
    }
    if (!any) return nullptr;
    octree->updateInnerOccupancy();
    auto tree = std::make_unique<fcl::CollisionObjectd>(
        std::make_shared<fcl::OcTreed>(std::shared_ptr<const octomap::OcTree>(octree)));
    tree->computeAABB();
    return tree;
  }

  /// Whether brick (bx, by, bz) of a bricked grid and its 26 neighbours (inside the grid) are
  /// all full: then none of its voxels has a free neighbour.
  bool buried(int bx, int by, int bz) const {
    const Eigen::Vector3i& bricks = grid_.brickDims();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const Eigen::Vector3i next(bx + dx, by + dy, bz + dz);
          if ((next.array() < 0).any() || (next.array() >= bricks.array()).any()) continue;
          if (!grid_.brickFull(next.x(), next.y(), next.z())) return false;
        }
      }
    }
    return true;
  }

  const VoxelGrid& grid_;
  int tiles_x_;
  int tiles_y_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> trees_;
  std::vector<std::uint8_t> made_;
};

/// The surface tiles of `world`, shared by its checkers: they live while a checker holds them,
/// and a world outlives its checkers, so the world's address identifies them. (The experiment
/// runner makes every tile of a dense world before forking workers, which then inherit them.)
std::shared_ptr<SurfaceTiles> sharedTiles(const World& world) {
  static std::mutex mutex;
  static std::map<const World*, std::weak_ptr<SurfaceTiles>> tiles;
  const std::lock_guard<std::mutex> lock(mutex);
  if (auto shared = tiles[&world].lock()) return shared;
  auto shared = std::make_shared<SurfaceTiles>(world.grid());
  tiles[&world] = shared;
  return shared;
}

/// A sphere against the surface tiles of a world, with FCL.
class FclBody final : public BodyCollision {
 public:
  FclBody(const World& world, double radius)
      : origin_(world.grid().origin()),
        tile_side_(SurfaceTiles::kTile * world.grid().resolution()),
        tiles_(sharedTiles(world)),
        sphere_(std::make_shared<fcl::Sphered>(radius)),
        body_(sphere_) {}

  bool collides(const Eigen::Vector3d& position) const override {
    const Eigen::Vector3d local = position - origin_;
    const double radius = sphere_->radius;
    const auto [x0, x1] = reach(local.x(), radius, tiles_->tilesX());
    const auto [y0, y1] = reach(local.y(), radius, tiles_->tilesY());
    for (int tx = x0; tx <= x1; ++tx) {
      for (int ty = y0; ty <= y1; ++ty) {
        const fcl::CollisionObjectd* tree = tiles_->tile(tx, ty);
        if (tree == nullptr) continue;
        body_.setTranslation(local - Eigen::Vector3d(tx * tile_side_, ty * tile_side_, 0.0));
        body_.computeAABB();
        fcl::CollisionRequestd request;
        fcl::CollisionResultd result;
        fcl::collide(&body_, tree, request, result);
        if (result.isCollision()) return true;
      }
    }
    return false;
  }

  void makeEveryTile() const override {
    for (int tx = 0; tx < tiles_->tilesX(); ++tx) {
      for (int ty = 0; ty < tiles_->tilesY(); ++ty) tiles_->tile(tx, ty);
    }
  }

 private:
  /// The tiles [first, last] the sphere at `local` (grid coordinates) reaches along one axis
  /// (a micrometre wider, so that rounding at a border never drops the tile beyond).
  std::pair<int, int> reach(double local, double radius, int count) const {
    const auto at = [&](double x) {
      return static_cast<int>(std::clamp(std::floor(x / tile_side_), 0.0, count - 1.0));
    };
    const double wide = radius + 1e-6;
    return {at(local - wide), at(local + wide)};
  }

  Eigen::Vector3d origin_;
  double tile_side_;  ///< m
  std::shared_ptr<SurfaceTiles> tiles_;
  std::shared_ptr<fcl::Sphered> sphere_;
  mutable fcl::CollisionObjectd body_;
};

}  // namespace
}  // namespace kinolab

extern "C" __attribute__((visibility("default"))) kinolab::BodyCollision*
kinolab_make_body_collision(const kinolab::World& world, double radius) {
  return new kinolab::FclBody(world, radius);
}
