#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "kinolab/core/parameters.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {

/// How the queries of a world are made (`queries:`): a fixed list, seeded random pairs, and
/// seeded pairs across the world from one side to the other (in that order).
struct QuerySpec {
  struct Fixed {
    Eigen::Vector3d start = Eigen::Vector3d::Zero();
    Eigen::Vector3d goal = Eigen::Vector3d::Zero();
    template <typename Fields>
    void fields(Fields& f) {
      f.point("start", start, "start position, m", {.required = true});
      f.point("goal", goal, "goal position, m", {.required = true});
    }
  };
  /// x and y on the lattice offset + step k (a benchmark problem's rule).
  struct Lattice {
    double step = 0.0;
    double offset = 0.0;
    template <typename Fields>
    void fields(Fields& f) {
      f.real("step", step, 1e-3, 1e4, "lattice spacing, m", {.required = true});
      f.real("offset", offset, -1e4, 1e4, "lattice origin on x and y, m");
    }
  };
  struct Random {
    int count = 0;
    double min_distance = 5.0;
    double max_distance = 1e6;  ///< m: no limit
    double clearance = 0.6;
    std::array<double, 2> height = {1.0, 2.0};
    std::optional<Lattice> lattice;
    bool connected = false;
    /// m: the radius `connected` joins start and goal at, set when the experiment is read: its
    /// planners' largest body radius, plus a flight's planning_margin.
    double connected_radius = 0.0;
    template <typename Fields>
    void fields(Fields& f) {
      // The count is not part of a query's rule: more random queries leave the first ones.
      f.integer("count", count, 1, 1000000, "random queries per world",
                {.required = true, .identity = false});
      f.real("min_distance", min_distance, 0.0, 1e6, "least distance from start to goal, m");
      f.real("max_distance", max_distance, 0.0, 1e6, "greatest distance from start to goal, m");
      f.real("clearance", clearance, 0.0, 100.0, "least free space around start and goal, m");
      f.interval("height", height, -1e4, 1e4, "start and goal height above the map's floor, m");
      f.group("lattice", lattice, "x and y on offset + step k (optional)");
      // In a run's identity as the radius it stands for (QuerySpec::queryText).
      f.boolean("connected", connected,
                "start and goal in one piece of the world's free space at the planners' largest "
                "radius (a flight's: plus its planning_margin): a way between them exists",
                {.identity = false});
    }
  };
  struct Across {
    int count = 0;
    int axis = 0;  ///< 0: from low x to high x, 1: along y
    double margin = 1.0;
    double clearance = 0.6;
    std::array<double, 2> height = {1.0, 2.0};
    template <typename Fields>
    void fields(Fields& f) {
      f.integer("count", count, 1, 1000000, "queries across per world",
                {.required = true, .identity = false});
      f.choice("axis", axis, {{"x", 0}, {"y", 1}}, "from the low to the high face along x or y");
      f.real("margin", margin, 0.0, 1e4, "start and goal this far inside the two faces, m");
      f.real("clearance", clearance, 0.0, 100.0, "least free space around start and goal, m");
      f.interval("height", height, -1e4, 1e4, "start and goal height above the map's floor, m");
    }
  };
  std::vector<Fixed> fixed;
  Random random;
  Across across;

  template <typename Fields>
  void fields(Fields& f) {
    f.list("fixed", fixed, "fixed queries, in order");
    f.group("random", random, "seeded random start-goal pairs in free space");
    f.group("across", across, "seeded pairs from one side of the world to the other");
  }

  int count() const { return static_cast<int>(fixed.size()) + random.count + across.count; }
  /// The queries of one world, deterministic in `seed` and the world. A random or across
  /// query that cannot be placed in 100000 draws is a ConfigError naming `world_id`.
  std::vector<PlanningQuery> make(const World& world, const std::string& world_id,
                                  std::uint64_t seed) const;
  /// Exact text of everything that determines query `index` (make()'s order): a fixed
  /// query's points; a random query's rule and its place in the draws (not how many follow,
  /// so that more random queries leave the first ones' runs as they are); an across query's
  /// rule, place and the random draws before it.
  std::string queryText(int index) const;
};

