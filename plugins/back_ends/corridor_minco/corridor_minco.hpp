#pragma once

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include "kinolab/planner/back_end.hpp"
#include "kinolab/validation/trajectory_checker.hpp"

namespace kinolab::minco {

class MincoProblem;

/// The back end's parameters (core/fields.hpp): declared, read and written from this one list.
struct CorridorMincoSettings {
  int order = 3;                     ///< s: 3 minimum jerk, 4 minimum snap
  double weight_time = 2000.0;       ///< rho
  double weight_corridor = 1e6;      ///< corridor penalty weight
  double weight_velocity = 1e4;      ///< velocity penalty weight
  double weight_acceleration = 1e4;  ///< acceleration penalty weight
  double box_half_size = 1.0;        ///< corridor box around its segment, m
  double piece_length = 1.5;         ///< pieces per corridor: its segment's length over this, m
  int samples = 16;                  ///< penalty samples (trapezoid intervals) per piece
  int max_iterations = 200;          ///< L-BFGS iterations per round
  double relative_tolerance = 3e-4;  ///< L-BFGS stops at this relative decrease over 3
  int max_rounds = 3;                ///< solves: after a check fails, again with heavier penalties
  double initial_speed = 0.5;        ///< first time allocation: this share of max_velocity
  double safety_margin = 0.02;       ///< the corridor penalty acts this far inside, m
  double limit_margin = 0.02;        ///< the limit penalties act at this share below the limits
  double budget_share = 0.2;         ///< of a time budget kept for the back end

  template <typename Fields>
  void fields(Fields& f) {
    f.integer("order", order, 3, 4, "MINCO order s: 3 minimum jerk (quintic), 4 minimum snap");
    f.real("weight_time", weight_time, 0.0, 1e6, "rho: cost per second of duration");
    f.real("weight_corridor", weight_corridor, 0.0, 1e9,
           "weight of the cubic penalty on the excess over the corridor");
    f.real("weight_velocity", weight_velocity, 0.0, 1e9,
           "weight of the cubic penalty on the per-axis velocity excess");
    f.real("weight_acceleration", weight_acceleration, 0.0, 1e9,
           "weight of the cubic penalty on the per-axis acceleration excess");
    f.real("box_half_size", box_half_size, 0.1, 100.0,
           "each corridor lies in its segment's box grown by this, m");
    f.real("piece_length", piece_length, 0.1, 100.0,
           "polynomial pieces per corridor: the segment's length over this, rounded up, m");
    f.integer("samples", samples, 2, 1000, "penalty samples per piece");
    f.integer("max_iterations", max_iterations, 1, 100000, "L-BFGS iterations per round");
    f.real("relative_tolerance", relative_tolerance, 0.0, 1.0,
           "L-BFGS stops when the cost fell by less than this share of itself over 3 iterations");
    f.integer("max_rounds", max_rounds, 1, 20,
              "solves: after a collision (a limit), again with 10x the corridor (limit) weights "
              "and a wider margin");
    f.real("initial_speed", initial_speed, 0.05, 1.0,
           "first time allocation: this share of max_velocity along the path");
    f.real("safety_margin", safety_margin, 0.0, 1.0,
           "the corridor penalty acts this far inside the corridor, m");
    f.real("limit_margin", limit_margin, 0.0, 0.5,
           "the velocity and acceleration penalties act this share below the limits");
    f.real("budget_share", budget_share, 0.0, 0.9,
           "share of the time budget kept for the back end (the front end stops at the rest)");
  }
};

/// The corridor MINCO back end (GCOPTER's, Wang et al., "Geometrically Constrained Trajectory
/// Optimization for Multicopters", T-RO 2022): convex corridors around the shortcut front-end
/// path, then a MINCO trajectory through them optimised jointly in space and time with L-BFGS,
/// checked by the independent checker before it is returned.
class CorridorMinco : public BackEnd {
 public:
  explicit CorridorMinco(const CorridorMincoSettings& settings) : settings_(settings) {}

  void setup(std::shared_ptr<const World> world, const Body& body,
             const PlannerLimits& limits) override;
  BackEndResult refine(const BackEndProblem& problem, StopCondition& stop) const override;
  double budgetShare() const override { return settings_.budget_share; }

 private:
  /// What the solves did: the last trajectory and, when it failed the check, why.
  struct Rounds {
    Trajectory trajectory;
    std::string failure;
    long long iterations = 0;
    int rounds = 0;
    int stretches = 0;
    double final_cost = NAN;
    double check_ms = 0.0;
  };
  /// Optimises and checks until the trajectory passes, max_rounds is reached, no remedy
  /// applies or the budget is spent. A limit exceeded is first mended by stretching every
  /// duration (MincoProblem::stretchNeeded, checked again, at most kMaxStretches times); what
  /// that does not mend, and a collision, start another round with heavier penalties.
  Rounds solve(MincoProblem& minco, Eigen::VectorXd& x, const CheckQuery& query,
               StopCondition& stop) const;
  /// Stretches `x` while its check fails on a limit; the last check.
  CheckResult stretchToLimits(MincoProblem& minco, Eigen::VectorXd& x, const CheckQuery& query,
                              CheckResult check, Rounds& rounds) const;
  static constexpr int kMaxStretches = 3;

  std::shared_ptr<const World> world_;
  Body body_;
  PlannerLimits limits_;
  std::optional<TrajectoryChecker> checker_;
  CorridorMincoSettings settings_;
};

/// The statistics refine() reports, declared once.
MetricSpecs corridorMincoStatistics();

}  // namespace kinolab::minco
