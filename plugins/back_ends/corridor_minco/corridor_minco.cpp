#include "corridor_minco.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>
#include <vector>

#include "corridor.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "minco_problem.hpp"

namespace kinolab::minco {
namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point begin) {
  return std::chrono::duration<double, std::milli>(Clock::now() - begin).count();
}

/// The corridors of a shortcut path, one per segment.
struct Corridors {
  std::vector<Eigen::Vector3d> path;  ///< the shortcut path
  std::vector<Polytope> polytopes;
  CorridorTally tally;
};

/// The initial guess: pieces along each segment at a constant speed.
struct Pieces {
  std::vector<int> corridor_of_piece;
  Eigen::Matrix3Xd waypoints;
  Eigen::VectorXd durations;
};

Pieces initialPieces(const std::vector<Eigen::Vector3d>& path, double piece_length, double speed) {
  Pieces pieces;
  std::vector<Eigen::Vector3d> inner;
  std::vector<double> durations;
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const double length = (path[k + 1] - path[k]).norm();
    const int count = std::max(1, static_cast<int>(std::ceil(length / piece_length)));
    for (int j = 0; j < count; ++j) {
      pieces.corridor_of_piece.push_back(static_cast<int>(k));
      // Half a second at least: a piece of no length (a stop in place) still takes time.
      durations.push_back(std::max(length / count / speed, 0.5));
      if (k + 2 < path.size() || j + 1 < count) {
        const double fraction = static_cast<double>(j + 1) / count;
        inner.push_back(path[k] + fraction * (path[k + 1] - path[k]));
      }
    }
  }
  pieces.waypoints.resize(3, static_cast<Eigen::Index>(inner.size()));
  for (std::size_t i = 0; i < inner.size(); ++i) {
    pieces.waypoints.col(static_cast<Eigen::Index>(i)) = inner[i];
  }
  pieces.durations = Eigen::Map<const Eigen::VectorXd>(durations.data(),
                                                       static_cast<Eigen::Index>(durations.size()));
  return pieces;
}

/// The worst excesses of `x` over its corridors and over the unmargined limits.
Violations trueViolations(MincoProblem& problem, const Eigen::VectorXd& x,
                          const DynamicLimits& limits) {
  const ProblemWeights held = problem.weights();
  problem.weights().max_velocity = limits.bound[1];
  problem.weights().max_acceleration = limits.bound[2];
  const Violations violations = problem.violations(x);
  problem.weights() = held;
  return violations;
}

}  // namespace

void CorridorMinco::setup(std::shared_ptr<const World> world, const Body& body,
                          const PlannerLimits& limits) {
  world_ = std::move(world);
  body_ = body;
  limits_ = limits;
  checker_.emplace(world_, checkerSettings(body_, limits_));
}

namespace {

Corridors buildCorridors(const World& world, const Body& body, const BackEndProblem& problem,
                         double box_half_size) {
  std::vector<Eigen::Vector3d> path = problem.path;
  const Eigen::Vector3d start = problem.start.col(0);
  if ((path.front() - start).norm() > 1e-9) path.insert(path.begin(), start);
  Corridors corridors;
  corridors.path = shortcutPath(world, path, body);
  // A path of one point: the trajectory stops where it is (from a moving start, beyond it).
  if (corridors.path.size() == 1) corridors.path.push_back(corridors.path.front());
  for (std::size_t k = 0; k + 1 < corridors.path.size(); ++k) {
    corridors.polytopes.push_back(corridorAround(world, corridors.path[k], corridors.path[k + 1],
                                                 box_half_size, body.keptRadius(),
                                                 &corridors.tally));
  }
  return corridors;
}

/// Makes the remedy for a failed check, or returns false when none can help.
bool strengthen(ProblemWeights& weights, const std::string& failed_check, double safety_margin,
                double limit_margin) {
  if (failed_check == "collision" || failed_check == "bounds") {
    weights.corridor *= 10.0;
    weights.corridor_margin += safety_margin;
    return true;
  }
  if (failed_check == "limits") {
    weights.velocity *= 10.0;
    weights.acceleration *= 10.0;
    weights.max_velocity *= 1.0 - limit_margin;
    weights.max_acceleration *= 1.0 - limit_margin;
    return true;
  }
  return false;
}

}  // namespace