struct ExperimentBudget;

/// One planner of an experiment: its registry key and its parameters (its plugin parameters'
/// own nested), all resolved and validated.
struct ExperimentPlanner {
  std::string id;
  std::string type;
  std::vector<ParameterAssignment> assignments;  ///< own and `PLUGIN.NAME` ones
  ParameterSet parameters;  ///< a plugin parameter's own nested (parameters.nested(its name))
  /// The key of its control sampler (its plugin parameter of kind "sampler"), "" for a
  /// planner without one: the runs table's `sampler`.
  std::string sampler() const;
  /// Everything that determines its behaviour, as text.
  std::string canonicalText() const;
  /// Whether the entry sets its own `time_limit` (else the experiment's budget.time is its
  /// time limit), and the time limit of each of its plans.
  bool ownTimeLimit() const;
  double timeLimit(const ExperimentBudget& budget) const;
};

struct ExperimentWorld {
  std::string id;
  WorldSpec spec;
};

/// Budgets of one run (`budget:`): planning time (passed to the planner), memory of the worker
/// process, and iterations (expansions, tree iterations; 0: none).
struct ExperimentBudget {
  double time = 10.0;          ///< s; the worker is killed at time + grace
  long long memory_mb = 4096;  ///< address space the worker may add
  long long iterations = 0;
  template <typename Fields>
  void fields(Fields& f) {
    f.real("time", time, 0.001, 1e6,
           "time per plan (a flight's replans), s, unless a planner sets its own time_limit");
    f.integer("memory_mb", memory_mb, 16, 1 << 24, "address space the worker may add, MB");
    f.integer("iterations", iterations, 0, 1LL << 50,
              "expansions or tree iterations per plan (0: no limit)");
  }
};

/// How a run's planning time is measured (`timing:`): `warmup` plans of the run's query in
/// its worker, discarded, then `repeats` timed plans; the run keeps the last plan's result,
/// the median of the timed plans as planning_time_ms, their minimum, and the first plan's
/// time (the cold one: a fresh process, caches and heap untouched). A plan that spends the
/// whole time budget ends the protocol and is the one timed plan. The worker's deadline is
/// (warmup + repeats) x the time budget + the grace.
struct TimingProtocol {
  int warmup = 1;
  int repeats = 3;
  template <typename Fields>
  void fields(Fields& f) {
    f.integer("warmup", warmup, 0, 100, "plans of the run's query made first and discarded");
    f.integer("repeats", repeats, 1, 100, "timed plans (the median is planning_time_ms)");
  }
};

/// The optional tables of an experiment's database (`store:`).
struct ExperimentStore {
  bool trajectories = false;
  /// Search trees of queries 0 .. tree_queries - 1 of each world (-1: all, 0: none).
  int tree_queries = 0;
  template <typename Fields>
  void fields(Fields& f) {
    f.boolean("trajectories", trajectories, "store every run's trajectory");
    f.countOrAll("trees", tree_queries, 1000000,
                 "store the search trees (a flight's known maps) of the first N queries per world");
  }
};

/// One point of the sweep: a complete, validated configuration.
struct ExperimentVariant {
  std::string label;  ///< "planners.lazy.params.heuristic_weight=2, ..." ("" without a sweep)
  std::vector<ExperimentWorld> worlds;
  QuerySpec queries;
  std::vector<ExperimentPlanner> planners;
  int repetitions = 1;
  ExperimentBudget budget;
  TimingProtocol timing;
  /// `flight:` (kind: flight): the flight's parameters (kinolab list flight), resolved.
  ParameterSet flight;

