#include "kinolab/validation/trajectory_checker.hpp"

#include <fcl/fcl.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {
namespace {

const char* kAxes[] = {"x", "y", "z"};
const char* kDerivatives[] = {"position", "velocity", "acceleration", "jerk", "snap"};

/// An upper bound on the speed over a segment: sum_k k |c_k| T^(k-1) per axis.
double speedBound(const TrajectorySegment& segment) {
  Eigen::Array3d bound = Eigen::Array3d::Zero();
  for (int k = 1; k < segment.coefficients.cols(); ++k) {
    bound += k * segment.coefficients.col(k).array().abs() * std::pow(segment.duration, k - 1);
  }
  return bound.matrix().norm();
}

}  // namespace

namespace {

/// The world's occupied voxels as an OctoMap tree wrapped for FCL. The tree is built in grid
/// coordinates (world minus the grid origin), so its cubes are exactly the grid's voxels.
/// Building it scans the whole grid (tens of milliseconds for a large world), so checkers of
/// one world share one tree: it lives while a checker holds it, and a world outlives its
/// checkers, so the world's address identifies it. (The experiment runner builds it before
/// forking workers, which then inherit it.)
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

/// The tree holds the occupied voxels with a free neighbour only (a wall's skin, not its
/// inside): a ball that meets an occupied cube while its centre lies in none meets one of
/// these, because the segment from its centre to the first point of an occupied cube it
/// reaches runs through free cubes, the last of which shares that point with the cube. With
/// the test of the centre (collides()) the verdicts are those of every cube.
std::shared_ptr<const fcl::CollisionObjectd> sharedOctree(const World& world) {
  static std::mutex mutex;
  static std::map<const World*, std::weak_ptr<const fcl::CollisionObjectd>> trees;
  const std::lock_guard<std::mutex> lock(mutex);
  if (auto tree = trees[&world].lock()) return tree;
  const VoxelGrid& grid = world.grid();
  auto octree = std::make_shared<octomap::OcTree>(grid.resolution());
  const double r = grid.resolution();
  grid.forEachOccupied([&](const VoxelIndex& v) {
    if (!onSurface(grid, v)) return;
    octree->updateNode(octomap::point3d(static_cast<float>((v.x() + 0.5) * r),
                                        static_cast<float>((v.y() + 0.5) * r),
                                        static_cast<float>((v.z() + 0.5) * r)),
                       true, /*lazy_eval=*/true);
  });
  octree->updateInnerOccupancy();
  auto tree = std::make_shared<fcl::CollisionObjectd>(
      std::make_shared<fcl::OcTreed>(std::shared_ptr<const octomap::OcTree>(octree)));
  tree->computeAABB();
  trees[&world] = tree;
  return tree;
}

}  // namespace

struct TrajectoryChecker::Fcl {
  Eigen::Vector3d origin;
  std::shared_ptr<const fcl::CollisionObjectd> tree;
  std::shared_ptr<fcl::Sphered> sphere;
  mutable fcl::CollisionObjectd body;

  Fcl(const World& world, double radius)
      : origin(world.grid().origin()),
        tree(sharedOctree(world)),
        sphere(std::make_shared<fcl::Sphered>(radius)),
        body(sphere) {}

  bool collides(const Eigen::Vector3d& position) const {
    body.setTranslation(position - origin);
    body.computeAABB();
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    fcl::collide(&body, tree.get(), request, result);
    return result.isCollision();
  }
};

TrajectoryChecker::TrajectoryChecker(std::shared_ptr<const World> world, CheckerSettings settings)
    : world_(std::move(world)), settings_(std::move(settings)) {
  if (!world_) throw InvalidArgument("trajectory checker: no world");
  if (!(settings_.robot_radius >= 0.0)) {
    throw InvalidArgument("trajectory checker: robot_radius must be >= 0");
  }
  if (settings_.max_derivative < 1 || settings_.max_derivative > 4) {
    throw InvalidArgument("trajectory checker: max_derivative must be in [1, 4]");
  }
  if (!(settings_.collision_tolerance >= 0.0)) {
    throw InvalidArgument("trajectory checker: collision_tolerance must be >= 0");
  }
  const double voxel = world_->esdf().resolution();
  spacing_ = settings_.spacing > 0.0 ? settings_.spacing : std::min(0.25 * voxel, 0.025);
  body_radius_ = std::max(settings_.robot_radius - settings_.collision_tolerance, 0.0);
  // OctoMap's keys hold 2^15 voxels either side of its centre: beyond, its tree loses voxels.
  if (body_radius_ > 0.0 && world_->grid().dims().maxCoeff() > 32767) {
    throw InvalidArgument("trajectory checker: world '" + world_->name() + "' is " +
                          std::to_string(world_->grid().dims().maxCoeff()) +
                          " voxels long; the checker's octree holds at most 32767 a side");
  }
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

/// The sample times of a segment `spacing` apart along its path (a bound of it), at least
/// its two ends: (global time, local time).
void sampleTimes(const TrajectorySegment& segment, double segment_start, double speed_bound,
                 double spacing, std::vector<std::pair<double, double>>& times) {
  const double path = speed_bound * segment.duration;
  const int steps = std::clamp(static_cast<int>(std::ceil(path / spacing)), 1, 1000000);
  times.clear();
  for (int i = 0; i <= steps; ++i) {
    const double local = segment.duration * i / steps;
    times.emplace_back(segment_start + local, local);
  }
}

}  // namespace

CheckResult TrajectoryChecker::check(const Trajectory& trajectory, const CheckQuery& query) const {
  CheckResult result;
  result.body_radius = body_radius_;
  if (trajectory.empty()) {
    violation(result, "empty", 0.0, query.start.col(0), "no trajectory");
    return result;
  }
  result.valid = checkStart(trajectory, query, result) && checkLimits(trajectory, result) &&
                 checkCollision(trajectory, result) && checkGoal(trajectory, query, result);
  return result;
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
  // Every position sample against the map bounds and the occupied cubes; the clearance
  // figures from the exact distance to the cubes at every sample.
  const World& world = *world_;
  double clearance_sum = 0.0;
  double least = INFINITY;
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
      // Up to the map's diagonal (where the ESDF caps, in a map without obstacles); always
      // finite (a position inside the map is).
      const double distance = world.esdf().exactDistance(position, world.esdf().maxDistance());
      clearance_sum += std::max(distance, 0.0) - settings_.robot_radius;
      least = std::min(least, std::max(distance, 0.0));
      if (collides(position)) {
        return violation(result, "collision", time, position,
                         body_radius_ > 0.0
                             ? "a sphere of radius " + formatNumber(body_radius_) +
                                   " m (robot_radius less the collision tolerance) touches an "
                                   "occupied voxel cube (FCL)"
                             : "the point is inside an occupied voxel cube");
      }
    }
    segment_start += segment.duration;
  }
  result.mean_clearance = clearance_sum / result.samples;
  result.min_clearance = least - settings_.robot_radius;
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
