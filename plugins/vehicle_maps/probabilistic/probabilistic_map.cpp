// The vehicle map kind `probabilistic`: a dense grid of log-odds updated by ray casting, as
// the local maps of Fast-Planner (SDFMap) and FIESTA are, a frame at a time.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/flight/cell_walk.hpp"
#include "kinolab/flight/vehicle_map.hpp"

namespace kinolab {
namespace {

/// The sensor model: OctoMap's default probabilities, so that the two kinds differ in how
/// they store and cast, not in what a reading means.
struct ProbabilisticModel {
  double probability_hit = 0.7;
  double probability_miss = 0.4;
  double clamp_min = 0.12;
  double clamp_max = 0.97;
  double threshold = 0.5;
  double threshold_free = -1.0;
  double exact_range = 3.0;
  bool projection = true;

  /// The probability an occupied voxel turns free below: threshold_free, or by default (when
  /// negative) 0.3, or threshold when that is lower.
  double freeBelow() const {
    return threshold_free >= 0.0 ? threshold_free : std::min(0.3, threshold);
  }

  template <typename Fields>
  void fields(Fields& f) {
    f.real("probability_hit", probability_hit, 0.51, 0.99,
           "the probability a frame's hit gives its voxel");
    f.real("probability_miss", probability_miss, 0.01, 0.49,
           "the probability a frame's passing ray gives a voxel");
    f.real("clamp_min", clamp_min, 0.001, 0.499, "a voxel's probability is kept at least this");
    f.real("clamp_max", clamp_max, 0.501, 0.999, "and at most this");
    f.real("threshold", threshold, 0.01, 0.99, "a voxel turns occupied above this probability");
    f.real(
        "threshold_free", threshold_free, -1.0, 0.99,
        "an occupied voxel turns free again only below this probability (at most threshold, "
        "at least clamp_min; equal to threshold: no hysteresis; negative: 0.3, or threshold "
        "when that is lower): a surface the noisy sensor hits in some frames and passes in others "
        "stays an obstacle instead of flickering, and the window's ESDF is updated only "
        "where the map really changed");
    f.real("exact_range", exact_range, 0.0, 1000.0,
           "within this distance of the sensor every voxel a ray crosses is counted; beyond it a "
           "ray's walk stops at the first voxel an earlier ray of the frame walked (fast, but it "
           "leaves voxels between converging rays unseen); keep it where the rays are dense: "
           "where they are sparse, a ray grazing an obstacle's voxel outvotes its hits, m");
    f.boolean("projection", projection,
              "a camera's frame within exact_range by projection, as nvblox and Voxblox "
              "integrate depth images (a voxel seen free by the pixel nearest its centre; one a "
              "hit ended in voted on with the rays of the pixels its cube covers): a visit per "
              "voxel in view, not per ray crossing it; used where the pixels are dense enough "
              "that the nearest one's ray crosses the voxel; false: every ray walked, as a "
              "lidar's always is");
  }
};

double logit(double p) { return std::log(p / (1.0 - p)); }

/// The point where the ray from `from` towards `to` leaves `box` (`to` when it does not), a
/// thousandth of a voxel inside.
Eigen::Vector3d clipToBox(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const Box& box,
                          double voxel) {
  const Eigen::Vector3d d = to - from;
  double t = 1.0;
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] > 0.0) t = std::min(t, (box.max[axis] - from[axis]) / d[axis]);
    if (d[axis] < 0.0) t = std::min(t, (box.min[axis] - from[axis]) / d[axis]);
  }
  if (t >= 1.0) return to;
  const double length = d.norm();
  return from + std::max(0.0, t - 1e-3 * voxel / length) * d;
}

class ProbabilisticVehicleMap final : public VehicleMap {
 public:
  explicit ProbabilisticVehicleMap(const ProbabilisticModel& model)
      : hit_(static_cast<float>(logit(model.probability_hit))),
        miss_(static_cast<float>(logit(model.probability_miss))),
        low_(static_cast<float>(logit(model.clamp_min))),
        high_(static_cast<float>(logit(model.clamp_max))),
        threshold_(static_cast<float>(logit(model.threshold))),
        threshold_free_(static_cast<float>(logit(model.freeBelow()))),
        exact_range_(model.exact_range),
        projection_(model.projection) {}

