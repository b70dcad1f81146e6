// The heuristic kind `geodesic`: a lower bound on the time to the goal through the free space
// itself (a breadth-first search over the voxels the body can be in), consistent with every
// edge, at most as large as any path's cost however the obstacles lie.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/search/search_policies.hpp"

namespace kinolab {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;

/// Chebyshev hop counts over a grid's voxels from the goal region: H(v) is the fewest steps
/// between 26-neighbours, through voxels the body's centre can be in, from v to a voxel that
/// meets the goal ball.
///
/// Why it bounds every path: a curve in space whose L-infinity length (the integral of
/// max_i |v_i|) is l crosses a chain of voxels in which consecutive ones are 26-neighbours (or
/// equal) and that has at most floor(l / voxel) + 1 steps: cut the curve where it first gets
/// one voxel (in L-infinity) from the last cut; two points at most one voxel apart on every
/// axis lie in voxels at most one index apart on every axis. Every point of a valid edge is
/// where the body's centre can be, so its voxels are nodes of the graph, and the edge's two
/// ends have hop counts that differ by at most that many steps.
///
/// The graph is searched level by level on bit columns (each (x, y) column of voxels packed
/// into 64-bit words along z): a level's dilation is the OR of the nine neighbouring columns'
/// frontier words, shifted by one bit both ways, masked by the voxels not yet reached. Only
/// the columns next to the frontier are touched, and only as far as asked: hops() runs levels
/// until the voxel asked for is reached, so a query costs the ball its search asks about, not
/// the map (a column's words and counts are made when the search first touches it). The
/// counts are the same whatever the order of the questions.
///
/// Memory: 8 bytes a column of the map, and 2 bytes a voxel plus 24 bytes a 64 voxels and 24
/// bytes for each column the search touches, within a budget: when the next level L would need
/// more, the search ends before it, and every node not reached reads L, a lower bound of its
/// count (the field then reads min(H, L), which differs between two voxels by no more than H
/// does: still consistent; a node no chain joins to the goal reads L too).
class HopField {
 public:
  static constexpr std::uint16_t kUnreached = 0xFFFF;
  static constexpr std::uint16_t kMaxHops = 0xFFFE;  ///< counts stop here (a lower bound beyond)

  /// The voxels where the body's centre can be are those whose centre's distance plus half a
  /// voxel's diagonal reaches `threshold` (no point of the others is `threshold` from every
  /// cube: the distance is 1-Lipschitz and exact at the centres). On a sparse world's field,
  /// truncated at T, that test is the dense field's when T exceeds the test's value in
  /// magnitude; a shorter truncation is refused. Keeps a reference to the world's field (the
  /// search that asks holds the world) and a copy of `stop`.
  HopField(const World& world, double threshold, const Eigen::Vector3d& goal, double goal_radius,
           double memory_bytes, const StopCondition& stop)
      : origin_(world.grid().origin()),
        resolution_(world.grid().resolution()),
        dims_(world.grid().dims()),
        words_((dims_.z() + 63) / 64),
        columns_(static_cast<std::size_t>(dims_.x()) * dims_.y()),
        esdf_(world.esdf()),
        stop_(stop) {
    // Less a ten-thousandth of a voxel: the stored distances are floats.
    const double reach = threshold - (0.5 * std::sqrt(3.0) + 1e-4) * resolution_;
    at_least_ = std::nextafter(static_cast<float>(reach), -INFINITY);  // <= reach
    // A truncated field reads +T beyond T and -T deeper than T: the node test is the dense
    // field's when T passes it (a voxel reading T is at least T away) and -T fails it.
    world.requireExactDistancesTo(std::abs(at_least_), "heuristic geodesic");
    const double table_bytes = 2.0 * sizeof(std::uint32_t) * static_cast<double>(columns_);
    if (!(memory_bytes >= table_bytes)) {
      throw InvalidArgument(
          "heuristic geodesic: memory_limit_mb " + formatNumber(memory_bytes / kMiB) +
          " is below the " + formatNumber(std::ceil(table_bytes / kMiB * 100.0) / 100.0) +
          " MB its tables take on world " + world.name() + " (8 bytes a column of the map)");
    }
    // A touched column's counts and three words a 64 voxels, and its place in the three
    // lists of columns.
    const double slot_bytes = sizeof(std::uint16_t) * static_cast<double>(dims_.z()) +
                              3.0 * sizeof(std::uint64_t) * words_ + 3.0 * sizeof(std::size_t);
    max_slots_ = static_cast<std::size_t>(
        std::min(static_cast<double>(columns_), (memory_bytes - table_bytes) / slot_bytes));
    slot_.assign(columns_, 0);
    stamp_.assign(columns_, 0);
    // Room for every column the budget holds (address space only until a column is touched):
    // no copies as the search grows.
    const std::size_t words = max_slots_ * static_cast<std::size_t>(words_);
    open_.reserve(words);
    frontier_.reserve(words);
    next_.reserve(words);
    hops_.reserve(max_slots_ * static_cast<std::size_t>(dims_.z()));
    seed(goal, goal_radius);
  }

