#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/planner/metrics.hpp"

struct sqlite3;

namespace kinolab {

/// What the runner measures of every run beside the planner's result.
const MetricSpecs& runnerMetrics();

/// The version of the results database layout this kinolab writes (meta `schema_version`).
/// Version 2 derives the runs table and the `metrics` table from the declared metrics;
/// version 6 adds the `progress` table (anytime progress series); version 7 the runs' load
/// average and the meta table's machine (CPU model, cores); version 8 the checker's
/// evaluation of every trajectory, the runs' objective and time limit, the metrics' direction
/// and comparability, and the `planned` table (the run hashes of the experiment as last run).
inline constexpr int kResultsSchemaVersion = 8;

/// One finished run as stored: what defines it, then the values of resultMetrics() and
/// runnerMetrics() (by name; a missing or none value is NULL) and the planner's statistics.
struct RunRecord {
  std::string run_hash;
  int variant = 0;
  std::string sweep;  ///< the variant's sweep label
  std::string world;
  std::string world_hash;
  int query = 0;
  std::string planner;       ///< the experiment's id
  std::string planner_type;  ///< the registry key
  std::string sampler;
  int repetition = 0;
  std::string seed;  ///< hex (64-bit)
  double start[3] = {0, 0, 0};
  double goal[3] = {0, 0, 0};

  MetricValues metrics;  ///< resultMetrics() and runnerMetrics(), by name
  MetricValues statistics;
  Progress progress;             ///< the planner's anytime progress (its declared series)
  std::string trajectory_csv;    ///< when the experiment stores trajectories
  std::string tree_csv;          ///< when it stores search trees
  std::string replans_csv;       ///< a flight's replans (kind: flight)
  std::string known_map;         ///< a flight's known map from above (store.trees' queries)
  std::string clearance_csv;     ///< a flight's clearance to the ground truth over time
  std::string known_voxels_csv;  ///< its final known map's voxels, each first seen when

  /// The text of a metric ("" when it is none or absent).
  std::string text(std::string_view name) const;
  /// A numeric metric (NaN when it is none or absent).
  double number(std::string_view name) const;
};

/// A world as the report draws it: its grid geometry, a top view (per x, y column the
/// height of the highest occupied voxel, in voxels: 0 when the column is free) and a side
/// view (per x, z: 1 when any voxel along y is occupied), and its obstacles as boxes for the
/// 3D viewer (view::viewerBoxes).
struct WorldRecord {
  std::string world_hash;
  std::string id;
  double resolution = 0.0;
  double origin[3] = {0, 0, 0};
  int dims[3] = {0, 0, 0};
  std::vector<std::uint16_t> top;  ///< nx * ny, index x * ny + y
  std::vector<std::uint8_t> side;  ///< nx * nz, index x * nz + z
  int box_stride = 1;
  std::vector<std::int32_t> boxes;  ///< per box x0, y0, z0, x1, y1, z1 (voxel indices, [lo, hi))
};

/// The results database of one experiment (SQLite, WAL journal): a `meta` table (the
/// expanded config, its hash, provenance, `schema_version`), `runs` (one row per run keyed by
/// `run_hash`: the identity columns, then one column per result and runner metric),
/// `statistics` (run_hash, name, value: every statistic a planner reported), `progress`
/// (run_hash, name, time_ms, value: samples of the planner's progress series), `metrics` (the
/// declaration of every column, statistic and series: kind, planner type, type, unit, doc,
/// clock),
/// `worlds` (for figures), and optional `trajectories` and `trees` (CSV text) and `flights`
/// (a flight's replans as CSV and its final known map's top view). Every run is written
/// in its own transaction, so a kill at any moment loses at most the runs in flight.
class ResultsStore {
 public:
  explicit ResultsStore(const std::string& path);
  ~ResultsStore();
  ResultsStore(const ResultsStore&) = delete;
  ResultsStore& operator=(const ResultsStore&) = delete;

  const std::string& path() const { return path_; }

  std::optional<std::string> meta(const std::string& key) const;
  /// A meta value that must be a whole number (schema_version, runs_planned): none when
  /// absent; ConfigError naming the database, the table and the key when it is not one.
  std::optional<long long> metaInteger(const std::string& key) const;
  std::map<std::string, std::string> allMeta() const;
  void setMeta(const std::map<std::string, std::string>& values);

  /// Deletes the stored runs whose status is one of `statuses` and that the experiment still
  /// plans (with their statistics, trajectories and trees), in one transaction; returns how
  /// many.
  long long removeRuns(const std::set<std::string>& statuses);
  /// The hashes of every stored run.
  std::set<std::string> runHashes() const;
  long long runCount() const;
  /// The stored runs the experiment plans now (the `planned` table's).
  long long plannedRunCount() const;
  /// Records the run hashes of the experiment as it is now: stored runs not among them are of
  /// an earlier configuration of it (kept, never pooled with these by the report).
  void setPlanned(const std::vector<std::string>& run_hashes);
  void insert(const RunRecord& record);
  /// Stores a world's views once (a world already stored is left as it is).
  void insertWorld(const WorldRecord& world);
  /// Declares metrics in the `metrics` table: `kind` is "result", "runner" or "statistic"
  /// ("progress" for a series among the statistics); statistics are declared per planner
  /// type.
  void declareMetrics(const std::string& kind, const std::string& planner_type,
                      const MetricSpecs& specs);
  /// The schema version of the stored runs (1 for databases written before versions were
  /// recorded), or none for a database without runs or meta.
  std::optional<int> schemaVersion() const;
  /// Refuses (ConfigError naming the database, table and column) a database of this schema
  /// version whose tables lack a column this kinolab writes, or declare it another type.
  void requireCurrentColumns() const;

  /// Joins shard databases into `output` (which must not exist yet). Refuses inputs whose
  /// config hashes differ, that are not shards of the same count, that repeat a shard, or
  /// that are incomplete (a shard's `runs_planned` above its stored runs) unless `partial`.
  static void merge(const std::string& output, const std::vector<std::string>& inputs,
                    bool partial);

 private:
  /// The run's statistics and progress samples (within insert()'s transaction).
  void insertStatistics(const RunRecord& record);

  void execute(const std::string& sql) const;
  /// Runs `body` in one write transaction, rolled back when it throws.
  void transaction(const std::function<void()>& body);

  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace kinolab