 protected:
  void doSetup() override {
    log_odds_.assign(lattice().size(), 0.0f);
    slot_.assign(lattice().size(), 0);
    touched_.clear();
  }

  /// Every voxel a frame reaches is updated once: as a hit when at least as many of the
  /// frame's rays ended in it as passed through it, else as a miss (Fast-Planner's rule).
  /// Beyond exact_range of the origin, free space is walked from each ray's end back towards
  /// the origin, and a walk stops at the first voxel an earlier ray of the frame walked
  /// (counting it): rays converge at the sensor, so most of each walk is shared
  /// (Fast-Planner's raycasting shortcut). But the rest of a stopped ray is not the rest of the
  /// ray it met, and the voxels only it crosses stay unseen: with the shortcut alone, about
  /// half the voxels a camera frame's rays cross (at every distance), and a flight that
  /// commits only into seen space crept. So within exact_range every ray is walked in full,
  /// and a voxel there is counted by every ray that crosses it: by a dedicated traversal from
  /// the origin counting into a dense block of the voxels around it (a ray's voxels in
  /// sequence; most of a frame's voxel visits are there, and the block's counters are
  /// neighbours in memory where the frame's touched list is not). A camera's frame is
  /// counted there by projection instead (projectNear(), exactPasses()), without walking its
  /// rays.
  void doInsert(const SensorFrame& frame, double max_range) override {
    const VoxelGrid& grid = lattice();
    const double voxel = grid.resolution();
    const Box box = grid.bounds();
    // The near part: voxels that rays cross in full within exact_range of the origin.
    const bool origin_inside = grid.inside(voxelOf(frame.origin));
    const double near = origin_inside ? exact_range_ : 0.0;
    // A camera's image dense enough that every voxel within the near range holds the ray of
    // the pixel nearest its centre: the near part by projection (projectNear()).
    const SensorFrame::Image& image = frame.image;
    // Projected: every voxel that reaches within the near range (its centre within half a
    // voxel's diagonal more), so that the far walks' shortcut leaves no gap at its edge.
    const double reach = std::min(near, max_range) + 0.5 * std::sqrt(3.0) * voxel;
    const bool projective = projection_ && near > 0.0 && !image.ranges.empty() &&
                            reach * image.grid.maxOffset() < 0.5 * voxel;
    if (near > 0.0) startBlock(frame, std::min(near, max_range));
    for (const Eigen::Vector3d& p : frame.hits) {
      const VoxelIndex v = voxelOf(p);
      if (!grid.inside(v)) continue;
      Counts* counts = near > 0.0 ? inBlock(v) : nullptr;
      std::uint16_t& hits = counts != nullptr ? counts->hits : entry(grid.index(v)).counts.hits;
      if (hits < UINT16_MAX) ++hits;
    }
    if (projective) projectNear(frame, reach);
    const auto walk = [&](const Eigen::Vector3d& end, bool hit) {
      const Eigen::Vector3d start = clipToBox(frame.origin, end, box, voxel);
      const double length = (start - frame.origin).norm();
      if (!(length > 0.0)) return;
      const Eigen::Vector3d outwards = (start - frame.origin) / length;
      const bool skip_end = hit && start == end;  // a hit's own voxel is not passed
      if (near > 0.0 && !projective) {
        walkNear(frame.origin, outwards, std::min(length, near), !skip_end);
      }
      if (length <= near) return;
      // The far part, inwards from the end: a voxel entered (on its far side) within
      // exact_range of the origin is the near walk's.
      walkFar(start, -outwards, length, near, skip_end);
    };
    for (const Eigen::Vector3d& p : frame.hits) walk(p, true);
    for (const Eigen::Vector3d& p : frame.misses) {
      // Misses lie beyond the range: free space only to it.
      const Eigen::Vector3d d = p - frame.origin;
      walk(frame.origin + std::min(1.0, max_range / d.norm()) * d, false);
    }
    if (near > 0.0) mergeBlock(projective ? &frame : nullptr, reach, max_range);
    // The far walks' voxels lie all over the lattice: each update waits on three loads that
    // miss the cache (its log-odds, state and slot) unless they were asked for ahead.
    constexpr std::size_t kAhead = 16;
    for (std::size_t k = 0; k < touched_.size(); ++k) {
      if (k + kAhead < touched_.size()) {
        const std::size_t later = touched_[k + kAhead].index;
        __builtin_prefetch(&log_odds_[later], 1);
        __builtin_prefetch(&slot_[later], 1);
        prefetchState(later);
      }
      const Touched& touched = touched_[k];
      update(touched.index, touched.counts);
      slot_[touched.index] = 0;
    }
    touched_.clear();
  }

