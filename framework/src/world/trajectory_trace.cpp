#include "kinolab/world/trajectory_trace.hpp"

#include <algorithm>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/trajectory/segment_bounds.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {
namespace {

/// The distance from a point inside `box` to its nearest face.
double insideMargin(const Box& box, const Eigen::Vector3d& point) {
  return std::min((point - box.min).minCoeff(), (box.max - point).minCoeff());
}

/// traceTrajectory() over `clearance` (World::clearanceFor's contract), a template so that
/// the searches' own check calls the world's directly.
template <typename Clearance>
TraceResult traceWith(const Clearance& clearanceFor, const Box& domain,
                      const Trajectory& trajectory, double radius, double tolerance, double from,
                      double to) {
  if (!(radius >= 0.0 && radius < INFINITY && tolerance > 0.0 && tolerance < INFINITY)) {
    throw InvalidArgument("traceTrajectory: radius " + formatNumber(radius) + " and tolerance " +
                          formatNumber(tolerance) +
                          " must be finite, the radius >= 0 and the tolerance > 0");
  }
  TraceResult result;
  double segment_start = 0.0;
  for (const TrajectorySegment& segment : trajectory.segments()) {
    const double segment_end = segment_start + segment.duration;
    const double begin = std::max(from, segment_start) - segment_start;
    const double end = std::min(to, segment_end) - segment_start;
    if (begin <= end) {
      const double speed = speedBound(segment);
      for (double t = begin;;) {
        const Eigen::Vector3d position = segment.evaluate(t);
        ++result.queries;
        const bool inside = position.allFinite() && domain.contains(position);
        const double clearance = inside ? clearanceFor(position, radius) : -INFINITY;
        if (!(clearance >= radius)) {
          result = {false, !inside, segment_start + t, position, result.queries};
          return result;
        }
        if (t >= end) break;
        const double reach = std::max(
            std::min(clearance - radius + tolerance, insideMargin(domain, position)), tolerance);
        t = speed > 0.0 ? std::min(end, t + reach / speed) : end;
      }
    }
    segment_start = segment_end;
  }
  return result;
}

}  // namespace

TraceResult traceTrajectory(const World& world, const Trajectory& trajectory, double radius,
                            double tolerance, double from, double to) {
  return traceWith([&](const Eigen::Vector3d& p, double r) { return world.clearanceFor(p, r); },
                   world.bounds(), trajectory, radius, tolerance, from, to);
}

TraceResult traceTrajectory(const TraceClearance& clearance, const Box& domain,
                            const Trajectory& trajectory, double radius, double tolerance,
                            double from, double to) {
  return traceWith(clearance, domain, trajectory, radius, tolerance, from, to);
}

}  // namespace kinolab
