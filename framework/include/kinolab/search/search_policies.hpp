#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/stop_condition.hpp"
#include "kinolab/primitives/edge_evaluator.hpp"
#include "kinolab/trajectory/trajectory.hpp"

namespace kinolab {

/// The small policies a motion-primitive planner hands the search core: how an edge is
/// evaluated when its parent is expanded, and the heuristic. The core knows no parameter
/// names. Both are plugin kinds (`kinolab list lower_bounds`, `kinolab list heuristics`),
/// chosen by a planner's `lower_bound` and `heuristic` parameters; a new one is a class in a
/// plugin folder or a `--plugin` library (docs/extending/), not a framework edit.

/// What an EdgeEvaluationPolicy's evaluation of a primitive is.
enum class EdgeEstimate : std::uint8_t {
  kFull,        ///< the full evaluation: the edge's true cost (or invalid)
  kLowerBound,  ///< a lower bound of the true cost; the search evaluates fully when popped
  kCertified,   ///< the true cost, proved without full evaluation
};

/// How the search evaluates an edge when its parent is expanded. Eager search evaluates
/// fully; lazy search queues a lower bound and evaluates fully only when the candidate is
/// popped. A lower bound must be at most the full cost of every valid edge, and may call an
/// edge invalid only when full evaluation would (a limit breach, a collision, or leaving the
/// map); then lazy and eager search return the same cost.
class EdgeEvaluationPolicy {
 public:
  virtual ~EdgeEvaluationPolicy() = default;

  /// Evaluates the primitive `control` from `parent` into `evaluation` (its end state,
  /// validity, cost and ESDF queries) and says what that evaluation is.
  /// `parent_clearance` is Esdf::clearance at the parent's position.
  virtual EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent,
                                double parent_clearance, const Eigen::Vector3d& control,
                                EdgeEvaluation& evaluation) const = 0;
  /// True when an evaluation is heavy enough (a full one) for a state's edges to be worth
  /// spreading over threads (SearchSettings::threads); a lower bound of one ESDF query is not:
  /// handing it over costs more than it does.
  virtual bool evaluatesFully() const { return false; }
};

/// Eager: every edge fully evaluated (EdgeEvaluator::full).
class FullEvaluationPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent,
                        double parent_clearance, const Eigen::Vector3d& control,
                        EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.full(parent, control, parent_clearance);
    return EdgeEstimate::kFull;
  }
  bool evaluatesFully() const override { return true; }
};

/// Lazy, the paper's bound: the end sample's collision test and obstacle share
/// (EdgeEvaluator::partial).
class EndpointBoundPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    return EdgeEstimate::kLowerBound;
  }
};

/// Lazy without a map query: time, length and control terms (EdgeEvaluator::controlOnly).
class ControlOnlyBoundPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.controlOnly(parent, control);
    return EdgeEstimate::kLowerBound;
  }
};

/// Lazy with the endpoint bound, and exact when the parent's clearance covers the edge in one
/// sphere-tracing step and the ESDF's Lipschitz bound between the two endpoints keeps it out
/// of the penalty band (EdgeEvaluator::certify).
class LipschitzBoundPolicy final : public EdgeEvaluationPolicy {
 public:
  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent,
                        double parent_clearance, const Eigen::Vector3d& control,
                        EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    return evaluator.certify(parent, parent_clearance, control, evaluation)
               ? EdgeEstimate::kCertified
               : EdgeEstimate::kLowerBound;
  }
};

/// The registry of edge-evaluation policies, kind "lower_bound": built-in `full` (eager),
/// `endpoint` (the paper's), `control_only` and `lipschitz`.
template <>
PluginRegistry<EdgeEvaluationPolicy>& pluginRegistry<EdgeEvaluationPolicy>();

