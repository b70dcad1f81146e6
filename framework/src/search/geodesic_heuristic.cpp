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
#include "kinolab/search/search_policies.hpp"

namespace kinolab {
namespace {

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
/// the columns next to the frontier are touched, so a level costs its frontier, not the grid.
class HopField {
 public:
  static constexpr std::uint16_t kUnreached = 0xFFFF;
  static constexpr std::uint16_t kMaxHops = 0xFFFE;  ///< counts stop here (a lower bound beyond)

  /// The voxels where the body's centre can be are those whose centre's distance plus half a
  /// voxel's diagonal reaches `threshold` (no point of the others is `threshold` from every
  /// cube: the distance is 1-Lipschitz and exact at the centres).
  HopField(const World& world, double threshold, const Eigen::Vector3d& goal, double goal_radius,
           StopCondition& stop)
      : origin_(world.grid().origin()),
        resolution_(world.grid().resolution()),
        dims_(world.grid().dims()),
        words_((dims_.z() + 63) / 64),
        columns_(static_cast<std::size_t>(dims_.x()) * dims_.y()),
        hops_(world.grid().size(), kUnreached) {
    const std::vector<float>& distance = world.esdf().values();
    // Less a ten-thousandth of a voxel: the stored distances are floats.
    const double reach = threshold - (0.5 * std::sqrt(3.0) + 1e-4) * resolution_;
    const float at_least = std::nextafter(static_cast<float>(reach), -INFINITY);  // <= reach
    open_.assign(columns_ * words_, 0);
    for (std::size_t column = 0; column < columns_; ++column) {
      const float* values = &distance[column * dims_.z()];
      std::uint64_t* words = &open_[column * words_];
      for (int z = 0; z < dims_.z(); ++z) {
        words[z / 64] |= static_cast<std::uint64_t>(values[z] >= at_least) << (z % 64);
      }
    }
    search(seeds(goal, goal_radius), stop);
  }

  /// H of the voxel holding `point` (clamped into the grid): kUnreached when no chain joins it
  /// to the goal region; when the search was cut short, at most the true count.
  std::uint16_t hops(const Eigen::Vector3d& point) const {
    const Eigen::Vector3d local = (point - origin_) / resolution_;
    VoxelIndex voxel;
    for (int axis = 0; axis < 3; ++axis) {
      const double value = std::floor(local[axis]);
      voxel[axis] =
          value < 0.0 ? 0 : (value >= dims_[axis] ? dims_[axis] - 1 : static_cast<int>(value));
    }
    const std::uint16_t hops = hops_[index(voxel)];
    return hops == kUnreached ? floor_ : hops;
  }

  double resolution() const { return resolution_; }

 private:
  std::size_t index(const VoxelIndex& voxel) const {
    return (static_cast<std::size_t>(voxel.x()) * dims_.y() + voxel.y()) * dims_.z() + voxel.z();
  }

  static std::uint64_t bit(int z) { return std::uint64_t{1} << (z % 64); }

  /// The open voxels whose cube meets the closed goal ball, marked with 0 hops; their columns.
  std::vector<std::size_t> seeds(const Eigen::Vector3d& goal, double radius) {
    std::vector<std::size_t> columns;
    const double r = resolution_;
    Eigen::Vector3i low;
    Eigen::Vector3i high;
    for (int axis = 0; axis < 3; ++axis) {
      const double from = std::floor((goal[axis] - radius - origin_[axis]) / r);
      const double to = std::floor((goal[axis] + radius - origin_[axis]) / r);
      if (!(to >= 0.0 && from < dims_[axis])) return columns;  // misses the grid (or NaN)
      low[axis] = static_cast<int>(std::max(from, 0.0));
      high[axis] = static_cast<int>(std::min(to, dims_[axis] - 1.0));
    }
    frontier_.assign(columns_ * words_, 0);
    for (int x = low.x(); x <= high.x(); ++x) {
      for (int y = low.y(); y <= high.y(); ++y) {
        const std::size_t column = static_cast<std::size_t>(x) * dims_.y() + y;
        bool seeded = false;
        for (int z = low.z(); z <= high.z(); ++z) {
          const VoxelIndex voxel(x, y, z);
          const Eigen::Vector3d corner = origin_ + voxel.cast<double>() * r;
          const Eigen::Vector3d gap =
              (corner - goal).cwiseMax(goal - corner - Eigen::Vector3d::Constant(r)).cwiseMax(0.0);
          std::uint64_t& open = open_[column * words_ + z / 64];
          if (gap.norm() > radius || !(open & bit(z))) continue;
          open &= ~bit(z);
          frontier_[column * words_ + z / 64] |= bit(z);
          hops_[index(voxel)] = 0;
          seeded = true;
        }
        if (seeded) columns.push_back(column);
      }
    }
    return columns;
  }