  /// H of the voxel holding `point` (clamped into the grid): kUnreached when no chain joins it
  /// to the goal region (or the body cannot be there); when the search was cut short by its
  /// stop condition or its memory budget, at most the true count.
  std::uint16_t hops(const Eigen::Vector3d& point) {
    const Eigen::Vector3d local = (point - origin_) / resolution_;
    VoxelIndex voxel;
    for (int axis = 0; axis < 3; ++axis) {
      const double value = std::floor(local[axis]);
      voxel[axis] =
          value < 0.0 ? 0 : (value >= dims_[axis] ? dims_[axis] - 1 : static_cast<int>(value));
    }
    const std::size_t column = static_cast<std::size_t>(voxel.x()) * dims_.y() + voxel.y();
    const auto nz = static_cast<std::size_t>(dims_.z());
    const auto z = static_cast<std::size_t>(voxel.z());
    // Most voxels a search asks about are reached already: their count, with no more reads.
    for (bool node_checked = false;; node_checked = true) {
      const std::uint32_t slot = slot_[column];
      const std::uint16_t hops = slot != 0 ? hops_[(slot - 1) * nz + z] : kUnreached;
      if (hops != kUnreached) return hops;
      if (!node_checked && esdf_.voxelDistance(column * nz + z) < at_least_) {
        return kUnreached;  // never
      }
      if (frontier_columns_.empty()) return floor_;  // searched out (or cut short)
      advance();
    }
  }

  double resolution() const { return resolution_; }

 private:
  static std::uint64_t bit(int z) { return std::uint64_t{1} << (z % 64); }

  /// The column's slot (1 + its place in the per-column arrays), made on first touch: its
  /// open words from the distances, no counts, no frontier.
  std::uint32_t slotOf(std::size_t column) {
    std::uint32_t& slot = slot_[column];
    if (slot != 0) return slot;
    slot = static_cast<std::uint32_t>(made_++) + 1;
    const auto words = static_cast<std::size_t>(words_);
    open_.resize(made_ * words, 0);
    frontier_.resize(made_ * words, 0);
    next_.resize(made_ * words, 0);
    hops_.resize(made_ * static_cast<std::size_t>(dims_.z()), kUnreached);
    std::uint64_t* open = &open_[(slot - 1) * words];
    const std::size_t first = column * static_cast<std::size_t>(dims_.z());
    for (int z = 0; z < dims_.z(); ++z) {
      open[z / 64] |= static_cast<std::uint64_t>(esdf_.voxelDistance(first + z) >= at_least_)
                      << (z % 64);
    }
    return slot;
  }

