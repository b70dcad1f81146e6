#include "kinolab/experiment/slurm.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/experiment/shard.hpp"

namespace kinolab {
namespace {

namespace fs = std::filesystem;

std::string header(const SlurmRequest& request, const std::string& name, const std::string& logs) {
  std::string text = "#SBATCH --job-name=" + name + "\n#SBATCH --output=" + logs + "\n";
  if (!request.partition.empty()) text += "#SBATCH --partition=" + request.partition + "\n";
  if (!request.time.empty()) text += "#SBATCH --time=" + request.time + "\n";
  return text;
}

/// True when every character of `text` is in `allowed` (or a letter or digit).
bool onlyOf(const std::string& text, std::string_view allowed) {
  return std::all_of(text.begin(), text.end(), [&](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           allowed.find(c) != std::string_view::npos;
  });
}

std::string in(const std::string& directory, const std::string& name) {
  return (fs::path(directory) / name).string();
}

}  // namespace

void SlurmRequest::validate() const {
  if (shards < 1) throw ConfigError("--shards " + std::to_string(shards) + ": expected >= 1");
  if (cpus_per_task < 1) {
    throw ConfigError("--cpus-per-task " + std::to_string(cpus_per_task) + ": expected >= 1");
  }
  // These values go into #SBATCH directive lines, which nothing can quote: only the
  // characters Slurm's own syntax uses are accepted.
  if (!partition.empty() && !onlyOf(partition, "_-.,")) {
    throw ConfigError("--partition '" + printable(partition) +
                      "': expected partition names (letters, digits, '_', '-', '.', commas)");
  }
  const std::size_t digits = memory.find_first_not_of("0123456789");
  const bool memory_valid =
      digits > 0 && (digits == std::string::npos ||
                     (digits == memory.size() - 1 &&
                      std::string_view("KMGTkmgt").find(memory.back()) != std::string_view::npos));
  if (!memory.empty() && !memory_valid) {
    throw ConfigError("--mem '" + printable(memory) + "': expected a size such as 8G or 16000M");
  }
  if (time.empty()) return;
  int h = 0, m = 0, s = 0;
  char rest = 0;
  if (std::sscanf(time.c_str(), "%d:%d:%d%c", &h, &m, &s, &rest) != 3 || h < 0 || m < 0 || m > 59 ||
      s < 0 || s > 59) {
    throw ConfigError("--time '" + printable(time) + "': expected HH:MM:SS, e.g. 02:00:00");
  }
}

std::string SlurmLayout::arrayScript() const { return in(out, "kinolab_shards.sh"); }
std::string SlurmLayout::mergeScript() const { return in(out, "kinolab_merge.sh"); }
std::string SlurmLayout::jobsFile() const { return in(out, "slurm_jobs.txt"); }
std::string SlurmLayout::logs() const { return in(out, "logs"); }
std::string SlurmLayout::merged() const { return in(out, "results.sqlite"); }
std::string SlurmLayout::shardDatabase(int index) const {
  return in(Shard::directory(out, index), "results.sqlite");
}

SlurmScripts slurmScripts(const Experiment& experiment, const std::string& experiment_path,
                          const SlurmLayout& layout, const SlurmRequest& request,
                          const std::string& kinolab_path, const std::string& cache_dir) {
  request.validate();
  // A shard without a run is an empty array task, and the merge script names every shard's
  // database: at most one shard per run, and Slurm's array sizes are bounded.
  const std::size_t runs = experiment.runs().size();
  constexpr int kMaxShards = 100000;
  if (static_cast<std::size_t>(request.shards) > runs || request.shards > kMaxShards) {
    throw ConfigError("--shards " + std::to_string(request.shards) + ": expected at most " +
                      std::to_string(std::min<std::size_t>(runs, kMaxShards)) +
                      " (the experiment has " + std::to_string(runs) + " runs, and at most " +
                      std::to_string(kMaxShards) + " array tasks are written)");
  }
  // The output directory appears in #SBATCH --output lines too.
  if (!onlyOf(layout.out, "/_-.,+@%~=:")) {
    throw ConfigError("--out '" + printable(layout.out) +
                      "': a Slurm output directory may hold letters, digits and / _ - . , + @ "
                      "% ~ = : only (its path goes into #SBATCH lines, which cannot be quoted)");
  }
  const std::string shards = std::to_string(request.shards);
  const std::string job = "kinolab-" + experiment.name;
  SlurmScripts scripts;
  scripts.array = "#!/bin/bash\n# kinolab: experiment '" + experiment.name + "' (" +
                  std::to_string(experiment.runs().size()) + " runs) as " + shards +
                  " shards, one array task each.\n"
                  "# Submitted by `kinolab slurm`; to rerun one failed shard K alone:\n"
                  "#   sbatch --array=K " +
                  layout.arrayScript() + "   (it resumes), then sbatch " + layout.mergeScript() +
                  "\n" + header(request, job, in(layout.logs(), "shard_%a.out")) +
                  "#SBATCH --array=1-" + shards +
                  "\n#SBATCH --cpus-per-task=" + std::to_string(request.cpus_per_task) + "\n";
  if (!request.memory.empty()) scripts.array += "#SBATCH --mem=" + request.memory + "\n";
  scripts.array += "set -euo pipefail\nexec " + shellQuote(kinolab_path) + " run " +
                   shellQuote(experiment_path) + " \\\n  --out " +
                   shellQuote(Shard::parentDirectory(layout.out)) +
                   "/\"$SLURM_ARRAY_TASK_ID\" --shard \"$SLURM_ARRAY_TASK_ID/" + shards +
                   "\" --resume \\\n  -j \"${SLURM_CPUS_PER_TASK:-1}\" --cache-dir " +
                   shellQuote(cache_dir) + "\n";
  scripts.merge = "#!/bin/bash\n# kinolab: joins the " + shards +
                  " shard databases into results.sqlite (refuses partial or mixed inputs).\n" +
                  header(request, job + "-merge", in(layout.logs(), "merge.out")) +
                  "set -euo pipefail\nrm -f " + shellQuote(layout.merged()) + "*\nexec " +
                  shellQuote(kinolab_path) + " merge " + shellQuote(layout.merged());
  for (int shard = 1; shard <= request.shards; ++shard) {
    scripts.merge += " \\\n  " + shellQuote(layout.shardDatabase(shard));
  }
  scripts.merge += "\n";
  return scripts;
}

std::string SlurmJobs::text() const {
  return "array " + array_job + "\nmerge " + merge_job + "\nshards " + std::to_string(shards) +
         "\n";
}

SlurmJobs SlurmJobs::parse(const std::string& text, const std::string& source) {
  SlurmJobs jobs;
  std::istringstream lines(text);
  std::string key;
  while (lines >> key) {
    if (key == "array")
      lines >> jobs.array_job;
    else if (key == "merge")
      lines >> jobs.merge_job;
    else if (key == "shards")
      lines >> jobs.shards;
    else
      throw FileError(source + ": unknown entry '" + key + "'");
  }
  const auto job_id = [](const std::string& id) {
    return !id.empty() && id.find_first_not_of("0123456789") == std::string::npos;
  };
  if (!job_id(jobs.array_job) || !job_id(jobs.merge_job) || jobs.shards < 1) {
    throw FileError(source + ": expected 'array ID', 'merge ID' (numeric Slurm job ids) and " +
                    "'shards N'");
  }
  return jobs;
}

std::string shellQuote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace kinolab
