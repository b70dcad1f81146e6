// `ego_bspline`: EGO-Planner's back end (Zhou et al., RA-L 2021). A uniform cubic B-spline
// from the front end's path is optimised with L-BFGS over smoothness, feasibility and the
// ESDF-free collision term: where the spline collides, an A* guide path around the obstacle
// (the voxel search of grid_astar) gives each control point of the colliding run a {p, v}
// pair, an anchor on the obstacle's surface and a direction away from it, and the control
// point is pushed to s_f in front of the anchor; the optimisation rebounds until no span
// collides. Then the time is re-allocated (the knot interval scaled until the limits hold)
// and the control points refitted to the previous curve with EGO's anisotropic fitness.
#include "ego_bspline.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "grid_path.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/trajectory/uniform_bspline.hpp"

namespace kinolab::ego {
namespace {

constexpr int kFixed = 3;  // control points held at each end

/// The point at arc length `s` along a polyline.
Eigen::Vector3d pointAt(const std::vector<Eigen::Vector3d>& path, double s) {
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double leg = (path[i] - path[i - 1]).norm();
    if (s <= leg && leg > 0.0) return path[i - 1] + (path[i] - path[i - 1]) * (s / leg);
    s -= leg;
  }
  return path.back();
}

/// The control points of a first spline: the start state's three, the path at equal arc
/// lengths, three at its end (rest there).
Eigen::Matrix3Xd initialControl(const ChainState& start, const std::vector<Eigen::Vector3d>& path,
                                double spacing, double interval) {
  const double length = grid::polylineLength(path);
  const int pieces = std::max(2, static_cast<int>(std::ceil(length / spacing)));
  Eigen::Matrix3Xd control(3, pieces + 5);
  control.leftCols<kFixed>() = UniformBspline::startControlPoints(start, interval);
  for (int j = 1; j < pieces; ++j) control.col(2 + j) = pointAt(path, length * j / pieces);
  control.rightCols<kFixed>().colwise() = path.back();
  return control;
}

/// How much longer the knot interval must be for the derivative control points to be within
/// the limits (below 1: how much shorter it could be).
double limitFactor(const Eigen::Matrix3Xd& control, double interval, const DynamicLimits& limits) {
  const UniformBspline spline(control, interval);
  const Eigen::Matrix3Xd velocity = spline.derivativeControlPoints(1);
  const Eigen::Matrix3Xd acceleration = spline.derivativeControlPoints(2);
  double factor = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    factor = std::max(factor, velocity.row(axis).cwiseAbs().maxCoeff() / limits.bound[1][axis]);
    factor = std::max(
        factor, std::sqrt(acceleration.row(axis).cwiseAbs().maxCoeff() / limits.bound[2][axis]));
  }
  return factor;
}

}  // namespace

void EgoBspline::setup(std::shared_ptr<const World> world, const Body& body,
                       const PlannerLimits& limits) {
  world_ = std::move(world);
  body_ = body;
  limits_ = limits;
  checker_ = std::make_unique<TrajectoryChecker>(world_, checkerSettings(body_, limits_));
}

bool EgoBspline::occupied(const Eigen::Vector3d& point) const {
  const VoxelGrid& grid = world_->grid();
  const VoxelIndex voxel =
      ((point - grid.origin()) / grid.resolution()).array().floor().cast<int>();
  return !grid.inside(voxel) || grid.occupied(voxel);
}

std::vector<int> EgoBspline::collidingSpans(const Eigen::Matrix3Xd& control,
                                            double interval) const {
  const double spacing = 0.5 * world_->esdf().resolution();
  const double threshold = body_.keptRadius() + 0.5 * spacing;
  const Eigen::Matrix3Xd velocity = UniformBspline(control, interval).derivativeControlPoints(1);
  std::vector<int> spans;
  for (int span = 0; span + 3 < control.cols(); ++span) {
    const double speed = velocity.middleCols(span, 3).colwise().norm().maxCoeff();
    const int samples = std::max(1, static_cast<int>(std::ceil(speed * interval / spacing)));
    for (int k = 0; k <= samples; ++k) {
      const Eigen::Vector3d point =
          control.middleCols(span, 4) * UniformBspline::basis(static_cast<double>(k) / samples);
      if (!world_->bounds().contains(point) || world_->clearanceFor(point, threshold) < threshold) {
        spans.push_back(span);
        break;
      }
    }
  }
  return spans;
}