BackEndResult CorridorMinco::refine(const BackEndProblem& problem, StopCondition& stop) const {
  BackEndResult result;
  if (!world_) throw InvalidArgument("corridor_minco: refine() before setup()");
  if (const std::string bad = backEndInputProblem(problem); !bad.empty()) {
    result.failure = "corridor_minco: " + bad;
    return result;
  }
  const Clock::time_point begin = Clock::now();
  const Corridors corridors = buildCorridors(*world_, body_, problem, settings_.box_half_size);
  const double corridor_ms = millisecondsSince(begin);

  const Eigen::Vector3d& max_velocity = limits_.limits.bound[1];
  const Pieces pieces = initialPieces(corridors.path, settings_.piece_length,
                                      settings_.initial_speed * max_velocity.minCoeff());
  ProblemWeights weights{settings_.weight_time,
                         settings_.weight_corridor,
                         settings_.weight_velocity,
                         settings_.weight_acceleration,
                         settings_.samples,
                         settings_.safety_margin,
                         (1.0 - settings_.limit_margin) * max_velocity,
                         (1.0 - settings_.limit_margin) * limits_.limits.bound[2]};
  MincoProblem minco(settings_.order, problem.start, corridors.path.back(), corridors.polytopes,
                     pieces.corridor_of_piece, weights);
  Eigen::VectorXd x = minco.variables(pieces.waypoints, pieces.durations);
  Eigen::VectorXd gradient;
  const double initial_cost = minco.cost(x, gradient);

  CheckQuery query;
  query.start = problem.start;
  query.goal = corridors.path.back();
  query.goal_radius = limits_.goal_radius;
  Rounds rounds = solve(minco, x, query, stop);
  const Violations violations = trueViolations(minco, x, limits_.limits);
  if (rounds.failure.empty()) {
    result.trajectory = std::move(rounds.trajectory);
  } else {
    result.failure = rounds.failure;
  }
  result.statistics = {
      {"minco_iterations", static_cast<double>(rounds.iterations)},
      {"minco_rounds", rounds.rounds},
      {"minco_stretches", rounds.stretches},
      {"minco_corridors", static_cast<double>(corridors.polytopes.size())},
      {"minco_pieces", minco.pieces()},
      {"minco_halfspaces", corridors.tally.halfspaces},
      {"minco_obstacle_cubes", corridors.tally.obstacles},
      {"minco_corridor_violation", violations.corridor},
      {"minco_velocity_violation", violations.velocity},
      {"minco_acceleration_violation", violations.acceleration},
      {"minco_initial_cost", initial_cost},
      {"minco_final_cost", rounds.final_cost},
      {"minco_time_corridor_ms", corridor_ms},
      {"minco_time_optimise_ms", millisecondsSince(begin) - corridor_ms - rounds.check_ms},
      {"minco_time_check_ms", rounds.check_ms}};
  return result;
}

CorridorMinco::Rounds CorridorMinco::solve(MincoProblem& minco, Eigen::VectorXd& x,
                                           const CheckQuery& query, StopCondition& stop) const {
  Rounds rounds;
  while (rounds.rounds < settings_.max_rounds) {
    ++rounds.rounds;
    const MincoProblem::Outcome outcome = minco.optimise(
        x, settings_.max_iterations, settings_.relative_tolerance, stop, rounds.iterations);
    rounds.iterations += outcome.iterations;
    Eigen::VectorXd gradient;
    rounds.final_cost = minco.cost(x, gradient);
    rounds.trajectory = minco.trajectory(x);
    const Clock::time_point check_begin = Clock::now();
    CheckResult check = backEndSelfCheck(*checker_, *world_, rounds.trajectory, query);
    rounds.check_ms += millisecondsSince(check_begin);
    check = stretchToLimits(minco, x, query, std::move(check), rounds);
    if (check.valid) {
      rounds.failure.clear();
      break;
    }
    rounds.failure = "corridor_minco round " + std::to_string(rounds.rounds) + ": " + check.check +
                     " check at t = " + formatNumber(check.time) + " s: " + check.detail;
    if (outcome.status == 1 && stop.expired(rounds.iterations)) break;  // the budget is spent
    if (!strengthen(minco.weights(), check.check, settings_.safety_margin,
                    settings_.limit_margin)) {
      break;
    }
  }
  return rounds;
}

