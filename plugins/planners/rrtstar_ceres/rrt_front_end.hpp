#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "kinolab/core/stop_condition.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world.hpp"

namespace ompl::base {
class ProblemDefinition;
}  // namespace ompl::base
namespace ompl::geometric {
class PathGeometric;
}  // namespace ompl::geometric

namespace kinolab::rrt {

/// The OMPL geometric planners the front end runs (ompl_geometric's `planner`).
enum class OmplPlanner {
  kRrtConnect,
  kRrtStar,
  kInformedRrtStar,
  kBitStar,
  kAbitStar,
  kAitStar,
  kLazyPrmStar
};

/// The geometric front end: an OMPL planner in the world's bounds (OMPL stays inside the .cpp).
struct FrontEndSettings {
  /// RRT* (rrtstar, rrtstar_ceres) runs its own loop: refinement iterations, vertex cap. The
  /// others run to the budget (or their first solution, with stop_at_first). Every random
  /// stream of every planner comes from the plan's seed (plan_seeds.hpp): a plan that ends by
  /// work (iterations, first solution, vertex cap), not by the clock, repeats bit for bit.
  OmplPlanner planner = OmplPlanner::kRrtStar;
  bool stop_at_first = false;
  double range = 1.5;          ///< longest tree edge, m (0: OMPL's choice, 20 % of the extent)
  double goal_bias = 0.05;     ///< probability of sampling the goal
  double rewire_factor = 1.1;  ///< scales RRT*'s rewiring radius or k
  bool k_nearest = true;       ///< rewire over k nearest (else a radius)
  bool delay_collision_checking = true;
  bool simplify = true;                ///< OMPL's vertex reduction and shortcutting afterwards
  long long refine_iterations = 1000;  ///< iterations after the first exact solution
  /// Tree vertices at most: the search stops there as on a budget, so that no run, not even
  /// one without a time limit towards an unreachable goal, exhausts the machine.
  long long max_vertices = 500000;
  // Set by the planner from its body, world and goal region (not parameters):
  double clearance = 0.35;          ///< a valid state's ESDF value: body radius + margin, m
  double motion_resolution = 0.05;  ///< spacing of checked states along a motion, m
  double goal_radius = 0.5;

  /// Its parameters (core/fields.hpp).
  template <typename Fields>
  void fields(Fields& f) {
    f.real("range", range, 0.0, 1000.0,
           "longest RRT* edge, m (0: OMPL's default, 20 % of the map's extent)");
    f.real("goal_bias", goal_bias, 0.0, 1.0, "probability of sampling the goal");
    f.real("rewire_factor", rewire_factor, 1.0, 10.0, "scales RRT*'s rewiring neighbourhood");
    f.boolean("k_nearest", k_nearest, "rewire over the k nearest vertices (else within a radius)");
    f.boolean("delay_collision_checking", delay_collision_checking,
              "check a neighbour's edge only when it would win");
    f.boolean("simplify", simplify, "OMPL's vertex reduction and shortcutting of the path");
    f.integer("refine_iterations", refine_iterations, 0, 1000000000,
              "RRT* iterations after the first solution (0: stop at the first)");
    f.integer("max_vertices", max_vertices, 100, 100000000,
              "RRT* tree size budget: the search stops there (bounds its memory)");
  }
};

struct FrontEndResult {
  enum class Outcome { kExact, kApproximate, kNone };
  Outcome outcome = Outcome::kNone;
  std::vector<Eigen::Vector3d> path;  ///< start .. end, every motion collision-checked
  double path_length = 0.0;
  long long iterations = 0;
  Statistics statistics;
  /// The anytime progress: the `anytime_cost` series, a sample at every improvement.
  Progress progress;
};

class RrtFrontEnd {
 public:
  RrtFrontEnd(std::shared_ptr<const World> world, const FrontEndSettings& settings);
  ~RrtFrontEnd();
  RrtFrontEnd(const RrtFrontEnd&) = delete;
  RrtFrontEnd& operator=(const RrtFrontEnd&) = delete;

  /// One run of the planner from `start` towards the goal ball, every random stream from
  /// `seed`: the same seed and a work budget give the same path, whatever ran before.
  FrontEndResult plan(const Eigen::Vector3d& start, const Eigen::Vector3d& goal, std::uint64_t seed,
                      StopCondition& stop);
  /// The last plan's final tree: at most `max_edges` edges, decimated evenly beyond that.
  SearchTree tree(std::size_t max_edges) const;

 private:
  struct Ompl;
  /// Any planner but RRT*, to its budget.
  FrontEndResult planOther(const std::shared_ptr<ompl::base::ProblemDefinition>& problem,
                           StopCondition& stop);
  /// Counters of the validity checks into `result` (every planner).
  void countChecks(FrontEndResult& result) const;
  std::shared_ptr<ompl::base::ProblemDefinition> problem(const Eigen::Vector3d& start,
                                                         const Eigen::Vector3d& goal) const;
  /// Simplifies the found path (when the settings say so) into `result`'s path, with the
  /// path statistics.
  void simplify(ompl::geometric::PathGeometric& path, FrontEndResult& result) const;

  std::unique_ptr<Ompl> ompl_;
};

/// The OMPL release this plugin was built against ("1.5.2"), for provenance.
std::string omplVersion();

}  // namespace kinolab::rrt