std::optional<std::vector<Eigen::Vector3d>> EgoBspline::guidePath(const Eigen::Vector3d& from,
                                                                  const Eigen::Vector3d& to) const {
  const VoxelGrid& grid = world_->grid();
  const auto voxelOf = [&](const Eigen::Vector3d& point) -> VoxelIndex {
    return ((point - grid.origin()) / grid.resolution()).array().floor().cast<int>();
  };
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(settings_.guide_window);
  const grid::FreeVoxels voxels(*world_, body_.keptRadius(), voxelOf(from.cwiseMin(to) - margin),
                                voxelOf(from.cwiseMax(to) + margin));
  // The nearest free voxel to each end, within a few voxels (a control point may lie inside
  // an obstacle: the guide path need only pass around it).
  const auto nearestFree = [&](const Eigen::Vector3d& point) -> std::optional<VoxelIndex> {
    const VoxelIndex centre = voxelOf(point);
    for (int reach = 0; reach <= 5; ++reach) {
      std::optional<VoxelIndex> best;
      for (int dx = -reach; dx <= reach; ++dx) {
        for (int dy = -reach; dy <= reach; ++dy) {
          for (int dz = -reach; dz <= reach; ++dz) {
            const VoxelIndex voxel = centre + VoxelIndex(dx, dy, dz);
            if (!voxels.free(voxel)) continue;
            if (!best || (grid.center(voxel) - point).squaredNorm() <
                             (grid.center(*best) - point).squaredNorm()) {
              best = voxel;
            }
          }
        }
      }
      if (best) return best;
    }
    return std::nullopt;
  };
  const std::optional<VoxelIndex> first = nearestFree(from);
  const std::optional<VoxelIndex> last = nearestFree(to);
  if (!first || !last) return std::nullopt;
  Budget budget;
  budget.max_iterations = 200000;  // the window bounds it; this only guards a huge window
  StopCondition stop(budget);
  const grid::GridSearchResult search =
      grid::searchGrid(voxels, *first, *last, grid::GridAlgorithm::kAStar, stop);
  if (!search.found) return std::nullopt;
  return grid::voxelCentres(grid, search.voxels);
}

std::optional<RepulsionPair> EgoBspline::pairFor(const Eigen::Matrix3Xd& control, int index,
                                                 const std::vector<Eigen::Vector3d>& guide) const {
  const Eigen::Vector3d q = control.col(index);
  const Eigen::Vector3d tangent = control.col(index + 1) - control.col(index - 1);
  if (tangent.norm() < 1e-9) return std::nullopt;
  // The guide path's crossing of the plane through Q normal to the tangent nearest Q.
  std::optional<Eigen::Vector3d> crossing;
  for (std::size_t k = 0; k + 1 < guide.size(); ++k) {
    const double a = (guide[k] - q).dot(tangent);
    const double b = (guide[k + 1] - q).dot(tangent);
    if (a * b > 0.0 || (a == 0.0 && b == 0.0)) continue;
    const Eigen::Vector3d point = guide[k] + (guide[k + 1] - guide[k]) * (a / (a - b));
    if (!crossing || (point - q).norm() < (*crossing - q).norm()) crossing = point;
  }
  if (!crossing) return std::nullopt;
  const double length = (*crossing - q).norm();
  if (length < 1e-5) return std::nullopt;
  const Eigen::Vector3d direction = (*crossing - q) / length;
  // The anchor: walking from the guide path towards Q, the last point before the first
  // occupied voxel (Q itself when none is in between).
  const double step = world_->grid().resolution();
  Eigen::Vector3d anchor = q;
  for (double along = length; along >= 0.0; along -= step) {
    if (occupied(q + along * direction)) {
      anchor = q + std::min(along + step, length) * direction;
      break;
    }
  }
  return RepulsionPair{anchor, direction};
}

