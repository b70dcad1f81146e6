// `kinolab report`: runs the analysis package (analysis/kinolab_analysis, Python) with the
// interpreter the build found, on a results directory.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/version.hpp"
#include "kinolab/view/scene.hpp"

namespace kinolab::apps {
namespace {

struct ReportOptions {
  std::vector<std::string> results;
  std::string out;
  std::string compare;
  std::string sampling_study;
  bool allow_mixed = false;
  // Which of the valued options were given (an empty value is passed on, and refused there).
  std::vector<std::pair<std::string, const std::string*>> given;
};

/// Runs `python3 -m kinolab_analysis ARGUMENTS...` in place of this process.
[[noreturn]] void runAnalysis(std::vector<std::string> arguments) {
  const std::string directory = analysisDirectory();
  const char* existing = std::getenv("PYTHONPATH");
  const std::string path = directory + (existing && *existing ? ":" + std::string(existing) : "");
  setenv("PYTHONPATH", path.c_str(), 1);
  setenv("MPLBACKEND", "Agg", 1);
  // The 3D viewer page the report's views are made of (none: the report has no 3D views).
  try {
    setenv("KINOLAB_VIEWER", view::viewerTemplatePath().c_str(), 1);
  } catch (const FileError& error) {
    std::fprintf(stderr, "report: no 3D views: %s\n", error.what());
  }
  arguments.insert(arguments.begin(), {kPythonExecutable, "-m", "kinolab_analysis"});
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  execv(kPythonExecutable, argv.data());
  throw FileError(std::string("kinolab: cannot run ") + kPythonExecutable +
                  " (install python3, python3-pandas, python3-scipy, python3-matplotlib and "
                  "python3-jinja2: scripts/setup_debian.sh)");
}

[[noreturn]] void runReport(const ReportOptions& options) {
  std::vector<std::string> arguments = {"report"};
  arguments.insert(arguments.end(), options.results.begin(), options.results.end());
  for (const auto& [flag, value] : options.given) {
    arguments.push_back(flag);
    arguments.push_back(*value);
  }
  if (options.allow_mixed) arguments.emplace_back("--allow-mixed");
  runAnalysis(std::move(arguments));
}

struct ExportOptions {
  std::vector<std::string> results;
  std::string format;
  std::string out;
};

}  // namespace

void addReportCommand(CLI::App& app) {
  auto options = std::make_shared<ReportOptions>();
  CLI::App* command = app.add_subcommand(
      "report",
      "Write a self-contained HTML report (figures as PNG and SVG, tables as Markdown and "
      "LaTeX) of a results directory and print a summary");
  command
      ->add_option("results", options->results,
                   "Results directories (or results.sqlite files) of one experiment")
      ->required();
  const std::vector<std::pair<CLI::Option*, const std::string*>> valued = {
      {command->add_option("--out", options->out, "Report directory (default: RESULTS/report)"),
       &options->out},
      {command->add_option("--compare", options->compare,
                           "A second result set to report side by side (e.g. before a change)"),
       &options->compare},
      {command->add_option("--sampling-study", options->sampling_study,
                           "A sampling study's summary.csv for Table I (default: "
                           "RESULTS/sampling_study/*/summary.csv when present)"),
       &options->sampling_study}};
  command->add_flag("--allow-mixed", options->allow_mixed,
                    "Report databases of different experiments (config hashes) side by side, "
                    "each planner labelled with its experiment (refused otherwise: one report "
                    "pools one experiment's runs)");
  command->footer(
      "Statistics: Wilson intervals for success rates, bootstrap intervals for "
      "medians, Wilcoxon signed-rank and McNemar for paired comparisons, "
      "Holm-corrected. A 3D view per world (view_<world>.html, also inline): the obstacles, "
      "the stored trajectories, search trees and flights. Runs with the interpreter " +
      std::string(kPythonExecutable) + ".");
  command->callback([options, valued] {
    for (const auto& [option, value] : valued) {
      if (option->count() > 0) options->given.emplace_back(option->get_name(), value);
    }
    runReport(*options);
  });
}

void addExportCommand(CLI::App& app) {
  auto options = std::make_shared<ExportOptions>();
  CLI::App* command = app.add_subcommand(
      "export", "Write a results directory in another tool's format: OMPL benchmark logs");
  command
      ->add_option("results", options->results,
                   "Results directories (or results.sqlite files) of one experiment, then OUT")
      ->required();
  command->add_option("--format", options->format, "ompl: OMPL's benchmark log format")
      ->required()
      ->check(CLI::IsMember({"ompl"}));
  command->footer(
      "kinolab export DIR --format ompl OUT writes OUT/<world>[_<variant>].log, one OMPL "
      "benchmark log per world and sweep variant (its runs: every query and repetition of each "
      "planner, the query a run property); OMPL's ompl_benchmark_statistics OUT/*.log -d "
      "benchmark.db makes the database Planner Arena (plannerarena) reads. Time is the "
      "planner's in seconds; solved means a success (exact and checker-valid).");
  command->callback([options] {
    if (options->results.size() < 2) {
      throw ConfigError("kinolab export: expected RESULTS... OUT (the output directory last)");
    }
    std::vector<std::string> arguments = {"export"};
    arguments.insert(arguments.end(), options->results.begin(), options->results.end() - 1);
    arguments.insert(arguments.end(), {"--format", options->format, options->results.back()});
    runAnalysis(std::move(arguments));
  });
}

}  // namespace kinolab::apps
