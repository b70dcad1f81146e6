#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "kinolab/core/parameters.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {

/// How the queries of a world are made: a fixed list, seeded random pairs, and seeded pairs
/// across the world from one side to the other (in that order).
struct QuerySpec {
  struct Random {
    int count = 0;
    double min_distance = 5.0;
    double max_distance = INFINITY;
    double clearance = 0.6;
    double height[2] = {1.0, 2.0};
    /// > 0: x and y on the lattice offset + step k (a benchmark problem's rule), m.
    double lattice_step = 0.0;
    double lattice_offset = 0.0;
  };
  struct Across {
    int count = 0;
    int axis = 0;         ///< 0: from low x to high x, 1: along y
    double margin = 1.0;  ///< start and goal this far inside the two faces, m
    double clearance = 0.6;
    double height[2] = {1.0, 2.0};
  };
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> fixed;
  Random random;
  Across across;

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

/// Budgets of one run: planning time (passed to the planner), memory of the worker process,
/// and iterations (expansions, tree iterations; 0: none).
struct ExperimentBudget {
  double time = 10.0;          ///< s; the worker is killed at time + grace
  long long memory_mb = 4096;  ///< address space the worker may add
  long long iterations = 0;
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
  bool store_trajectories = false;
  /// Search trees of queries 0 .. store_tree_queries - 1 of each world (-1: all, 0: none).
  int store_tree_queries = 0;
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