int EgoBspline::addPairs(const Eigen::Matrix3Xd& control, const std::vector<int>& spans,
                         EgoObjective& objective, EgoTally& tally) const {
  const int count = static_cast<int>(control.cols());
  if (count <= 2 * kFixed) return 0;
  const double resolution = world_->grid().resolution();
  std::set<int> marked;
  for (const int span : spans) {
    for (const int i : {span + 1, span + 2}) {
      const int index = std::clamp(i, kFixed, count - kFixed - 1);
      // A point whose pair still has it behind (or barely in front of) its anchor is being
      // pushed already (EGO's check): no new guide path for it.
      const auto& pairs = objective.pairs()[index];
      const bool pushed = std::any_of(pairs.begin(), pairs.end(), [&](const RepulsionPair& p) {
        return (control.col(index) - p.anchor).dot(p.direction) < resolution;
      });
      if (!pushed) marked.insert(index);
    }
  }
  int added = 0;
  for (auto it = marked.begin(); it != marked.end();) {
    int last = *it;
    const int first = last;
    while (std::next(it) != marked.end() && *std::next(it) == last + 1) last = *++it;
    ++it;
    const auto guide = guidePath(control.col(first - 1), control.col(last + 1));
    if (!guide) {
      ++tally.guide_failures;
      continue;
    }
    ++tally.guide_paths;
    std::vector<std::optional<RepulsionPair>> run;
    for (int j = first; j <= last; ++j) run.push_back(pairFor(control, j, *guide));
    // Points without a crossing take their neighbour's pair (EGO's step 3).
    for (std::size_t j = 1; j < run.size(); ++j) {
      if (!run[j]) run[j] = run[j - 1];
    }
    for (std::size_t j = run.size() - 1; j-- > 0;) {
      if (!run[j]) run[j] = run[j + 1];
    }
    for (std::size_t j = 0; j < run.size(); ++j) {
      if (!run[j]) continue;
      // A new pair replaces those that push the other way (not in the paper): at a doorway
      // such opposite pairs hold the point between them, short of both safe distances.
      std::vector<RepulsionPair>& pairs = objective.pairs()[first + static_cast<int>(j)];
      std::erase_if(pairs, [&](const RepulsionPair& old) {
        return old.direction.dot(run[j]->direction) < 0.0;
      });
      pairs.push_back(*run[j]);
      ++added;
    }
  }
  return added;
}

bool EgoBspline::rebound(Eigen::Matrix3Xd& control, double interval, EgoObjective& objective,
                         StopCondition& stop, EgoTally& tally) const {
  for (;;) {
    tally.iterations += minimise(objective, control, interval, settings_.max_iterations, stop);
    const std::vector<int> spans = collidingSpans(control, interval);
    if (spans.empty()) return true;
    if (tally.rebounds >= settings_.max_rebounds || stop.elapsed() >= stop.budget().time_limit) {
      return false;
    }
    ++tally.rebounds;
    // No new pair: the present ones push too weakly against the other terms.
    if (addPairs(control, spans, objective, tally) == 0) objective.scaleCollision(2.0);
  }
}

bool EgoBspline::reallocate(const ChainState& start, Eigen::Matrix3Xd& control, double& interval,
                            EgoObjective& objective, StopCondition& stop, EgoTally& tally) const {
  const bool at_rest = start.col(1).isZero() && start.col(2).isZero();
  const double first_interval = interval;
  for (int attempt = 0; attempt < 40; ++attempt) {
    const double factor = limitFactor(control, interval, limits_.limits);
    if (!(factor > 1.0)) return true;
    // The refit's reference: the present curve at its knots (the same places, later).
    Eigen::Matrix3Xd reference(3, control.cols() - 2);
    for (int k = 0; k < reference.cols(); ++k) {
      reference.col(k) = (control.col(k) + 4.0 * control.col(k + 1) + control.col(k + 2)) / 6.0;
    }
    interval *= factor * (1.0 + 1e-9);
    if (!(interval < 100.0 * first_interval)) return false;
    if (!at_rest) control.leftCols<kFixed>() = UniformBspline::startControlPoints(start, interval);
    if (tally.reallocations >= settings_.max_reallocations) continue;  // stretch only
    ++tally.reallocations;
    objective.setReference(std::move(reference));
    tally.iterations += minimise(objective, control, interval, settings_.max_iterations, stop);
    objective.setReference({});
    if (!rebound(control, interval, objective, stop, tally)) return false;
  }
  return !(limitFactor(control, interval, limits_.limits) > 1.0);
}

