#pragma once

#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/shard.hpp"

namespace kinolab {

/// Where a running experiment stands (RunnerOptions::on_progress).
struct RunnerProgress {
  long long done = 0;      ///< runs of this shard in the database
  long long total = 0;     ///< runs of this shard
  long long unsolved = 0;  ///< of the runs finished now, those that did not succeed
  double seconds = 0.0;    ///< since the runner started
};

struct RunnerOptions {
  std::string out_dir;
  int jobs = 1;
  bool resume = false;
  Shard shard;
  std::string cache_dir;       ///< built worlds (WorldCache)
  double grace_seconds = 5.0;  ///< a worker is killed this long after its time budget
  /// With `resume`: stored runs with these statuses are deleted and run again (e.g. crash
  /// and killed, for workers stopped from outside). Every name must be a run status.
  std::set<std::string> retry;
  /// Called in the runner's process after every finished run (done counts stored runs of
  /// this shard, the resumed ones too), instead of the progress on stderr: e.g. the Python
  /// bindings' progress bar in a notebook (one display, not two).
  std::function<void(const RunnerProgress&)> on_progress;
};

struct RunnerSummary {
  long long planned = 0;    ///< runs of this shard
  long long skipped = 0;    ///< already in the database (resume)
  long long finished = 0;   ///< run now
  long long succeeded = 0;  ///< of those, successes (isSuccess: exact and checker-valid)
  std::map<std::string, long long> by_status;
  bool interrupted = false;
  double seconds = 0.0;
};

/// Runs an experiment into out_dir/results.sqlite. Worlds are built (or loaded from the
/// cache) once, before any worker starts, and shared copy-on-write; each run executes in a
/// forked worker process with an address-space limit, killed past its time budget plus the
/// grace: a crash, hang, exhausted memory or exception becomes that run's status (crash,
/// timeout, oom, error) and the experiment goes on. Each finished run is one transaction.
/// With `resume` only the runs missing from the database run; without it, a database that
/// already holds runs is an error (nothing is overwritten). SIGINT and SIGTERM stop it
/// cleanly: workers in flight are killed and not recorded, and the database stays
/// resumable. Progress goes to stderr: a bar on a terminal, log lines otherwise.
RunnerSummary runExperiment(const Experiment& experiment, const RunnerOptions& options);

/// Every status a stored run can have: the planner's and the runner's (crash, killed, oom,
/// error).
std::vector<std::string> runStatuses();

/// The worlds and queries of some runs, as an experiment runs them.
struct PlacedInputs {
  std::map<std::uint64_t, std::shared_ptr<const World>> worlds;  ///< by world spec hash
  /// By (variant, world): every query, random ones placed from the experiment's seed.
  std::map<std::pair<std::size_t, std::size_t>, std::vector<PlanningQuery>> queries;
};

/// Builds (or loads from the cache in `cache_dir`, the default cache when empty) the worlds of
/// `runs` and places their queries exactly as runExperiment() does, so that a dry run or a
/// Slurm submission refuses what the run would refuse (a random query that cannot be placed:
/// a ConfigError naming the world). `on_world(world, built, cached)` is called once per world.
PlacedInputs placeInputs(
    const Experiment& experiment, const std::vector<const RunSpec*>& runs,
    const std::string& cache_dir,
    const std::function<void(const ExperimentWorld&, const std::shared_ptr<const World>&, bool)>&
        on_world = {});

/// What `kinolab run --dry-run` prints: the run count and a table of variants, worlds,
/// queries and planners.
std::string describeRuns(const Experiment& experiment, const std::vector<RunSpec>& runs);

/// Provenance of this process: kinolab version, git commit and dirty flag, compiler and
/// flags, library versions, CPU model, host.
std::map<std::string, std::string> provenance();

}  // namespace kinolab
