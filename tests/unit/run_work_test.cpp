// The per-run work of the runner, without the command line: a planned and a flown run's
// worker text holds declared metrics only, and the record of a worker follows how it ended.
#include "kinolab/experiment/run_work.hpp"

#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "kinolab/planner/metrics.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

/// An experiment of one world, one query and one planner, written to a file and read back.
Experiment experimentOf(const std::string& kind, const std::string& extra) {
  test::loadTestPlugins();
  const auto path = std::filesystem::temp_directory_path() / ("run_work_" + kind + ".yaml");
  std::ofstream(path) << "kind: " << kind << "\nname: work\nseed: 5\n"
                      << "worlds:\n  - id: wall\n    spec:\n      resolution: 0.1\n"
                      << "      bounds: {min: [0, 0, 0], max: [12, 6, 3]}\n"
                      << "      generators: [{type: box_list, boxes: [{min: [5, 0, 0], "
                      << "max: [5.4, 4, 3]}]}]\n"
                      << "queries:\n  fixed:\n    - {start: [2, 2, 1.5], goal: [9, 2, 1.5]}\n"
                      << "planners:\n  - id: lazy\n    type: lazy_mp_astar\n"
                      << "    sampler: {type: uniform, params: {samples_per_axis: 3}}\n"
                      << extra;
  return Experiment::fromFile(path.string());
}

struct Case {
  Experiment experiment;
  RunSpec run;
  std::shared_ptr<const World> world;
  PlanningQuery query;

  explicit Case(Experiment e) : experiment(std::move(e)), run(experiment.runs().front()) {
    const ExperimentVariant& variant = experiment.variants.front();
    world = World::build(variant.worlds.front().spec);
    query = variant.queries.make(*world, variant.worlds.front().id, experiment.seed).front();
  }
};

TEST(RunWork, APlannedRunReportsDeclaredMetricsAndItsTiming) {
  const Case c(experimentOf("planning", "timing: {warmup: 1, repeats: 3}\n"));
  const auto out = nlohmann::json::parse(planRun(c.experiment, c.run, c.world, c.query));
  const auto& metrics = out["metrics"];
  ASSERT_EQ(metrics["status"], "exact") << out.dump();
  EXPECT_EQ(metrics["line_blocked"], true);  // the wall stands between start and goal
  EXPECT_LE(metrics["planning_time_min_ms"].get<double>(),
            metrics["planning_time_ms"].get<double>());
  EXPECT_GT(out["statistics"]["expansions"].get<double>(), 0.0);
  for (const auto& [name, value] : metrics.items()) {
    EXPECT_TRUE(resultMetrics().find(name) || runnerMetrics().find(name)) << name;
  }

  WorkerOutcome worker;
  worker.output = out.dump();
  worker.wall_ms = 12.5;
  const RunRecord record = recordOf(c.experiment, c.run, worker, c.query);
  EXPECT_EQ(record.text("status"), "exact");
  EXPECT_EQ(record.number("wall_time_ms"), 12.5);
  EXPECT_EQ(record.planner_type, "lazy_mp_astar");
  EXPECT_EQ(record.sampler, "uniform");
}

TEST(RunWork, AFlownRunReportsTheFlightInTheResultSchema) {
  const Case c(experimentOf("flight", "flight: {max_time: 40}\n"));
  const auto out = nlohmann::json::parse(flyRun(c.experiment, c.run, c.world, c.query));
  const auto& metrics = out["metrics"];
  EXPECT_EQ(metrics["status"], "reached") << out.dump();
  EXPECT_EQ(metrics["line_blocked"], true);
  EXPECT_TRUE(out["statistics"].contains("replans"));
  EXPECT_FALSE(out["replans"].get<std::string>().empty());
}

TEST(RunWork, TheRecordSaysHowTheWorkerEnded) {
  const Case c(experimentOf("planning", ""));
  WorkerOutcome killed;
  killed.killed_for_time = true;
  EXPECT_EQ(recordOf(c.experiment, c.run, killed, c.query).text("status"), "killed");
  WorkerOutcome signalled;
  signalled.wait_status = SIGSEGV;  // as waitpid reports a death by that signal
  const RunRecord crash = recordOf(c.experiment, c.run, signalled, c.query);
  EXPECT_EQ(crash.text("status"), "crash");
  EXPECT_NE(crash.text("message").find("signal 11"), std::string::npos) << crash.text("message");
  WorkerOutcome silent;  // exited 0 without writing a result
  EXPECT_NE(recordOf(c.experiment, c.run, silent, c.query).text("message").find("without a result"),
            std::string::npos);
}

TEST(RunWork, AnUndeclaredMetricIsAnErrorWhereItIsReported) {
  MetricValues values = {{"status", std::string("exact")}, {"planing_time_ms", 1.0}};
  try {
    toJson(values, resultMetrics());
    FAIL() << "accepted";
  } catch (const InvalidArgument& error) {
    EXPECT_NE(std::string(error.what()).find("did you mean 'planning_time_ms'"), std::string::npos)
        << error.what();
  }
}

TEST(RunWork, ProgressSeriesAreDeclaredInOrderFiniteAndSurviveTheWorkersJson) {
  const MetricSpecs declared =
      MetricSpecs().counter("iterations", "i").series("anytime_cost", "m", "best cost");
  PlanResult result;
  result.statistics = {{"iterations", 7.0}};
  result.progress = {
      {"anytime_cost", 1.5, 30.0}, {"anytime_cost", 1.5, 29.0}, {"anytime_cost", 4.25, 21.5}};
  EXPECT_NO_THROW(checkStatisticsDeclared(result, declared, "p"));
  const Progress back = progressFromJson(progressToJson(result.progress));
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(back[2].name, "anytime_cost");
  EXPECT_EQ(back[2].time_ms, 4.25);
  EXPECT_EQ(back[2].value, 21.5);

  const auto refused = [&](const PlanResult& bad, const std::string& expected) {
    try {
      checkStatisticsDeclared(bad, declared, "p");
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const PluginError& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
    }
  };
  PlanResult bad = result;
  bad.progress.push_back({"anytime_cots", 5.0, 20.0});
  refused(bad, "'anytime_cots', which it does not declare with MetricSpecs::series");
  bad = result;
  bad.progress.push_back({"iterations", 5.0, 20.0});  // a value, not a series
  refused(bad, "does not declare with MetricSpecs::series");
  bad = result;
  bad.statistics.emplace_back("anytime_cost", 20.0);  // a series, not a value
  refused(bad, "declares as a progress series");
  bad = result;
  bad.progress.push_back({"anytime_cost", 2.0, 20.0});
  refused(bad, "out of time order (2 ms after 4.25 ms)");
  bad = result;
  bad.progress.push_back({"anytime_cost", 5.0, INFINITY});
  refused(bad, "not finite");
  EXPECT_THROW(progressFromJson(R"([["anytime_cost", 1.0]])"), InvalidArgument);
}

}  // namespace
}  // namespace kinolab
