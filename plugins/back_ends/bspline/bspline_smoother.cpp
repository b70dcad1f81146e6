#include "bspline_smoother.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>

#include "kinolab/core/text.hpp"
#include "kinolab/planner/back_end.hpp"

namespace kinolab::smoothing {
namespace {

template <typename T>
T hinge(const T& x) {
  return x > T(0) ? x : T(0);
}

/// Smoothness: the third difference of four consecutive control points (jerk times dt^3),
/// independent of the time allocation.
struct SmoothnessCost {
  double scale;
  template <typename T>
  bool operator()(const T* p0, const T* p1, const T* p2, const T* p3, T* residual) const {
    for (int axis = 0; axis < 3; ++axis) {
      residual[axis] = scale * (p3[axis] - 3.0 * p2[axis] + 3.0 * p1[axis] - p0[axis]);
    }
    return true;
  }
};

/// Guidance: a control point's offset from where the time-allocated path put it.
struct GuideCost {
  double scale;
  Eigen::Vector3d target;
  template <typename T>
  bool operator()(const T* p, T* residual) const {
    for (int axis = 0; axis < 3; ++axis) residual[axis] = scale * (p[axis] - T(target[axis]));
    return true;
  }
};

/// Velocity limit on V_i = (P_{i+1} - P_i) / dt, per axis, as a distance: the excess of
/// |P_{i+1} - P_i| over v_max dt.
struct VelocityCost {
  double scale;
  Eigen::Vector3d reach;  // v_max dt per axis
  template <typename T>
  bool operator()(const T* p0, const T* p1, T* residual) const {
    using std::abs;
    for (int axis = 0; axis < 3; ++axis) {
      residual[axis] = scale * hinge(abs(p1[axis] - p0[axis]) - T(reach[axis]));
    }
    return true;
  }
};

/// Acceleration limit on A_i = (P_{i+2} - 2 P_{i+1} + P_i) / dt^2, as a distance.
struct AccelerationCost {
  double scale;
  Eigen::Vector3d reach;  // a_max dt^2 per axis
  template <typename T>
  bool operator()(const T* p0, const T* p1, const T* p2, T* residual) const {
    using std::abs;
    for (int axis = 0; axis < 3; ++axis) {
      residual[axis] = scale * hinge(abs(p2[axis] - 2.0 * p1[axis] + p0[axis]) - T(reach[axis]));
    }
    return true;
  }
};

/// Keeps a control point inside the map (the curve then stays inside: the box is convex).
/// Obstacle penalty at one curve point p = sum_j b_j P_{i+j}: scale (threshold - d(p)) where
/// the trilinear ESDF value d is below the threshold, with the ESDF's analytic gradient:
/// d residual / d P_{i+j} = -scale b_j grad d(p).
class ObstacleCost final : public ceres::SizedCostFunction<1, 3, 3, 3, 3> {
 public:
  ObstacleCost(const Esdf& esdf, const Eigen::Vector4d& weights, double threshold, double scale)
      : esdf_(esdf), weights_(weights), threshold_(threshold), scale_(scale) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    for (int j = 0; j < 4; ++j)
      point += weights_[j] * Eigen::Map<const Eigen::Vector3d>(parameters[j]);
    Eigen::Vector3d gradient;
    const double excess = threshold_ - esdf_.distanceWithGradient(point, &gradient);
    const bool active = excess > 0.0;
    residuals[0] = active ? scale_ * excess : 0.0;
    if (jacobians) {
      for (int j = 0; j < 4; ++j) {
        if (!jacobians[j]) continue;
        Eigen::Map<Eigen::RowVector3d> row(jacobians[j]);
        if (active) {
          row = -scale_ * weights_[j] * gradient.transpose();
        } else {
          row.setZero();
        }
      }
    }
    return true;
  }

