// What a flight records: its statistics and run metrics (declared once), the replans and
// known voxels as CSV.
#include <algorithm>
#include <cmath>

#include "kinolab/core/text.hpp"
#include "kinolab/flight/flight.hpp"

namespace kinolab {

const MetricSpecs& flightStatistics() {
  static const MetricSpecs specs =
      MetricSpecs()
          .real("time_to_goal", "s", "simulated flight time to the goal (reached only)")
          .lower()
          .comparable()
          .real("mean_speed", "m/s", "flown length over flight time")
          .counter("replans", "replans made (planned, on collision, retries)")
          .counter("failed_replans",
                   "replans whose plan was not taken (kept replans are not failures)")
          .counter("kept_replans",
                   "replans whose plan was set aside for the committed trajectory, which comes "
                   "as near the local goal no later")
          .clock("replan_time_median_ms", "median planning time of the replans")
          .clock("replan_time_p95_ms", "95th percentile planning time of the replans")
          .clock("replan_time_max_ms", "largest planning time of a replan")
          .counter("inside_margin",
                   "1 when the body came nearer the ground truth than the planning margin "
                   "(tracking took it inside the clearance it was planned with), else 0: its "
                   "mean is the share of such flights")
          .real("plan_distance_median", "m", "median D of the replans' plans to their goals")
          .real("plan_distance_max", "m", "largest D of a replan's plan")
          .real("tracking_error_max", "m",
                "largest distance between the flown and the committed position (0: perfect "
                "tracking)")
          .real("tracking_error_rms", "m", "its root mean square over the flight")
          .counter("late_replans", "replans whose plan came past the latency (real time)")
          .counter("backups",
                   "times the vehicle flew onto its back-up, the stop in known-free space that "
                   "ends every committed trajectory, at speed and short of the goal: no plan took "
                   "over in time (one failed, came late, or was cut where the known map stops "
                   "vouching for it)")
          .real("guide_length", "m",
                "the query's difficulty, on the ground truth: the shortened guide's length")
          .real("traversability_obstruction", "",
                "FlightBench's TO along the guide: narrow passages make it large")
          .real("view_occlusion", "", "FlightBench's VO: obstacles close ahead along the guide")
          .real("angle_over_length", "1/m",
                "FlightBench's AOL: the guide's turns, sum exp(2 theta / pi) - 1, over its length")
          .real("obstacles_per_hectare", "1/ha",
                "obstacles cut by the horizontal slice at the start's height per hectare (trees "
                "in a forest)")
          .counter("frames", "sensor frames")
          .clock("frame_time_ms", "mean per frame: sensing, map insertion, window and ESDF")
          .clock("guide_time_ms", "mean per replan: the global guide on the known map");
  return specs;
}

namespace {

/// The `q` quantile (linear between order statistics) of `values`; none when empty.
MetricValue quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::monostate{};
  std::sort(values.begin(), values.end());
  const double position = q * static_cast<double>(values.size() - 1);
  const auto low = static_cast<std::size_t>(std::floor(position));
  const std::size_t high = std::min(values.size() - 1, low + 1);
  return values[low] + (position - static_cast<double>(low)) * (values[high] - values[low]);
}

/// The planning times of the replans that planned.
std::vector<double> replanTimes(const FlightResult& result) {
  std::vector<double> times;
  for (const FlightReplan& replan : result.replans) {
    if (replan.status != "no_local_goal") times.push_back(replan.planning_time_ms);
  }
  return times;
}

}  // namespace

const MetricList<FlightResult>& flightRunMetrics() {
  using F = FlightResult;
  static const MetricList<F> list =
      MetricList<F>()
          .add(MetricSpecs().text("status",
                                  "reached, collision (with the ground truth), left_map (the "
                                  "vehicle left the world's box), stuck, timeout, "
                                  "invalid_start, invalid_goal"),
               [](const F& f) -> MetricValue { return f.status; })
          .add(MetricSpecs().text("message", "why, for statuses other than reached"),
               [](const F& f) -> MetricValue { return f.message; })
          .add(MetricSpecs()
                   .boolean("success", "reached the goal without a collision")
                   .higher()
                   .comparable(),
               [](const F& f) -> MetricValue { return f.status == "reached" ? 1.0 : 0.0; })
          .add(MetricSpecs()
                   .clock("planning_time_ms", "the replans' median planning time")
                   .lower()
                   .comparable(),
               [](const F& f) { return quantile(replanTimes(f), 0.5); })
          .add(MetricSpecs()
                   .real("distance_to_goal", "m", "from where the flight ended to the goal")
                   .lower()
                   .comparable(),
               [](const F& f) { return numberOrNone(f.distance_to_goal); })
          .include(evaluationMetrics(),
                   [](const F& f) { return f.flown.empty() ? nullptr : &f.evaluation; })
          .add(MetricSpecs()
                   .boolean("checker_valid", "the flown trajectory kept off the ground truth")
                   .higher()
                   .comparable(),
               [](const F& f) -> MetricValue { return f.status == "collision" ? 0.0 : 1.0; })
          .add(MetricSpecs().text("checker_check", "collision, when the flight hit"),
               [](const F& f) -> MetricValue {
                 return f.status == "collision" ? std::string("collision") : std::string();
               })
          .add(MetricSpecs().text("checker_detail", "where it hit"), [](const F& f) -> MetricValue {
            return f.status == "collision" ? f.message : std::string();
          });
  return list;
}