  void search(std::vector<std::size_t> frontier_columns, StopCondition& stop) {
    std::vector<std::uint64_t> next(frontier_.size(), 0);
    std::vector<std::uint32_t> stamp(columns_, 0);
    std::vector<std::size_t> touched;
    std::vector<std::size_t> next_columns;
    std::vector<std::uint64_t> gathered(words_);
    const int nx = dims_.x();
    const int ny = dims_.y();
    for (std::uint32_t level = 1; !frontier_columns.empty(); ++level) {
      if (level > kMaxHops || stop.expired(0)) {
        floor_ = static_cast<std::uint16_t>(std::min<std::uint32_t>(level, kMaxHops));
        return;
      }
      // The columns next to the frontier (each once).
      touched.clear();
      for (const std::size_t column : frontier_columns) {
        const int x = static_cast<int>(column / ny);
        const int y = static_cast<int>(column % ny);
        for (int cx = std::max(x - 1, 0); cx <= std::min(x + 1, nx - 1); ++cx) {
          for (int cy = std::max(y - 1, 0); cy <= std::min(y + 1, ny - 1); ++cy) {
            const std::size_t neighbour = static_cast<std::size_t>(cx) * ny + cy;
            if (stamp[neighbour] == level) continue;
            stamp[neighbour] = level;
            touched.push_back(neighbour);
          }
        }
      }
      next_columns.clear();
      for (const std::size_t column : touched) {
        const int x = static_cast<int>(column / ny);
        const int y = static_cast<int>(column % ny);
        std::array<const std::uint64_t*, 9> neighbours{};
        int count = 0;
        for (int cx = std::max(x - 1, 0); cx <= std::min(x + 1, nx - 1); ++cx) {
          for (int cy = std::max(y - 1, 0); cy <= std::min(y + 1, ny - 1); ++cy) {
            neighbours[count++] = &frontier_[(static_cast<std::size_t>(cx) * ny + cy) * words_];
          }
        }
        for (int k = 0; k < words_; ++k) {
          std::uint64_t words = 0;
          for (int i = 0; i < count; ++i) words |= neighbours[i][k];
          gathered[k] = words;
        }
        bool reached = false;
        for (int k = 0; k < words_; ++k) {
          // One voxel up and down along z, across word boundaries.
          std::uint64_t dilated = gathered[k] | (gathered[k] << 1) | (gathered[k] >> 1);
          if (k > 0) dilated |= gathered[k - 1] >> 63;
          if (k + 1 < words_) dilated |= gathered[k + 1] << 63;
          std::uint64_t& open = open_[column * words_ + k];
          std::uint64_t fresh = dilated & open;
          if (!fresh) continue;
          open &= ~fresh;
          next[column * words_ + k] = fresh;
          reached = true;
          const std::size_t first = column * dims_.z() + 64 * static_cast<std::size_t>(k);
          for (; fresh; fresh &= fresh - 1) {
            hops_[first + std::countr_zero(fresh)] = static_cast<std::uint16_t>(level);
          }
        }
        if (reached) next_columns.push_back(column);
      }
      for (const std::size_t column : frontier_columns) {
        std::fill_n(frontier_.begin() + static_cast<std::ptrdiff_t>(column * words_), words_, 0);
      }
      frontier_.swap(next);
      frontier_columns.swap(next_columns);
    }
  }

