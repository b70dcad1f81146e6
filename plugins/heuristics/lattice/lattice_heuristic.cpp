// The heuristic kind `lattice`: the exact cost to the goal of the control set's own lattice with
// no obstacles, the three axes moving together (as hybrid A*'s "non-holonomic without
// obstacles" heuristic is the exact cost of its car in free space), by max with time_optimal
// in whole primitives.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/search_policies.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {
namespace {

/// Within this (in steps, relative beyond one) a state's offset or velocity counts as a whole
/// number of steps.
constexpr double kOnLattice = 1e-6;

/// True when `steps` is a whole number, to kOnLattice.
bool wholeSteps(double steps) {
  return std::abs(steps - std::round(steps)) <= kOnLattice * std::max(1.0, std::abs(steps));
}
/// At most this many table entries a query (8 bytes each: 256 MiB).
constexpr double kMaxEntries = 1 << 25;

/// One axis of an order-2 control set: every control's value on the axis is a whole multiple
/// of `step`; `moves` are those multiples (each once).
struct AxisControls {
  double step = 1.0;
  std::vector<int> moves;
};

/// The axis's values of `controls` as multiples of one step (the largest step that makes each a
/// whole number, the smallest non-zero value over n for n = 1..64); throws InvalidArgument when
/// there is none (e.g. a random control set).
AxisControls axisControls(const std::vector<Eigen::Vector3d>& controls, int axis) {
  double smallest = INFINITY;
  for (const auto& control : controls) {
    if (control[axis] != 0.0) smallest = std::min(smallest, std::abs(control[axis]));
  }
  AxisControls result;
  if (!std::isfinite(smallest)) {  // no control moves along this axis
    result.moves = {0};
    return result;
  }
  for (int n = 1; n <= 64; ++n) {
    const double step = smallest / n;
    bool whole = true;
    std::vector<int> moves;
    for (const auto& control : controls) {
      const double steps = control[axis] / step;
      const double rounded = std::round(steps);
      if (std::abs(steps - rounded) > kOnLattice) {  // (absolute: a control is a grid's exactly)
        whole = false;
        break;
      }
      moves.push_back(static_cast<int>(rounded));
    }
    if (!whole) continue;
    std::sort(moves.begin(), moves.end());
    moves.erase(std::unique(moves.begin(), moves.end()), moves.end());
    result.step = step;
    result.moves = std::move(moves);
    return result;
  }
  throw InvalidArgument(std::string("lattice needs a control grid: the controls' ") + "xyz"[axis] +
                        " values are not whole multiples of one step, as a uniform sampler's "
                        "are; use time_optimal with this control set, or heuristic.fallback=true");
}

/// What one axis's cost counts: a primitive's duration tau at w_T per second, and the axis's
/// share w_U u^2 tau of the control effort; the goal interval [-R, R] (the goal ball's extent
/// on the axis) and the velocity limit.
struct AxisCosts {
  double tau = 0.0;
  double weight_duration = 0.0;
  double weight_control = 0.0;
  double goal_radius = 0.0;
  double max_velocity = 0.0;
};

/// The lattice's position step w = q tau^2 / 2 on an axis.
double latticeStep(const AxisControls& controls, const AxisCosts& costs) {
  return 0.5 * controls.step * costs.tau * costs.tau;
}

/// One axis's lattice, with no obstacles: for every state and every number N of primitives up
/// to a horizon, the least control effort of the axis (w_U u^2 tau a primitive) over exactly N
/// primitives that end with the axis's offset to the goal in [-R, R], within its velocity limit.
///
/// The lattice: with controls u = q m (m whole) and a velocity v = v_0 + q tau j (j whole), a
/// primitive moves the axis by v tau + u tau^2 / 2 = v_0 tau + w (2 j + m), w = q tau^2 / 2, and
/// ends at velocity v_0 + q tau (j + m). Every state a search reaches has the velocity of the
/// start plus whole steps, so v_0 is the start's velocity, or 0 when that is a whole number of
/// steps (a start at rest). The table holds a row per (cell, j) for every offset within the
/// world (a state cannot leave the world, so neither can its axis), filled N by N from
/// the cells that meet [-R, R] (N = 0).
/// - v_0 = 0 (exact): every state's offset is (c + phase) w for whole c, phase that of the
///   start: the cells are those points, and a primitive goes from cell c to c + 2 j + m.
/// - v_0 != 0 (a moving start): the offsets drift by v_0 tau a primitive, not a whole number of
///   cells; the cells are K to a w (subCells()), a state is in the cell its offset falls in, and
///   a primitive goes from cell c to one of c + K (2 j + m) + floor(d) + {-1, 0, 1, 2}, d = v_0
///   tau over the cell's width (the one its end falls in, whatever rounding moved either end
///   across a border): a relaxation whose cost is a lower bound, its path gaining at most two
///   cells a primitive over the real one.
class AxisTable {
 public:
  /// The cells a w is cut into under a drifting lattice: up to 16, none narrower than a 64th
  /// of the way a primitive goes at full speed (so that the relaxation gains at most 1/32 of
  /// that a primitive, and a fine lattice's tables stay small).
  static int subCells(const AxisControls& controls, const AxisCosts& costs) {
    const double finest = costs.max_velocity * costs.tau / 64.0;
    return static_cast<int>(
        std::clamp(std::floor(latticeStep(controls, costs) / finest), 1.0, 16.0));
  }