const MetricSpecs& flightMetrics() {
  static const MetricSpecs specs =
      MetricSpecs(flightRunMetrics().specs()).include(flightStatistics());
  return specs;
}

std::string knownVoxelsCsv(const FlightResult& result) {
  std::string csv = "t,x,y,z\n";
  for (const auto& [time, center] : result.known_voxels) {
    csv += formatNumber(time) + "," + formatNumber(center.x()) + "," + formatNumber(center.y()) +
           "," + formatNumber(center.z()) + "\n";
  }
  return csv;
}

namespace {

/// A CSV field: quoted (inner quotes doubled) when it holds a comma, a quote or a line break.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

}  // namespace

std::string replansCsv(const FlightResult& result) {
  const auto point = [](const Eigen::Vector3d& p) {
    return formatNumber(p.x()) + "," + formatNumber(p.y()) + "," + formatNumber(p.z());
  };
  std::string csv =
      "replan,time,reason,start_x,start_y,start_z,goal_x,goal_y,goal_z,status,planning_time_ms,"
      "distance_to_goal,accepted,kept,backup,recovery,why\n";
  for (std::size_t i = 0; i < result.replans.size(); ++i) {
    const FlightReplan& r = result.replans[i];
    csv += std::to_string(i) + "," + formatNumber(r.time) + "," + r.reason + "," + point(r.start) +
           "," + point(r.local_goal) + "," + r.status + "," + formatNumber(r.planning_time_ms) +
           "," + formatNumber(r.distance_to_goal) + "," + (r.accepted ? "1" : "0") + "," +
           (r.kept ? "1" : "0") + "," + (r.backup ? "1" : "0") + "," + r.recovery + "," +
           csvField(r.why) + "\n";
  }
  return csv;
}

MetricValues flightStatisticValues(const FlightResult& result) {
  std::vector<double> distances;
  int failed = 0;
  for (const FlightReplan& replan : result.replans) {
    if (std::isfinite(replan.distance_to_goal)) distances.push_back(replan.distance_to_goal);
    failed += replan.accepted || replan.kept ? 0 : 1;
  }
  const std::vector<double> times = replanTimes(result);
  const double duration = result.flown.duration();
  const double length = result.flown.length();
  const double per_frame =
      result.frames > 0
          ? (result.time_sense_ms + result.time_map_ms + result.time_window_ms) / result.frames
          : NAN;
  return {
      {"time_to_goal", numberOrNone(result.time_to_goal)},
      {"mean_speed", numberOrNone(duration > 0.0 ? length / duration : NAN)},
      {"replans", static_cast<double>(result.replans.size())},
      {"failed_replans", static_cast<double>(failed)},
      {"kept_replans",
       static_cast<double>(std::count_if(result.replans.begin(), result.replans.end(),
                                         [](const FlightReplan& r) { return r.kept; }))},
      {"replan_time_median_ms", quantile(times, 0.5)},
      {"replan_time_p95_ms", quantile(times, 0.95)},
      {"replan_time_max_ms", quantile(times, 1.0)},
      {"inside_margin", result.inside_margin ? 1.0 : 0.0},
      {"plan_distance_median", quantile(distances, 0.5)},
      {"plan_distance_max", quantile(distances, 1.0)},
      {"tracking_error_max", numberOrNone(result.tracking_error_max)},
      {"tracking_error_rms", numberOrNone(result.tracking_error_rms)},
      {"guide_length", numberOrNone(result.difficulty.guide_length)},
      {"traversability_obstruction", numberOrNone(result.difficulty.traversability_obstruction)},
      {"view_occlusion", numberOrNone(result.difficulty.view_occlusion)},
      {"angle_over_length", numberOrNone(result.difficulty.angle_over_length)},
      {"obstacles_per_hectare", numberOrNone(result.difficulty.obstacles_per_hectare)},
      {"late_replans", static_cast<double>(std::count_if(
                           result.replans.begin(), result.replans.end(),
                           [](const FlightReplan& replan) { return replan.status == "late"; }))},
      {"backups", static_cast<double>(result.backups)},
      {"frames", static_cast<double>(result.frames)},
      {"frame_time_ms", numberOrNone(per_frame)},
      {"guide_time_ms",
       numberOrNone(result.replans.empty() ? NAN : result.time_guide_ms / result.replans.size())}};
}

MetricValues flightValues(const FlightResult& result) {
  MetricValues values = flightRunMetrics().values(result);
  const MetricValues statistics = flightStatisticValues(result);
  values.insert(values.end(), statistics.begin(), statistics.end());
  return values;
}

}  // namespace kinolab
