#include "kinolab/validation/trajectory_checker.hpp"

#include <fcl/fcl.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>
#include <mutex>
#include <utility>

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
  static constexpr int kTile = 256;

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

/// The sample times of a segment `spacing` apart along its path (a bound of it), at least
/// its two ends: (global time, local time).
void sampleTimes(const TrajectorySegment& segment, double segment_start, double speed_bound,
                 double spacing, std::vector<std::pair<double, double>>& times) {
  const double path = speed_bound * segment.duration;
  // Clamped before the cast: a diverged trajectory's path overflows an int.
  const double wanted = std::ceil(path / spacing);
  const int steps =
      std::isfinite(wanted) ? static_cast<int>(std::clamp(wanted, 1.0, 1000000.0)) : 1000000;
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

namespace {

/// "NAME: REASON" for each name, a line each (what the report reads per metric).
void markUndefined(std::vector<std::string>& lines, std::initializer_list<const char*> names,
                   const std::string& reason) {
  for (const char* name : names) lines.push_back(std::string(name) + ": " + reason);
}

}  // namespace

TrajectoryEvaluation TrajectoryChecker::evaluate(const Trajectory& trajectory) const {
  TrajectoryEvaluation result;
  if (trajectory.empty()) return result;
  std::vector<std::string> undefined;
  for (const TrajectorySegment& segment : trajectory.segments()) {
    if (!std::isfinite(segment.duration) || !segment.coefficients.allFinite()) {
      for (const MetricSpec& spec : evaluationMetrics().specs().all()) {
        if (spec.type == MetricType::kReal) {
          undefined.push_back(spec.name + ": the trajectory is not finite");
        }
      }
      result.undefined = join(undefined, "\n");
      return result;
    }
  }
  result.duration = trajectory.duration();
  result.length = trajectory.length();
  // A jump of any derivative below k at a joint makes derivative k impulsive there (a jump of
  // the position, a teleport, makes every derivative so): its squared integral is not finite,
  // whatever the polynomials' own figure says.
  const auto firstJump = [&](int below) -> std::pair<int, Trajectory::Jumps> {
    for (int d = 0; d < below; ++d) {
      if (const Trajectory::Jumps jumps = trajectory.jumps(d); jumps.count > 0) return {d, jumps};
    }
    return {-1, {}};
  };
  const auto jumpReason = [](int d, const Trajectory::Jumps& jumps) {
    return std::string("the ") + kDerivatives[d] + " jumps at " + std::to_string(jumps.count) +
           " joint" + (jumps.count > 1 ? "s" : "") + ", so what is above it is impulsive there";
  };
  const auto integral = [&](int derivative, const char* name, const char* per_metre) {
    const auto [d, jumps] = firstJump(derivative);
    if (d < 0) return trajectory.squaredIntegral(derivative);
    markUndefined(undefined, {name, per_metre}, jumpReason(d, jumps));
    return static_cast<double>(NAN);
  };
  result.acceleration_integral = integral(2, "acceleration_integral", "acceleration_per_metre");
  result.jerk_integral = integral(3, "jerk_integral", "jerk_per_metre");
  if (const auto [d, jumps] = firstJump(2); d < 0) {
    result.acceleration_jumps = trajectory.jumps(2).squared_sum;
  } else {
    markUndefined(undefined, {"acceleration_jumps"}, jumpReason(d, jumps));
  }

  const World& world = *world_;
  const DynamicLimits& limits = settings_.limits;
  const double cap = std::min(world.esdf().maxDistance(), world.esdf().truncation());
  double least = INFINITY;
  double clearance_sum = 0.0;
  int samples = 0;
  double peak_speed = 0.0;
  double peak_acceleration = 0.0;
  double speed_ratio = 0.0;
  double acceleration_ratio = 0.0;
  double max_curvature = 0.0;
  double turning = 0.0;  // curvature over arc length of the moving samples, plus the corners
  double moving_length = 0.0;
  // The direction of travel at the last moving sample; a change of it across a stretch too
  // slow to have a direction, or across a joint, is a corner: turned in place.
  Eigen::Vector3d last_direction = Eigen::Vector3d::Zero();
  bool across = false;  // a slow stretch or a joint lies since the last moving sample
  int corners = 0;
  double segment_start = 0.0;
  std::vector<std::pair<double, double>> times;
  for (const auto& segment : trajectory.segments()) {
    sampleTimes(segment, segment_start, speedBound(segment), spacing_, times);
    across = true;
    for (std::size_t i = 0; i < times.size(); ++i) {
      const double local = times[i].second;
      const Eigen::Vector3d position = segment.evaluate(local);
      const Eigen::Vector3d velocity = segment.evaluate(local, 1);
      const Eigen::Vector3d acceleration = segment.evaluate(local, 2);
      // The exact distance, up to the map's diagonal or a truncated field's truncation (a
      // sparse world's clearance figures are capped there: exact below it).
      const double distance = std::max(world.esdf().exactDistance(position, cap), 0.0);
      least = std::min(least, distance);
      clearance_sum += distance;
      ++samples;
      const double speed = velocity.norm();
      peak_speed = std::max(peak_speed, speed);
      peak_acceleration = std::max(peak_acceleration, acceleration.norm());
      for (int axis = 0; axis < 3; ++axis) {
        speed_ratio = std::max(speed_ratio, std::abs(velocity[axis]) / limits.bound[1][axis]);
        acceleration_ratio =
            std::max(acceleration_ratio, std::abs(acceleration[axis]) / limits.bound[2][axis]);
      }
      if (speed < TrajectoryEvaluation::kCurvatureMinSpeed) {
        across = true;
        continue;
      }
      const Eigen::Vector3d direction = velocity / speed;
      if (across && last_direction.squaredNorm() > 0.0) {
        const double angle = std::acos(std::clamp(direction.dot(last_direction), -1.0, 1.0));
        if (angle > 1e-3) {  // a milliradian: rounding at a smooth joint stays far below
          turning += angle;
          ++corners;
        }
      }
      last_direction = direction;
      across = false;
      const double curvature = velocity.cross(acceleration).norm() / (speed * speed * speed);
      max_curvature = std::max(max_curvature, curvature);
      // The sample's share of the segment's time (half of each neighbouring interval).
      const double before = i > 0 ? local - times[i - 1].second : 0.0;
      const double after = i + 1 < times.size() ? times[i + 1].second - local : 0.0;
      const double arc = 0.5 * (before + after) * speed;
      turning += curvature * arc;
      moving_length += arc;
    }
    segment_start += segment.duration;
  }
  result.min_clearance = least - settings_.body.radius;
  result.mean_clearance = clearance_sum / samples - settings_.body.radius;
  result.peak_speed = peak_speed;
  result.peak_acceleration = peak_acceleration;
  result.speed_limit_ratio = speed_ratio;
  result.acceleration_limit_ratio = acceleration_ratio;
  if (moving_length <= 0.0) {
    markUndefined(undefined, {"max_curvature", "mean_curvature"},
                  "the trajectory never moves faster than " +
                      formatNumber(TrajectoryEvaluation::kCurvatureMinSpeed) +
                      " m/s, so its direction is not defined");
  } else {
    result.mean_curvature = turning / moving_length;
    if (corners == 0) {
      result.max_curvature = max_curvature;
    } else {
      markUndefined(undefined, {"max_curvature"},
                    "the path turns " + std::to_string(corners) + " corner" +
                        (corners > 1 ? "s" : "") +
                        " in place (at rest, or where the velocity jumps), where its curvature "
                        "is unbounded; mean_curvature counts their angles");
    }
  }
  result.undefined = join(undefined, "\n");
  return result;
}

const MetricList<TrajectoryEvaluation>& evaluationMetrics() {
  using E = TrajectoryEvaluation;
  const auto of = [](double E::*field) {
    return [field](const E& e) { return numberOrNone(e.*field); };
  };
  // Per metre of path: a long detour and a short direct flight compared on one scale
  // (FlightBench's energy measures).
  const auto perMetre = [](double E::*field) {
    return [field](const E& e) { return numberOrNone(e.length > 0.0 ? e.*field / e.length : NAN); };
  };
  static const MetricList<E> list =
      MetricList<E>()
          .add(MetricSpecs().real("duration", "s", "trajectory duration").lower().comparable(),
               of(&E::duration))
          .add(MetricSpecs().real("length", "m", "trajectory length").lower().comparable(),
               of(&E::length))
          .add(MetricSpecs()
                   .real("acceleration_integral", "m^2/s^3",
                         "integral of |a|^2 over the trajectory (undefined where the velocity "
                         "jumps)")
                   .lower()
                   .comparable(),
               of(&E::acceleration_integral))
          .add(MetricSpecs()
                   .real("acceleration_per_metre", "m/s^3", "acceleration_integral per metre")
                   .lower()
                   .comparable(),
               perMetre(&E::acceleration_integral))
          .add(MetricSpecs()
                   .real("jerk_integral", "m^2/s^5",
                         "integral of |j|^2 over the trajectory; undefined (never 0) where the "
                         "acceleration jumps: see acceleration_jumps")
                   .lower()
                   .comparable(),
               of(&E::jerk_integral))
          .add(MetricSpecs()
                   .real("jerk_per_metre", "m/s^5", "jerk_integral per metre")
                   .lower()
                   .comparable(),
               perMetre(&E::jerk_integral))
          .add(MetricSpecs()
                   .real("acceleration_jumps", "m^2/s^4",
                         "sum of the squared acceleration jumps at the joints (0: continuous "
                         "acceleration)")
                   .lower()
                   .comparable(),
               of(&E::acceleration_jumps))
          .add(MetricSpecs()
                   .real("max_curvature", "1/m",
                         "largest curvature |v x a| / |v|^3 where the speed is at least 0.1 m/s; "
                         "undefined where the path turns a corner in place")
                   .lower()
                   .comparable(),
               of(&E::max_curvature))
          .add(MetricSpecs()
                   .real("mean_curvature", "1/m",
                         "turning per metre: curvature integrated over arc length (where the "
                         "speed is at least 0.1 m/s) plus the corners turned in place, over the "
                         "length")
                   .lower()
                   .comparable(),
               of(&E::mean_curvature))
          .add(MetricSpecs()
                   .real("min_clearance", "m",
                         "least exact distance from the trajectory's checked positions to the "
                         "occupied voxel cubes, less the robot radius")
                   .higher()
                   .comparable(),
               of(&E::min_clearance))
          .add(MetricSpecs()
                   .real("mean_clearance", "m",
                         "mean exact distance from the trajectory's checked positions to the "
                         "occupied voxel cubes, less the robot radius")
                   .higher()
                   .comparable(),
               of(&E::mean_clearance))
          .add(MetricSpecs().real("peak_speed", "m/s", "largest speed |v|").comparable(),
               of(&E::peak_speed))
          .add(MetricSpecs()
                   .real("peak_acceleration", "m/s^2", "largest acceleration |a|")
                   .comparable(),
               of(&E::peak_acceleration))
          .add(MetricSpecs()
                   .real("speed_limit_ratio", "",
                         "largest per-axis speed over its limit (above 1: beyond the limit)")
                   .comparable(),
               of(&E::speed_limit_ratio))
          .add(MetricSpecs()
                   .real("acceleration_limit_ratio", "",
                         "largest per-axis acceleration over its limit (above 1: beyond the "
                         "limit)")
                   .comparable(),
               of(&E::acceleration_limit_ratio))
          .add(MetricSpecs().text("undefined",
                                  "the figures not defined for this trajectory, NAME: REASON a "
                                  "line (never stored as 0)"),
               [](const E& e) -> MetricValue { return e.undefined; });
  return list;
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
                         body_radius_ > 0.0
                             ? "a sphere of radius " + formatNumber(body_radius_) +
                                   " m (robot_radius less the collision tolerance) touches an "
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
