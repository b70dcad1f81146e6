#pragma once

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/metric_specs.hpp"
#include "kinolab/core/parameters.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/trajectory/trajectory.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

// ---- the sensor ------------------------------------------------------------------------------

/// A range sensor ray-cast into the ground-truth grid: a pinhole depth camera looking along
/// the vehicle's heading, or a 360-degree lidar (beams around, channels up and down).
struct SensorModel {
  enum class Kind { kDepthCamera, kLidar };
  Kind kind = Kind::kDepthCamera;
  double range = 5.0;                ///< m
  double rate = 10.0;                ///< frames per second
  double fov_horizontal = M_PI / 2;  ///< rad (camera)
  double fov_vertical = M_PI / 3;    ///< rad (camera and lidar)
  int width = 32;                    ///< pixels (camera)
  int height = 24;
  int beams = 360;  ///< per revolution (lidar)
  int channels = 16;

  /// Every ray's direction in the vehicle frame (x ahead, z up), unit length.
  std::vector<Eigen::Vector3d> rayDirections() const;
};

/// One frame: where it was taken, the hit points (on the struck cube's face, nudged inside it)
/// and the ends of rays that struck nothing within range (placed just beyond it).
struct SensorFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> hits;
  std::vector<Eigen::Vector3d> misses;
};

/// Distance along the unit `direction` from `origin` to the first occupied voxel cube of
/// `grid` (0 when origin is inside one), exact (the cube's entry point, Amanatides-Woo
/// traversal); INFINITY when the ray leaves the grid or passes `max_range` first.
double castRay(const VoxelGrid& grid, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction, double max_range);

/// A frame of `model` from `origin`, the vehicle heading `yaw` (rad about z), world frame.
SensorFrame senseFrame(const VoxelGrid& truth, const SensorModel& model,
                       const Eigen::Vector3d& origin, double yaw);

// ---- the vehicle's map -------------------------------------------------------------------------

/// How the planning window treats space the sensor has not seen.
enum class UnknownSpace { kFree, kOccupied, kFreeBeyond };

struct MapModel {
  double resolution = 0.1;     ///< m; the map's voxels align with the ground truth's lattice
  double window = 8.0;         ///< m: the planning window's side in x and y
  double window_height = 2.0;  ///< m: its height (centred on the vehicle, within the map)
  UnknownSpace unknown = UnknownSpace::kFree;
  double free_beyond = 2.0;      ///< m (kFreeBeyond): unknown is occupied closer than this
  double probability_hit = 0.7;  ///< OctoMap sensor model
  double probability_miss = 0.4;
};

/// What the vehicle knows: an OctoMap OcTree updated with every frame (log-odds, max range),
/// and from it a planning window around the vehicle with its exact ESDF.
class KnownMap {
 public:
  /// A map of `bounds` (the ground truth's box; positions outside are never mapped).
  KnownMap(const Box& bounds, const MapModel& model);
  ~KnownMap();
  KnownMap(KnownMap&&) noexcept;
  KnownMap& operator=(KnownMap&&) noexcept;

  /// Inserts a frame: free space along every ray, an occupied voxel at every hit.
  void insert(const SensorFrame& frame, double max_range);
  /// Marks the unseen voxels within `radius` of `center` free (where the vehicle is, nothing
  /// can be), in the tree and the mirror; voxels the sensor has seen keep their state.
  void markFree(const Eigen::Vector3d& center, double radius);
  /// The planning world: the window of side `window` around `center` (clamped to the map),
  /// known occupied voxels and unknown ones as `unknown` says (kFreeBeyond: measured from
  /// `center`), with its exact ESDF.
  std::shared_ptr<const World> window(const Eigen::Vector3d& center) const;
  /// A shortest 8-connected path over the map's x-y cells from `from` to `to`, through cells
  /// with no known occupied voxel within `radius` in the heights [z_low, z_high] (unknown is
  /// free): the global guide a local goal is taken from. Cell centres at heights
  /// interpolated from `from` to `to`; empty when the known map leaves no way.
  std::vector<Eigen::Vector3d> guide(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                     double radius, double z_low, double z_high) const;
  /// The known map from above over heights [z_low, z_high], as text: a line
  /// "nx,ny,origin_x,origin_y,resolution", then per x one line of ny digits, per column 2 (a
  /// known obstacle in the band), 1 (known free there) or 0 (unknown).
  std::string topView(double z_low, double z_high) const;
  /// Voxels known free and known occupied.
  std::size_t knownFree() const;
  std::size_t knownOccupied() const;
  /// The known occupied voxels, as indices of the map's lattice (x slowest, z fastest).
  std::vector<std::size_t> occupiedVoxels() const;
  /// The centre of the lattice voxel `index` (world frame).
  Eigen::Vector3d voxelCenter(std::size_t index) const;
  /// Writes the OcTree as a .bt file (world frame: the tree is kept relative to the map's
  /// origin, so the file is shifted back on writing).
  void write(const std::string& path) const;

 private:
  struct Tree;
  std::unique_ptr<Tree> tree_;
  Box bounds_;
  MapModel model_;
};

// ---- the flight ------------------------------------------------------------------------------