  void doMarkFree(std::size_t index, const Eigen::Vector3d& /*center*/) override {
    log_odds_[index] = std::clamp(miss_, low_, high_);
    setState(index, log_odds_[index] > threshold_ ? Voxel::kOccupied : Voxel::kFree);
  }

 private:
  /// A frame's counts of the rays that ended in a voxel and of those that passed through it.
  struct Counts {
    std::uint16_t hits = 0;
    std::uint16_t passes = 0;
  };
  struct Touched {
    std::size_t index;
    Counts counts;
  };

  VoxelIndex voxelOf(const Eigen::Vector3d& p) const {
    return ((p - lattice().origin()) / lattice().resolution()).array().floor().cast<int>();
  }

  /// Counts a ray passing through; false when an earlier ray of the frame passed too.
  static bool countPass(Touched& touched) {
    std::uint16_t& passes = touched.counts.passes;
    if (passes < UINT16_MAX) ++passes;
    return passes == 1;
  }

  /// Applies a frame's counts to voxel `index`: a hit when at least as many of the frame's
  /// rays ended in it as passed through it, else a miss; occupied above the threshold, and
  /// once occupied until below threshold_free.
  void update(std::size_t index, const Counts& counts) {
    float& value = log_odds_[index];
    value = std::clamp(value + (counts.hits >= counts.passes ? hit_ : miss_), low_, high_);
    const bool occupied = state(index) == Voxel::kOccupied;
    setState(index,
             value > (occupied ? threshold_free_ : threshold_) ? Voxel::kOccupied : Voxel::kFree);
  }

  /// Makes the block the lattice's voxels around the frame's rays within `reach` of its origin
  /// (their bounding box within the lattice's, and two voxels more, so that a traversal's
  /// rounding never leaves it), all counts zero. It may reach beyond the lattice: those cells
  /// are never counted.
  void startBlock(const SensorFrame& frame, double reach) {
    Eigen::Vector3d low = frame.origin;
    Eigen::Vector3d high = frame.origin;
    for (const auto* points : {&frame.hits, &frame.misses}) {
      for (const Eigen::Vector3d& p : *points) {
        const Eigen::Vector3d d = p - frame.origin;
        const double length = d.norm();
        const Eigen::Vector3d end =
            length > reach ? Eigen::Vector3d(frame.origin + reach / length * d) : p;
        low = low.cwiseMin(end);
        high = high.cwiseMax(end);
      }
    }
    const Box& box = lattice().bounds();
    low = low.cwiseMax(box.min);
    high = high.cwiseMin(box.max).cwiseMax(low);
    const double r = lattice().resolution();
    block_first_ = ((low - lattice().origin()) / r).array().floor().cast<int>() - 2;
    const VoxelIndex last = ((high - lattice().origin()) / r).array().floor().cast<int>() + 2;
    block_dims_ = last - block_first_ + VoxelIndex::Ones();
    block_.assign(static_cast<std::size_t>(block_dims_.prod()), Counts{});
  }

  /// The block's counts of the lattice voxel `v`, or null when the block does not hold it.
  Counts* inBlock(const VoxelIndex& v) {
    const Eigen::Vector3i cell = v - block_first_;
    if ((cell.array() < 0).any() || (cell.array() >= block_dims_.array()).any()) return nullptr;
    return &block_[(static_cast<std::size_t>(cell.x()) * block_dims_.y() + cell.y()) *
                       block_dims_.z() +
                   cell.z()];
  }