  /// The open voxels whose cube meets the closed goal ball, marked with 0 hops; their columns
  /// are the first frontier.
  void seed(const Eigen::Vector3d& goal, double radius) {
    const double r = resolution_;
    Eigen::Vector3i low;
    Eigen::Vector3i high;
    for (int axis = 0; axis < 3; ++axis) {
      const double from = std::floor((goal[axis] - radius - origin_[axis]) / r);
      const double to = std::floor((goal[axis] + radius - origin_[axis]) / r);
      if (!(to >= 0.0 && from < dims_[axis])) return;  // misses the grid (or NaN)
      low[axis] = static_cast<int>(std::max(from, 0.0));
      high[axis] = static_cast<int>(std::min(to, dims_[axis] - 1.0));
    }
    for (int x = low.x(); x <= high.x(); ++x) {
      for (int y = low.y(); y <= high.y(); ++y) {
        const std::size_t column = static_cast<std::size_t>(x) * dims_.y() + y;
        bool seeded = false;
        for (int z = low.z(); z <= high.z(); ++z) {
          const VoxelIndex voxel(x, y, z);
          const Eigen::Vector3d corner = origin_ + voxel.cast<double>() * r;
          const Eigen::Vector3d gap =
              (corner - goal).cwiseMax(goal - corner - Eigen::Vector3d::Constant(r)).cwiseMax(0.0);
          if (gap.norm() > radius) continue;
          const std::size_t slot = slotOf(column) - 1;
          std::uint64_t& open = open_[slot * words_ + z / 64];
          if (!(open & bit(z))) continue;
          open &= ~bit(z);
          frontier_[slot * words_ + z / 64] |= bit(z);
          hops_[slot * dims_.z() + z] = 0;
          seeded = true;
        }
        if (seeded) frontier_columns_.push_back(column);
      }
    }
  }

  /// The next level of the search (the frontier's columns must not be empty); past the stop
  /// condition, at kMaxHops, or when its columns would not fit the memory budget, it ends the
  /// search instead, unreached voxels then reading the level (a lower bound of their count).
  void advance() {
    const auto level = static_cast<std::uint32_t>(level_ + 1);
    const auto end = [&] {
      floor_ = static_cast<std::uint16_t>(std::min<std::uint32_t>(level, kMaxHops));
      frontier_columns_.clear();
    };
    if (level > kMaxHops || stop_.expired(0)) return end();
    const int nx = dims_.x();
    const int ny = dims_.y();
    // The columns next to the frontier (each once), and how many of them are new.
    std::size_t fresh_columns = 0;
    touched_.clear();
    for (const std::size_t column : frontier_columns_) {
      const int x = static_cast<int>(column / ny);
      const int y = static_cast<int>(column % ny);
      for (int cx = std::max(x - 1, 0); cx <= std::min(x + 1, nx - 1); ++cx) {
        for (int cy = std::max(y - 1, 0); cy <= std::min(y + 1, ny - 1); ++cy) {
          const std::size_t neighbour = static_cast<std::size_t>(cx) * ny + cy;
          if (stamp_[neighbour] == level) continue;
          stamp_[neighbour] = level;
          touched_.push_back(neighbour);
          fresh_columns += slot_[neighbour] == 0;
        }
      }
    }
    if (made_ + fresh_columns > max_slots_) return end();
    level_ = level;
    for (const std::size_t column : touched_) slotOf(column);  // (before pointers into them)
    next_columns_.clear();
    gathered_.resize(static_cast<std::size_t>(words_));
    for (const std::size_t column : touched_) {
      const int x = static_cast<int>(column / ny);
      const int y = static_cast<int>(column % ny);
      std::array<const std::uint64_t*, 9> neighbours{};
      int count = 0;
      for (int cx = std::max(x - 1, 0); cx <= std::min(x + 1, nx - 1); ++cx) {
        for (int cy = std::max(y - 1, 0); cy <= std::min(y + 1, ny - 1); ++cy) {
          const std::uint32_t slot = slot_[static_cast<std::size_t>(cx) * ny + cy];
          if (slot != 0) neighbours[count++] = &frontier_[(slot - 1) * words_];
        }
      }
      for (int k = 0; k < words_; ++k) {
        std::uint64_t words = 0;
        for (int i = 0; i < count; ++i) words |= neighbours[i][k];
        gathered_[k] = words;
      }
      const std::size_t slot = slot_[column] - 1;
      bool reached = false;
      for (int k = 0; k < words_; ++k) {
        // One voxel up and down along z, across word boundaries.
        std::uint64_t dilated = gathered_[k] | (gathered_[k] << 1) | (gathered_[k] >> 1);
        if (k > 0) dilated |= gathered_[k - 1] >> 63;
        if (k + 1 < words_) dilated |= gathered_[k + 1] << 63;
        std::uint64_t& open = open_[slot * words_ + k];
        std::uint64_t fresh = dilated & open;
        if (!fresh) continue;
        open &= ~fresh;
        next_[slot * words_ + k] = fresh;
        reached = true;
        const std::size_t first = slot * dims_.z() + 64 * static_cast<std::size_t>(k);
        for (; fresh; fresh &= fresh - 1) {
          hops_[first + std::countr_zero(fresh)] = static_cast<std::uint16_t>(level);
        }
      }
      if (reached) next_columns_.push_back(column);
    }
    for (const std::size_t column : frontier_columns_) {
      const std::size_t slot = slot_[column] - 1;
      std::fill_n(frontier_.begin() + static_cast<std::ptrdiff_t>(slot * words_), words_, 0);
    }
    frontier_.swap(next_);
    frontier_columns_.swap(next_columns_);
  }