  /// The cells a w takes in the table of a start at `start_velocity`: 1 when that is a whole
  /// number of velocity steps (the table is exact), else subCells().
  static int cellsPerStep(const AxisControls& controls, const AxisCosts& costs,
                          double start_velocity) {
    return wholeSteps(start_velocity / (controls.step * costs.tau)) ? 1 : subCells(controls, costs);
  }

  AxisTable(const AxisControls& controls, const AxisCosts& costs, double low, double high,
            int horizon, double start_offset, double start_velocity)
      : unit_velocity_(controls.step * costs.tau), horizon_(horizon) {
    // (A drifting lattice may be cut into one cell a w too: exact is the start's velocity.)
    exact_ = wholeSteps(start_velocity / unit_velocity_);
    Moves moves{&controls, {}, {0}, cellsPerStep(controls, costs, start_velocity)};
    cell_ = latticeStep(controls, costs) / moves.sub;
    // The cells a primitive's end may lie beyond its move: none, or the drift's four.
    if (exact_) {
      phase_ = start_offset / cell_ - std::floor(start_offset / cell_);
    } else {
      velocity_origin_ = start_velocity;
      const auto drift = static_cast<long long>(std::floor(start_velocity * costs.tau / cell_));
      moves.shifts = {drift - 1, drift, drift + 1, drift + 2};
    }
    for (const int m : controls.moves) {
      const double u = controls.step * m;
      moves.effort.push_back(costs.weight_control * u * u * costs.tau);
    }
    layOut(costs, low, high);
    fillAlone(moves, costs.weight_duration * costs.tau);
    moves_ = std::move(moves);
  }

  static constexpr int kNever = std::numeric_limits<int>::max();

  /// The row of the state at the axis's offset to the goal and velocity; -1 when they are not
  /// on this table's lattice (or outside it).
  long long row(double offset, double velocity) const {
    const double step = (velocity - velocity_origin_) / unit_velocity_;
    if (!wholeSteps(step)) return -1;
    const double j = std::round(step);
    double c = 0.0;
    if (exact_) {
      const double cell = offset / cell_ - phase_;
      if (!wholeSteps(cell)) return -1;
      c = std::round(cell);
    } else {
      c = std::floor(offset / cell_);
    }
    const double r = c - static_cast<double>(first_cell_);
    if (!(r >= 0.0 && r < static_cast<double>(cells_) && j >= lowest_ && j < lowest_ + width_)) {
      return -1;
    }
    return static_cast<long long>(r) * width_ + static_cast<long long>(j) - lowest_;
  }
  /// The least number of primitives (up to the horizon) that brings the row's state to the
  /// goal interval; kNever when none does.
  int first(long long row) const {
    const auto state = static_cast<std::size_t>(row);
    while (first_[state] == kNever && filled_ < horizon_) addLayer();
    return first_[state];
  }
  /// The least effort of exactly n primitives (n <= horizon) from the row's state.
  double effort(int n, long long row) const {
    while (filled_ < n) addLayer();
    return effort_[static_cast<std::size_t>(n) * static_cast<std::size_t>(cells_ * width_) +
                   static_cast<std::size_t>(row)];
  }
  int horizon() const { return horizon_; }
  /// The least cost of any number of primitives, w_T tau each plus the axis's effort, from the
  /// row's state: the axis's cost moving alone (+infinity: it never meets the goal interval).
  double alone(long long row) const { return alone_[static_cast<std::size_t>(row)]; }