  /// Counts a pass in every voxel the ray origin + t direction (unit) crosses over a positive
  /// length and leaves at t <= limit, and in the voxel it is in at `limit` when `count_end`.
  void walkNear(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double limit,
                bool count_end) {
    const double r = lattice().resolution();
    // In voxels from the lattice's corner, as the grid's own traversal has it, then shifted
    // by the block's first voxel (exact: integers).
    CellWalk walk((origin - lattice().origin()) / r - block_first_.cast<double>(), direction,
                  block_dims_);
    const std::int64_t end = CellWalk::fixed(limit / r);
    Counts* counts = block_.data();
    const auto pass = [&] {
      std::uint16_t& passes = counts[walk.index].passes;
      passes += passes < UINT16_MAX ? 1 : 0;
    };
    std::int64_t entered = 0;  // a cell left where it was entered was only touched
    while (true) {
      const std::int64_t leave = walk.leave();
      if (leave > end) break;
      if (leave > entered) pass();
      entered = leave;
      walk.step(leave);
    }
    if (count_end) pass();
  }

  /// The near part of a camera's frame by projection, for the voxels of the block that no hit
  /// of the frame ended in and whose centre lies within `reach` of the origin (those with a hit
  /// are counted exactly, exactPasses()). Such a voxel in view, in front of the range its
  /// nearest pixel measured, was passed: it is seen free. The nearest pixel's ray passes
  /// within half a voxel of the centre (doInsert() checks that the pixels are that dense), so
  /// through the voxel's cube: an obstacle's voxel would have stopped it nearer than its
  /// centre, so without noise no obstacle's voxel is passed. A visit per voxel instead of one
  /// per ray and voxel.
  void projectNear(const SensorFrame& frame, double reach) {
    const SensorFrame::Image& image = frame.image;
    const PixelGrid& pixels = image.grid;
    const double r = lattice().resolution();
    const double c = std::cos(image.yaw);
    const double s = std::sin(image.yaw);
    const Eigen::Vector3d first = lattice().origin() +
                                  (block_first_.cast<double>().array() + 0.5).matrix() * r -
                                  frame.origin;
    const double reach2 = reach * reach;
    const float* ranges = image.ranges.data();
    Counts* counts = block_.data();
    const std::size_t nz = static_cast<std::size_t>(block_dims_.z());
    for (int x = 0; x < block_dims_.x(); ++x) {
      const double dx = first.x() + x * r;
      for (int y = 0; y < block_dims_.y(); ++y, counts += nz) {
        const double dy = first.y() + y * r;
        const double ahead = c * dx + s * dy;  // the camera frame: x ahead, y left, z up
        if (!(ahead > 0.0)) continue;
        const double column = std::floor(pixels.column_scale * (c * dy - s * dx) / ahead +
                                         pixels.column_offset + 0.5);
        if (!(column >= 0.0 && column < pixels.columns)) continue;
        const double across2 = dx * dx + dy * dy;
        const float* column_ranges = ranges + static_cast<std::ptrdiff_t>(column);
        for (std::size_t z = 0; z < nz; ++z) {
          const double dz = first.z() + static_cast<double>(z) * r;
          const double row = std::floor(pixels.row_scale * dz / ahead + pixels.row_offset + 0.5);
          const double distance2 = across2 + dz * dz;
          if (!(row >= 0.0 && row < pixels.rows) || distance2 > reach2) continue;
          const double measured = column_ranges[static_cast<std::ptrdiff_t>(row) * pixels.columns];
          // (NaN: lost, no pass)
          if (counts[z].hits == 0 && distance2 < measured * measured) counts[z].passes = 1;
        }
      }
    }
  }

