// `kinolab slurm`: an experiment as a Slurm array job of shards plus a dependent merge job
// (the scripts and layout: kinolab/experiment/slurm.hpp);
// `kinolab slurm-status`: how far it got.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/experiment/runner.hpp"
#include "kinolab/experiment/slurm.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::apps {
namespace {

namespace fs = std::filesystem;

struct SlurmOptions {
  std::string experiment;
  std::string out_dir;
  SlurmRequest request;
  std::string cache_dir = WorldCache::defaultDirectory();
  bool dry_run = false;
};

/// A Slurm client call; under a timeout, since clients block while the controller is down.
CommandOutput client(const std::vector<std::string>& arguments) {
  return runCommand(arguments, 60);
}

void runSlurm(const SlurmOptions& o) {
  o.request.validate();
  const Experiment experiment = Experiment::fromFile(o.experiment);
  const SlurmLayout layout{fs::absolute(o.out_dir).string()};
  const std::string cache = fs::absolute(o.cache_dir).string();
  // Worlds are built once here, into the cache every shard reads, and every query is placed
  // as the shards will place it, before anything is written or submitted.
  const std::vector<RunSpec> runs = experiment.runs();
  std::vector<const RunSpec*> pointers;
  for (const RunSpec& run : runs) pointers.push_back(&run);
  placeInputs(experiment, pointers, cache,
              [](const ExperimentWorld& world, const std::shared_ptr<const World>&, bool cached) {
                std::printf("world %s: %s\n", world.id.c_str(), cached ? "cached" : "built");
              });
  const SlurmScripts scripts =
      slurmScripts(experiment, fs::absolute(o.experiment).string(), layout, o.request,
                   fs::read_symlink("/proc/self/exe").string(), cache);

  fs::create_directories(layout.logs());
  writeFileAtomically(layout.arrayScript(), scripts.array);
  writeFileAtomically(layout.mergeScript(), scripts.merge);
  if (o.dry_run) {
    std::cout << "# " << layout.arrayScript() << "\n"
              << scripts.array << "\n# " << layout.mergeScript() << "\n"
              << scripts.merge << "\n(dry run: nothing submitted)\n";
    return;
  }
  const CommandOutput array = client({"sbatch", "--parsable", layout.arrayScript()});
  if (array.status != 0) throw Error("slurm: sbatch failed: " + array.output);
  const std::string& array_id = array.output;
  SlurmJobs jobs;
  jobs.shards = o.request.shards;
  jobs.array_job = array_id.substr(0, array_id.find(';'));
  const CommandOutput merge = client(
      {"sbatch", "--parsable", "--dependency=afterok:" + jobs.array_job, layout.mergeScript()});
  if (merge.status != 0) throw Error("slurm: sbatch of the merge failed: " + merge.output);
  const std::string& merge_id = merge.output;
  jobs.merge_job = merge_id.substr(0, merge_id.find(';'));
  // What sbatch printed must be job ids (parse() refuses anything else).
  writeFileAtomically(layout.jobsFile(), SlurmJobs::parse(jobs.text(), "sbatch's answers").text());
  std::printf(
      "submitted: array job %s (%d shards), merge job %s (after all succeed)\n"
      "status: kinolab slurm-status %s\n",
      jobs.array_job.c_str(), jobs.shards, jobs.merge_job.c_str(), layout.out.c_str());
}

void runStatus(const std::string& directory) {
  const SlurmLayout layout{directory};
  std::ifstream file(layout.jobsFile());
  if (!file) throw FileError(layout.jobsFile() + ": no submission here");
  std::stringstream text;
  text << file.rdbuf();
  const SlurmJobs jobs = SlurmJobs::parse(text.str(), layout.jobsFile());
  const CommandOutput squeue = client({"squeue", "--noheader", "--array", "--format=%i %T %R",
                                       "--jobs=" + jobs.array_job + "," + jobs.merge_job});
  const std::string& queue = squeue.output;
  std::printf("array job %s, merge job %s\n", jobs.array_job.c_str(), jobs.merge_job.c_str());
  if (squeue.status != 0) {
    std::printf("  squeue: %s\n", queue.c_str());
  } else if (queue.empty()) {
    std::printf("  nothing queued or running\n");
  } else {
    std::istringstream lines(queue);
    for (std::string line; std::getline(lines, line);) std::printf("  %s\n", line.c_str());
  }
  long long done = 0;
  for (int shard = 1; shard <= jobs.shards; ++shard) {
    const std::string database = layout.shardDatabase(shard);
    if (!fs::exists(database)) {
      std::printf("  shard %d/%d: not started\n", shard, jobs.shards);
      continue;
    }
    ResultsStore store(database);
    const long long stored = store.runCount();
    const long long expected = std::stoll(store.meta("runs_planned").value_or("0"));
    done += stored;
    std::printf("  shard %d/%d: %lld of %lld runs%s\n", shard, jobs.shards, stored, expected,
                stored == expected ? " (complete)" : "");
  }
  const bool merged = fs::exists(layout.merged());
  std::printf("  %lld runs stored in the shards; merged database: %s\n", done,
              merged ? layout.merged().c_str() : "not yet");
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
  command->add_option("--shards", o->request.shards, "Number of array tasks (shards)")->required();
  command->add_option("--partition", o->request.partition, "Slurm partition");
  command->add_option("--time", o->request.time, "Time limit of each shard, HH:MM:SS");
  command->add_option("--cpus-per-task", o->request.cpus_per_task, "CPUs per shard (its -j)")
      ->check(within(1, 1024))
      ->capture_default_str();
  command->add_option("--mem", o->request.memory, "Memory per shard, e.g. 8G");
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