  /// About the rows (states) of the table of an axis whose offsets to the goal lie in
  /// [low, high], from a start at `start_velocity` (at least the constructor's, less one
  /// cell): what a query's tables are budgeted by.
  static double rows(const AxisControls& controls, const AxisCosts& costs, double low, double high,
                     double start_velocity) {
    const double cell =
        latticeStep(controls, costs) / cellsPerStep(controls, costs, start_velocity);
    const double velocities =
        std::floor(costs.max_velocity / (controls.step * costs.tau) * (1.0 + 1e-9));
    return (std::ceil((high - low) / cell) + 4.0) * (2.0 * velocities + 2.0);
  }

 private:
  /// The moves of an axis's controls: their control effort, the cells a primitive's end may
  /// lie beyond its move (`shifts`), and the cells a velocity step takes (`sub`).
  struct Moves {
    const AxisControls* controls = nullptr;
    std::vector<double> effort;
    std::vector<long long> shifts;
    int sub = 1;
    /// The move in cells of control m from velocity step j: sub (2 j + m) (and a shift).
    long long move(int j, int m) const { return static_cast<long long>(sub) * (2 * j + m); }
  };

  /// The table's cells and velocities over [low, high], every layer +infinity but for the
  /// states inside the goal interval (0 from layer 0 on).
  void layOut(const AxisCosts& costs, double low, double high) {
    const double limit = costs.max_velocity * (1.0 + 1e-9) + 1e-12;
    lowest_ = static_cast<int>(std::ceil((-limit - velocity_origin_) / unit_velocity_));
    const int highest = static_cast<int>(std::floor((limit - velocity_origin_) / unit_velocity_));
    width_ = std::max(highest - lowest_ + 1, 0);
    first_cell_ = static_cast<long long>(std::floor(low / cell_ - phase_)) - 1;
    cells_ = static_cast<long long>(std::ceil(high / cell_ - phase_)) + 2 - first_cell_;
    const auto states = static_cast<std::size_t>(cells_ * width_);
    // Layer 0 now, the others as estimates first need them (addLayer()).
    effort_.reserve(states * static_cast<std::size_t>(horizon_ + 1));
    effort_.assign(states, INFINITY);
    first_.assign(states, kNever);
    const double reach = costs.goal_radius * (1.0 + 1e-9) + 1e-12;
    for (long long c = 0; c < cells_; ++c) {
      // The lattice point (exact) or the lower end of the cell (a moving start).
      const double edge = (static_cast<double>(c + first_cell_) + phase_) * cell_;
      // A point of the lattice inside [-R, R] (exact), or a cell meeting it.
      if (exact_ ? std::abs(edge) > reach : (edge > reach || edge + cell_ < -reach)) continue;
      for (int j = 0; j < width_; ++j) {
        effort_[static_cast<std::size_t>(c * width_ + j)] = 0.0;
        first_[static_cast<std::size_t>(c * width_ + j)] = 0;
      }
    }
  }

  /// The least cost in any number of primitives, time (`step_cost` each) included: a
  /// backward Dijkstra from the goal interval; +infinity where the axis never meets it.
  void fillAlone(const Moves& moves, double step_cost) {
    const auto states = static_cast<std::size_t>(cells_ * width_);
    alone_.assign(states, INFINITY);
    using Entry = std::pair<double, std::size_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
    for (std::size_t state = 0; state < states; ++state) {
      if (first_[state] != 0) continue;
      alone_[state] = 0.0;
      open.emplace(0.0, state);
    }
    while (!open.empty()) {
      const auto [value, state] = open.top();
      open.pop();
      if (value > alone_[state]) continue;
      const auto c_after = static_cast<long long>(state) / width_;
      const int j_after = static_cast<int>(static_cast<long long>(state) % width_) + lowest_;
      for (std::size_t k = 0; k < moves.controls->moves.size(); ++k) {
        const int m = moves.controls->moves[k];
        const int j = j_after - m;
        if (j < lowest_ || j >= lowest_ + width_) continue;
        const double candidate = value + step_cost + moves.effort[k];
        for (const long long shift : moves.shifts) {
          const long long c = c_after - moves.move(j, m) - shift;
          if (c < 0 || c >= cells_) continue;
          const auto before = static_cast<std::size_t>(c * width_ + j - lowest_);
          if (candidate < alone_[before]) {
            alone_[before] = candidate;
            open.emplace(candidate, before);
          }
        }
      }
    }
  }