  /// The rays of a camera's frame that passed through the cube of side `r` about `centre`
  /// (entered it and ended beyond it; one that struck nothing, entered it within `max_range`),
  /// counted pixel by pixel over the pixels its corners project to: the walks' count for that
  /// voxel, without walking.
  std::uint16_t exactPasses(const SensorFrame& frame, const Eigen::Vector3d& centre,
                            double max_range) const {
    const SensorFrame::Image& image = frame.image;
    const PixelGrid& pixels = image.grid;
    const double half = 0.5 * lattice().resolution();
    const double c = std::cos(image.yaw);
    const double s = std::sin(image.yaw);
    const Eigen::Vector3d low = centre.array() - half - frame.origin.array();
    const Eigen::Vector3d high = centre.array() + half - frame.origin.array();
    // The corners' pixels (the whole image when the cube reaches behind the camera).
    std::pair<int, int> columns{0, pixels.columns - 1};
    std::pair<int, int> rows{0, pixels.rows - 1};
    double u_low = INFINITY;
    double u_high = -INFINITY;
    double v_low = INFINITY;
    double v_high = -INFINITY;
    bool ahead = true;
    for (int k = 0; k < 8 && ahead; ++k) {
      const Eigen::Vector3d d(k & 1 ? high.x() : low.x(), k & 2 ? high.y() : low.y(),
                              k & 4 ? high.z() : low.z());
      const double forward = c * d.x() + s * d.y();
      ahead = forward > 1e-9;
      const double u = (c * d.y() - s * d.x()) / forward;
      const double v = d.z() / forward;
      u_low = std::min(u_low, u);
      u_high = std::max(u_high, u);
      v_low = std::min(v_low, v);
      v_high = std::max(v_high, v);
    }
    if (ahead) {
      columns = pixels.columnsIn(u_low, u_high);
      rows = pixels.rowsIn(v_low, v_high);
    }
    int passes = 0;
    for (int row = rows.first; row <= rows.second; ++row) {
      const double v = (row - pixels.row_offset) / pixels.row_scale;
      for (int column = columns.first; column <= columns.second; ++column) {
        const float measured =
            image.ranges[static_cast<std::size_t>(row) * pixels.columns + column];
        if (std::isnan(measured)) continue;
        const double u = (column - pixels.column_offset) / pixels.column_scale;
        // The pixel's ray, (1, u, v) turned by the heading, over the cube's slabs.
        const double length = std::sqrt(1.0 + u * u + v * v);
        const Eigen::Vector3d w(c - s * u, s + c * u, v);
        double enter = 0.0;
        double leave = INFINITY;
        for (int axis = 0; axis < 3; ++axis) {
          if (w[axis] == 0.0) {
            if (low[axis] > 0.0 || high[axis] < 0.0) leave = -1.0;
            continue;
          }
          const double a = low[axis] / w[axis];
          const double b = high[axis] / w[axis];
          enter = std::max(enter, std::min(a, b));
          leave = std::min(leave, std::max(a, b));
        }
        const bool through =
            std::isinf(measured) ? enter * length < max_range : measured > leave * length;
        if (enter < leave && through) ++passes;
      }
    }
    return static_cast<std::uint16_t>(std::min(passes, UINT16_MAX + 0));
  }

  /// The far part of a walk, from `start` along the unit `inwards` to the origin `length`
  /// away: counts a pass in every voxel entered before `length - near` (the first one unless
  /// `skip_first`), and stops after one an earlier ray of the frame passed (the shortcut).
  void walkFar(const Eigen::Vector3d& start, const Eigen::Vector3d& inwards, double length,
               double near, bool skip_first) {
    const VoxelGrid& grid = lattice();
    const double r = grid.resolution();
    CellWalk walk((start - grid.origin()) / r, inwards, grid.dims());
    if (!walk.inside(grid.dims())) return;
    const std::int64_t end = CellWalk::fixed((length - near) / r);
    if (!skip_first && !countPass(entry(static_cast<std::size_t>(walk.index)))) return;
    while (true) {
      const std::int64_t leave = walk.leave();
      if (leave >= end) return;
      walk.step(leave);
      if (!walk.inside(grid.dims())) return;  // rounding at the origin, on the lattice's side
      if (!countPass(entry(static_cast<std::size_t>(walk.index)))) return;
    }
  }

