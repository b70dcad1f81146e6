// The experiment runner's own cost: 100 runs of `test_trivial` (a planner that returns at
// once) on a small forest, each in a forked worker, written to SQLite; with -j 1 and -j 2.
// Counters: runs per second and the wall time per run minus the planner's (the overhead of
// fork, setup, checker construction, result transfer and the database transaction).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/runner.hpp"

namespace kinolab {
namespace {

void BM_RunnerTrivialPlanner(benchmark::State& state) {
  registerBuiltinPlugins();
  const auto directory = std::filesystem::temp_directory_path() / "kinolab_runner_benchmark";
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  const std::string path = (directory / "trivial.yaml").string();
  std::ofstream(path) << "kind: planning\nname: trivial\nplugins: [" KINOLAB_TEST_PLUGIN "]\n"
                      << "worlds:\n  - id: small\n    spec:\n      name: small\n      seed: 4\n"
                      << "      resolution: 0.1\n      bounds: {min: [0, 0, 0], max: [10, 10, 3]}\n"
                      << "      generators: [{type: forest, density: 0.1, ground_plane: true}]\n"
                      << "queries: {random: {count: 100, min_distance: 2}}\n"
                      << "planners: [{id: trivial, type: test_trivial}]\n";
  const Experiment experiment = Experiment::fromFile(path);
  RunnerOptions options;
  options.jobs = static_cast<int>(state.range(0));
  options.cache_dir = (directory / "cache").string();
  double runs = 0.0;
  double seconds = 0.0;
  for (auto _ : state) {
    options.out_dir = (directory / ("out" + std::to_string(runs))).string();
    const RunnerSummary summary = runExperiment(experiment, options);
    runs += static_cast<double>(summary.finished);
    seconds += summary.seconds;
  }
  state.counters["runs_per_s"] = runs / seconds;
  state.counters["ms_per_run"] = 1000.0 * seconds / runs;
  std::filesystem::remove_all(directory);
}
BENCHMARK(BM_RunnerTrivialPlanner)->Arg(1)->Arg(2)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kinolab