  /// The next layer from the one before (the tables hold the layers estimates have needed so
  /// far: a query near its goal fills few of the horizon's). The shifts are consecutive, so a
  /// primitive reads the least of that layer over a window of cells: least[s + window - 1] is
  /// it for the window starting at cell s (made for every window that meets the table).
  void addLayer() const {
    const Moves& moves = moves_;
    const auto states = static_cast<std::size_t>(cells_ * width_);
    const long long lowest_shift = moves.shifts.front();
    const auto window = static_cast<long long>(moves.shifts.size());
    const long long starts = cells_ + window - 1;
    least_.resize(static_cast<std::size_t>(starts * width_));
    const int n = filled_ + 1;
    effort_.resize(static_cast<std::size_t>(n + 1) * states);  // within the reserve
    const double* before = &effort_[static_cast<std::size_t>(n - 1) * states];
    double* now = &effort_[static_cast<std::size_t>(n) * states];
    for (long long i = 0; i < starts; ++i) {
      const long long from = std::max(i - (window - 1), 0LL);
      const long long to = std::min(i + 1, cells_);
      for (int j = 0; j < width_; ++j) {
        double value = INFINITY;
        for (long long t = from; t < to; ++t) value = std::min(value, before[t * width_ + j]);
        least_[static_cast<std::size_t>(i * width_ + j)] = value;
      }
    }
    for (long long c = 0; c < cells_; ++c) {
      for (int j = lowest_; j < lowest_ + width_; ++j) {
        double best = INFINITY;
        for (std::size_t k = 0; k < moves.controls->moves.size(); ++k) {
          const int m = moves.controls->moves[k];
          const int j_after = j + m;
          const long long start = c + moves.move(j, m) + lowest_shift;
          if (j_after < lowest_ || j_after >= lowest_ + width_ || start + window <= 0 ||
              start >= cells_) {
            continue;
          }
          const auto i = static_cast<std::size_t>(start + window - 1);
          best = std::min(best, moves.effort[k] + least_[i * width_ + j_after - lowest_]);
        }
        const auto state = static_cast<std::size_t>(c * width_ + j - lowest_);
        now[state] = best;
        if (best < INFINITY && first_[state] == kNever) first_[state] = n;
      }
    }
    filled_ = n;
  }

