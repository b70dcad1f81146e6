// `kinolab slurm`: an experiment as a Slurm array job of shards plus a dependent merge job;
// `kinolab slurm-status`: how far it got.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/experiment/shard.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::apps {
namespace {

namespace fs = std::filesystem;

struct SlurmOptions {
  std::string experiment;
  std::string out_dir;
  int shards = 0;
  std::string partition;
  std::string time;
  int cpus_per_task = 1;
  std::string memory;
  std::string cache_dir = WorldCache::defaultDirectory();
  bool dry_run = false;
};

/// Single-quoted for bash.
std::string quote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

/// A Slurm client call; under a timeout, since clients block while the controller is down.
CommandOutput client(const std::string& command) { return runCommand(command, 60); }

std::string selfPath() { return fs::read_symlink("/proc/self/exe").string(); }

void checkTime(const std::string& time) {
  int h = 0, m = 0, s = 0;
  char rest = 0;
  if (time.empty()) return;
  if (std::sscanf(time.c_str(), "%d:%d:%d%c", &h, &m, &s, &rest) != 3 || h < 0 || m < 0 || m > 59 ||
      s < 0 || s > 59) {
    throw ConfigError("--time '" + time + "': expected HH:MM:SS, e.g. 02:00:00");
  }
}

std::string header(const SlurmOptions& o, const std::string& name, const std::string& logs) {
  std::string text = "#SBATCH --job-name=" + name + "\n#SBATCH --output=" + logs + "\n";
  if (!o.partition.empty()) text += "#SBATCH --partition=" + o.partition + "\n";
  if (!o.time.empty()) text += "#SBATCH --time=" + o.time + "\n";
  return text;
}

void runSlurm(const SlurmOptions& o) {
  if (o.shards < 1) throw ConfigError("--shards " + std::to_string(o.shards) + ": expected >= 1");
  if (o.cpus_per_task < 1) throw ConfigError("--cpus-per-task: expected >= 1");
  checkTime(o.time);
  const Experiment experiment = Experiment::fromFile(o.experiment);
  const std::size_t runs = experiment.runs().size();
  const fs::path out = fs::absolute(o.out_dir);
  const std::string experiment_path = fs::absolute(o.experiment).string();
  const std::string cache = fs::absolute(o.cache_dir).string();
  const std::string shards = std::to_string(o.shards);
  const std::string job = "kinolab-" + experiment.name;

  std::string array = "#!/bin/bash\n# kinolab: experiment '" + experiment.name + "' (" +
                      std::to_string(runs) + " runs) as " + shards +
                      " shards, one array task each.\n"
                      "# Submitted by `kinolab slurm`; to rerun one failed shard K alone:\n"
                      "#   sbatch --array=K " +
                      (out / "kinolab_shards.sh").string() + "   (it resumes), then sbatch " +
                      (out / "kinolab_merge.sh").string() + "\n" +
                      header(o, job, (out / "logs" / "shard_%a.out").string()) +
                      "#SBATCH --array=1-" + shards +
                      "\n#SBATCH --cpus-per-task=" + std::to_string(o.cpus_per_task) + "\n";
  if (!o.memory.empty()) array += "#SBATCH --mem=" + o.memory + "\n";
  array += "set -euo pipefail\nexec " + quote(selfPath()) + " run " + quote(experiment_path) +
           " \\\n  --out " + quote(Shard::parentDirectory(out.string())) +
           "/\"$SLURM_ARRAY_TASK_ID\" --shard \"$SLURM_ARRAY_TASK_ID/" + shards +
           "\" --resume \\\n  -j \"${SLURM_CPUS_PER_TASK:-1}\" --cache-dir " + quote(cache) + "\n";
  std::string merge = "#!/bin/bash\n# kinolab: joins the " + shards +
                      " shard databases into results.sqlite (refuses partial or mixed inputs).\n" +
                      header(o, job + "-merge", (out / "logs" / "merge.out").string()) +
                      "set -euo pipefail\nrm -f " + quote((out / "results.sqlite").string()) +
                      "*\nexec " + quote(selfPath()) + " merge " +
                      quote((out / "results.sqlite").string());
  for (int shard = 1; shard <= o.shards; ++shard) {
    merge +=
        " \\\n  " + quote((fs::path(Shard::directory(out.string(), shard)) / "results.sqlite").string());
  }
  merge += "\n";

  fs::create_directories(out / "logs");
  writeFileAtomically((out / "kinolab_shards.sh").string(), array);
  writeFileAtomically((out / "kinolab_merge.sh").string(), merge);
  if (o.dry_run) {
    std::cout << "# " << (out / "kinolab_shards.sh").string() << "\n"
              << array << "\n# " << (out / "kinolab_merge.sh").string() << "\n"
              << merge << "\n(dry run: nothing submitted)\n";
    return;
  }
  // Worlds are built once here, into the cache every shard reads.
  std::set<std::uint64_t> built;
  const WorldCache world_cache(cache);
  for (const ExperimentVariant& variant : experiment.variants) {
    for (const ExperimentWorld& world : variant.worlds) {
      if (built.insert(world.spec.hash()).second) {
        const WorldLoad load = world_cache.loadOrBuild(world.spec);
        std::printf("world %s: %s\n", world.id.c_str(),
                    load.source == WorldSource::kCache ? "cached" : "built");
      }
    }
  }
  const auto [array_status, array_id] =
      client("sbatch --parsable " + quote((out / "kinolab_shards.sh").string()));
  if (array_status != 0) throw Error("slurm: sbatch failed: " + array_id);
  const std::string array_job = array_id.substr(0, array_id.find(';'));
  const auto [merge_status, merge_id] =
      client("sbatch --parsable --dependency=afterok:" + array_job + " " +
             quote((out / "kinolab_merge.sh").string()));
  if (merge_status != 0) throw Error("slurm: sbatch of the merge failed: " + merge_id);
  const std::string merge_job = merge_id.substr(0, merge_id.find(';'));
  writeFileAtomically((out / "slurm_jobs.txt").string(),
                      "array " + array_job + "\nmerge " + merge_job + "\nshards " + shards + "\n");
  std::printf(
      "submitted: array job %s (%d shards), merge job %s (after all succeed)\n"
      "status: kinolab slurm-status %s\n",
      array_job.c_str(), o.shards, merge_job.c_str(), out.string().c_str());
}

void runStatus(const std::string& directory) {
  const fs::path out(directory);
  std::ifstream jobs(out / "slurm_jobs.txt");
  if (!jobs) throw FileError((out / "slurm_jobs.txt").string() + ": no submission here");
  std::string key, array_job, merge_job;
  int shards = 0;
  while (jobs >> key) {
    if (key == "array") jobs >> array_job;
    if (key == "merge") jobs >> merge_job;
    if (key == "shards") jobs >> shards;
  }
  const auto [status, queue] =
      client("squeue --noheader --array --format='%i %T %R' --jobs=" + array_job + "," + merge_job);
  std::printf("array job %s, merge job %s\n", array_job.c_str(), merge_job.c_str());
  if (status != 0) {
    std::printf("  squeue: %s\n", queue.c_str());
  } else if (queue.empty()) {
    std::printf("  nothing queued or running\n");
  } else {
    std::istringstream lines(queue);
    for (std::string line; std::getline(lines, line);) std::printf("  %s\n", line.c_str());
  }
  long long done = 0, planned = 0;
  for (int shard = 1; shard <= shards; ++shard) {
    const fs::path file = fs::path(Shard::directory(out.string(), shard)) / "results.sqlite";
    if (!fs::exists(file)) {
      std::printf("  shard %d/%d: not started\n", shard, shards);
      continue;
    }
    ResultsStore store(file.string());
    const long long stored = store.runCount();
    const long long expected = std::stoll(store.meta("runs_planned").value_or("0"));
    done += stored;
    planned += expected;
    std::printf("  shard %d/%d: %lld of %lld runs%s\n", shard, shards, stored, expected,
                stored == expected ? " (complete)" : "");
  }
  const bool merged = fs::exists(out / "results.sqlite");
  std::printf("  %lld runs stored in the shards; merged database: %s\n", done,
              merged ? (out / "results.sqlite").string().c_str() : "not yet");
}

}  // namespace

