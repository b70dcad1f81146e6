// `rrtstar_ceres`: the TGK analogue. OMPL's RRT* plans a geometric path on the ESDF
// (states need the robot radius plus a margin of clearance), OMPL's simplifier shortens it,
// and its back end, `bspline` by default (plugins/back_ends/bspline), turns it into a
// uniform cubic B-spline trajectory with Ceres. `rrtstar` is the same with no back end: the
// path flown stop-and-go (for ablations). `ompl_geometric` runs OMPL's geometric planners
// by name with any back end.
#include <cmath>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/trajectory/uniform_bspline.hpp"
#include "ompl_control.hpp"
#include "rrt_front_end.hpp"

namespace kinolab::rrt {
namespace {

/// What the planner adds to the front end's fields.
struct RrtChecks {
  double clearance_margin = 0.1;   ///< m beyond the body radius
  double motion_resolution = 0.5;  ///< voxels between checked states of a motion
  long long max_iterations = 0;    ///< 0: none

  template <typename Fields>
  void fields(Fields& f) {
    f.real("clearance_margin", clearance_margin, 0.0, 10.0,
           "RRT* states need the radius plus this much clearance, m");
    f.real("motion_resolution", motion_resolution, 0.05, 10.0,
           "RRT* motions are checked every this many voxels");
    f.integer("max_iterations", max_iterations, 0, 1000000000, "RRT* iteration budget (0: none)");
  }
};

ParameterSpecs frontEndParameters(double time_limit, const std::string& back_end) {
  return declareFields<FrontEndSettings>()
      .include(motionParameters(time_limit, back_end))
      .include(declareFields<RrtChecks>());
}

/// ompl_geometric's choices: which OMPL planner.
struct GeometricChoice {
  OmplPlanner planner = OmplPlanner::kBitStar;
  bool stop_at_first = false;

  template <typename Fields>
  void fields(Fields& f) {
    f.choice("planner", planner,
             {{"rrtconnect", OmplPlanner::kRrtConnect},
              {"rrtstar", OmplPlanner::kRrtStar},
              {"informed_rrtstar", OmplPlanner::kInformedRrtStar},
              {"bitstar", OmplPlanner::kBitStar},
              {"abitstar", OmplPlanner::kAbitStar},
              {"aitstar", OmplPlanner::kAitStar},
              {"lazyprmstar", OmplPlanner::kLazyPrmStar}},
             "OMPL's geometric planner (rrtstar: kinolab's seeded RRT* loop, as rrtstar and "
             "rrtstar_ceres)");
    f.boolean("stop_at_first", stop_at_first,
              "stop at the first exact solution (else refine to the budget; not rrtstar)");
  }
};

ParameterSpecs geometricParameters() {
  return declareFields<GeometricChoice>().include(frontEndParameters(1.0, "none"));
}

MetricSpecs frontEndStatistics() {
  MetricSpecs specs;
  specs.clock("time_simplify_ms", "OMPL path simplification")
      .counter("path_vertices_raw", "RRT* path vertices before simplification")
      .real("path_length_raw", "m", "RRT* path length before simplification")
      .counter("path_vertices", "path vertices after simplification")
      .real("path_length", "m", "path length after simplification")
      .counter("iterations", "RRT* iterations")
      .counter("tree_size", "RRT* tree vertices")
      .counter("collision_checks", "state validity checks (ESDF clearance)")
      .counter("motion_checks", "motion validity checks")
      .counter("motion_checks_invalid", "motion checks that found a collision")
      .counter("first_solution_iteration", "iteration of the first exact solution")
      .clock("first_solution_ms", "time to the first exact solution")
      .real("first_solution_cost", "m", "path length of the first exact solution")
      .real("best_cost", "m", "RRT*'s best path length")
      .clock("time_rrt_ms", "RRT* time (rrtstar, rrtstar_ceres)")
      .clock("time_ompl_ms", "the OMPL planner's own time (ompl_geometric other than rrtstar)");
  specs.series("anytime_cost", "m",
               "RRT*'s best path length over its planning time (a sample at every "
               "improvement)");
  return specs;
}

class RrtStarPlanner final : public Planner {
 public:
  explicit RrtStarPlanner(const ParameterSet& parameters,
                          OmplPlanner planner = OmplPlanner::kRrtStar, bool stop_at_first = false)
      : front_end_settings_(readFields<FrontEndSettings>(parameters)),
        checks_(readFields<RrtChecks>(parameters)),
        limits_(plannerLimitsFrom(parameters)),
        budget_(timeBudgetFrom(parameters)) {
    if (checks_.max_iterations > 0) budget_.max_iterations = checks_.max_iterations;
    front_end_settings_.goal_radius = limits_.goal_radius;
    front_end_settings_.planner = planner;
    front_end_settings_.stop_at_first = stop_at_first;
    // RRT*'s loop stops at its vertex cap; the others only at the budget.
    if (planner != OmplPlanner::kRrtStar && !std::isfinite(budget_.time_limit) &&
        checks_.max_iterations <= 0) {
      throw ConfigError(
          "ompl_geometric: time_limit 0 (none) needs max_iterations > 0: this planner stops "
          "only at its budget");
    }
  }