/// A lower bound on the cost from a state to the goal region, consistent with the edge costs:
/// h(s) <= c(s, s') + h(s') for every valid edge. Then the search with weight 1 is optimal, and
/// lazy search returns eager's cost whatever lower bound it queues: a queued entry's priority
/// is at most that of the candidate it becomes, so the first candidate of a state popped is
/// its cheapest (up to ties). The built-in heuristics are consistent even with the weakest
/// bound (control_only); tests/conformance checks every registered one against full costs.
///
/// +infinity is a valid estimate: it says that no path from the state reaches the goal region
/// (the search does not queue such a state). A heuristic that reads the map (its free space)
/// prepares for each query in forQuery(); one that reads the search's control set prepares for
/// it in forControls().
class SearchHeuristic {
 public:
  virtual ~SearchHeuristic() = default;
  /// The estimate from `state` to the goal region around `goal`.
  virtual double estimate(const ChainState& state, const Eigen::Vector3d& goal) const = 0;
  /// The heuristic for one query on `world` towards `goal`, or nullptr (the default) when it
  /// is this one as it is. The search calls it before its first estimate of a query, so what
  /// it computes (e.g. a distance field over the free space) counts as planning time; past
  /// `stop` it may return a weaker (still consistent) heuristic at once. The result may keep
  /// references into `world` (the search holds both) and need not be safe to use from several
  /// threads at once (the built-in `geodesic` grows its field as it is asked).
  virtual std::shared_ptr<const SearchHeuristic> forQuery(const World& world,
                                                          const Eigen::Vector3d& goal,
                                                          StopCondition& stop) const;
  /// The heuristic for a search whose edges are the primitives of `controls` (the planner's
  /// control set, fixed for its searches), or nullptr (the default) when it is this one as it
  /// is. The search calls it once when it is made, before any forQuery(). Throws
  /// InvalidArgument when the heuristic cannot serve that set.
  virtual std::shared_ptr<const SearchHeuristic> forControls(
      const std::vector<Eigen::Vector3d>& controls) const;
};

/// `heuristic`'s forQuery(), or `heuristic` itself when that returns nullptr.
std::shared_ptr<const SearchHeuristic> heuristicForQuery(
    const std::shared_ptr<const SearchHeuristic>& heuristic, const World& world,
    const Eigen::Vector3d& goal, StopCondition& stop);
/// `heuristic`'s forControls(), or `heuristic` itself when that returns nullptr.
std::shared_ptr<const SearchHeuristic> heuristicForControls(
    const std::shared_ptr<const SearchHeuristic>& heuristic,
    const std::vector<Eigen::Vector3d>& controls);

/// The distance from `position` to the goal ball of radius `radius` around `goal` (0 inside).
double ballDistance(const Eigen::Vector3d& position, const Eigen::Vector3d& goal, double radius);

/// w_T |d| / |v_max| + w_L |d|, d the distance to the goal ball.
class EuclideanHeuristic final : public SearchHeuristic {
 public:
  EuclideanHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;

 private:
  double weight_duration_;
  double weight_length_;
  double goal_radius_;
  double inverse_speed_;
};

/// w_T max_i(|d_i| / v_max_i) + w_L |d|, d_i the distance to the goal cube of half-width R
/// on axis i (MPL's minimum-time bound, Liu et al., RA-L 2018). Ignores the state's velocity.
class MinTimeHeuristic final : public SearchHeuristic {
 public:
  MinTimeHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;

 private:
  double weight_duration_;
  double weight_length_;
  double goal_radius_;
  Eigen::Vector3d inverse_v_max_;
};

/// w_T max_i T_i + w_L |d|: T_i is the minimum time for axis i to reach the goal cube's
/// extent [g_i - R, g_i + R] from the state's position and velocity under the velocity and
/// acceleration limits (accelerate at a_max towards it, then cruise at v_max: the time-optimal
/// profile with a free end velocity). For order 3 and 4 the state's acceleration counts too:
/// the acceleration bound ramps from it at the jerk limit (the snap limit relaxed). Each is
/// the exact optimum of a relaxation in which every edge is feasible, so T(s) <= tau + T(s'):
/// consistent. With `whole_primitives`, T is rounded up to whole primitives, tau ceil(T / tau):
/// a path of primitives that ends in the goal region has at least that many (its duration is
/// at least T), and the rounded value still grows by at most tau an edge. Not for searches
/// that end with a goal shot shorter than a primitive (hybrid A*).
class TimeOptimalHeuristic final : public SearchHeuristic {
 public:
  TimeOptimalHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius,
                       bool whole_primitives = false);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;
  /// max_i T_i alone (never rounded), seconds.
  double minimumTime(const ChainState& state, const Eigen::Vector3d& goal) const;

 private:
  bool whole_primitives_;
  double tau_;
  double weight_duration_;
  double weight_length_;
  double goal_radius_;
  Eigen::Vector3d v_max_;
  Eigen::Vector3d a_max_;
  Eigen::Vector3d j_max_;  ///< infinite below order 3
};

