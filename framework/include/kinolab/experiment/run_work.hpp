#pragma once

#include <memory>
#include <string>

#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/process_pool.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {

/// The work of one run, as its worker process does it: plan the query under the timing
/// protocol (planRun) or fly it (flyRun), and return the worker's text: JSON with the run's
/// metrics, statistics and stored artefacts. Every metric and statistic is a declared one
/// (resultMetrics(), runnerMetrics(), the planner's or the flight's statistics): an
/// undeclared name is an error where it is reported, never a silent NULL. A failure the run
/// can report itself (out of memory, an exception) becomes its status (oom, error).
std::string planRun(const Experiment& experiment, const RunSpec& run,
                    const std::shared_ptr<const World>& world, const PlanningQuery& query);
std::string flyRun(const Experiment& experiment, const RunSpec& run,
                   const std::shared_ptr<const World>& world, const PlanningQuery& query);

/// The record of a finished worker, from its text and how it ended: killed (past its
/// deadline), crash (a signal, or an exit without a result), or what the worker reported;
/// with the run's identity and the runner's metrics (peak memory, wall time, start).
RunRecord recordOf(const Experiment& experiment, const RunSpec& run, const WorkerOutcome& worker,
                   const PlanningQuery& query);

}  // namespace kinolab