 private:
  const Esdf& esdf_;
  Eigen::Vector4d weights_;
  double threshold_;
  double scale_;
};

/// The point at arc length `s` along a polyline.
Eigen::Vector3d pointAt(const std::vector<Eigen::Vector3d>& path, double s) {
  for (std::size_t leg = 1; leg < path.size(); ++leg) {
    const double leg_length = (path[leg] - path[leg - 1]).norm();
    if (s <= leg_length || leg + 1 == path.size()) {
      const double t = leg_length > 0.0 ? std::clamp(s / leg_length, 0.0, 1.0) : 0.0;
      return path[leg - 1] + t * (path[leg] - path[leg - 1]);
    }
    s -= leg_length;
  }
  return path.back();
}

/// Arc length travelled at time t by a trapezoidal speed profile over `length` from speed
/// `initial` to rest (cruise speed v, acceleration a; a start too fast to stop within the
/// length brakes harder), and that profile's duration.
struct SpeedProfile {
  double length, initial, speed, up, down, rise, fall, duration;
  SpeedProfile(double length_, double v, double a, double initial_)
      : length(length_), initial(std::min(initial_, v)), up(a), down(a) {
    if (initial * initial > 2.0 * a * length) {
      // Only braking, as hard as the length needs.
      speed = initial;
      down = initial * initial / (2.0 * length);
      rise = 0.0;
      fall = initial / down;
      duration = fall;
      return;
    }
    // The peak where speeding up from `initial` and braking to rest meet, at most v.
    speed = std::min(v, std::sqrt(a * length + 0.5 * initial * initial));
    rise = (speed - initial) / a;
    fall = speed / a;
    const double ramps = (speed * speed - initial * initial + speed * speed) / (2.0 * a);
    duration = rise + fall + std::max(0.0, length - ramps) / speed;
  }
  double at(double t) const {
    if (t <= rise) return initial * t + 0.5 * up * t * t;
    if (t >= duration - fall) {
      const double left = std::max(0.0, duration - t);
      return length - 0.5 * down * left * left;
    }
    return initial * rise + 0.5 * up * rise * rise + speed * (t - rise);
  }
};

double polylineLength(const std::vector<Eigen::Vector3d>& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

/// The factor that scales the knot interval so that the tightest velocity or acceleration
/// control point is exactly at its limit (> 1: a limit is broken; < 1: all are slack).
double limitFactor(const UniformBspline& spline, const DynamicLimits& limits) {
  double factor = 0.0;
  for (int derivative = 1; derivative <= 2; ++derivative) {
    const Eigen::Matrix3Xd points = spline.derivativeControlPoints(derivative);
    const Eigen::Vector3d peak = points.cwiseAbs().rowwise().maxCoeff();
    const double ratio = peak.cwiseQuotient(limits.bound[derivative]).maxCoeff();
    factor = std::max(factor, std::pow(ratio, 1.0 / derivative));
  }
  return factor;
}

/// Ends a solve once the planning budget is spent (on its clock), keeping the last iterate.
class BudgetCallback final : public ceres::IterationCallback {
 public:
  explicit BudgetCallback(const StopCondition& stop) : stop_(stop) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return stop_.elapsed() >= stop_.budget().time_limit ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                                        : ceres::SOLVER_CONTINUE;
  }

 private:
  const StopCondition& stop_;
};

CheckerSettings clearanceCheck(const SmootherSettings& settings) {
  CheckerSettings check;
  check.body = settings.body;
  check.limits = settings.limits;
  check.max_derivative = 2;
  return check;
}

}  // namespace

BsplineSmoother::BsplineSmoother(std::shared_ptr<const World> world,
                                 const SmootherSettings& settings)
    : world_(world), settings_(settings), checker_(world, clearanceCheck(settings)) {
  // The obstacle cost reads the trilinear distance and its gradient out to the band's edge.
  world_->requireExactDistancesTo(world_->obstacleCostReach(settings_.body.costReach()),
                                  "bspline smoother (obstacle cost)");
}

