#include "kinolab/experiment/results_store.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string_view>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/flight/flight.hpp"

namespace kinolab {

const MetricSpecs& runnerMetrics() {
  static const MetricSpecs specs =
      MetricSpecs()
          .machine("peak_memory_mb", MetricType::kReal, "MB",
                   "the worker process's maximum resident set")
          .clock("planning_time_min_ms",
                 "the fastest of the timed plans (planning_time_ms is their median; the "
                 "experiment's timing: warm-up and repeats)")
          .clock("planning_time_cold_ms",
                 "the first plan in the fresh worker process (cold caches and heap)")
          .boolean("line_blocked",
                   "the straight line from start to goal collides for the planner's body: the "
                   "query needs a detour")
          .real("time_limit", "s",
                "the time budget of each plan: the experiment's budget.time, or the planner "
                "entry's own time_limit")
          .boolean("time_limit_own",
                   "the planner's entry set its own time_limit (else budget.time is its budget)")
          .clock("wall_time_ms", "the worker process, from fork to exit")
          .machine("started_at", MetricType::kText, "", "when the run started, UTC, ISO 8601")
          .machine("load_average", MetricType::kReal, "",
                   "the machine's 1-minute load average when the run started (above its core "
                   "count, runs wait for a core and clock figures grow)");
  return specs;
}

std::string RunRecord::text(std::string_view name) const {
  for (const auto& [key, item] : metrics) {
    if (const auto* text = std::get_if<std::string>(&item); key == name && text) return *text;
  }
  return "";
}

double RunRecord::number(std::string_view name) const {
  for (const auto& [key, item] : metrics) {
    if (const auto* number = std::get_if<double>(&item); key == name && number) return *number;
  }
  return NAN;
}

namespace {

/// The identity columns of `runs`: what defines a run. The metric columns follow them.
constexpr const char* kIdentityColumns =
    "run_hash TEXT PRIMARY KEY, variant INTEGER, sweep TEXT, world TEXT, world_hash TEXT, "
    "query INTEGER, planner TEXT, planner_type TEXT, sampler TEXT, repetition INTEGER, seed TEXT, "
    "start_x REAL, start_y REAL, start_z REAL, goal_x REAL, goal_y REAL, goal_z REAL";
constexpr int kIdentityCount = 17;

/// The tables of a results database (kTables and the runs table); older schema versions had
/// a subset.
const std::set<std::string> kResultsTables = {"meta",     "statistics",   "metrics", "worlds",
                                              "progress", "trajectories", "trees",   "flights",
                                              "runs",     "planned"};

constexpr const char* kTables = R"sql(
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS statistics (
  run_hash TEXT NOT NULL, name TEXT NOT NULL, value REAL, PRIMARY KEY (run_hash, name));
CREATE TABLE IF NOT EXISTS metrics (
  name TEXT NOT NULL, kind TEXT NOT NULL, planner_type TEXT NOT NULL, type TEXT, unit TEXT,
  doc TEXT, clock INTEGER, direction TEXT, comparable INTEGER, PRIMARY KEY (name, planner_type));
CREATE TABLE IF NOT EXISTS planned (run_hash TEXT PRIMARY KEY);
CREATE TABLE IF NOT EXISTS worlds (
  world_hash TEXT PRIMARY KEY, id TEXT, resolution REAL, origin_x REAL, origin_y REAL,
  origin_z REAL, nx INTEGER, ny INTEGER, nz INTEGER, top BLOB, side BLOB, box_stride INTEGER,
  boxes BLOB);
CREATE TABLE IF NOT EXISTS progress (
  run_hash TEXT NOT NULL, name TEXT NOT NULL, time_ms REAL NOT NULL, value REAL NOT NULL,
  PRIMARY KEY (run_hash, name, time_ms));
CREATE TABLE IF NOT EXISTS trajectories (run_hash TEXT PRIMARY KEY, csv TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS trees (run_hash TEXT PRIMARY KEY, csv TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS flights (run_hash TEXT PRIMARY KEY, replans TEXT NOT NULL,
  known_map TEXT NOT NULL, clearance TEXT NOT NULL, known_voxels TEXT NOT NULL);
)sql";

/// Every metric column of `runs`, in order: a plan's metrics, a flight's that a plan has not,
/// then the runner's. A name both kinds declare is one column, of one type.
std::vector<const MetricSpec*> metricColumns() {
  std::vector<const MetricSpec*> columns;
  for (const MetricSpecs* specs :
       {&resultMetrics(), &flightRunMetrics().specs(), &runnerMetrics()}) {
    for (const MetricSpec& spec : specs->all()) {
      const auto same = std::find_if(columns.begin(), columns.end(),
                                     [&](const MetricSpec* c) { return c->name == spec.name; });
      if (same == columns.end()) {
        columns.push_back(&spec);
      } else if ((*same)->type != spec.type) {
        throw std::logic_error("metric '" + spec.name + "' is declared with two types");
      }
    }
  }
  return columns;
}

std::string sqlType(MetricType type) {
  switch (type) {
    case MetricType::kInteger:
    case MetricType::kBoolean:
      return "INTEGER";
    case MetricType::kText:
      return "TEXT";
    case MetricType::kReal:
      break;
  }
  return "REAL";
}

std::string runsTable() {
  std::string sql = std::string("CREATE TABLE IF NOT EXISTS runs (") + kIdentityColumns;
  for (const MetricSpec* spec : metricColumns())
    sql += ", " + spec->name + " " + sqlType(spec->type);
  return sql + ");";
}

const MetricValue* findValue(const MetricValues& values, std::string_view name) {
  for (const auto& [key, value] : values) {
    if (key == name) return &value;
  }
  return nullptr;
}

/// A prepared statement, finalised on scope exit.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::string& path) : db_(db) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement_, nullptr) != SQLITE_OK) {
      throw FileError(path + ": SQLite: " + sqlite3_errmsg(db));
    }
  }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  /// Binds the next parameter (1, 2, ... after each reset()).
  void add(const std::string& text) {
    sqlite3_bind_text(statement_, ++next_, text.c_str(), static_cast<int>(text.size()),
                      SQLITE_TRANSIENT);
  }
  void add(double value) {
    if (std::isfinite(value)) {
      sqlite3_bind_double(statement_, ++next_, value);
    } else {
      sqlite3_bind_null(statement_, ++next_);
    }
  }
  void add(int value) { sqlite3_bind_int(statement_, ++next_, value); }
  /// A metric value as its declared type: none is NULL.
  void add(const MetricValue* value, MetricType type) {
    const auto* number = value ? std::get_if<double>(value) : nullptr;
    const auto* text = value ? std::get_if<std::string>(value) : nullptr;
    if (text) {
      add(*text);
    } else if (number && std::isfinite(*number) && type != MetricType::kReal &&
               type != MetricType::kText) {
      sqlite3_bind_int64(statement_, ++next_, static_cast<sqlite3_int64>(std::llround(*number)));
    } else {
      add(number ? *number : NAN);
    }
  }
  void addBlob(const void* data, std::size_t size) {
    sqlite3_bind_blob(statement_, ++next_, data, static_cast<int>(size), SQLITE_TRANSIENT);
  }
  /// True while there is a row.
  bool step(const std::string& path) {
    const int code = sqlite3_step(statement_);
    if (code == SQLITE_ROW) return true;
    if (code == SQLITE_DONE) return false;
    throw FileError(path + ": SQLite: " + sqlite3_errmsg(db_));
  }
  void reset() {
    next_ = 0;
    sqlite3_reset(statement_);
    sqlite3_clear_bindings(statement_);
  }
  std::string text(int column) const {
    const auto* value = sqlite3_column_text(statement_, column);
    return value ? reinterpret_cast<const char*>(value) : "";
  }
  long long integer(int column) const { return sqlite3_column_int64(statement_, column); }