  /// Applies the block's counts (with a voxel's far-walk counts when it has both) and clears
  /// them. With a camera's frame `projected` (projectNear()), a voxel there that a hit ended
  /// in, with its centre within `reach` of the origin, is counted exactly instead
  /// (exactPasses(): every ray that crossed it, the far walks' among them).
  void mergeBlock(const SensorFrame* projected, double reach, double max_range) {
    const VoxelGrid& grid = lattice();
    std::size_t cell = 0;
    for (int x = 0; x < block_dims_.x(); ++x) {
      for (int y = 0; y < block_dims_.y(); ++y) {
        for (int z = 0; z < block_dims_.z(); ++z, ++cell) {
          Counts counts = block_[cell];
          if (counts.hits == 0 && counts.passes == 0) continue;
          const VoxelIndex v = block_first_ + VoxelIndex(x, y, z);
          if (!grid.inside(v)) continue;
          const std::size_t index = grid.index(v);
          bool exact = false;
          if (projected != nullptr && counts.hits > 0) {
            const Eigen::Vector3d centre = grid.center(v);
            if ((centre - projected->origin).squaredNorm() <= reach * reach) {
              counts.passes = exactPasses(*projected, centre, max_range);
              exact = true;
            }
          }
          if (slot_[index] == 0) {
            update(index, counts);
            continue;
          }
          Counts& far = touched_[slot_[index] - 1].counts;
          if (exact) {
            far = counts;
            continue;
          }
          far.hits = static_cast<std::uint16_t>(std::min(far.hits + counts.hits, UINT16_MAX + 0));
          far.passes =
              static_cast<std::uint16_t>(std::min(far.passes + counts.passes, UINT16_MAX + 0));
        }
      }
    }
  }

  /// This frame's counts of voxel `index`, made on first use.
  Touched& entry(std::size_t index) {
    std::uint32_t& slot = slot_[index];
    if (slot == 0) {
      touched_.push_back({index, {}});
      slot = static_cast<std::uint32_t>(touched_.size());
    }
    return touched_[slot - 1];
  }

  float hit_;
  float miss_;
  float low_;
  float high_;
  float threshold_;
  float threshold_free_;
  double exact_range_;
  bool projection_;
  std::vector<float> log_odds_;
  std::vector<std::uint32_t> slot_;  // 1 + the voxel's place in touched_, 0 when not touched
  std::vector<Touched> touched_;     // the frame's voxels
  // The frame's dense block around its origin (walkNear()): its first voxel's lattice index,
  // its size and one cell's counts a voxel (x slowest, z fastest).
  VoxelIndex block_first_ = VoxelIndex::Zero();
  Eigen::Vector3i block_dims_ = Eigen::Vector3i::Zero();
  std::vector<Counts> block_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<VehicleMap>(
      "probabilistic",
      "a dense log-odds grid updated by ray casting, each voxel once a frame (the local maps of "
      "Fast-Planner and FIESTA); OctoMap's probabilities by default",
      declareFields<ProbabilisticModel>(), [](const ParameterSet& p) {
        const auto model = readFields<ProbabilisticModel>(p);
        if (model.threshold_free >= 0.0 && model.threshold_free > model.threshold) {
          throw ConfigError("probabilistic: threshold_free " + formatNumber(model.threshold_free) +
                            " is above threshold " + formatNumber(model.threshold) +
                            ": an occupied voxel turns free below threshold_free, at most "
                            "threshold");
        }
        const double free_below = model.freeBelow();
        if (free_below < model.clamp_min) {
          throw ConfigError("probabilistic: threshold_free " + formatNumber(free_below) +
                            (model.threshold_free >= 0.0
                                 ? std::string()
                                 : " (threshold " + formatNumber(model.threshold) + ")") +
                            " is below clamp_min " + formatNumber(model.clamp_min) +
                            ": an occupied voxel would never turn free; set it at least clamp_min");
        }
        return std::make_unique<ProbabilisticVehicleMap>(model);
      });
}