CheckResult CorridorMinco::stretchToLimits(MincoProblem& minco, Eigen::VectorXd& x,
                                           const CheckQuery& query, CheckResult check,
                                           Rounds& rounds) const {
  for (int attempt = 1; attempt <= kMaxStretches && check.check == "limits"; ++attempt) {
    // A little beyond the factor found, more each time: the check samples more finely.
    const double factor = minco.stretchNeeded(x, limits_.limits) * (1.0 + 1e-4 * attempt);
    const Eigen::VectorXd longer = minco.stretched(x, factor);
    Trajectory trajectory = minco.trajectory(longer);
    const Clock::time_point check_begin = Clock::now();
    CheckResult again = backEndSelfCheck(*checker_, *world_, trajectory, query);
    rounds.check_ms += millisecondsSince(check_begin);
    ++rounds.stretches;
    // A stretch that trades the limit for a collision is not kept: the round's remedy for
    // the limit (heavier limit penalties) is the better next step.
    if (!again.valid && again.check != "limits") break;
    x = longer;
    rounds.trajectory = std::move(trajectory);
    check = std::move(again);
  }
  return check;
}

MetricSpecs corridorMincoStatistics() {
  return MetricSpecs()
      .counter("minco_iterations", "L-BFGS iterations over all rounds")
      .counter("minco_rounds", "solves (a failed check starts another with heavier penalties)")
      .counter("minco_stretches",
               "durations stretched to mend a limit the check found exceeded (all rounds)")
      .counter("minco_corridors", "convex corridors (segments of the shortcut path)")
      .counter("minco_pieces", "polynomial pieces of the trajectory")
      .counter("minco_halfspaces", "obstacle planes over all corridors (beyond their boxes)")
      .counter("minco_obstacle_cubes", "surface voxel cubes the corridors were cut against")
      .real("minco_corridor_violation", "m",
            "largest excess of a penalty sample over its corridor (last round)")
      .real("minco_velocity_violation", "m/s",
            "largest per-axis excess of a penalty sample over the velocity limit")
      .real("minco_acceleration_violation", "m/s^2",
            "largest per-axis excess of a penalty sample over the acceleration limit")
      .real("minco_initial_cost", "", "objective at the initial guess")
      .real("minco_final_cost", "", "objective after the last round")
      .clock("minco_time_corridor_ms", "path shortcut and corridor generation time")
      .clock("minco_time_optimise_ms", "optimisation time")
      .clock("minco_time_check_ms", "the back end's own checks of its trajectories");
}

}  // namespace kinolab::minco

KINOLAB_REGISTER_PLUGINS(registrar) {
  using kinolab::minco::CorridorMinco;
  using kinolab::minco::CorridorMincoSettings;
  registrar.add<kinolab::BackEnd>(
      "corridor_minco",
      "GCOPTER-style: convex corridors around the path, MINCO trajectory optimised in space and "
      "time by L-BFGS (Wang et al., T-RO 2022)",
      kinolab::declareFields<CorridorMincoSettings>(),
      [](const kinolab::ParameterSet& parameters) {
        return std::make_unique<CorridorMinco>(
            kinolab::readFields<CorridorMincoSettings>(parameters));
      },
      kinolab::minco::corridorMincoStatistics());
}