void BsplineSmoother::addCosts(ceres::Problem& problem, Eigen::Matrix3Xd& control, double interval,
                               double weight_obstacle) const {
  const int count = static_cast<int>(control.cols());
  for (int i = 0; i < count; ++i) problem.AddParameterBlock(control.col(i).data(), 3);
  for (const int i : {0, 1, 2, count - 3, count - 2, count - 1}) {
    problem.SetParameterBlockConstant(control.col(i).data());
  }
  const auto block = [&](int i) { return control.col(i).data(); };
  const double smooth_scale = std::sqrt(settings_.weight_smoothness);
  const double obstacle_scale = std::sqrt(weight_obstacle / settings_.obstacle_samples);
  const double threshold = settings_.body.costReach();
  for (int i = 0; i + 3 < count; ++i) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SmoothnessCost, 3, 3, 3, 3, 3>(
                                 new SmoothnessCost{smooth_scale}),
                             nullptr, block(i), block(i + 1), block(i + 2), block(i + 3));
    for (int k = 0; k < settings_.obstacle_samples; ++k) {
      const double u = static_cast<double>(k) / settings_.obstacle_samples;
      problem.AddResidualBlock(
          new ObstacleCost(world_->esdf(), UniformBspline::basis(u), threshold, obstacle_scale),
          nullptr, block(i), block(i + 1), block(i + 2), block(i + 3));
    }
  }
  const double feasibility_scale = std::sqrt(settings_.weight_feasibility);
  const Eigen::Vector3d velocity_reach = settings_.limits.bound[1] * interval;
  const Eigen::Vector3d acceleration_reach = settings_.limits.bound[2] * interval * interval;
  for (int i = 0; i + 1 < count; ++i) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<VelocityCost, 3, 3, 3>(
                                 new VelocityCost{feasibility_scale, velocity_reach}),
                             nullptr, block(i), block(i + 1));
  }
  for (int i = 0; i + 2 < count; ++i) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AccelerationCost, 3, 3, 3, 3>(
                                 new AccelerationCost{feasibility_scale, acceleration_reach}),
                             nullptr, block(i), block(i + 1), block(i + 2));
  }
  const double guide_scale = std::sqrt(settings_.weight_guide);
  const Eigen::Vector3d low = world_->bounds().min;
  const Eigen::Vector3d high = world_->bounds().max;
  for (int i = 3; i < count - 3; ++i) {
    // The free control points stay in the map, as hard bounds: a uniform B-spline lies in
    // the convex hull of its control points, so the curve cannot leave the map (a soft
    // penalty let splines dip below a floor), except in its first span from a moving start
    // whose fixed leading points lie outside. A micrometre inside, so that rounding in the
    // curve's evaluation cannot put a point on the wrong side of the map's face.
    constexpr double kInside = 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
      const double lower = low[axis] + kInside;
      const double upper = high[axis] - kInside;
      control(axis, i) = std::clamp(control(axis, i), lower, upper);
      problem.SetParameterLowerBound(block(i), axis, lower);
      problem.SetParameterUpperBound(block(i), axis, upper);
    }
    if (guide_scale > 0.0) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<GuideCost, 3, 3>(
                                   new GuideCost{guide_scale, control.col(i)}),
                               nullptr, block(i));
    }
  }
}

void BsplineSmoother::solve(Eigen::Matrix3Xd& control, double interval, double weight_obstacle,
                            StopCondition& stop, Tally& tally) const {
  ceres::Problem problem;
  addCosts(problem, control, interval, weight_obstacle);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = settings_.max_solver_iterations;
  options.logging_type = ceres::SILENT;
  options.num_threads = 1;
  // Ceres' own time limit reads the wall clock; the budget may be on the CPU's, so the budget
  // is checked after every iteration instead.
  BudgetCallback budget_callback(stop);
  if (std::isfinite(stop.budget().time_limit)) options.callbacks.push_back(&budget_callback);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  tally.ceres_iterations += static_cast<int>(summary.iterations.size());
  if (tally.rounds == 1) tally.initial_cost = summary.initial_cost;
  tally.final_cost = summary.final_cost;
}

bool BsplineSmoother::reallocateTime(const ChainState& start, Eigen::Matrix3Xd& control,
                                     double& interval, int& reallocations) const {
  // Scale the knot interval until the tightest velocity or acceleration control point is at
  // its limit (stretching when a limit is broken, compressing when all are slack). At rest
  // the leading points do not depend on the interval, so one scaling suffices; otherwise
  // they move with it and the scaling can circle the limit without settling: then the last
  // interval within the limits is kept, or, when none was, the interval is only stretched.
  const bool at_rest = start.col(1).isZero() && start.col(2).isZero();
  const double first_interval = interval;
  const auto rescale = [&](double factor) {
    interval *= factor * (1.0 + 1e-9);
    ++reallocations;
    if (!at_rest) control.leftCols<3>() = UniformBspline::startControlPoints(start, interval);
    // From a moving start on a path too short to stop on, the scaling collapses or inflates
    // the interval without end: no spline within the limits fits, a failure, not an error.
    return interval > 1e-9 && interval < 100.0 * first_interval;
  };
  std::optional<std::pair<double, Eigen::Matrix3Xd>> within;  // the last fit within the limits
  for (int attempt = 0; attempt < 40; ++attempt) {
    const double factor = limitFactor(UniformBspline(control, interval), settings_.limits);
    if (!(factor > 0.0)) return true;  // no motion: nothing to scale
    // After 20 attempts aiming at the limit, a fit within it is taken as it is.
    const bool settling = attempt >= 20;
    if (factor <= 1.0) {
      if (factor > 1.0 - 1e-6 || settling) return true;
      within.emplace(interval, control);
    } else if (settling && within) {
      break;
    }
    if (!rescale(factor)) return false;
  }
  if (!within) return false;
  std::tie(interval, control) = std::move(*within);
  return true;
}