 private:
  sqlite3* db_;
  sqlite3_stmt* statement_ = nullptr;
  int next_ = 0;
};

/// Refuses, before a byte is written, an existing file at `path` that is not a kinolab results
/// database kinolab may add to: not SQLite, tables of something else, or runs without the
/// experiment they belong to (an empty meta table). An empty file or a database without tables
/// (kinolab's own, interrupted before its first write) is fine.
void refuseForeignDatabase(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error) ||
      std::filesystem::file_size(path, error) == 0) {
    return;
  }
  sqlite3* db = nullptr;
  // Without a -wal file beside it the file is the whole database: read it immutable (no
  // lock, no -wal or -shm file made); with one, the log holds pages that count.
  const bool logged = std::filesystem::exists(path + "-wal", error);
  std::string uri = "file:";
  for (const char c : path) {  // a URI's own characters in the path are escaped
    uri += c == '?' ? "%3f" : c == '#' ? "%23" : c == '%' ? "%25" : std::string(1, c);
  }
  uri += logged ? "?mode=ro" : "?immutable=1";
  const int opened =
      sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  if (opened == SQLITE_OK) sqlite3_busy_timeout(db, 10000);  // as the store: a dying worker's lock
  std::set<std::string> tables;
  std::string problem;
  bool has_hash = false;
  long long runs = 0;
  const auto query = [&](const char* sql, const std::function<void(sqlite3_stmt*)>& row) {
    sqlite3_stmt* statement = nullptr;
    int code = sqlite3_prepare_v2(db, sql, -1, &statement, nullptr);
    if (code == SQLITE_OK) {
      while ((code = sqlite3_step(statement)) == SQLITE_ROW) row(statement);
    }
    sqlite3_finalize(statement);
    if (code != SQLITE_DONE && problem.empty()) problem = sqlite3_errmsg(db);
  };
  if (opened != SQLITE_OK) {
    problem = db ? sqlite3_errmsg(db) : "out of memory";
  } else {
    query("SELECT name FROM sqlite_master WHERE type = 'table'", [&](sqlite3_stmt* statement) {
      tables.insert(reinterpret_cast<const char*>(sqlite3_column_text(statement, 0)));
    });
    if (problem.empty() && tables.count("meta")) {
      query("SELECT 1 FROM meta WHERE key = 'config_hash'",
            [&](sqlite3_stmt*) { has_hash = true; });
    }
    if (problem.empty() && tables.count("runs")) {
      query("SELECT COUNT(*) FROM runs",
            [&](sqlite3_stmt* statement) { runs = sqlite3_column_int64(statement, 0); });
    }
  }
  sqlite3_close(db);
  if (!problem.empty()) {
    throw FileError(path + ": not a readable SQLite database (" + problem +
                    "): kinolab writes nothing into it; choose another --out directory");
  }
  if (tables.empty()) return;
  std::vector<std::string> foreign;
  for (const std::string& table : tables) {
    if (!kResultsTables.count(table) && table.rfind("sqlite_", 0) != 0) foreign.push_back(table);
  }
  if (!foreign.empty() || !tables.count("meta") || !tables.count("runs")) {
    throw FileError(path + ": not a kinolab results database (its tables: " +
                    join(std::vector<std::string>(tables.begin(), tables.end()), ", ") +
                    "): kinolab writes nothing into it; choose another --out directory");
  }
  if (!has_hash && runs > 0) {
    throw FileError(path + " holds " + std::to_string(runs) +
                    " runs but no experiment (its meta table has no config_hash): kinolab cannot "
                    "tell whose they are and adds nothing; choose another --out directory");
  }
}

}  // namespace

