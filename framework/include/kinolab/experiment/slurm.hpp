#pragma once

#include <string>

#include "kinolab/experiment/experiment.hpp"

namespace kinolab {

/// What `kinolab slurm` asks the cluster for. Empty strings leave Slurm's defaults.
struct SlurmRequest {
  int shards = 1;
  std::string partition;
  std::string time;  ///< per shard, HH:MM:SS
  int cpus_per_task = 1;
  std::string memory;  ///< per shard, e.g. 8G

  /// Throws ConfigError naming the option when a value is out of range or malformed.
  void validate() const;
};

/// Where a Slurm submission keeps its files under its output directory (absolute).
struct SlurmLayout {
  std::string out;

  std::string arrayScript() const;  ///< OUT/kinolab_shards.sh
  std::string mergeScript() const;  ///< OUT/kinolab_merge.sh
  std::string jobsFile() const;     ///< OUT/slurm_jobs.txt
  std::string logs() const;         ///< OUT/logs
  std::string merged() const;       ///< OUT/results.sqlite
  /// Shard `index`'s database: Shard::directory(OUT, index)/results.sqlite.
  std::string shardDatabase(int index) const;
};

/// The two sbatch scripts: an array job of shards (task i runs `kinolab run EXPERIMENT
/// --shard i/N --resume` into its shard directory) and the merge of every shard.
struct SlurmScripts {
  std::string array;
  std::string merge;
};
SlurmScripts slurmScripts(const Experiment& experiment, const std::string& experiment_path,
                          const SlurmLayout& layout, const SlurmRequest& request,
                          const std::string& kinolab_path, const std::string& cache_dir);

/// The job ids of a submission (`slurm_jobs.txt`).
struct SlurmJobs {
  std::string array_job;
  std::string merge_job;
  int shards = 0;

  std::string text() const;
  /// Parses what text() wrote; a missing or malformed entry is a FileError naming `source`.
  static SlurmJobs parse(const std::string& text, const std::string& source);
};

/// `text` in single quotes for bash (a quote inside becomes '\'').
std::string shellQuote(const std::string& text);

}  // namespace kinolab