  Eigen::Vector3d origin_;
  double resolution_;
  Eigen::Vector3i dims_;
  int words_;
  std::size_t columns_;
  const Esdf& esdf_;           ///< the world's distances, a voxel each
  float at_least_ = 0.0f;      ///< a voxel is a node when its distance is at least this
  std::size_t max_slots_ = 0;  ///< the columns the memory budget holds
  // Per (x, y) column: 1 + its slot in the arrays below (0: not touched yet), and the last
  // level that touched it.
  std::vector<std::uint32_t> slot_;
  std::vector<std::uint32_t> stamp_;
  std::size_t made_ = 0;  ///< slots made
  // Per slot: its column's counts (dims_.z() each) and words (words_ each).
  std::vector<std::uint16_t> hops_;
  std::vector<std::uint64_t> open_;      ///< voxels the body can be in, not yet reached
  std::vector<std::uint64_t> frontier_;  ///< the voxels reached at the last level
  std::vector<std::uint64_t> next_;      ///< those of the level being made
  std::vector<std::size_t> frontier_columns_;
  std::vector<std::size_t> next_columns_;
  std::vector<std::size_t> touched_;
  std::vector<std::uint64_t> gathered_;
  std::uint32_t level_ = 0;           ///< the last level made
  std::uint16_t floor_ = kUnreached;  ///< what an unreached node reads once the search ends
  StopCondition stop_;
};

/// What the geodesic bound is combined with.
enum class TimeOptimalPart { kWhole, kPlain, kOff };

struct GeodesicOptions {
  TimeOptimalPart time_optimal = TimeOptimalPart::kWhole;
  double memory_limit_mb = 2048.0;

