// The vehicle map kind `probabilistic`: a dense grid of log-odds updated by ray casting, as
// the local maps of Fast-Planner (SDFMap) and FIESTA are, a frame at a time.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
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
  double exact_range = 3.0;

  template <typename Fields>
  void fields(Fields& f) {
    f.real("probability_hit", probability_hit, 0.51, 0.99,
           "the probability a frame's hit gives its voxel");
    f.real("probability_miss", probability_miss, 0.01, 0.49,
           "the probability a frame's passing ray gives a voxel");
    f.real("clamp_min", clamp_min, 0.001, 0.499, "a voxel's probability is kept at least this");
    f.real("clamp_max", clamp_max, 0.501, 0.999, "and at most this");
    f.real("threshold", threshold, 0.01, 0.99, "a voxel is occupied above this probability");
    f.real("exact_range", exact_range, 0.0, 1000.0,
           "within this distance of the sensor every voxel a ray crosses is counted; beyond it a "
           "ray's walk stops at the first voxel an earlier ray of the frame walked (fast, but it "
           "leaves voxels between converging rays unseen); keep it where the rays are dense: "
           "where they are sparse, a ray grazing an obstacle's voxel outvotes its hits, m");
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
        exact_range_(model.exact_range) {}

 protected:
  void doSetup() override {
    log_odds_.assign(lattice().size(), 0.0f);
    slot_.assign(lattice().size(), 0);
    touched_.clear();
  }

  /// Every voxel a frame reaches is updated once: as a hit when at least as many of the
  /// frame's rays ended in it as passed through it, else as a miss (Fast-Planner's rule).
  /// Free space is walked from each ray's end back towards the origin. Beyond exact_range of
  /// the origin a walk stops at the first voxel an earlier ray of the frame walked (counting
  /// it): rays converge at the sensor, so most of each walk is shared (Fast-Planner's
  /// raycasting shortcut). But the rest of a stopped ray is not the rest of the ray it met,
  /// and the voxels only it crosses stay unseen: with the shortcut alone, about half the
  /// voxels a camera frame's rays cross (at every distance), and a flight that commits only
  /// into seen space crept. So within exact_range every ray is walked in full, and a voxel
  /// there is counted by every ray that crosses it.
  void doInsert(const SensorFrame& frame, double max_range) override {
    const VoxelGrid& grid = lattice();
    const double voxel = grid.resolution();
    const Box box = grid.bounds();
    for (const Eigen::Vector3d& p : frame.hits) {
      const VoxelIndex v = voxelOf(p);
      if (grid.inside(v)) {
        Touched& touched = entry(grid.index(v));
        if (touched.hits < UINT16_MAX) ++touched.hits;
      }
    }
    const auto walk = [&](const Eigen::Vector3d& end, bool skip_first) {
      const Eigen::Vector3d start = clipToBox(frame.origin, end, box, voxel);
      const double length = (start - frame.origin).norm();
      if (!(length > 0.0)) return;
      const Eigen::Vector3d inwards = (frame.origin - start) / length;
      bool first = skip_first && start == end;
      std::size_t stopped = lattice().size();  // the voxel where the shared walk stopped
      grid.walkRay(start, inwards, length, [&](const VoxelIndex& v, double t) {
        if (first) {
          first = false;
          return true;
        }
        // Counted; beyond exact_range the walk ends if an earlier ray walked on from here.
        const std::size_t index = grid.index(v);
        if (countPass(entry(index)) || length - t < exact_range_) return true;
        stopped = index;
        return false;
      });
      if (stopped == lattice().size() || !(exact_range_ > 0.0)) return;
      // The part within exact_range, in full (the voxel it starts in may be where the walk
      // stopped, already counted).
      const Eigen::Vector3d near = frame.origin - exact_range_ * inwards;
      grid.walkRay(near, inwards, exact_range_, [&](const VoxelIndex& v, double /*t*/) {
        const std::size_t index = grid.index(v);
        if (index != stopped) countPass(entry(index));
        return true;
      });
    };
    for (const Eigen::Vector3d& p : frame.hits) walk(p, true);
    for (const Eigen::Vector3d& p : frame.misses) {
      // Misses lie beyond the range: free space only to it.
      const Eigen::Vector3d d = p - frame.origin;
      walk(frame.origin + std::min(1.0, max_range / d.norm()) * d, false);
    }
    for (const Touched& touched : touched_) {
      float& value = log_odds_[touched.index];
      value = std::clamp(value + (touched.hits >= touched.passes ? hit_ : miss_), low_, high_);
      setState(touched.index, value > threshold_ ? Voxel::kOccupied : Voxel::kFree);
      slot_[touched.index] = 0;
    }
    touched_.clear();
  }

  void doMarkFree(std::size_t index, const Eigen::Vector3d& /*center*/) override {
    log_odds_[index] = std::clamp(miss_, low_, high_);
    setState(index, log_odds_[index] > threshold_ ? Voxel::kOccupied : Voxel::kFree);
  }

 private:
  struct Touched {
    std::size_t index;
    std::uint16_t hits;
    std::uint16_t passes;
  };

  VoxelIndex voxelOf(const Eigen::Vector3d& p) const {
    return ((p - lattice().origin()) / lattice().resolution()).array().floor().cast<int>();
  }

  /// Counts a ray passing through; false when an earlier ray of the frame passed too.
  static bool countPass(Touched& touched) {
    if (touched.passes < UINT16_MAX) ++touched.passes;
    return touched.passes == 1;
  }

  /// This frame's counts of voxel `index`, made on first use.
  Touched& entry(std::size_t index) {
    std::uint32_t& slot = slot_[index];
    if (slot == 0) {
      touched_.push_back({index, 0, 0});
      slot = static_cast<std::uint32_t>(touched_.size());
    }
    return touched_[slot - 1];
  }

  float hit_;
  float miss_;
  float low_;
  float high_;
  float threshold_;
  double exact_range_;
  std::vector<float> log_odds_;
  std::vector<std::uint32_t> slot_;  // 1 + the voxel's place in touched_, 0 when not touched
  std::vector<Touched> touched_;     // the frame's voxels
};

void registerBuiltins() {
  PluginRegistrar registrar("built-in (framework)");
  registrar.add<VehicleMap>(
      "probabilistic",
      "a dense log-odds grid updated by ray casting, each voxel once a frame (the local maps of "
      "Fast-Planner and FIESTA); OctoMap's probabilities by default",
      declareFields<ProbabilisticModel>(), [](const ParameterSet& p) {
        return std::make_unique<ProbabilisticVehicleMap>(readFields<ProbabilisticModel>(p));
      });
  registrar.commit();
}

[[maybe_unused]] const bool builtins_registered = (registerBuiltins(), true);

}  // namespace
}  // namespace kinolab
