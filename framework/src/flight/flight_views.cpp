#include "flight_views.hpp"

#include <algorithm>
#include <cmath>

namespace kinolab::flight_motion {

double lookAlong(const Trajectory& intended, double t, const VehicleMap& map, const Body& body,
                 bool seen_only, double speed, const Eigen::Vector3d& goal) {
  constexpr double kNearestLook = 0.5;  // m
  const auto towards = [](const Eigen::Vector2d& v) { return std::atan2(v.y(), v.x()); };
  const Eigen::Vector3d here = intended.evaluate(std::min(t, intended.duration()));
  const Eigen::Vector2d ahead =
      (intended.evaluate(std::min(t + 1.0, intended.duration())) - here).head<2>();
  if (ahead.norm() > 0.3) return towards(ahead);
  const double spacing = 0.5 * map.model().resolution;
  std::optional<Eigen::Vector2d> first;
  std::optional<Eigen::Vector2d> unseen;
  everySample(t, intended.duration(), spacing, speed, [&](double s) {
    const Eigen::Vector3d p = intended.evaluate(s);
    const Eigen::Vector2d away = (p - here).head<2>();
    if (away.norm() < kNearestLook) return true;
    if (!first) first = away;
    if (!seen_only) return false;  // the first point that far is all it looks for
    if (map.knownFreeAround(p, body.keptRadius())) return true;
    unseen = away;
    return false;
  });
  if (unseen) return towards(*unseen);
  if (first) return towards(*first);
  const Eigen::Vector2d to_goal = (goal - here).head<2>();
  return to_goal.norm() > 1e-9 ? towards(to_goal) : 0.0;
}

std::pair<double, double> elevationTangents(const std::vector<Eigen::Vector3d>& rays) {
  std::pair<double, double> tangents{0.0, 0.0};
  for (const Eigen::Vector3d& ray : rays) {
    const double across = ray.head<2>().norm();
    const double tangent = across > 1e-9 ? ray.z() / across : (ray.z() > 0 ? 1e9 : -1e9);
    tangents.first = std::max(tangents.first, tangent);
    tangents.second = std::max(tangents.second, -tangent);
  }
  return tangents;
}

std::optional<Eigen::Vector3d> planBlocker(const VehicleMap& map, const Trajectory& plan,
                                           const Body& body, double inset) {
  const TraceResult trace = vouchedTrace(map, plan, 0.0, body, inset);
  if (trace.free || trace.left_domain) return std::nullopt;
  const double reach = body.radius + map.model().resolution;
  Eigen::Vector3d nearest;
  if (map.unvouchedDistance(trace.position, reach, &nearest) >= reach) return std::nullopt;
  return nearest;
}

double yawTowards(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  return std::atan2(to.y() - from.y(), to.x() - from.x());
}

std::vector<StepBackMove> stepBackMoves(const Eigen::Vector3d& position,
                                        const Eigen::Vector3d& blocker,
                                        const Eigen::Vector2d& facing,
                                        std::pair<double, double> tangents, double radius,
                                        double voxel, double longest) {
  Eigen::Vector2d towards = (blocker - position).head<2>();
  towards = towards.norm() < 1e-3 ? facing : towards.normalized();
  const double rise = blocker.z() - position.z();
  const double tangent = rise >= 0.0 ? tangents.first : tangents.second;
  const double needed = std::max(std::abs(rise), radius) / std::max(tangent, 1e-3) + 2.0 * voxel;
  const Eigen::Vector2d from = (position - blocker).head<2>();
  std::vector<StepBackMove> moves;
  for (double shortfall = 0.0; shortfall <= longest - 0.2 + 1e-9; shortfall += 0.2) {
    for (const double turn : {0.0, 45.0, -45.0, 90.0, -90.0}) {
      const double c = std::cos(turn * kDegree);
      const double s = std::sin(turn * kDegree);
      const Eigen::Vector2d away(-(c * towards.x() - s * towards.y()),
                                 -(s * towards.x() + c * towards.y()));
      // The length that ends `needed` from the blocker: |from + L away| = needed.
      const double b = from.dot(away);
      const double disc = b * b - (from.squaredNorm() - needed * needed);
      if (disc < 0.0) continue;
      const double length = std::min(longest, -b + std::sqrt(disc)) - shortfall;
      if (length < 0.2) continue;
      const Eigen::Vector3d offset(length * away.x(), length * away.y(), 0.0);
      moves.push_back({offset, yawTowards(position + offset, blocker)});
    }
  }
  return moves;
}

std::vector<std::vector<Eigen::Vector3d>> levelGuides(const VehicleMap& map,
                                                      std::span<const Eigen::Vector3d> froms,
                                                      const Eigen::Vector3d& goal, double radius,
                                                      double margin,
                                                      std::span<const Eigen::Vector3d> trail) {
  const Box& box = map.bounds();
  std::vector<double> levels;
  for (double level = box.min.z() + radius + margin; level <= box.max.z() - radius - margin + 1e-9;
       level += radius) {
    levels.push_back(level);
  }
  return levelColumnGuides(map.lattice(), map.obstacleColumns(), froms, goal, radius, levels,
                           radius, map.model().inset, trail);
}

std::vector<std::vector<Eigen::Vector3d>> flightGuides(const VehicleMap& map,
                                                       const PlanningQuery& query,
                                                       std::array<Eigen::Vector3d, 2> froms,
                                                       std::pair<double, double> band,
                                                       double radius, double margin,
                                                       std::span<const Eigen::Vector3d> trail) {
  const double low = std::min(query.start(2, 0), query.goal.z());
  const double high = std::max(query.start(2, 0), query.goal.z());
  std::array<Eigen::Vector3d, 2> band_froms = froms;
  for (Eigen::Vector3d& from : band_froms) from.z() = std::clamp(from.z(), low, high);
  auto guides = map.guides(band_froms, query.goal, radius, band.first, band.second, radius, trail);
  if (!guides[0].empty()) return guides;
  return levelGuides(map, froms, query.goal, radius, margin, trail);
}

std::vector<BackOff> backOffMoves(const std::string& status, const Eigen::Vector3d& position,
                                  const World& window, const Box& domain, double radius,
                                  double voxel) {
  std::vector<BackOff> moves;
  const bool refused = status == "invalid_start";
  if (refused && !domain.contains(position)) {
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant(0.05);
    const Eigen::Vector3d inside =
        position.cwiseMax(domain.min + margin).cwiseMin(domain.max - margin);
    moves.push_back({inside - position, true});
  }
  const double touching = radius + 0.5 * voxel;
  const bool pressed = (status == "no_solution" || status == "timeout") &&
                       window.bounds().contains(position) &&
                       window.clearanceFor(position, touching) < touching;
  if (!refused && !pressed) return moves;
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  window.esdf().distanceWithGradient(position, &gradient);
  const Eigen::Vector3d full = gradient;
  gradient.z() = 0.0;
  if (gradient.norm() < 0.2 * full.norm()) gradient = full;
  if (gradient.norm() >= 1e-6) moves.push_back({0.3 * gradient.normalized(), refused});
  return moves;
}

bool arrivesFirst(const Trajectory& committed, const Trajectory& plan, double t_start,
                  const Eigen::Vector3d& goal, double spacing, double speed) {
  if (plan.empty() || committed.duration() <= t_start) return false;
  const double reach = (plan.endPosition() - goal).norm() + 1e-9;
  const double by = std::min(committed.duration(), t_start + plan.duration());
  const auto far = [&](double s) { return (committed.evaluate(s) - goal).norm() > reach; };
  return !everySample(t_start, by, spacing, speed, far) || !far(by);
}

}  // namespace kinolab::flight_motion
