#include "kinolab/search/primitive_graph.hpp"

#include <utility>

#include "edge_workers.hpp"
#include "kinolab/core/error.hpp"

namespace kinolab {

PrimitiveGraph::PrimitiveGraph(const std::string& who, std::shared_ptr<const World> world,
                               std::vector<Eigen::Vector3d> controls, SearchSettings settings,
                               SearchPolicies policies)
    : world_(std::move(world)),
      controls_(std::move(controls)),
      settings_(std::move(settings)),
      given_policies_(policies),
      policies_(std::move(policies)),
      evaluator_(world_, settings_.edges) {
  if (controls_.empty()) throw InvalidArgument(who + ": no controls");
  if (!policies_.edges || !policies_.heuristic || !policies_.space) {
    throw InvalidArgument(who + ": an edge policy, a heuristic and a search space are needed");
  }
  if (!(settings_.heuristic_weight >= 1.0)) {
    throw InvalidArgument(who + ": heuristic_weight must be >= 1");
  }
  if (!(settings_.cost_weight >= 0.0)) {
    throw InvalidArgument(who + ": cost_weight must be >= 0");
  }
  if (controls_.size() >= (std::size_t{1} << 30)) {
    throw InvalidArgument(who + ": at most 2^30 controls, got " + std::to_string(controls_.size()));
  }
  if (settings_.threads < 1) {
    throw InvalidArgument(who + ": threads must be >= 1, got " + std::to_string(settings_.threads));
  }
  policies_.heuristic = heuristicForControls(policies_.heuristic, controls_);
  if (settings_.threads > 1) workers_ = std::make_unique<EdgeWorkers>(settings_.threads);
  // Of a state's estimates, only full evaluations are worth handing over
  // (EdgeEvaluationPolicy::evaluatesFully); a lazy search's go to evaluateMany().
  parallel_estimates_ = workers_ && policies_.edges->evaluatesFully();
}

PrimitiveGraph::~PrimitiveGraph() = default;
PrimitiveGraph::PrimitiveGraph(PrimitiveGraph&&) noexcept = default;
PrimitiveGraph& PrimitiveGraph::operator=(PrimitiveGraph&&) noexcept = default;

void PrimitiveGraph::beginQuery(const ChainState& start, const Eigen::Vector3d& goal,
                                StopCondition& stop) {
  query_begin_ = Clock::now();
  counters_ = {};
  start_ = start;
  goal_ = goal;
  heuristic_ = heuristicForQuery(policies_.heuristic, *world_, goal, stop);
  counters_.start_heuristic = heuristic_->estimate(start, goal);
}

void PrimitiveGraph::count(EdgeEstimate estimate, const EdgeEvaluation& evaluation) {
  counters_.esdf_queries += evaluation.esdf_queries;
  if (estimate == EdgeEstimate::kFull) {
    ++counters_.full_evaluations;
    if (evaluation.within_limits && !evaluation.collision_free) ++counters_.rejected_edges;
  } else {
    ++counters_.partial_evaluations;
    counters_.certified_edges += estimate == EdgeEstimate::kCertified;
  }
}

void PrimitiveGraph::countFull(const EdgeEvaluation& evaluation) {
  ++counters_.full_evaluations;
  counters_.esdf_queries += evaluation.esdf_queries;
  if (!evaluation.valid()) ++counters_.rejected_edges;
}

void PrimitiveGraph::estimateAll(const ChainState& parent, double parent_clearance,
                                 std::vector<EdgeEvaluation>& evaluations,
                                 std::vector<EdgeEstimate>& estimates) {
  evaluations.resize(controls_.size());
  estimates.resize(controls_.size());
  const EdgeEvaluationPolicy& policy = *policies_.edges;
  const auto begin = Clock::now();
  const auto evaluateOne = [&](std::size_t i) {
    estimates[i] =
        policy.evaluate(evaluator_, parent, parent_clearance, controls_[i], evaluations[i]);
  };
  if (parallel_estimates_) {
    workers_->run(controls_.size(), evaluateOne);
  } else {
    for (std::size_t i = 0; i < controls_.size(); ++i) evaluateOne(i);
  }
  for (std::size_t i = 0; i < controls_.size(); ++i) count(estimates[i], evaluations[i]);
  counters_.evaluation_seconds += secondsSince(begin);
}

EdgeEstimate PrimitiveGraph::estimate(const ChainState& parent, double parent_clearance,
                                      int control, EdgeEvaluation& evaluation) {
  const auto begin = Clock::now();
  const EdgeEstimate estimate = policies_.edges->evaluate(evaluator_, parent, parent_clearance,
                                                          controls_[control], evaluation);
  counters_.evaluation_seconds += secondsSince(begin);
  count(estimate, evaluation);
  return estimate;
}

EdgeEvaluation PrimitiveGraph::evaluate(const ChainState& parent, int control,
                                        double parent_clearance) {
  const auto begin = Clock::now();
  EdgeEvaluation full = evaluator_.full(parent, controls_[control], parent_clearance);
  counters_.evaluation_seconds += secondsSince(begin);
  countFull(full);
  return full;
}

void PrimitiveGraph::evaluateMany(const std::vector<EdgeJob>& jobs,
                                  std::vector<EdgeEvaluation>& results) {
  results.resize(jobs.size());
  const auto begin = Clock::now();
  const auto evaluateOne = [&](std::size_t i) {
    results[i] =
        evaluator_.full(*jobs[i].parent, controls_[static_cast<std::size_t>(jobs[i].control)],
                        jobs[i].parent_clearance);
  };
  if (workers_ && jobs.size() > 1) {
    workers_->run(jobs.size(), evaluateOne);
  } else {
    for (std::size_t i = 0; i < jobs.size(); ++i) evaluateOne(i);
  }
  counters_.evaluation_seconds += secondsSince(begin);
}

EdgeEvaluation PrimitiveGraph::evaluate(const ChainState& parent, int control) {
  const double parent_clearance = clearance(parent.col(0));
  return evaluate(parent, control, parent_clearance);
}

bool PrimitiveGraph::stopHere(StopCondition& stop, long long iterations, double bytes) {
  if (stop.expired(iterations)) return true;
  if (bytes > settings_.memory_limit_mb * 1024.0 * 1024.0) {
    counters_.memory_limited = true;
    return true;
  }
  return false;
}

Statistics PrimitiveGraph::statistics() const {
  const auto value = [](long long count) { return static_cast<double>(count); };
  return {{"expansions", value(counters_.expansions)},
          {"partial_evaluations", value(counters_.partial_evaluations)},
          {"full_evaluations", value(counters_.full_evaluations)},
          {"ahead_evaluations", value(counters_.ahead_evaluations)},
          {"wasted_evaluations", value(counters_.wasted_evaluations)},
          {"certified_edges", value(counters_.certified_edges)},
          {"rejected_edges", value(counters_.rejected_edges)},
          {"esdf_queries", value(counters_.esdf_queries)},
          {"time_evaluation_ms", 1e3 * counters_.evaluation_seconds},
          {"time_search_ms", 1e3 * (counters_.search_seconds - counters_.evaluation_seconds)},
          {"start_heuristic", counters_.start_heuristic}};
}

}  // namespace kinolab