/// Fast-Planner's optimal boundary value problem bound (Zhou et al., RA-L 2019) for order 2
/// (acceleration control): min over the duration T > 0 of w_T T + w_U J(T) + w_L |d|, J(T) the
/// least control effort (integral of |u|^2) of the unconstrained double integrator from the
/// state's position and velocity to the goal cube of half-width R at time T, in closed form
/// sum_i 3 e_i(T)^2 / T^3 (e_i the distance of p_i + v_i T to the cube's extent). The
/// minimum over T is exact: on each stretch of T where the set of axes outside the cube is
/// fixed, the stationary points are the real roots of a quartic, solved in closed form
/// (Ferrari). The exact optimum of a relaxation in which every edge is feasible: consistent.
/// Orders above 2 are refused (the control is not the acceleration there).
class ObvpHeuristic final : public SearchHeuristic {
 public:
  ObvpHeuristic(const EdgeEvaluatorSettings& edges, double goal_radius);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;

 private:
  double weight_duration_;
  double weight_control_;
  double weight_length_;
  double goal_radius_;
};

/// An analytic expansion, as hybrid A* tries one (Fast-Planner's computeShotTraj): from a state
/// the search has just closed, a trajectory straight to the goal region. The search accepts the
/// first shot the independent checker accepts (the search's limits, the map's bounds, the body
/// clear of every occupied cube to collision_tolerance, ending in the goal region) and ends
/// with it; the path is then the closed state's followed by the shot, which no longer makes the
/// search optimal. Optional (SearchPolicies::shot); a plugin gives one.
class GoalShot {
 public:
  virtual ~GoalShot() = default;
  /// The shot from `state` towards `goal`, starting at `state` (time 0), or an empty
  /// trajectory when it does not try from here (e.g. too far from the goal).
  virtual Trajectory shoot(const ChainState& state, const Eigen::Vector3d& goal) const = 0;
  /// The shot's cost in the search's terms (added to the closed state's for the path's cost).
  virtual double cost(const Trajectory& shot) const = 0;
};

/// Fast-Planner's shot for acceleration control (order 2): from a state within `reach` of the
/// goal, the double integrator's least-effort cubic to rest at the goal in time T, T the
/// minimiser of w_T T + w_U J(T) (J(T) = 12 |d|^2 / T^3 - 12 d.e / T^2 + 4 |e|^2 / T, with
/// d = goal - p - v T, e = -v, the effort of that cubic), stretched (x1.25, up to 8 times)
/// while its velocity or acceleration breaks a limit. Its cost: w_T T + w_U J(T) + w_L times
/// its length (no obstacle term: the checker decides collisions).
class ObvpShot final : public GoalShot {
 public:
  ObvpShot(const EdgeEvaluatorSettings& edges, double reach);
  Trajectory shoot(const ChainState& state, const Eigen::Vector3d& goal) const override;
  double cost(const Trajectory& shot) const override;

  /// The cubic from `state` to rest at `goal` in time `duration`.
  static TrajectorySegment cubic(const ChainState& state, const Eigen::Vector3d& goal,
                                 double duration);

 private:
  /// w_T T + w_U J(T).
  double objective(const ChainState& state, const Eigen::Vector3d& goal, double t) const;

  CostWeights weights_;
  DynamicLimits limits_;
  double reach_;
};

/// How the search tells states apart (kind "search_space", a motion-primitive planner's
/// `search_space`): states whose keys are equal are one state, closed once. The key is taken
/// relative to the search's start. `lattice` rounds every derivative finely: exact on the
/// lattice a control grid spans, so the search is optimal over it. `cells` keeps one state per
/// position cell and velocity bin, as hybrid A* does (Fast-Planner): far fewer states, no
/// optimality.
class SearchSpace {
 public:
  /// Up to 4 derivatives (position .. jerk) x 3 axes; unused entries 0.
  using Key = std::array<std::int32_t, 12>;
  virtual ~SearchSpace() = default;
  /// The key of `state` (derivatives 0 .. order - 1 meaningful) relative to `start`.
  virtual Key key(const ChainState& state, const ChainState& start, int order) const = 0;
};