SmootherResult BsplineSmoother::smooth(const ChainState& start,
                                       const std::vector<Eigen::Vector3d>& path,
                                       StopCondition& stop) const {
  SmootherResult result;
  // The profile starts at the start's speed along the path's first leg (none backwards).
  const Eigen::Vector3d lead =
      path.size() > 1 ? Eigen::Vector3d(path[1] - path[0]).normalized() : Eigen::Vector3d::Zero();
  const SpeedProfile profile(polylineLength(path),
                             settings_.initial_speed * settings_.limits.bound[1].minCoeff(),
                             settings_.initial_speed * settings_.limits.bound[2].minCoeff(),
                             std::max(0.0, start.col(1).dot(lead)));
  double spacing = settings_.knot_spacing;
  double weight_obstacle = settings_.weight_obstacle;
  Tally tally;
  int& rounds = tally.rounds;
  while (rounds < settings_.max_rounds) {
    if (rounds > 0 && stop.elapsed() >= stop.budget().time_limit) {
      result.problem += "; the time budget ran out before another round";
      break;
    }
    ++rounds;
    // Fit: the leading points of the start state, the path sampled at equal times of a
    // trapezoidal speed profile as interior points, and three copies of the end (rest).
    const int pieces =
        std::max(3, static_cast<int>(std::ceil(profile.duration * profile.speed / spacing)));
    double interval = profile.duration / pieces;
    if (!(interval > 1e-9 && std::isfinite(interval))) {
      result.problem = "the path (" + std::to_string(polylineLength(path)) +
                       " m) leaves no positive time to fit a spline in";
      break;
    }
    Eigen::Matrix3Xd control(3, pieces + 5);
    control.leftCols<3>() = UniformBspline::startControlPoints(start, interval);
    for (int j = 1; j < pieces; ++j) control.col(2 + j) = pointAt(path, profile.at(j * interval));
    control.rightCols<3>().colwise() = path.back();

    solve(control, interval, weight_obstacle, stop, tally);
    if (!reallocateTime(start, control, interval, tally.reallocations)) {
      result.problem = "no time allocation fits the start state on this path (" +
                       std::to_string(polylineLength(path)) + " m)";
      result.trajectory = Trajectory();
      break;
    }
    result.trajectory = UniformBspline(control, interval).toTrajectory();
    tally.control_points = static_cast<double>(control.cols());
    tally.knot_interval = interval;

    CheckQuery query;
    query.start = start;
    query.require_goal = false;
    const CheckResult check = backEndSelfCheck(checker_, *world_, result.trajectory, query);
    result.valid = check.valid;
    if (check.valid) {
      result.problem.clear();
      break;
    }
    result.problem = "round " + std::to_string(rounds) + ": " + check.check +
                     " check at t = " + formatNumber(check.time) + " s: " + check.detail;
    if (check.check != "collision" && check.check != "bounds") break;  // more rounds cannot help
    spacing *= 0.5;
    weight_obstacle *= 4.0;
  }

  result.statistics = {{"smoothing_rounds", rounds},
                       {"ceres_iterations", tally.ceres_iterations},
                       {"ceres_initial_cost", tally.initial_cost},
                       {"ceres_final_cost", tally.final_cost},
                       {"time_reallocations", tally.reallocations},
                       {"control_points", tally.control_points},
                       {"knot_interval", tally.knot_interval}};
  return result;
}

MetricSpecs smootherStatistics() {
  return MetricSpecs()
      .counter("smoothing_rounds", "Ceres solves")
      .counter("ceres_iterations", "Ceres iterations over all solves")
      .real("ceres_initial_cost", "", "objective before the first solve")
      .real("ceres_final_cost", "", "objective after the last solve")
      .counter("time_reallocations", "time re-allocations until the limits hold")
      .counter("control_points", "B-spline control points")
      .real("knot_interval", "s", "B-spline knot interval");
}

std::string ceresVersion() { return CERES_VERSION_STRING; }

}  // namespace kinolab::smoothing
