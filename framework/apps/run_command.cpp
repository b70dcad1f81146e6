// `kinolab run`: an experiment file into a results database; `kinolab merge`: shard
// databases into one.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/experiment/runner.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::apps {
namespace {

struct RunOptions {
  std::string experiment;
  RunnerOptions runner;
  std::string shard;
  std::string retry;
  bool dry_run = false;
};

int runCommand(RunOptions& options) {
  if (!options.shard.empty()) options.runner.shard = Shard::parse(options.shard);
  if (!options.retry.empty()) {
    if (!options.runner.resume) throw ConfigError("--retry runs stored runs again: add --resume");
    const std::vector<std::string> known = runStatuses();
    std::stringstream items(options.retry);
    for (std::string status; std::getline(items, status, ',');) {
      if (std::find(known.begin(), known.end(), status) == known.end()) {
        throw ConfigError("--retry '" + printable(status) + "': not a run status" +
                          didYouMean(status, known) + "; statuses: " + join(known, ", "));
      }
      options.runner.retry.insert(status);
    }
  }
  const Experiment experiment = Experiment::fromFile(options.experiment);
  if (options.dry_run) {
    const auto runs = options.runner.shard.select(experiment.runs());
    // The worlds are built (or loaded) and every query placed as the run will place them.
    std::vector<const RunSpec*> pointers;
    for (const RunSpec& run : runs) pointers.push_back(&run);
    const PlacedInputs placed = placeInputs(experiment, pointers, options.runner.cache_dir);
    std::cout << describeRuns(experiment, runs);
    std::cout << "\nevery query placed in its world (" << placed.worlds.size()
              << " world(s) built or loaded)\n";
    return 0;
  }
  if (options.runner.out_dir.empty()) throw ConfigError("--out DIR is required (or --dry-run)");
  const RunnerSummary summary = runExperiment(experiment, options.runner);
  std::string statuses;
  for (const auto& [status, count] : summary.by_status) {
    statuses += (statuses.empty() ? "" : ", ") + std::to_string(count) + " " + status;
  }
  std::printf(
      "%s: %lld runs ran, %lld succeeded (%s), %lld were already done, %lld planned, %.1f s -> "
      "%s/results.sqlite\n",
      summary.interrupted ? "interrupted" : "done", summary.finished, summary.succeeded,
      statuses.empty() ? "none" : statuses.c_str(), summary.skipped, summary.planned,
      summary.seconds, options.runner.out_dir.c_str());
  if (summary.interrupted) {
    std::printf("resume with: kinolab run %s --out %s --resume\n", options.experiment.c_str(),
                options.runner.out_dir.c_str());
    return 130;
  }
  return 0;
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  options->runner.cache_dir = WorldCache::defaultDirectory();
  CLI::App* command = app.add_subcommand(
      "run",
      "Run an experiment file (worlds x queries x planners x repetitions x sweep) into "
      "DIR/results.sqlite, each run in an isolated worker process");
  command->add_option("experiment", options->experiment, "Experiment YAML (experiments/*.yaml)")
      ->required();
  command->add_option("--out", options->runner.out_dir, "Output directory for results.sqlite");
  command->add_option("-j,--jobs", options->runner.jobs, "Worker processes at a time")
      ->check(within(1, 1024))
      ->capture_default_str();
  command->add_flag("--resume", options->runner.resume,
                    "Continue a stopped run: only the runs missing from the database run");
  command->add_option("--retry", options->retry,
                      "With --resume: run again the stored runs with these statuses, e.g. "
                      "crash,killed (workers stopped from outside)");
  command->add_option("--shard", options->shard,
                      "Run the deterministic i-th of N parts (i/N), for array jobs");
  command->add_flag(
      "--dry-run", options->dry_run,
      "Validate, build (or load) the worlds and place every query as the run will, and "
      "print the expanded runs (count and table); run nothing");
  command->add_option("--cache-dir", options->runner.cache_dir, "World cache directory")
      ->capture_default_str();
  command
      ->add_option("--grace", options->runner.grace_seconds,
                   "Seconds past its time budget before a worker is killed (status killed)")
      ->check(within(0.0, 86400.0))
      ->capture_default_str();
  command->footer(
      "A run's status is its planner's (exact, approximate, no_solution, timeout, "
      "invalid_start, invalid_goal, invalid_trajectory, back_end_failed) or the runner's: crash (the worker "
      "died), killed (past its time budget), oom (memory budget), error (an exception).\n"
      "Exit status 0 when every run finished (whatever their statuses); 1 for bad input or a "
      "fault outside kinolab (a full disk, a directory in use, an unwritable --out: the "
      "message says which, and what was stored is kept); 130 when interrupted (the database "
      "is resumable); 3 for an unexpected internal error.");
  command->callback([options] {
    const int code = runCommand(*options);
    if (code != 0) throw CLI::RuntimeError(code);
  });

  auto inputs = std::make_shared<std::vector<std::string>>();
  auto output = std::make_shared<std::string>();
  auto partial = std::make_shared<bool>(false);
  CLI::App* merge =
      app.add_subcommand("merge", "Join the shard databases of one experiment into a new database");
  merge->add_option("output", *output, "The merged database to create (must not exist)")
      ->required();
  merge->add_option("shards", *inputs, "Shard databases (DIR/results.sqlite of each shard)")
      ->required();
  merge->add_flag("--partial", *partial, "Accept missing or incomplete shards");
  merge->footer(
      "Refuses shards of different experiments (config hashes), repeated shards, and (without "
      "--partial) missing or incomplete ones.");
  merge->callback([inputs, output, partial] {
    ResultsStore::merge(*output, *inputs, *partial);
    ResultsStore merged(*output);
    std::printf("merged %zu shard(s): %lld runs -> %s\n", inputs->size(), merged.runCount(),
                output->c_str());
  });
}

}  // namespace kinolab::apps
