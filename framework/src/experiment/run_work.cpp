// The work of one run in its worker process (plan or fly) and the record made of what the
// worker returned; the runner (runner.cpp) schedules these.
#include "kinolab/experiment/run_work.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>

#include "kinolab/core/hash.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/planner/result_csv.hpp"

namespace kinolab {
namespace {

/// What a worker's `metrics` hold: the result's (a plan's or a flight's) and the runner's.
const MetricSpecs& workerMetrics(bool flight) {
  static const MetricSpecs plan = MetricSpecs(resultMetrics()).include(runnerMetrics());
  static const MetricSpecs flown = MetricSpecs(flightRunMetrics().specs()).include(runnerMetrics());
  return flight ? flown : plan;
}

/// Whether the straight line from start to goal collides for the body: the query needs a
/// detour.
double lineBlocked(const World& world, const PlanningQuery& query, const Body& body) {
  return world.segmentFree(query.start.col(0), query.goal, body.radius) ? 0.0 : 1.0;
}

/// A worker's output when memory ran out: the run's status `oom`, what ran out and its budget.
nlohmann::json outOfMemoryOutput(const ExperimentVariant& variant, const std::string& message) {
  return {{"metrics",
           {{"status", "oom"},
            {"message", message + "; the run's budget adds " +
                            std::to_string(variant.budget.memory_mb) +
                            " MB to its worker (budget.memory_mb)"}}}};
}

/// Runs `work`, which fills a run's JSON ({"metrics": {...}, "statistics": {...},
/// "trajectory", "tree"}), inside its worker process: every failure the run can report itself
/// (out of memory, an exception) becomes its status.
template <typename Work>
std::string workerOutput(const ExperimentVariant& variant, Work&& work) {
  nlohmann::json out;
  try {
    work(out);
  } catch (const OutOfMemory& error) {
    out = outOfMemoryOutput(variant, error.what());
  } catch (const std::bad_alloc&) {
    out = outOfMemoryOutput(variant, outOfMemoryMessage(""));
  } catch (const std::exception& error) {
    out = {{"metrics", {{"status", "error"}, {"message", error.what()}}}};
  } catch (...) {
    out = {{"metrics",
            {{"status", "error"},
             {"message", "an exception that is not a std::exception (plugin code?)"}}}};
  }
  try {
    return out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  } catch (const std::bad_alloc&) {
    out = nullptr;  // the answer is what did not fit: free it for a status that does
    return outOfMemoryOutput(variant, outOfMemoryMessage("writing the run's output")).dump();
  }
}

/// One run, inside its worker process: plan (under the timing protocol) and return the
/// result as JSON text.
}  // namespace

std::string planRun(const Experiment& experiment, const RunSpec& run,
                    const std::shared_ptr<const World>& world, const PlanningQuery& query) {
  const ExperimentVariant& variant = experiment.variants[run.variant];
  return workerOutput(variant, [&](nlohmann::json& out) {
    const ExperimentPlanner& spec = variant.planners[run.planner];
    // One budget: the experiment's time is the planner's own time_limit too, unless the
    // planner's entry set one (then that is its budget, recorded with the run).
    const double time_limit = spec.timeLimit(variant.budget);
    std::vector<ParameterAssignment> assignments = spec.assignments;
    if (!spec.ownTimeLimit() && spec.parameters.has("time_limit")) {
      assignments.push_back({"time_limit", formatNumber(time_limit), "budget.time"});
    }
    ConfiguredPlanner configured = configurePlanner(spec.type, assignments);
    configured.planner->setup({world, run.seed});
    Budget budget{time_limit, std::numeric_limits<long long>::max()};
    if (variant.budget.iterations > 0) budget.max_iterations = variant.budget.iterations;
    SearchTree tree;
    const bool store_tree =
        experiment.store.tree_queries < 0 || run.query < experiment.store.tree_queries;
    // The timing protocol (TimingProtocol): warm-up plans, then timed ones; every plan of a
    // case repeats the same work (planners are deterministic in their seed and the query).
    // A plan that spends the whole time budget it has (time_limit above, as the planner sees it
    // through Planner::budgetFor) would spend it again: it is the only one timed.
    const double limit_ms = 1000.0 * configured.planner->budgetFor(budget).time_limit;
    const int plans = variant.timing.warmup + variant.timing.repeats;
    std::vector<double> timed;
    double cold_ms = NAN;
    PlanResult result;
    for (int i = 0; i < plans; ++i) {
      result = configured.planner->plan(query, budget, store_tree ? &tree : nullptr);
      if (i == 0) cold_ms = result.planning_time_ms;
      const bool spent = result.planning_time_ms >= limit_ms;
      if (i >= variant.timing.warmup || spent) timed.push_back(result.planning_time_ms);
      if (spent) break;
    }
    std::sort(timed.begin(), timed.end());
    const std::size_t middle = timed.size() / 2;
    result.planning_time_ms =
        timed.size() % 2 ? timed[middle] : 0.5 * (timed[middle - 1] + timed[middle]);
    MetricValues metrics = resultValues(result);
    metrics.emplace_back("planning_time_min_ms", timed.front());
    metrics.emplace_back("planning_time_cold_ms", cold_ms);
    metrics.emplace_back("line_blocked", lineBlocked(*world, query, configured.planner->body()));
    metrics.emplace_back("time_limit", time_limit);
    metrics.emplace_back("time_limit_own", spec.ownTimeLimit() ? 1.0 : 0.0);
    out["metrics"] = nlohmann::json::parse(toJson(metrics, workerMetrics(false)));
    out["statistics"] = nlohmann::json::parse(
        toJson(statisticValues(result.statistics), declaredStatistics(*configured.info)));
    // The anytime progress of the last plan (a clock figure, as its planning time).
    if (!result.progress.empty())
      out["progress"] = nlohmann::json::parse(progressToJson(result.progress));
    if (!result.trajectory.empty() && experiment.store.trajectories) {
      out["trajectory"] = trajectoryCsv(result.trajectory, 0.05);
    }
    if (store_tree) out["tree"] = treeCsv(tree);
  });
}

/// One flight run, inside its worker process: fly and return the result as JSON text, in the
/// result schema (status, success, planning_time_ms = the replans' median, distance_to_goal
/// at the end, duration, length, jerk, clearance, the checker's verdict against the ground
/// truth) with every flight metric as a statistic.
std::string flyRun(const Experiment& experiment, const RunSpec& run,
                   const std::shared_ptr<const World>& world, const PlanningQuery& query) {
  const ExperimentVariant& variant = experiment.variants[run.variant];
  return workerOutput(variant, [&](nlohmann::json& out) {
    const ExperimentPlanner& spec = variant.planners[run.planner];
    FlightSetup setup = flightSetup(variant.flight);
    FlightSettings& settings = setup.settings;
    settings.seed = run.seed;
    // The known map's growth for the queries whose trees a planning experiment would store.
    const bool keep_map =
        experiment.store.tree_queries < 0 || run.query < experiment.store.tree_queries;
    if (keep_map) settings.snapshot_period = 2.0;
    ConfiguredPlanner configured = configurePlanner(spec.type, spec.assignments);
    const FlightResult flight = fly(world, *configured.planner, run.seed, query, setup);
    const bool flown = !flight.flown.empty();
    MetricValues metrics = flightRunMetrics().values(flight);
    metrics.emplace_back("line_blocked", lineBlocked(*world, query, flight.body));
    out["metrics"] = nlohmann::json::parse(toJson(metrics, workerMetrics(true)));
    const double radius = flight.body.radius;
    out["statistics"] =
        nlohmann::json::parse(toJson(flightStatisticValues(flight), flightStatistics()));
    if (flown && experiment.store.trajectories) {
      out["trajectory"] = trajectoryCsv(flight.flown, 0.05);
    }
    out["replans"] = replansCsv(flight);
    // Clearance to the ground truth (its ESDF less the body) over the flight, every 0.05 s.
    std::string clearance = "t,clearance\n";
    for (const TrajectorySample& sample : flight.flown.sample(0.05)) {
      clearance += formatNumber(sample.time) + "," +
                   formatNumber(world->distance(sample.position) - radius) + "\n";
    }
    out["clearance"] = clearance;
    if (keep_map) {
      // Snapshots one after the other, each after a line "t=SECONDS"; the last is the end.
      std::string maps;
      for (const auto& [time, view] : flight.snapshots) {
        maps += "t=" + formatNumber(time) + "\n" + view;
      }
      out["known_map"] = maps;
      out["known_voxels"] = knownVoxelsCsv(flight);
    }
  });
}

/// The record of a finished worker, from its output and how it ended.
RunRecord recordOf(const Experiment& experiment, const RunSpec& run, const WorkerOutcome& worker,
                   const PlanningQuery& query) {
  const ExperimentVariant& variant = experiment.variants[run.variant];
  const ExperimentWorld& world = variant.worlds[run.world];
  const ExperimentPlanner& planner = variant.planners[run.planner];
  RunRecord record;
  record.run_hash = run.hash;
  record.variant = static_cast<int>(run.variant);
  record.sweep = variant.label;
  record.world = world.id;
  record.world_hash = toHex(world.spec.hash());
  record.query = run.query;
  record.planner = planner.id;
  record.planner_type = planner.type;
  record.sampler = planner.sampler();
  record.repetition = run.repetition;
  record.seed = toHex(run.seed);
  for (int axis = 0; axis < 3; ++axis) {
    record.start[axis] = query.start(axis, 0);
    record.goal[axis] = query.goal[axis];
  }
  const double wall_time_ms = worker.wall_ms;
  const int wait_status = worker.wait_status;
  const auto finish = [&](std::string status, std::string message) {
    record.metrics.insert(
        record.metrics.begin(),
        {{"status", std::move(status)}, {"message", std::move(message)}, {"success", 0.0}});
  };
  record.metrics = {{"peak_memory_mb", static_cast<double>(worker.usage.ru_maxrss) / 1024.0},
                    {"wall_time_ms", wall_time_ms},
                    {"started_at", worker.started_at},
                    {"load_average", worker.load_average}};

  if (worker.killed_for_time) {
    const auto seconds = [](const timeval& t) {
      return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
    };
    const double cpu_s = seconds(worker.usage.ru_utime) + seconds(worker.usage.ru_stime);
    finish(
        "killed",
        "killed after " + formatNumber(wall_time_ms / 1000.0) + " s (" + formatNumber(cpu_s) +
            " s of CPU time; its limit is on the " +
            (worker.clock == BudgetClock::kCpu ? "CPU" : "wall") + " clock): " +
            (experiment.flights
                 ? "the flight ran past its budget of " + formatNumber(variant.budget.time) + " s"
                 : "the planner ignored its time budget of " +
                       formatNumber(planner.timeLimit(variant.budget)) + " s per plan (" +
                       std::to_string(variant.timing.warmup + variant.timing.repeats) + " plans)"));
    return record;
  }
  if (WIFSIGNALED(wait_status)) {
    finish("crash", std::string("the worker died of signal ") +
                        std::to_string(WTERMSIG(wait_status)) + " (" +
                        strsignal(WTERMSIG(wait_status)) + ")");
    return record;
  }
  const nlohmann::json out = nlohmann::json::parse(worker.output, nullptr, false);
  if (!WIFEXITED(wait_status) || WEXITSTATUS(wait_status) != 0 || out.is_discarded() ||
      !out.contains("metrics") || !out["metrics"].contains("status")) {
    finish("crash", "the worker exited with status " +
                        std::to_string(WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1) +
                        " without a result");
    return record;
  }
  MetricValues metrics = metricValuesFromJson(out["metrics"].dump());
  record.metrics.insert(record.metrics.begin(), metrics.begin(), metrics.end());
  if (out.contains("statistics"))
    record.statistics = metricValuesFromJson(out["statistics"].dump());
  if (out.contains("progress")) record.progress = progressFromJson(out["progress"].dump());
  record.trajectory_csv = out.value("trajectory", "");
  record.tree_csv = out.value("tree", "");
  record.replans_csv = out.value("replans", "");
  record.known_map = out.value("known_map", "");
  record.known_voxels_csv = out.value("known_voxels", "");
  record.clearance_csv = out.value("clearance", "");
  return record;
}

}  // namespace kinolab