  /// The keys of a variant read from its field list (worlds, planners and flight are read by
  /// hand: their entries name plugins).
  template <typename Fields>
  void fields(Fields& f) {
    f.group("queries", queries, "the queries of every world, made per world in this order",
            {.required = true});
    f.integer("repetitions", repetitions, 1, 100000, "runs of every planner on every query");
    f.group("budget", budget, "the budget of every run");
    f.group("timing", timing, "how a run's planning time is measured (kind: planning)");
  }
  /// The run's budget and timing as text, a flight's parameters with them: part of the hash
  /// of every run.
  std::string budgetText(bool flights) const;
};

/// One run: a planner on a query of a world, one repetition, in one variant.
struct RunSpec {
  std::string hash;  ///< content hash of everything that defines the run (hex)
  std::size_t variant = 0;
  std::size_t world = 0;  ///< index into the variant's worlds
  int query = 0;          ///< index into that world's queries
  std::size_t planner = 0;
  int repetition = 0;
  std::uint64_t seed = 0;  ///< from the master seed, world, query and repetition
};

/// An experiment file (`kind: planning`), with `extends:` resolved and its sweep expanded
/// (in time linear in the number of variants; at most 100,000 variants and 10,000,000 runs,
/// refused up front). Every variant is validated before anything runs: unknown keys, type
/// mismatches, unknown plugins or parameters, out-of-range values and missing files are
/// ConfigErrors naming the file, line and key path.
struct Experiment {
  /// `kind: planning` (a run is one plan) or `kind: flight` (a run is one closed-loop flight:
  /// the planner replans through a world seen by its sensor, `flight:` sets the sensor, map
  /// and loop; budget.time is the flight's limit on its replans' clock, CPU time by default, and
  /// `timing:` does not apply).
  bool flights = false;
  std::string name;
  std::string source;  ///< the file
  std::uint64_t seed = 1;
  std::vector<std::string> plugins;  ///< libraries loaded before validation
  ExperimentStore store;
  /// What the experiment reproduces (`reproduces:`): a paper the report knows
  /// ("lazy_mp_astar_paper") and which planner id stands for which of its rows. Empty: none,
  /// and the report shows no paper's tables.
  std::string reproduces_paper;
  std::vector<std::pair<std::string, std::string>> reproduces_rows;  ///< planner id, row
  /// The sweep variants (labels) the experiment declares to be run in the paper's setting
  /// (`reproduces: {setting: [LABEL, ...]}`, or `true` for every variant): only beside these
  /// does the report test kinolab's figures against the paper's.
  std::vector<std::string> reproduces_setting;
  std::vector<ExperimentVariant> variants;
  /// The configuration as YAML (`extends:` merged, world spec files inlined, no sweep), then
  /// one line per variant with the sweep values it sets.
  std::string canonical;
  std::string config_hash;  ///< hash of `canonical` (hex): shards of one experiment share it

  /// The top-level keys read from the field list (`name` is checked further: readName).
  template <typename Fields>
  void fields(Fields& f) {
    f.choice("kind", flights, {{"planning", false}, {"flight", true}},
             "a run is one plan (planning) or one closed-loop flight (flight)");
    f.text("name", name, "the experiment's name (letters, digits, _ - .)", {.required = true});
    f.integer("seed", seed, 0, 1LL << 62, "master seed: every run's seed derives from it");
    f.group("store", store, "optional tables of the database");
  }

  static Experiment fromFile(const std::string& path);

  /// Every run, ordered by variant, world, query, planner, repetition. A run the sweep does
  /// not change (same hash in several variants) appears once, in its first variant.
  std::vector<RunSpec> runs() const;
};

/// The papers an experiment can say it reproduces, with the rows of their tables: read from
/// their one definition, analysis/kinolab_analysis/papers.yaml (analysisDirectory()), which
/// also holds the figures the analysis package compares with.
std::map<std::string, std::vector<std::string>> reproducibleRows();

}  // namespace kinolab