template <>
PluginRegistry<SearchSpace>& pluginRegistry<SearchSpace>();

/// Rounds derivative k of each axis, relative to the start, to its resolution (jerk as
/// acceleration).
class LatticeSpace final : public SearchSpace {
 public:
  struct Resolution {
    double position = 0.01;
    double velocity = 0.01;
    double acceleration = 0.01;

    template <typename Fields>
    void fields(Fields& f) {
      f.real("position_resolution", position, 1e-6, 10.0, "position rounding, m");
      f.real("velocity_resolution", velocity, 1e-6, 10.0, "velocity rounding, m/s");
      f.real("acceleration_resolution", acceleration, 1e-6, 100.0,
             "acceleration (and jerk) rounding");
    }
  };
  explicit LatticeSpace(const Resolution& resolution);
  Key key(const ChainState& state, const ChainState& start, int order) const override;

 private:
  std::array<double, 3> inverse_;
};

/// Position cells of `cell_size` and velocity bins of `velocity_resolution` (relative to the
/// start); higher derivatives ignored: hybrid A*'s grid.
class CellSpace final : public SearchSpace {
 public:
  struct Cells {
    double cell_size = 0.2;
    double velocity_resolution = 0.5;

    template <typename Fields>
    void fields(Fields& f) {
      f.real("cell_size", cell_size, 1e-3, 100.0, "position cell side, m");
      f.real("velocity_resolution", velocity_resolution, 0.0, 100.0,
             "velocity bin, m/s (0: position cells only, as Fast-Planner keys its nodes)");
    }
  };
  explicit CellSpace(const Cells& cells);
  Key key(const ChainState& state, const ChainState& start, int order) const override;

 private:
  double inverse_cell_;
  double inverse_velocity_;
};

/// What a heuristic is made for: the planner's edges (dynamics, limits, cost weights) and goal
/// region.
struct HeuristicContext {
  EdgeEvaluatorSettings edges;
  double goal_radius = MotionDefaults::kGoalRadius;
};

/// A registered heuristic (kind "heuristic", `kinolab list heuristics`): its factory reads the
/// heuristic's own parameters, and each planner then makes the heuristic for its edges. A
/// heuristic that cannot serve those edges (obvp above order 2) throws
/// ParameterConflict("heuristic", why), which the planner's configuration reports where the
/// heuristic was chosen.
class HeuristicBuilder {
 public:
  using Make = std::function<std::shared_ptr<const SearchHeuristic>(const HeuristicContext&)>;
  explicit HeuristicBuilder(Make make) : make_(std::move(make)) {}
  std::shared_ptr<const SearchHeuristic> build(const HeuristicContext& context) const {
    return make_(context);
  }

 private:
  Make make_;
};

/// The registry of heuristics: built-in `euclidean`, `min_time`, `time_optimal`, `obvp`, `max`
/// (of any two), `geodesic` and `lattice`.
template <>
PluginRegistry<HeuristicBuilder>& pluginRegistry<HeuristicBuilder>();

/// The largest of several consistent heuristics (itself consistent).
class MaxHeuristic final : public SearchHeuristic {
 public:
  explicit MaxHeuristic(std::vector<std::shared_ptr<const SearchHeuristic>> parts);
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override;
  /// The largest of the parts' heuristics for the query (nullptr when none changes).
  std::shared_ptr<const SearchHeuristic> forQuery(const World& world, const Eigen::Vector3d& goal,
                                                  StopCondition& stop) const override;
  /// The largest of the parts' heuristics for the controls (nullptr when none changes).
  std::shared_ptr<const SearchHeuristic> forControls(
      const std::vector<Eigen::Vector3d>& controls) const override;

 private:
  std::vector<std::shared_ptr<const SearchHeuristic>> parts_;
};

}  // namespace kinolab