  template <typename Fields>
  void fields(Fields& f) {
    f.choice("time_optimal", time_optimal,
             {{"whole", TimeOptimalPart::kWhole},
              {"plain", TimeOptimalPart::kPlain},
              {"off", TimeOptimalPart::kOff}},
             "the larger of the geodesic bound and time_optimal with whole_primitives (whole), "
             "time_optimal as it is (plain), or the geodesic bound alone (off)");
    f.real("memory_limit_mb", memory_limit_mb, 1.0, 1e6,
           "memory of a query's search over the voxels, MB, besides the planner's own (8 bytes "
           "a column of the map, and about 2.4 bytes a voxel of each column it reaches): past "
           "it the search stops, and the voxels it has not reached read the level it did not "
           "make (a lower bound)");
  }
};

/// The query's heuristic: w_T tau ceil(H / m), with m = floor(v tau / voxel) + 1 the most
/// steps one primitive can take (v the largest velocity limit: an edge's L-infinity length is
/// at most v tau), and time_optimal by max. Consistent: an edge changes H by at most m, so
/// ceil(H / m) by at most 1, and every edge costs at least w_T tau; a lower bound: the path's
/// last state lies in the goal region (H = 0), so a path of primitives has at least
/// ceil(H / m) of them (a goal shot, as hybrid A* ends with, may be shorter).
class GeodesicQueryHeuristic final : public SearchHeuristic {
 public:
  GeodesicQueryHeuristic(HopField field, const EdgeEvaluatorSettings& edges,
                         std::shared_ptr<const TimeOptimalHeuristic> time_optimal)
      : field_(std::move(field)),
        time_optimal_(std::move(time_optimal)),
        step_cost_(edges.weights.duration * edges.duration),
        steps_per_primitive_(std::floor(edges.limits.bound[1].maxCoeff() * edges.duration /
                                        field_.resolution() * (1.0 + 1e-9)) +
                             1.0) {}

  /// (Not safe to call from several threads at once: the field grows as it is asked.)
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    const std::uint16_t hops = field_.hops(state.col(0));
    if (hops == HopField::kUnreached) return INFINITY;
    const double geodesic = step_cost_ * std::ceil(hops / steps_per_primitive_);
    return time_optimal_ ? std::max(geodesic, time_optimal_->estimate(state, goal)) : geodesic;
  }

 private:
  mutable HopField field_;  // grown as the search asks (HopField::hops())
  std::shared_ptr<const TimeOptimalHeuristic> time_optimal_;  ///< none with `off`
  double step_cost_;
  double steps_per_primitive_;
};

/// The registered heuristic: its time_optimal part alone until a query's world and goal are
/// known, then GeodesicQueryHeuristic.
class GeodesicHeuristic final : public SearchHeuristic {
 public:
  GeodesicHeuristic(const HeuristicContext& context, const GeodesicOptions& options)
      : edges_(context.edges),
        goal_radius_(context.goal_radius),
        memory_bytes_(options.memory_limit_mb * kMiB) {
    if (options.time_optimal != TimeOptimalPart::kOff) {
      time_optimal_ = std::make_shared<TimeOptimalHeuristic>(
          context.edges, context.goal_radius, options.time_optimal == TimeOptimalPart::kWhole);
    }
  }

  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return time_optimal_ ? time_optimal_->estimate(state, goal) : 0.0;
  }

  std::shared_ptr<const SearchHeuristic> forQuery(const World& world, const Eigen::Vector3d& goal,
                                                  StopCondition& stop) const override {
    // Where a valid edge's points can be: at least the body's kept radius from every cube.
    return std::make_shared<GeodesicQueryHeuristic>(
        HopField(world, edges_.body.keptRadius(), goal, goal_radius_, memory_bytes_, stop), edges_,
        time_optimal_);
  }

 private:
  EdgeEvaluatorSettings edges_;
  double goal_radius_;
  double memory_bytes_;  ///< the budget of a query's HopField
  std::shared_ptr<const TimeOptimalHeuristic> time_optimal_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<HeuristicBuilder>(
      "geodesic",
      "w_T tau ceil(H / m): H the voxel steps to the goal through the free space (a search over "
      "the map per query), m the most one primitive takes; with time_optimal by max",
      declareFields<GeodesicOptions>(), [](const ParameterSet& p) {
        const GeodesicOptions options = readFields<GeodesicOptions>(p);
        return std::make_unique<HeuristicBuilder>([options](const HeuristicContext& context) {
          return std::make_shared<GeodesicHeuristic>(context, options);
        });
      });
}