/// When the loop replans and how it treats time.
struct FlightSettings {
  double replan_period = 0.5;  ///< s between planned replans (and on every collision found)
  double replan_budget = 0.1;  ///< s: each replan's time budget
  /// A replan plans from the committed state this long after its frame (the vehicle flies
  /// the committed trajectory meanwhile), by default the budget: simulated time does not
  /// depend on the measured planning time, so a flight repeats bit for bit.
  double latency = 0.1;
  /// Reject a plan whose measured planning time exceeds the latency (real time).
  bool enforce_latency = false;
  double horizon = 3.5;             ///< m: the local goal's distance when the goal is farther
  double max_time = 120.0;          ///< s of flight
  double stuck_time = 15.0;         ///< s without 0.5 m of progress towards the goal
  double goal_tolerance = 0.5;      ///< m: reached when this close to the goal
  double brake_acceleration = 3.0;  ///< m/s^2 per axis for braking to a stop
  /// > 0: keep the known map from above (KnownMap::topView over the query's heights) every
  /// this many seconds of flight, for animations; 0: none.
  double snapshot_period = 0.0;
};

/// Every parameter of a flight (sensor, map, loop), declared, typed and ranged like a
/// planner's, their defaults those of SensorModel, MapModel and FlightSettings (`kinolab fly
/// --flight NAME=VALUE`, an experiment's `flight:`).
const ParameterSpecs& flightParameters();
/// The models and settings of resolved flight parameters.
void flightModels(const ParameterSet& parameters, SensorModel* sensor, MapModel* map,
                  FlightSettings* settings);

/// One replan of a flight.
struct FlightReplan {
  double time = 0.0;   ///< s: the frame that asked for it
  std::string reason;  ///< "start", "period", "collision", "retry"
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d local_goal = Eigen::Vector3d::Zero();
  std::string status;  ///< the planner's status
  double planning_time_ms = 0.0;
  double distance_to_goal = 0.0;  ///< the plan's D to its local goal
  bool accepted = false;          ///< it became the committed trajectory
  Trajectory trajectory;          ///< the plan (planner's time, from 0)
};

struct FlightResult {
  /// reached (within goal_tolerance), collision, stuck, timeout, invalid_start, invalid_goal
  std::string status;
  std::string message;
  PlanningModel model;  ///< the planner's body and limits the flight was judged with
  Trajectory flown;     ///< from t = 0 to the end of the flight (or the collision)
  std::vector<FlightReplan> replans;
  double time_to_goal = 0.0;   ///< s (NaN unless reached)
  double min_clearance = 0.0;  ///< m: to the ground truth's cubes, less the body radius
  int frames = 0;
  double time_sense_ms = 0.0;  ///< summed wall time: sensor, map insertion, window + ESDF
  double time_map_ms = 0.0;
  double time_window_ms = 0.0;
  double time_guide_ms = 0.0;  ///< summed over the replans: the global guide on the known map
  std::shared_ptr<const KnownMap> map;  ///< the final known map
  /// (time, KnownMap::topView) every snapshot_period and at the end, when asked for.
  std::vector<std::pair<double, std::string>> snapshots;
  /// With snapshots: every voxel the final known map holds occupied (its centre) and the
  /// snapshot time it was first known occupied, in that order: the map growing, in 3D.
  std::vector<std::pair<double, Eigen::Vector3d>> known_voxels;
};

/// FlightResult::known_voxels as CSV `t,x,y,z` (the runner's flights table).
std::string knownVoxelsCsv(const FlightResult& result);

/// Makes a planner set up on a world (one per replan window).
using PlannerFactory = std::function<std::unique_ptr<Planner>(std::shared_ptr<const World>)>;

/// Flies `query` through `truth`, seeing it only through `sensor`: simulated time, a replan
/// at every `replan_period` and whenever the committed trajectory collides in the updated
/// map; a replan starts from the committed state `latency` after its frame; a failed replan
/// keeps the committed trajectory (every committed trajectory ends at rest: plans get a
/// braking tail) or, if that collides in the known map, brakes at once. The vehicle tracks
/// the committed trajectory exactly. The flown trajectory goes through the independent
/// checker against `truth` at the end: a collision ends the flight there, as `collision`.
FlightResult fly(const std::shared_ptr<const World>& truth, const PlannerFactory& planner,
                 const PlanningQuery& query, const SensorModel& sensor, const MapModel& map,
                 const FlightSettings& settings);

/// The metrics of a flight (`kinolab list metrics`; the JSON summary of `kinolab fly`):
/// status, success (reached), time to goal, flown length, mean speed, replans and failed
/// replans, replan planning time (median, p95, max), minimum clearance to the ground truth,
/// the plans' D (median, max), jerk integral, frames and the per-frame sensing, map and
/// window times.
const MetricSpecs& flightMetrics();
/// Every replan of a flight as CSV: replan, time, reason, start and local goal (x, y, z),
/// status, planning_time_ms, distance_to_goal, accepted.
std::string replansCsv(const FlightResult& result);
/// The numeric ones (every flight metric but status, message and success): a flight run's
/// statistics in the runner's database.
const MetricSpecs& flightStatistics();
MetricValues flightValues(const FlightResult& result);

}  // namespace kinolab
