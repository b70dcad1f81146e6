#include "kinolab/validation/trajectory_checker.hpp"

#include <fcl/fcl.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <utility>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "trajectory_samples.hpp"

namespace kinolab {
namespace {

using checker_detail::kDerivatives;
using checker_detail::sampleTimes;

const char* kAxes[] = {"x", "y", "z"};

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

}  // namespace

struct TrajectoryChecker::Fcl {
  Eigen::Vector3d origin;
  double tile_side;  ///< m
  std::shared_ptr<SurfaceTiles> tiles;
  std::shared_ptr<fcl::Sphered> sphere;
  mutable fcl::CollisionObjectd body;

  Fcl(const World& world, double radius)
      : origin(world.grid().origin()),
        tile_side(SurfaceTiles::kTile * world.grid().resolution()),
        tiles(sharedTiles(world)),
        sphere(std::make_shared<fcl::Sphered>(radius)),
        body(sphere) {}

  /// The tiles [first, last] the sphere at `local` (grid coordinates) reaches along one axis
  /// (a micrometre wider, so that rounding at a border never drops the tile beyond).
  std::pair<int, int> reach(double local, double radius, int count) const {
    const auto at = [&](double x) {
      return static_cast<int>(std::clamp(std::floor(x / tile_side), 0.0, count - 1.0));
    };
    const double wide = radius + 1e-6;
    return {at(local - wide), at(local + wide)};
  }

  bool collides(const Eigen::Vector3d& position) const {
    const Eigen::Vector3d local = position - origin;
    const double radius = sphere->radius;
    const auto [x0, x1] = reach(local.x(), radius, tiles->tilesX());
    const auto [y0, y1] = reach(local.y(), radius, tiles->tilesY());
    for (int tx = x0; tx <= x1; ++tx) {
      for (int ty = y0; ty <= y1; ++ty) {
        const fcl::CollisionObjectd* tree = tiles->tile(tx, ty);
        if (tree == nullptr) continue;
        body.setTranslation(local - Eigen::Vector3d(tx * tile_side, ty * tile_side, 0.0));
        body.computeAABB();
        fcl::CollisionRequestd request;
        fcl::CollisionResultd result;
        fcl::collide(&body, tree, request, result);
        if (result.isCollision()) return true;
      }
    }
    return false;
  }