  double unit_velocity_;  ///< q tau
  int horizon_;
  bool exact_ = true;             ///< v_0 = 0: the cells are the lattice's points
  double velocity_origin_ = 0.0;  ///< v_0
  double cell_ = 0.0;             ///< the cells' width
  double phase_ = 0.0;            ///< (exact) the start's offset over w, less its floor
  int lowest_ = 0;                ///< the least j within the velocity limit
  int width_ = 1;                 ///< js within it
  long long first_cell_ = 0;      ///< the first row's cell
  long long cells_ = 0;           ///< cells
  Moves moves_;
  /// Per n (layers 0 to filled_), per (c, j), j fastest; +infinity: not in n.
  mutable std::vector<double> effort_;
  mutable std::vector<int> first_;     ///< per (c, j): the least n (of those filled) with an effort
  mutable std::vector<double> least_;  ///< addLayer()'s windows
  mutable int filled_ = 0;
  std::vector<double> alone_;  ///< per (c, j): alone()
};

/// One query's heuristic: the exact cost, with no obstacles, of the axes moving together on the
/// lattice, min over N of N w_T tau + sum_i E_i(N) (E_i the axis's least effort in exactly N
/// primitives; every axis must be in its goal interval at the same primitive), at most
/// (H + 1) w_T tau beyond the tables' horizon H; at least the largest axis's cost moving alone
/// (+infinity when an axis never meets its goal interval); plus w_L times the distance to the
/// goal ball; by max with time_optimal in whole primitives. Consistent: an edge of cost c from s
/// to s' has every axis's effort e_i, so the N-primitive sum at s is at most c plus the
/// (N - 1)-primitive one at s' (and a value capped at (H + 1) w_T tau, or reached at N = H,
/// is at most w_T tau more than the cap or H w_T tau at s'). The tables are made at the first
/// estimate, for the lattice of that state (the start): exact on an axis where it moves at a
/// whole number of velocity steps, a relaxation on finer cells where it does not (AxisTable);
/// their layers (numbers of primitives) are filled as estimates first need them, so a query
/// whose states reach the goal in few primitives fills few (the same values either way).
/// (Not safe to call from several threads at once.)
class LatticeQueryHeuristic final : public SearchHeuristic {
 public:
  LatticeQueryHeuristic(std::shared_ptr<const SearchHeuristic> fallback,
                        std::array<AxisControls, 3> axes, std::array<AxisCosts, 3> costs,
                        double weight_length, Eigen::Vector3d low, Eigen::Vector3d high,
                        int horizon)
      : fallback_(std::move(fallback)),
        axes_(std::move(axes)),
        costs_(costs),
        weight_length_(weight_length),
        low_(std::move(low)),
        high_(std::move(high)),
        horizon_(horizon) {}

  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    const double base = fallback_->estimate(state, goal);
    if (!prepared_) prepare(state, goal);
    if (tables_.empty()) return base;
    std::array<long long, 3> rows{};
    int first = 0;
    double alone = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      rows[axis] = tables_[axis].row(state(axis, 0) - goal[axis], state(axis, 1));
      // Off the start's lattice (no state a search of these controls reaches): time_optimal.
      if (rows[axis] < 0) return base;
      first = std::max(first, tables_[axis].first(rows[axis]));
      alone = std::max(alone, tables_[axis].alone(rows[axis]));
    }
    if (alone == INFINITY) return INFINITY;  // an axis never meets its goal interval
    const double step = costs_[0].weight_duration * costs_[0].tau;
    const int horizon = tables_[0].horizon();
    double best = (horizon + 1) * step;  // more primitives than the tables hold
    for (int n = first; n <= horizon && n * step < best; ++n) {
      double cost = n * step;
      for (int axis = 0; axis < 3; ++axis) cost += tables_[axis].effort(n, rows[axis]);
      best = std::min(best, cost);
    }
    best = std::max(best, alone);
    return std::max(
        base, best + weight_length_ * ballDistance(state.col(0), goal, costs_[0].goal_radius));
  }

 private:
  void prepare(const ChainState& state, const Eigen::Vector3d& goal) const {
    prepared_ = true;
    if (!state.leftCols(2).allFinite() || !goal.allFinite()) return;  // time_optimal's verdict
    // Room for twice the primitives the farthest axis needs at full speed, and some (unless
    // set), within kMaxEntries; a lattice too fine for even one primitive keeps time_optimal.
    double horizon = horizon_;
    if (horizon == 0) {
      double primitives = 0.0;
      for (int axis = 0; axis < 3; ++axis) {
        primitives = std::max(primitives, std::abs(state(axis, 0) - goal[axis]) /
                                              (costs_[axis].max_velocity * costs_[axis].tau));
      }
      horizon = 2.0 * std::ceil(primitives) + 16.0;
    }
    double rows = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      rows += AxisTable::rows(axes_[axis], costs_[axis], low_[axis], high_[axis], state(axis, 1));
    }
    horizon = std::min(horizon, std::floor(kMaxEntries / rows) - 2.0);
    if (!(horizon >= 1.0)) return;
    for (int axis = 0; axis < 3; ++axis) {
      tables_.emplace_back(axes_[axis], costs_[axis], low_[axis], high_[axis],
                           static_cast<int>(horizon), state(axis, 0) - goal[axis], state(axis, 1));
    }
  }

  std::shared_ptr<const SearchHeuristic> fallback_;
  std::array<AxisControls, 3> axes_;
  std::array<AxisCosts, 3> costs_;
  double weight_length_;
  Eigen::Vector3d low_;   ///< the least offset to the goal a state in the world has, per axis
  Eigen::Vector3d high_;  ///< the largest
  int horizon_;           ///< primitives the tables hold (0: from the start's distance)
  mutable bool prepared_ = false;
  mutable std::vector<AxisTable> tables_;  ///< none: time_optimal alone
};