 protected:
  void doSetup(const PlannerContext& context) override {
    FrontEndSettings settings = front_end_settings_;
    settings.clearance = body().radius + checks_.clearance_margin;
    settings.motion_resolution = checks_.motion_resolution * context.world->esdf().resolution();
    // A sparse world's truncated distances would read as the clearance: refused at setup.
    context.world->requireExactDistancesTo(
        settings.clearance,
        "the OMPL front end (its states keep robot_radius + clearance_margin clear)");
    front_end_ = std::make_unique<RrtFrontEnd>(context.world, settings);
    clearance_ = settings.clearance;
    seed_ = context.seed;
  }

  PlanResult doPlan(const PlanningQuery& query, StopCondition& stop) override {
    PlanResult result;
    const Eigen::Vector3d start = query.start.col(0);
    const bool at_rest = query.start.col(1).isZero() && query.start.col(2).isZero();
    if (!refinesFrontEnd() && !at_rest) {
      result.status = PlanStatus::kInvalidStart;
      result.message =
          "with back_end none the path is flown stop-and-go, so it starts at rest (choose a "
          "back end, e.g. back_end=bspline, for a moving start)";
      return result;
    }
    // The run's seed and the query decide OMPL's random streams: the same case repeats.
    std::uint64_t seed = hashBytes(query.goal.data(), 3 * sizeof(double), seed_);
    seed = hashBytes(query.start.data(), sizeof(ChainState), seed);
    FrontEndResult path = front_end_->plan(start, query.goal, seed, stop);
    result.statistics = std::move(path.statistics);
    result.progress = std::move(path.progress);
    if (path.outcome == FrontEndResult::Outcome::kNone) {
      result.status = PlanStatus::kTimeout;
      result.message = "no path after " + std::to_string(path.iterations) + " iterations";
      return result;
    }
    result.status = path.outcome == FrontEndResult::Outcome::kExact ? PlanStatus::kExact
                                                                    : PlanStatus::kApproximate;
    if (result.status == PlanStatus::kApproximate) {
      result.message = "budget spent after " + std::to_string(path.iterations) +
                       " iterations: the path to the vertex closest to the goal";
    }
    // A path of length 0 (the start is in the goal region) leaves nothing to fly. From a
    // moving start there is only the path: the back end makes the trajectory.
    if (path.path_length > 0.0) {
      result.path = std::move(path.path);
      if (at_rest) result.trajectory = stopAndGo(result.path, limits_.limits);
    }
    result.cost = result.trajectory.empty() ? path.path_length : result.trajectory.length();
    return result;
  }

  SearchTree doTree(std::size_t max_edges) const override {
    return front_end_ ? front_end_->tree(max_edges) : SearchTree{};
  }

  PlannerLimits plannerLimits() const override { return limits_; }

  Budget ownBudget() const override { return budget_; }
  /// The cost is the trajectory's length, whichever front and back end made it.
  std::string costObjective() const override { return "trajectory length"; }
  std::string stateProblem(const Eigen::Vector3d& position) const override {
    const double clearance = world().clearance(position);
    if (clearance >= clearance_) return "";
    return "clearance " + formatNumber(clearance) +
           " m is below robot_radius + clearance_margin = " + formatNumber(clearance_) +
           " m, which every RRT* state needs";
  }

 private:
  FrontEndSettings front_end_settings_;
  RrtChecks checks_;
  PlannerLimits limits_;
  Budget budget_;
  std::uint64_t seed_ = 0;
  double clearance_ = 0.0;
  std::unique_ptr<RrtFrontEnd> front_end_;
};

}  // namespace
}  // namespace kinolab::rrt

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.library("ompl", rrt::omplVersion());
  const auto rrtStar = [](const ParameterSet& parameters) {
    return std::make_unique<rrt::RrtStarPlanner>(parameters);
  };
  registrar.add<Planner>(
      "rrtstar_ceres",
      "TGK analogue: OMPL RRT* path, then the bspline back end by default (Ceres uniform cubic "
      "B-spline: jerk, ESDF, limits)",
      rrt::frontEndParameters(5.0, "bspline"), rrtStar, rrt::frontEndStatistics());
  registrar.add<Planner>(
      "rrtstar",
      "OMPL RRT* path, no back end by default: flown stop-and-go at the limits (ablation of the "
      "smoother)",
      rrt::frontEndParameters(5.0, "none"), rrtStar, rrt::frontEndStatistics());
  registrar.add<Planner>(
      "ompl_geometric",
      "OMPL's geometric planners by name (RRT-Connect, RRT*, Informed RRT*, BIT*, ABIT*, AIT*, "
      "LazyPRM*) on the ESDF, with any back end",
      rrt::geometricParameters(),
      [](const ParameterSet& parameters) {
        const auto choice = readFields<rrt::GeometricChoice>(parameters);
        if (choice.planner == rrt::OmplPlanner::kAitStar) {
          throw ConfigError(
              "ompl_geometric: planner 'aitstar' is refused: the AIT* of OMPL " +
              rrt::omplVersion() +
              " aborts the whole process on an internal assertion (AITstar.cpp:810, "
              "performForwardSearchIteration) on 2 of 4 forest queries tried; use bitstar or "
              "abitstar (OMPL 1.6 rewrote AIT*)");
        }
        return std::make_unique<rrt::RrtStarPlanner>(parameters, choice.planner,
                                                     choice.stop_at_first);
      },
      rrt::frontEndStatistics());
  registrar.add<Planner>(
      "ompl_control",
      "OMPL's kinodynamic planners by name (SST, KPIECE1, RRT, EST, PDST) over the integrator "
      "chain, exact propagation",
      rrt::omplControlParameters(), &rrt::makeOmplControl, rrt::omplControlStatistics());
}