  void makeEveryTile() const {
    for (int tx = 0; tx < tiles->tilesX(); ++tx) {
      for (int ty = 0; ty < tiles->tilesY(); ++ty) tiles->tile(tx, ty);
    }
  }
};

TrajectoryChecker::TrajectoryChecker(std::shared_ptr<const World> world, CheckerSettings settings)
    : world_(std::move(world)), settings_(std::move(settings)) {
  if (!world_) throw InvalidArgument("trajectory checker: no world");
  if (!(settings_.body.radius >= 0.0)) {
    throw InvalidArgument("trajectory checker: the body's radius must be >= 0");
  }
  if (settings_.max_derivative < 1 || settings_.max_derivative > 4) {
    throw InvalidArgument("trajectory checker: max_derivative must be in [1, 4]");
  }
  if (!(settings_.body.tolerance >= 0.0)) {
    throw InvalidArgument("trajectory checker: the body's collision tolerance must be >= 0");
  }
  const double voxel = world_->esdf().resolution();
  spacing_ = settings_.spacing > 0.0 ? settings_.spacing : std::min(0.25 * voxel, 0.025);
  body_radius_ = settings_.body.keptRadius();
  if (body_radius_ > 0.0) fcl_ = std::make_unique<Fcl>(*world_, body_radius_);
}

TrajectoryChecker::~TrajectoryChecker() = default;
TrajectoryChecker::TrajectoryChecker(TrajectoryChecker&&) noexcept = default;
TrajectoryChecker& TrajectoryChecker::operator=(TrajectoryChecker&&) noexcept = default;

bool TrajectoryChecker::collides(const Eigen::Vector3d& position) const {
  // The centre: is it in a closed occupied cube? On a face, edge or corner every voxel
  // sharing it counts. Then the body against the obstacles' surface voxels.
  return inOccupiedCube(position) || (fcl_ && fcl_->collides(position));
}

void TrajectoryChecker::makeCollisionModel() const {
  if (fcl_) fcl_->makeEveryTile();
}

bool TrajectoryChecker::inOccupiedCube(const Eigen::Vector3d& position) const {
  const VoxelGrid& grid = world_->grid();
  const Eigen::Vector3d scaled = (position - grid.origin()) / grid.resolution();
  int low[3];
  int high[3];
  for (int axis = 0; axis < 3; ++axis) {
    // On the face between voxels k - 1 and k (scaled == k) both hold the point; on the map's
    // own faces only the voxel inside.
    const double cell = std::clamp(std::floor(scaled[axis]), -1.0, 1.0 * grid.dims()[axis]);
    const int last = grid.dims()[axis] - 1;
    high[axis] = std::clamp(static_cast<int>(cell), 0, last);
    low[axis] = std::clamp(cell == scaled[axis] ? static_cast<int>(cell) - 1 : high[axis], 0, last);
  }
  for (int x = low[0]; x <= high[0]; ++x) {
    for (int y = low[1]; y <= high[1]; ++y) {
      for (int z = low[2]; z <= high[2]; ++z) {
        if (grid.occupied(grid.index(x, y, z))) return true;
      }
    }
  }
  return false;
}

namespace {

/// Records a violation in `result`; returns false (the trajectory is not valid).
bool violation(CheckResult& result, std::string check, double time, const Eigen::Vector3d& position,
               std::string detail) {
  result.valid = false;
  result.check = std::move(check);
  result.time = time;
  result.position = position;
  result.detail = std::move(detail);
  return false;
}

}  // namespace

namespace {

/// A verdict: "empty" for no trajectory, else `checks` (each adds its violation to the result
/// and returns false at the first).
template <typename Checks>
CheckResult verdict(double body_radius, const Trajectory& trajectory, const CheckQuery& query,
                    const Checks& checks) {
  CheckResult result;
  result.body_radius = body_radius;
  if (trajectory.empty()) {
    violation(result, "empty", 0.0, query.start.col(0), "no trajectory");
    return result;
  }
  result.valid = checks(result);
  return result;
}

}  // namespace

CheckResult TrajectoryChecker::check(const Trajectory& trajectory, const CheckQuery& query) const {
  return verdict(body_radius_, trajectory, query, [&](CheckResult& result) {
    return checkStart(trajectory, query, result) && checkLimits(trajectory, result) &&
           checkCollision(trajectory, result) && checkGoal(trajectory, query, result);
  });
}

CheckResult TrajectoryChecker::checkMotion(const Trajectory& trajectory,
                                           const CheckQuery& query) const {
  return verdict(body_radius_, trajectory, query, [&](CheckResult& result) {
    return checkStart(trajectory, query, result) && checkLimits(trajectory, result) &&
           checkGoal(trajectory, query, result);
  });
}

bool TrajectoryChecker::checkStart(const Trajectory& trajectory, const CheckQuery& query,
                                   CheckResult& result) const {
  // Position and every derivative below the control.
  const double tol = settings_.tolerance;
  for (int k = 0; k < settings_.max_derivative; ++k) {
    const Eigen::Vector3d value = trajectory.evaluate(0.0, k);
    if ((value - query.start.col(k)).cwiseAbs().maxCoeff() > tol) {
      return violation(result, "start", 0.0, trajectory.startPosition(),
                       std::string(kDerivatives[k]) + " at t = 0 is " + formatPoint(value) +
                           ", the query's start has " + formatPoint(query.start.col(k)));
    }
  }
  return true;
}

bool TrajectoryChecker::checkLimits(const Trajectory& trajectory, CheckResult& result) const {
  // On both sides of every joint and at the position samples in between.
  const DynamicLimits& limits = settings_.limits;
  const double tol = settings_.tolerance;
  double segment_start = 0.0;
  std::vector<std::pair<double, double>> times;
  for (const auto& segment : trajectory.segments()) {
    sampleTimes(segment, segment_start, speedBound(segment), spacing_, times);
    for (const auto& [time, local] : times) {
      for (int k = 1; k <= settings_.max_derivative; ++k) {
        const Eigen::Vector3d value = segment.evaluate(local, k);
        if (!value.allFinite()) {
          // A NaN passes every comparison: it is a failure of its own, never valid.
          return violation(
              result, "numeric", time, segment.evaluate(local),
              std::string(kDerivatives[k]) + " " + formatPoint(value) + " is not finite");
        }
        for (int axis = 0; axis < 3; ++axis) {
          const double bound = limits.bound[k][axis];
          if (std::abs(value[axis]) > bound * (1.0 + tol) + tol) {
            return violation(result, "limits", time, segment.evaluate(local),
                             std::string(kDerivatives[k]) + " " + kAxes[axis] + " = " +
                                 formatNumber(value[axis]) + " exceeds the limit " +
                                 formatNumber(bound));
          }
        }
      }
    }
    segment_start += segment.duration;
  }
  return true;
}

bool TrajectoryChecker::checkCollision(const Trajectory& trajectory, CheckResult& result) const {
  // Every position sample against the map bounds and the occupied cubes.
  const World& world = *world_;
  double segment_start = 0.0;
  std::vector<std::pair<double, double>> times;
  for (const auto& segment : trajectory.segments()) {
    sampleTimes(segment, segment_start, speedBound(segment), spacing_, times);
    for (const auto& [time, local] : times) {
      const Eigen::Vector3d position = segment.evaluate(local);
      ++result.samples;
      if (!world.bounds().contains(position)) {
        return violation(result, "bounds", time, position,
                         "position " + formatPoint(position) + " leaves the map");
      }
      if (collides(position)) {
        return violation(result, "collision", time, position,
                         body_radius_ > 0.0 ? "a sphere of radius " + formatNumber(body_radius_) +
                                                  " m (the body's kept radius: its radius less the "
                                                  "collision tolerance) touches an "
                                                  "occupied voxel cube (FCL)"
                                            : "the point is inside an occupied voxel cube");
      }
    }
    segment_start += segment.duration;
  }
  return true;
}

bool TrajectoryChecker::checkGoal(const Trajectory& trajectory, const CheckQuery& query,
                                  CheckResult& result) const {
  if (!query.require_goal) return true;
  const Eigen::Vector3d end = trajectory.endPosition();
  const double distance = (end - query.goal).norm();
  if (distance > query.goal_radius + settings_.tolerance) {
    return violation(result, "goal", trajectory.duration(), end,
                     "ends " + formatNumber(distance) + " m from the goal " +
                         formatPoint(query.goal) + ", outside the goal radius " +
                         formatNumber(query.goal_radius));
  }
  return true;
}

}  // namespace kinolab