  Eigen::Vector3d origin_;
  double resolution_;
  Eigen::Vector3i dims_;
  int words_;
  std::size_t columns_;
  std::vector<std::uint16_t> hops_;
  std::vector<std::uint64_t> open_;      ///< voxels the body can be in, not yet reached
  std::vector<std::uint64_t> frontier_;  ///< the voxels reached at the last level
  std::uint16_t floor_ = kUnreached;     ///< what an unreached voxel reads
};

/// What the geodesic bound is combined with.
enum class TimeOptimalPart { kWhole, kPlain, kOff };

struct GeodesicOptions {
  TimeOptimalPart time_optimal = TimeOptimalPart::kWhole;

  template <typename Fields>
  void fields(Fields& f) {
    f.choice("time_optimal", time_optimal,
             {{"whole", TimeOptimalPart::kWhole},
              {"plain", TimeOptimalPart::kPlain},
              {"off", TimeOptimalPart::kOff}},
             "the larger of the geodesic bound and time_optimal with whole_primitives (whole), "
             "time_optimal as it is (plain), or the geodesic bound alone (off)");
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

  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    const std::uint16_t hops = field_.hops(state.col(0));
    if (hops == HopField::kUnreached) return INFINITY;
    const double geodesic = step_cost_ * std::ceil(hops / steps_per_primitive_);
    return time_optimal_ ? std::max(geodesic, time_optimal_->estimate(state, goal)) : geodesic;
  }

 private:
  HopField field_;
  std::shared_ptr<const TimeOptimalHeuristic> time_optimal_;  ///< none with `off`
  double step_cost_;
  double steps_per_primitive_;
};

/// The registered heuristic: its time_optimal part alone until a query's world and goal are
/// known, then GeodesicQueryHeuristic.
class GeodesicHeuristic final : public SearchHeuristic {
 public:
  GeodesicHeuristic(const HeuristicContext& context, TimeOptimalPart part)
      : edges_(context.edges), goal_radius_(context.goal_radius) {
    if (part != TimeOptimalPart::kOff) {
      time_optimal_ = std::make_shared<TimeOptimalHeuristic>(context.edges, context.goal_radius,
                                                             part == TimeOptimalPart::kWhole);
    }
  }

  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return time_optimal_ ? time_optimal_->estimate(state, goal) : 0.0;
  }

  std::shared_ptr<const SearchHeuristic> forQuery(const World& world, const Eigen::Vector3d& goal,
                                                  StopCondition& stop) const override {
    // Where a valid edge's points can be: at least radius - tolerance from every cube (the
    // evaluator's verdict radius less the tolerance sphere tracing allows).
    const double threshold =
        std::max(edges_.robot_radius, edges_.collision_tolerance) - edges_.collision_tolerance;
    return std::make_shared<GeodesicQueryHeuristic>(
        HopField(world, threshold, goal, goal_radius_, stop), edges_, time_optimal_);
  }

 private:
  EdgeEvaluatorSettings edges_;
  double goal_radius_;
  std::shared_ptr<const TimeOptimalHeuristic> time_optimal_;
};

void registerBuiltins() {
  PluginRegistrar registrar("built-in (framework)");
  registrar.add<HeuristicBuilder>(
      "geodesic",
      "w_T tau ceil(H / m): H the voxel steps to the goal through the free space (a search over "
      "the map per query), m the most one primitive takes; with time_optimal by max",
      declareFields<GeodesicOptions>(), [](const ParameterSet& p) {
        const TimeOptimalPart part = readFields<GeodesicOptions>(p).time_optimal;
        return std::make_unique<HeuristicBuilder>([part](const HeuristicContext& context) {
          return std::make_shared<GeodesicHeuristic>(context, part);
        });
      });
  registrar.commit();
}

[[maybe_unused]] const bool builtins_registered = (registerBuiltins(), true);

}  // namespace
}  // namespace kinolab