BackEndResult EgoBspline::refine(const BackEndProblem& problem, StopCondition& stop) const {
  if (!world_) throw InvalidArgument("ego_bspline: refine() before setup()");
  BackEndResult result;
  EgoTally tally;
  const auto finish = [&](std::string failure) {
    result.failure = std::move(failure);
    result.statistics = {
        {"ego_iterations", tally.iterations},       {"ego_rebounds", tally.rebounds},
        {"ego_guide_paths", tally.guide_paths},     {"ego_guide_failures", tally.guide_failures},
        {"ego_reallocations", tally.reallocations}, {"ego_final_cost", tally.final_cost}};
    if (!result.failure.empty()) result.trajectory = Trajectory();
    return result;
  };
  if (std::string bad = backEndInputProblem(problem); !bad.empty()) return finish(std::move(bad));
  std::vector<Eigen::Vector3d> path{problem.start.col(0)};
  for (const Eigen::Vector3d& point : problem.path) {
    if ((point - path.back()).norm() > 1e-9) path.push_back(point);
  }
  if (path.size() < 2) return finish("the path has no length to refine");
  double interval =
      settings_.knot_spacing / (settings_.initial_speed * limits_.limits.bound[1].minCoeff());
  Eigen::Matrix3Xd control = initialControl(problem.start, path, settings_.knot_spacing, interval);
  EgoObjective objective(settings_.weights, limits_.limits, safeDistance());
  objective.pairs().resize(control.cols());
  addPairs(control, collidingSpans(control, interval), objective, tally);
  if (!rebound(control, interval, objective, stop, tally)) {
    return finish("the spline still collides after " + std::to_string(tally.rebounds) +
                  " rebounds");
  }
  if (!reallocate(problem.start, control, interval, objective, stop, tally)) {
    return finish("no time allocation within the limits keeps the spline free");
  }
  tally.final_cost = objective.evaluate(control, interval, nullptr);
  result.trajectory = UniformBspline(control, interval).toTrajectory();
  CheckQuery query;
  query.start = problem.start;
  query.goal = path.back();
  query.goal_radius = limits_.goal_radius;
  const CheckResult check = backEndSelfCheck(*checker_, *world_, result.trajectory, query);
  if (!check.valid) {
    return finish("its own check rejects the spline: " + check.check +
                  " at t = " + formatNumber(check.time) + " s: " + check.detail);
  }
  return finish("");
}

MetricSpecs egoStatistics() {
  MetricSpecs specs;
  specs.counter("ego_iterations", "L-BFGS iterations, every optimisation")
      .counter("ego_rebounds", "optimisations again after a collision was found")
      .counter("ego_guide_paths", "A* guide paths found for colliding runs of control points")
      .counter("ego_guide_failures", "colliding runs for which no guide path was found")
      .counter("ego_reallocations", "time re-allocations followed by a refit")
      .real("ego_final_cost", "1", "the objective at the end (smoothness, collision, limits)");
  return specs;
}

}  // namespace kinolab::ego

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<BackEnd>(
      "ego_bspline",
      "EGO-Planner's ESDF-free B-spline back end: L-BFGS on smoothness, limits and {p, v} "
      "pairs from A* guide paths around collisions, then time re-allocation",
      declareFields<ego::EgoSettings>(),
      [](const ParameterSet& parameters) {
        return std::make_unique<ego::EgoBspline>(readFields<ego::EgoSettings>(parameters));
      },
      ego::egoStatistics());
}
