#include "kinolab/validation/trajectory_checker.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "body_collision.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "trajectory_samples.hpp"

namespace kinolab {
namespace {

using checker_detail::kDerivatives;
using checker_detail::sampleTimes;

const char* kAxes[] = {"x", "y", "z"};

}  // namespace

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
  if (body_radius_ > 0.0) body_ = makeBodyCollision(*world_, body_radius_);
}

TrajectoryChecker::~TrajectoryChecker() = default;
TrajectoryChecker::TrajectoryChecker(TrajectoryChecker&&) noexcept = default;
TrajectoryChecker& TrajectoryChecker::operator=(TrajectoryChecker&&) noexcept = default;

bool TrajectoryChecker::collides(const Eigen::Vector3d& position) const {
  // The centre: is it in a closed occupied cube? On a face, edge or corner every voxel
  // sharing it counts. Then the body against the obstacles' surface voxels.
  return inOccupiedCube(position) || (body_ && body_->collides(position));
}

void TrajectoryChecker::makeCollisionModel() const {
  if (body_) body_->makeEveryTile();
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