void addSlurmCommand(CLI::App& app) {
  auto o = std::make_shared<SlurmOptions>();
  CLI::App* command = app.add_subcommand(
      "slurm",
      "Run an experiment on a Slurm cluster: an array job of shards (each `kinolab run "
      "--shard i/N --resume`) and a dependent merge job into DIR/results.sqlite");
  command->add_option("experiment", o->experiment, "Experiment YAML")->required();
  command->add_option("--out", o->out_dir, "Output directory (shared by the cluster's nodes)")
      ->required();
  command->add_option("--shards", o->shards, "Number of array tasks (shards)")->required();
  command->add_option("--partition", o->partition, "Slurm partition");
  command->add_option("--time", o->time, "Time limit of each shard, HH:MM:SS");
  command->add_option("--cpus-per-task", o->cpus_per_task, "CPUs per shard (its -j)")
      ->capture_default_str();
  command->add_option("--mem", o->memory, "Memory per shard, e.g. 8G");
  command
      ->add_option("--cache-dir", o->cache_dir,
                   "World cache directory (shared by the nodes); worlds are built here once")
      ->capture_default_str();
  command->add_flag("--dry-run", o->dry_run, "Write and print the scripts, submit nothing");
  command->footer(
      "Writes DIR/kinolab_shards.sh and DIR/kinolab_merge.sh (plain sbatch scripts: edit and "
      "submit them yourself if you like), DIR/slurm_jobs.txt, shard databases in "
      "DIR/shards/i/, logs in DIR/logs/. A failed shard: sbatch --array=K "
      "DIR/kinolab_shards.sh, then sbatch DIR/kinolab_merge.sh.");
  command->callback([o] { runSlurm(*o); });

  auto directory = std::make_shared<std::string>();
  CLI::App* status = app.add_subcommand(
      "slurm-status", "Summarise a `kinolab slurm` submission: job states and runs per shard");
  status->add_option("dir", *directory, "The --out directory of kinolab slurm")->required();
  status->callback([directory] { runStatus(*directory); });
}

}  // namespace kinolab::apps