ResultsStore::ResultsStore(const std::string& path) : path_(path) {
  refuseForeignDatabase(path);
  // Never through a link (as the lock): results written into whatever a planted link names
  // would be lost there, and that file damaged.
  if (sqlite3_open_v2(path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOFOLLOW,
                      nullptr) != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw FileError(path + ": cannot open the results database: " + message);
  }
  sqlite3_busy_timeout(db_, 10000);
  try {
    execute("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;");
    execute(kTables);
    // A database of another schema version keeps its runs table (schemaVersion() tells).
    execute(runsTable());
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

ResultsStore::~ResultsStore() { sqlite3_close(db_); }

void ResultsStore::transaction(const std::function<void()>& body) {
  execute("BEGIN IMMEDIATE");
  try {
    body();
    execute("COMMIT");
  } catch (...) {
    // SQLite may have rolled back already (a full disk, an I/O error): then a ROLLBACK would
    // fail and hide the error that matters.
    if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

void ResultsStore::execute(const std::string& sql) const {
  char* error = nullptr;
  if (const int code = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
      code != SQLITE_OK) {
    const std::string message = error ? error : sqlite3_errstr(code);
    sqlite3_free(error);
    std::string hint;
    switch (code & 0xff) {
      case SQLITE_FULL:
        hint = "the disk is full: what was stored is kept; free space, then resume";
        break;
      case SQLITE_READONLY:
      case SQLITE_CANTOPEN:
      case SQLITE_IOERR:
      case SQLITE_PERM:
        hint = "is its directory writable?";
        break;
      default:
        hint = "is it a kinolab results database?";
    }
    throw FileError(path_ + ": SQLite: " + message + " (" + hint + ")");
  }
}

std::optional<std::string> ResultsStore::meta(const std::string& key) const {
  Statement query(db_, "SELECT value FROM meta WHERE key = ?", path_);
  query.add(key);
  if (!query.step(path_)) return std::nullopt;
  return query.text(0);
}

std::map<std::string, std::string> ResultsStore::allMeta() const {
  std::map<std::string, std::string> values;
  Statement query(db_, "SELECT key, value FROM meta", path_);
  while (query.step(path_)) values[query.text(0)] = query.text(1);
  return values;
}

void ResultsStore::setMeta(const std::map<std::string, std::string>& values) {
  transaction([&] {
    Statement insert(db_, "INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)", path_);
    for (const auto& [key, value] : values) {
      insert.add(key);
      insert.add(value);
      insert.step(path_);
      insert.reset();
    }
  });
}

std::set<std::string> ResultsStore::runHashes() const {
  std::set<std::string> hashes;
  Statement query(db_, "SELECT run_hash FROM runs", path_);
  while (query.step(path_)) hashes.insert(query.text(0));
  return hashes;
}

long long ResultsStore::removeRuns(const std::set<std::string>& statuses) {
  long long removed = 0;
  transaction([&] {
    for (const std::string& status : statuses) {
      for (const char* table : {"statistics", "progress", "trajectories", "trees", "flights"}) {
        Statement remove(db_,
                         std::string("DELETE FROM ") + table +
                             " WHERE run_hash IN (SELECT run_hash FROM runs WHERE status = ? AND "
                             "run_hash IN (SELECT run_hash FROM planned))",
                         path_);
        remove.add(status);
        remove.step(path_);
      }
      // Only runs the experiment still plans: one it no longer plans would never run again.
      Statement remove(
          db_, "DELETE FROM runs WHERE status = ? AND run_hash IN (SELECT run_hash FROM planned)",
          path_);
      remove.add(status);
      remove.step(path_);
      removed += sqlite3_changes(db_);
    }
  });
  return removed;
}

void ResultsStore::setPlanned(const std::vector<std::string>& run_hashes) {
  transaction([&] {
    execute("DELETE FROM planned");
    Statement insert(db_, "INSERT OR IGNORE INTO planned (run_hash) VALUES (?)", path_);
    for (const std::string& hash : run_hashes) {
      insert.add(hash);
      insert.step(path_);
      insert.reset();
    }
  });
}

long long ResultsStore::runCount() const {
  Statement query(db_, "SELECT COUNT(*) FROM runs", path_);
  query.step(path_);
  return query.integer(0);
}

long long ResultsStore::plannedRunCount() const {
  Statement query(db_, "SELECT COUNT(*) FROM runs WHERE run_hash IN (SELECT run_hash FROM planned)",
                  path_);
  query.step(path_);
  return query.integer(0);
}

void ResultsStore::insertStatistics(const RunRecord& r) {
  Statement statistic(db_, "INSERT INTO statistics (run_hash, name, value) VALUES (?, ?, ?)",
                      path_);
  for (const auto& [name, value] : r.statistics) {
    statistic.add(r.run_hash);
    statistic.add(name);
    statistic.add(&value, MetricType::kReal);
    statistic.step(path_);
    statistic.reset();
  }
  // A series sampled twice at one time keeps its last value there (a step function).
  Statement progress(
      db_, "INSERT OR REPLACE INTO progress (run_hash, name, time_ms, value) VALUES (?, ?, ?, ?)",
      path_);
  for (const ProgressSample& sample : r.progress) {
    progress.add(r.run_hash);
    progress.add(sample.name);
    for (const double number : {sample.time_ms, sample.value}) progress.add(number);
    progress.step(path_);
    progress.reset();
  }
}

void ResultsStore::insert(const RunRecord& r) {
  const std::vector<const MetricSpec*> columns = metricColumns();
  std::string names =
      "run_hash, variant, sweep, world, world_hash, query, planner, "
      "planner_type, sampler, repetition, seed, start_x, start_y, start_z, "
      "goal_x, goal_y, goal_z";
  for (const MetricSpec* spec : columns) names += ", " + spec->name;
  std::string marks = "?";
  for (std::size_t i = 1; i < kIdentityCount + columns.size(); ++i) marks += ",?";
  transaction([&] {
    Statement run(db_, "INSERT INTO runs (" + names + ") VALUES (" + marks + ")", path_);
    run.add(r.run_hash);
    run.add(r.variant);
    for (const std::string* text : {&r.sweep, &r.world, &r.world_hash}) run.add(*text);
    run.add(r.query);
    for (const std::string* text : {&r.planner, &r.planner_type, &r.sampler}) run.add(*text);
    run.add(r.repetition);
    run.add(r.seed);
    for (const double v : r.start) run.add(v);
    for (const double v : r.goal) run.add(v);
    for (const MetricSpec* spec : columns) run.add(findValue(r.metrics, spec->name), spec->type);
    run.step(path_);
    insertStatistics(r);
    if (!r.trajectory_csv.empty()) {
      Statement trajectory(db_, "INSERT INTO trajectories (run_hash, csv) VALUES (?, ?)", path_);
      trajectory.add(r.run_hash);
      trajectory.add(r.trajectory_csv);
      trajectory.step(path_);
    }
    if (!r.tree_csv.empty()) {
      Statement tree(db_, "INSERT INTO trees (run_hash, csv) VALUES (?, ?)", path_);
      tree.add(r.run_hash);
      tree.add(r.tree_csv);
      tree.step(path_);
    }
    if (!r.replans_csv.empty()) {
      Statement flight(db_,
                       "INSERT INTO flights (run_hash, replans, known_map, clearance, "
                       "known_voxels) VALUES (?, ?, ?, ?, ?)",
                       path_);
      flight.add(r.run_hash);
      flight.add(r.replans_csv);
      flight.add(r.known_map);
      flight.add(r.clearance_csv);
      flight.add(r.known_voxels_csv);
      flight.step(path_);
    }
  });
}

void ResultsStore::declareMetrics(const std::string& kind, const std::string& planner_type,
                                  const MetricSpecs& specs) {
  transaction([&] {
    Statement insert(db_,
                     "INSERT OR REPLACE INTO metrics (name, kind, planner_type, type, unit, doc, "
                     "clock, direction, comparable) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                     path_);
    for (const MetricSpec& spec : specs.all()) {
      const std::string type = spec.typeName();
      const std::string row_kind = spec.series ? "progress" : kind;
      for (const std::string* text :
           {&spec.name, &row_kind, &planner_type, &type, &spec.unit, &spec.doc}) {
        insert.add(*text);
      }
      insert.add(spec.clock ? 1 : 0);
      insert.add(spec.directionName());
      insert.add(spec.comparable ? 1 : 0);
      insert.step(path_);
      insert.reset();
    }
  });
}

void ResultsStore::requireCurrentColumns() const {
  // The tables as this kinolab makes them, in memory: the file's must hold each one's columns
  // (CREATE TABLE IF NOT EXISTS leaves a damaged table as it is).
  sqlite3* made = nullptr;
  const int opened = sqlite3_open(":memory:", &made);
  const std::unique_ptr<sqlite3, decltype(&sqlite3_close)> closer(made, &sqlite3_close);
  if (opened != SQLITE_OK || sqlite3_exec(made, (std::string(kTables) + runsTable()).c_str(),
                                          nullptr, nullptr, nullptr) != SQLITE_OK) {
    throw FileError(path_ + ": SQLite: cannot lay out the tables in memory");
  }
  Statement tables(made, "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name",
                   path_);
  while (tables.step(path_)) {
    const std::string table = tables.text(0);
    std::map<std::string, std::string> stored;  // column: declared type
    Statement own(db_, "SELECT name, type FROM pragma_table_info(?)", path_);
    own.add(table);
    while (own.step(path_)) stored[own.text(0)] = own.text(1);
    Statement wanted(made, "SELECT name, type FROM pragma_table_info(?)", path_);
    wanted.add(table);
    while (wanted.step(path_)) {
      const std::string column = wanted.text(0), type = wanted.text(1);
      const auto found = stored.find(column);
      if (found == stored.end() || found->second != type) {
        throw ConfigError(
            path_ + ": table " + table + ", column '" + column + "': " +
            (found == stored.end() ? "missing" : "declared " + found->second + ", not " + type) +
            " (a damaged or foreign database): kinolab writes nothing into it");
      }
    }
  }
}

std::optional<long long> ResultsStore::metaInteger(const std::string& key) const {
  const std::optional<std::string> text = meta(key);
  if (!text) return std::nullopt;
  long long value = 0;
  const auto [end, error] = std::from_chars(text->data(), text->data() + text->size(), value);
  if (error != std::errc() || end != text->data() + text->size() || text->empty()) {
    throw ConfigError(path_ + ": table meta, key '" + key + "': expected a whole number, got '" +
                      *text + "' (a damaged or foreign database)");
  }
  return value;
}

std::optional<int> ResultsStore::schemaVersion() const {
  if (const auto version = metaInteger("schema_version")) {
    if (*version < 0 || *version > 1000000) {
      throw ConfigError(path_ + ": table meta, key 'schema_version': " + std::to_string(*version) +
                        " is not a schema version");
    }
    return static_cast<int>(*version);
  }
  if (meta("config_hash")) return 1;  // written before versions were recorded
  return std::nullopt;
}

void ResultsStore::insertWorld(const WorldRecord& w) {
  Statement insert(
      db_,
      "INSERT OR IGNORE INTO worlds (world_hash, id, resolution, origin_x, origin_y, "
      "origin_z, nx, ny, nz, top, side, box_stride, boxes) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?)",
      path_);
  insert.add(w.world_hash);
  insert.add(w.id);
  insert.add(w.resolution);
  for (const double v : w.origin) insert.add(v);
  for (const int n : w.dims) insert.add(n);
  insert.addBlob(w.top.data(), w.top.size() * sizeof(std::uint16_t));
  insert.addBlob(w.side.data(), w.side.size());
  insert.add(w.box_stride);
  insert.addBlob(w.boxes.data(), w.boxes.size() * sizeof(std::int32_t));
  insert.step(path_);
}

}  // namespace kinolab