/// The registered heuristic: time_optimal in whole primitives until the controls and then a
/// query are known.
class LatticeHeuristic final : public SearchHeuristic {
 public:
  LatticeHeuristic(const HeuristicContext& context, int horizon, bool fallback,
                   std::optional<std::array<AxisControls, 3>> axes = std::nullopt)
      : context_(context),
        horizon_(horizon),
        fallback_(fallback),
        axes_(std::move(axes)),
        time_optimal_(
            std::make_shared<TimeOptimalHeuristic>(context.edges, context.goal_radius, true)) {}

  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return time_optimal_->estimate(state, goal);
  }

  std::shared_ptr<const SearchHeuristic> forControls(
      const std::vector<Eigen::Vector3d>& controls) const override {
    std::array<AxisControls, 3> axes;
    try {
      for (int axis = 0; axis < 3; ++axis) axes[axis] = axisControls(controls, axis);
    } catch (const InvalidArgument&) {
      if (!fallback_) throw;
      return time_optimal_;  // not a grid: time_optimal in whole primitives
    }
    return std::make_shared<LatticeHeuristic>(context_, horizon_, fallback_, axes);
  }

  std::shared_ptr<const SearchHeuristic> forQuery(const World& world, const Eigen::Vector3d& goal,
                                                  StopCondition& /*stop*/) const override {
    if (!axes_) return nullptr;  // no controls yet: time_optimal
    const EdgeEvaluatorSettings& edges = context_.edges;
    std::array<AxisCosts, 3> costs;
    for (int axis = 0; axis < 3; ++axis) {
      costs[axis] = {edges.duration, edges.weights.duration, edges.weights.control_effort,
                     context_.goal_radius, edges.limits.bound[1][axis]};
    }
    return std::make_shared<LatticeQueryHeuristic>(time_optimal_, *axes_, costs,
                                                   edges.weights.length, world.bounds().min - goal,
                                                   world.bounds().max - goal, horizon_);
  }

 private:
  HeuristicContext context_;
  int horizon_;
  bool fallback_;
  std::optional<std::array<AxisControls, 3>> axes_;  ///< once the controls are known
  std::shared_ptr<const TimeOptimalHeuristic> time_optimal_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<HeuristicBuilder>(
      "lattice",
      "the exact cost to the goal of the control grid's lattice with no obstacles (time and "
      "control effort, the axes moving together to the goal's cube), by max with time_optimal "
      "in whole primitives; exact from a start at rest, a relaxation on finer cells from a "
      "moving one; the lattice needs order 2 and controls on a grid (whole multiples of one "
      "step per axis), elsewhere time_optimal in whole primitives alone (`fallback`)",
      ParameterSpecs()
          .integer("horizon", 0, 0, 100000,
                   "primitives the per-query tables hold (memory: that times the lattice's cells "
                   "and velocities, 8 bytes each, at most 256 MiB); beyond it the bound is "
                   "(horizon + 1) w_T tau; 0: twice the start's primitives at full speed, plus 16")
          .boolean("fallback", true,
                   "where the lattice does not apply (order above 2, controls not on a grid) use "
                   "time_optimal in whole primitives; false: refuse such a planner"),
      [](const ParameterSet& p) {
        const int horizon = static_cast<int>(p.integer("horizon"));
        const bool fallback = p.boolean("fallback");
        return std::make_unique<HeuristicBuilder>(
            [horizon,
             fallback](const HeuristicContext& context) -> std::shared_ptr<const SearchHeuristic> {
              if (context.edges.order == 2) {
                return std::make_shared<LatticeHeuristic>(context, horizon, fallback);
              }
              if (!fallback) {
                throw ParameterConflict("heuristic",
                                        "lattice needs order 2 (acceleration control), got order " +
                                            std::to_string(context.edges.order) +
                                            "; use time_optimal or heuristic.fallback=true");
              }
              return std::make_shared<TimeOptimalHeuristic>(context.edges, context.goal_radius,
                                                            true);
            });
      });
}
