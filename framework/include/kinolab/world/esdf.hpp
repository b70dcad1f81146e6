#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "kinolab/world/voxel_grid.hpp"

namespace kinolab {

/// The exact Euclidean signed distance field of a VoxelGrid, in metres, one float per voxel,
/// measured to the voxels' cubes (the obstacles are the occupied cubes, not their centres):
/// at a free voxel the distance from its centre to the nearest occupied cube (half a voxel
/// next to one), at an occupied voxel minus the distance from its centre to the nearest free
/// cube. Computed exactly by separable lower-envelope passes (Felzenszwalb and Huttenlocher,
/// "Distance Transforms of Sampled Functions", 2012) in integer arithmetic (half-voxel
/// units): per axis the offset to a cube k voxels away is max(|k| - 1/2, 0), the lower of two
/// parabolas centred half a voxel either side; linear in the number of voxels. Both distances
/// are found in one pass over each line: a run of voxels of one kind sees only its own entries
/// and the cubes of the other kind at its ends (any entry beyond such a cube is farther than
/// the cube). A grid without any occupied (or any free) voxel stores +maxDistance()
/// (or -maxDistance()), the grid's diagonal.
///
/// Between centres, distance() interpolates trilinearly. That can overstate the distance to
/// the cubes (by up to half a voxel near a cube's corner), so collision tests use
/// clearance(), a proven lower bound of it.
///
/// Points outside the map: every query clamps the point to the box spanned by the voxel
/// centres, so a point outside gets the value at its nearest in-map point, and the gradient
/// component along a clamped axis is zero (a NaN coordinate reads as the map's low side: a
/// value, never an out-of-range read). The map says nothing about space beyond it:
/// planners and the checker reject positions outside `bounds()`.
///
/// A truncated field (truncated(), for sparse worlds) keeps the exact value where it lies
/// within the truncation distance T and +T (-T) where it is farther (deeper): min(max(D, -T),
/// T), D the exact field, bit for bit. It stores 8 x 8 x 8 bricks, only those holding a value
/// strictly between -T and T (the bricks near the obstacles' surfaces); every other brick is one
/// shared brick of +T or of -T. A voxel takes 2 bytes: its squared distance in half voxels (an
/// integer, signed as the value; T is at most 90 voxels), read through a table of the floats
/// the dense field computes from it. The clamped field is 1-Lipschitz, exact where |D| < T and
/// never above D where it is not negative, so clearance() and centreBound() stay proven lower
/// bounds of the distance, and every verdict at a threshold up to T (decided()) is the dense
/// field's.
class Esdf {
 public:
  Esdf() = default;
  /// Builds the field of `grid` on `threads` threads (0: one below kParallelVoxels voxels,
  /// else one per core); the field is the same bit for bit on any number.
  explicit Esdf(const VoxelGrid& grid, int threads = 0);
  /// Grids of fewer voxels are built on one thread by default (starting threads would cost
  /// more than it saves).
  static constexpr std::size_t kParallelVoxels = std::size_t{1} << 20;
  /// Adopts precomputed values, one per voxel in grid order (a view of a world cache file is
  /// not copied).
  Esdf(const VoxelGrid& grid, ValueArray<float> values);
  /// The field of `grid` (either layout) truncated at `truncation` metres (> 0, finite), on
  /// bricks: computed tile by tile (16 x 16 bricks and every height holding an obstacle, with a
  /// margin of the truncation), each tile by the exact transform with every entry past T
  /// dropped after each pass (exact below T: a pass's entry never exceeds the final distance it
  /// leads to), tiles shared over `threads` threads as the constructor; memory for the bricks
  /// near obstacles only.
  static Esdf truncated(const VoxelGrid& grid, double truncation, int threads = 0);

  /// A truncated field from its bricks as brickCodes() gives them (a world cache file's):
  /// per brick of `grid` (x-major, z fastest) `slots` holds -1 for the shared brick of +T, -2
  /// for the one of -T, else the index of its 512 codes in `codes` (viewed where they lie:
  /// a mapped file is not copied). Throws InvalidArgument when they do not fit the grid.
  static Esdf fromBricks(const VoxelGrid& grid, double truncation,
                         std::span<const std::int32_t> slots, ValueArray<std::int16_t> codes);
  /// Bricks of a truncated field (0 for a dense one).
  std::size_t brickCount() const;
  /// A truncated field's brick `index` (x-major, z fastest): its 512 codes (x, y, z within the
  /// brick, z fastest), or null for a shared brick, whose sign `shared` then gives (+1 +T, -1
  /// -T; 0 for a brick of its own).
  const std::int16_t* brickCodes(std::size_t index, int& shared) const;

  /// The truncation distance T of a truncated field; +infinity for a dense one.
  double truncation() const { return truncation_; }
  /// Bricks holding values of their own (a truncated field; 0 for a dense one).
  std::size_t allocatedBricks() const;
  /// Bytes the values take.
  std::size_t memoryBytes() const;

  const Eigen::Vector3i& dims() const { return dims_; }
  double resolution() const { return resolution_; }
  const Eigen::Vector3d& origin() const { return origin_; }
  double maxDistance() const { return max_distance_; }
  /// One value per voxel in grid order: a dense field's only (throws InvalidArgument on a
  /// truncated one: use voxelDistance()).
  std::span<const float> values() const;
  /// Takes the values out of a field no one needs any more (their memory for the next one).
  std::vector<float> release() && { return std::move(values_).release(); }

  /// The stored value of one voxel (by index, or by voxel).
  float voxelDistance(std::size_t index) const {
    if (!brick_table_) return values_[index];
    const auto nz = static_cast<std::size_t>(dims_.z());
    const std::size_t column = index / nz;
    const auto ny = static_cast<std::size_t>(dims_.y());
    return brickValue(column / ny, column % ny, index % nz);
  }
  float voxelDistance(const VoxelIndex& voxel) const {
    return valueAt(static_cast<std::size_t>(voxel.x()), static_cast<std::size_t>(voxel.y()),
                   static_cast<std::size_t>(voxel.z()));
  }

  /// The value of the voxel nearest to `point` (after clamping): a lookup for callers with
  /// finite points (a NaN coordinate reads an in-range voxel; distance() is the checked query).
  double nearestDistance(const Eigen::Vector3d& point) const {
    std::size_t cell[3];
    for (int axis = 0; axis < 3; ++axis) {
      const double scaled = (point[axis] - origin_[axis]) * inverse_resolution_ - 0.5;
      // Clamped to >= 0 first, so truncation rounds to nearest (and needs no libm call);
      // max(0, x) first maps a NaN coordinate to 0, never to an index.
      const double clamped = std::min(std::max(0.0, scaled), upper_[axis]);
      cell[axis] = static_cast<std::size_t>(static_cast<std::int64_t>(clamped + 0.5));
    }
    return valueAt(cell[0], cell[1], cell[2]);
  }

  /// Trilinear interpolation of the voxel-centre values; NaN when a coordinate is not finite
  /// (the index is clamped in range first, so nothing out of range is read).
  double distance(const Eigen::Vector3d& point) const {
    return interpolate<false>(point, nullptr, nullptr);
  }

  /// Trilinear distance and its analytic gradient (metres per metre) from one 8-corner fetch.
  double distanceWithGradient(const Eigen::Vector3d& point, Eigen::Vector3d* gradient) const {
    return interpolate<true>(point, gradient, nullptr);
  }

  /// distance() at every point of `points`, into `distances` (as many): the same values bit for
  /// bit, faster for many points (a dense field's; a truncated one's are taken one at a time).
  /// Two points go through the arithmetic at once, one to a lane of SSE2 pairs, and sixteen
  /// points' corners are requested from memory while the sixteen before them are interpolated,
  /// so that the memory reads of many points overlap (docs/benchmarks.md has the figures).
  /// Throws InvalidArgument on a size mismatch.
  void distances(std::span<const Eigen::Vector3d> points, std::span<double> distances) const;
  /// distanceWithGradient() at every point likewise, into `distances` and `gradients`.
  void distancesWithGradients(std::span<const Eigen::Vector3d> points, std::span<double> distances,
                              std::span<Eigen::Vector3d> gradients) const;

  /// A lower bound of the distance from `point` to every occupied voxel cube (negative inside
  /// one), from the same 8-corner fetch: with I the trilinear value and s^2 = voxel^2 sum_i
  /// t_i (1 - t_i) (t_i the fractions within the cell), sqrt(I^2 - s^2) when I >= s, else
  /// I - s. Proof: the signed distance D to the cubes is 1-Lipschitz and exact at the centres,
  /// so D(p) >= I(p) - sum_j w_j |p - c_j| >= I(p) - s (Jensen), which also shows that I >= s
  /// only outside the obstacles. There, with Q the cube nearest p, I(p) <= sum_j w_j
  /// d_Q(c_j) <= sqrt(sum_j w_j d_Q(c_j)^2) <= sqrt(D(p)^2 + s^2): per axis the weighted mean
  /// of the squared offset to Q over the cell's two corners exceeds its square at p by at most
  /// voxel^2 t_i (1 - t_i). Exact at voxel centres; below I by at most s^2 / I when I >= s
  /// (about s^2 / (2 I) far from obstacles: 1.5 cm at 0.25 m on a 0.1 m grid), by up to
  /// sqrt(3) / 2 voxel next to one. With `distance`, I itself is stored there too.
  double clearance(const Eigen::Vector3d& point, double* distance = nullptr) const {
    double spread = 0.0;
    const double value = interpolate<false>(point, nullptr, &spread);
    if (distance) *distance = value;
    return value >= 0.0 && value * value >= spread ? std::sqrt(value * value - spread)
                                                   : value - std::sqrt(spread);
  }

  /// The distance to the cubes as a verdict at `threshold` needs it, given `bound` =
  /// clearance(point): `bound` when it reaches the threshold, else centreBound() when that
  /// does, else exactDistance() (searched up to `limit`, at least the threshold, stopping at
  /// the first cube nearer than the threshold). So `decided(p, b, t) >= t` exactly when the
  /// true distance is at least t; at or above t the value is a lower bound of the distance
  /// (exact up to `limit` where the cheaper bounds fall short): a larger limit costs a wider
  /// search and gives sphere tracing longer steps.
  double decided(const Eigen::Vector3d& point, double bound, double threshold, double limit) const {
    if (bound >= threshold) return bound;
    const double centres = centreBound(point);
    if (centres >= threshold) return centres;
    // Both bounds are proven: the search skips what the larger shows free.
    return std::max(bound, exactDistanceAbove(point, std::max(limit, threshold), threshold,
                                              std::max(bound, centres)));
  }
  /// Another lower bound of the distance to the cubes, from the same 8 voxel centres c_j as
  /// the trilinear value: max_j D(c_j) - |point - c_j| (D exact at the centres, 1-Lipschitz).
  /// Tight near a centre, where clearance() may still undershoot: a cheap test before
  /// exactDistance().
  double centreBound(const Eigen::Vector3d& point) const;

  /// The exact distance from `point` to the nearest occupied voxel cube when it is below
  /// `limit`, else `limit` (a lower bound of it); in or on a closed occupied cube, a negative
  /// value (minus half a voxel), so a point robot (radius 0) touching a cube collides. The
  /// occupied voxels are those with a negative value; the nearest cube lies within
  /// D(c) + |point - c| of the point (c the nearest voxel centre, where the stored value D is
  /// exact; D is 1-Lipschitz), and those voxels (at most `limit` away) are searched from the
  /// point's voxel outwards, skipping the ball within centreBound(), known free: the shell
  /// between the two bounds: for a distance r, about pi (r / voxel)^2 columns of a few
  /// look-ups each (the whole ball took (r / voxel)^3). On a truncated field a centre value at
  /// +T bounds nothing above, so there the search goes out to `limit` (keep it small: a sparse
  /// world's callers pass at most a few metres).
  /// With `enough` > 0 it returns as soon as it finds a cube nearer than that (a distance below
  /// `enough`, not necessarily the least): a verdict at radius `enough` needs no more.
  double exactDistance(const Eigen::Vector3d& point, double limit, double enough = 0.0) const {
    return exactDistanceAbove(point, limit, enough, centreBound(point));
  }

 private:
  friend class ExactDistanceRun;
  struct Bricks;
  /// The common start of truncated() and fromBricks(): the checks (naming `who`), the
  /// geometry, the code values and a table of +T bricks.
  std::shared_ptr<Bricks> startTruncated(const VoxelGrid& grid, double truncation, const char* who);
  /// Makes `store` this field's bricks.
  void finishTruncated(std::shared_ptr<Bricks> store);
  /// exactDistance() given `lower`, a proven lower bound of the distance (the search skips
  /// the ball it shows free).
  double exactDistanceAbove(const Eigen::Vector3d& point, double limit, double enough,
                            double lower) const;
  /// exactDistanceAbove() with the search over the field's layout.
  template <typename Search>
  double nearestCube(Search search, const Eigen::Vector3d& point, double limit, double enough,
                     double lower) const;
  /// A truncated field's value at voxel (x, y, z) (inside the grid).
  float brickValue(std::size_t x, std::size_t y, std::size_t z) const {
    return code_values_[static_cast<std::uint16_t>(
        brick_table_[(x >> 3) * brick_strides_[0] + (y >> 3) * brick_strides_[1] + (z >> 3)]
                    [((x & 7) << 6) | ((y & 7) << 3) | (z & 7)])];
  }
  /// The value at voxel (x, y, z) (inside the grid), either layout.
  float valueAt(std::size_t x, std::size_t y, std::size_t z) const {
    return brick_table_ ? brickValue(x, y, z)
                        : values_[x * strides_[0] + y * strides_[1] + z * strides_[2]];
  }

  /// The values at the 8 corners of a cell, cXYZ the corner (lower 0, upper 1) per axis.
  struct Corners {
    double c000, c001, c010, c011, c100, c101, c110, c111;
  };
  /// The corners of the cell whose lower corner is voxel `corners` (`base` its dense index).
  /// Always inlined: a step of interpolate(), on the hot path of every query.
  [[gnu::always_inline]] Corners cornerValues(std::size_t base,
                                              const std::size_t corners[3]) const {
    double c000, c001, c010, c011, c100, c101, c110, c111;
    if (!brick_table_) {
      const float* v = values_.data() + base;
      const std::size_t* step = neighbour_step_;
      c000 = v[0];
      c001 = v[step[2]];
      c010 = v[step[1]];
      c011 = v[step[1] + step[2]];
      c100 = v[step[0]];
      c101 = v[step[0] + step[2]];
      c110 = v[step[0] + step[1]];
      c111 = v[step[0] + step[1] + step[2]];
    } else {
      const std::size_t x0 = corners[0];
      const std::size_t y0 = corners[1];
      const std::size_t z0 = corners[2];
      const std::size_t x1 = x0 + unit_step_[0];
      const std::size_t y1 = y0 + unit_step_[1];
      const std::size_t z1 = z0 + unit_step_[2];
      c000 = brickValue(x0, y0, z0);
      c001 = brickValue(x0, y0, z1);
      c010 = brickValue(x0, y1, z0);
      c011 = brickValue(x0, y1, z1);
      c100 = brickValue(x1, y0, z0);
      c101 = brickValue(x1, y0, z1);
      c110 = brickValue(x1, y1, z0);
      c111 = brickValue(x1, y1, z1);
    }
    return {c000, c001, c010, c011, c100, c101, c110, c111};
  }

  /// The trilinear value; with `gradient`, its gradient; with `spread`, voxel^2 sum_i
  /// t_i (1 - t_i) for clearance().
  template <bool kWithGradient>
  double interpolate(const Eigen::Vector3d& point, Eigen::Vector3d* gradient,
                     double* spread) const {
    double fraction[3];
    double scale[3];
    std::size_t corners[3];
    std::size_t base = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double raw = point[axis] * inverse_resolution_ - shift_[axis];
      // max(0, x) first maps a NaN coordinate to 0, never to an index.
      const double scaled = std::min(std::max(0.0, raw), upper_[axis]);
      // Along a clamped axis the field is constant, so that gradient component is zero.
      if constexpr (kWithGradient) scale[axis] = raw == scaled ? gradient_scale_[axis] : 0.0;
      // The lower corner stays one below the last centre so that corner + 1 exists; on a
      // one-voxel axis the step is zero and both corners are the same voxel.
      // scaled >= 0, so truncation is floor (and needs no libm call); converted back from a
      // signed integer, which takes one instruction (an unsigned one takes a branch).
      const auto corner = static_cast<std::int64_t>(std::min(scaled, lower_corner_[axis]));
      fraction[axis] = scaled - static_cast<double>(corner);
      corners[axis] = static_cast<std::size_t>(corner);
      base += corners[axis] * strides_[axis];
    }
    const Corners v = cornerValues(base, corners);
    const double tx = fraction[0];
    const double ty = fraction[1];
    const double tz = fraction[2];
    if (spread) {
      *spread = (tx * (1.0 - tx) + ty * (1.0 - ty) + tz * (1.0 - tz)) * resolution_ * resolution_;
    }
    // Interpolate along z, then y, then x, the two x sides at once (lanes x0, x1 of a pair: the
    // same operations, in the same order, as one side at a time).
    using Pair = double __attribute__((vector_size(16)));
    const Pair a00 = {v.c000, v.c100};
    const Pair a01 = {v.c001, v.c101};
    const Pair a10 = {v.c010, v.c110};
    const Pair a11 = {v.c011, v.c111};
    const Pair dz_low = a01 - a00;       // c001 - c000, c101 - c100
    const Pair dz_high = a11 - a10;      // c011 - c010, c111 - c110
    const Pair e0 = a00 + dz_low * tz;   // c00, c10
    const Pair e1 = a10 + dz_high * tz;  // c01, c11
    const Pair dy = e1 - e0;
    const Pair c = e0 + dy * ty;  // c0, c1
    const double dx = c[1] - c[0];
    if constexpr (kWithGradient) {
      const Pair dz = dz_low + (dz_high - dz_low) * ty;  // dz0, dz1
      (*gradient)[0] = dx * scale[0];
      (*gradient)[1] = (dy[0] + (dy[1] - dy[0]) * tx) * scale[1];
      (*gradient)[2] = (dz[0] + (dz[1] - dz[0]) * tx) * scale[2];
    }
    // x * 0 is 0 for a finite coordinate and NaN otherwise: added last, off the loads' path,
    // so that a point with no position has no distance (the gradient is not poisoned).
    const double poison = point.x() * 0.0 + point.y() * 0.0 + point.z() * 0.0;
    return c[0] + dx * tx + poison;
  }

  /// distances() and distancesWithGradients().
  template <bool kWithGradient>
  void batch(const Eigen::Vector3d* points, std::size_t count, double* distances,
             Eigen::Vector3d* gradients) const;

  void setGeometry(const VoxelGrid& grid);

  static constexpr int kBrickVoxels = VoxelGrid::kBrick * VoxelGrid::kBrick * VoxelGrid::kBrick;

  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double resolution_ = 0.0;
  double inverse_resolution_ = 0.0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double max_distance_ = 0.0;
  double upper_[3] = {0.0, 0.0, 0.0};         // last centre index per axis
  double lower_corner_[3] = {0.0, 0.0, 0.0};  // highest lower-corner index per axis
  double shift_[3] = {0.0, 0.0, 0.0};         // origin / resolution + 1/2
  double gradient_scale_[3] = {0.0, 0.0, 0.0};
  std::size_t strides_[3] = {0, 0, 0};
  std::size_t neighbour_step_[3] = {0, 0, 0};
  std::size_t unit_step_[3] = {0, 0, 0};  // 1 along an axis of more than one voxel
  ValueArray<float> values_;              // a dense field's
  // A truncated field's bricks (immutable, shared by copies) and their table: per brick
  // (x-major, z fastest) a pointer to its 512 codes, x-major, z fastest; a code c (as 16
  // bits) reads code_values_[c].
  std::shared_ptr<const Bricks> bricks_;
  const std::int16_t* const* brick_table_ = nullptr;
  const float* code_values_ = nullptr;
  std::size_t brick_strides_[2] = {0, 0};
  double truncation_ = INFINITY;
};

/// Esdf::exactDistance(point, limit) at points that come in runs (a trajectory's samples, a
/// quarter voxel apart): for each block of kBlock^3 voxels met, the occupied cubes that can be
/// the nearest to some point of it are gathered once, and a point's distance is the least over
/// them, the same value as exactDistance() bit for bit. A voxel whose centre value is D has its
/// nearest cube within D + (its centre's distance to the block's farthest corner) of every
/// point of the block, so the gathered cubes are those that near the block, skipping the ball
/// of radius D about the centre of the block's voxel of largest D (known free) and the 8^3
/// bricks that hold no cube. Of those, a cube is kept only if no neighbour one voxel towards the
/// block is occupied (such a neighbour is never farther from any point of the block): over a
/// floor, the cubes under the block; of a solid column, its first cube each way. In a brick
/// whose occupancy is the same along an axis (a floor's, a wall's, a pillar's), only the layer
/// facing the block is read along that axis: the others are dominated within the brick. Points
/// outside the grid, and blocks whose values bound nothing (no obstacle in the grid, a truncated
/// field at its truncation) take exactDistance() itself.
class ExactDistanceRun {
 public:
  /// The side of a block, in voxels.
  static constexpr std::int64_t kBlock = 4;
  /// `esdf` outlives this object.
  ExactDistanceRun(const Esdf& esdf, double limit) : esdf_(esdf), limit_(limit) {}
  double operator()(const Eigen::Vector3d& point);
  /// Blocks whose cubes were gathered (a count of work, for tests and benchmarks).
  std::size_t gathers() const { return gathers_; }
  /// Cubes kept by all gathers (each tested at every point of its block).
  std::size_t cubesGathered() const { return cubes_gathered_; }
  /// Bricks of 8^3 voxels whose occupancy was read (each at most once while it stays cached).
  std::size_t bricksRead() const { return bricks_read_; }

 private:
  void gather(const std::int64_t block[3]);
  /// The cached words of the 8^3 brick (bx, by, bz): whether it holds an occupied voxel and
  /// along which axes its occupancy is uniform (bits, the first word's lowest four), then its
  /// layers' occupancy masks, as `scan(layers)` reads them on a miss of the small cache.
  template <typename Scan>
  const std::uint64_t* brickOccupancy(std::int64_t bx, std::int64_t by, std::int64_t bz,
                                      const Scan& scan);
  static constexpr std::size_t kBrickCacheSlots = 4096;

  const Esdf& esdf_;
  double limit_;
  std::int64_t block_[3] = {-1, -1, -1};  // the gathered block's first voxel
  bool usable_ = false;                   // the block's gathered cubes answer its points
  std::vector<std::int32_t> cubes_;       // x, y, z of each gathered cube
  std::size_t gathers_ = 0;
  std::size_t cubes_gathered_ = 0;
  std::size_t bricks_read_ = 0;
  std::vector<std::uint64_t> brick_cache_;  // brickOccupancy()'s words, direct-mapped
};

/// An Esdf kept up to date while its grid's occupancy changes (a moving vehicle's planning
/// window): update() visits only the lines of the three separable passes that the change
/// reaches (the x-lines holding a changed voxel, then the y-lines whose pass-1 values changed,
/// then the z-columns whose pass-2 values changed), with the same exact integer arithmetic. A
/// line whose inputs only shrank, or whose entries' minima none of the grown inputs gave, is
/// updated from its changed inputs alone; only the others are transformed anew.
/// The passes' order does not change an exact result, so after every update esdf() equals
/// Esdf(grid()) (z, y, x) bit for bit; the last pass, which has the most lines to redo, runs
/// along contiguous memory. Keeps every pass's result for both signs: 24 bytes a voxel besides
/// the grid and the values.
class IncrementalEsdf {
 public:
  /// The field of `grid`, built in full.
  explicit IncrementalEsdf(VoxelGrid grid);
  /// Builds the field of another grid in full, in this one's memory where it is large enough
  /// (a flight's window moved: the same size elsewhere).
  void rebuild(VoxelGrid grid);

  /// Makes `occupancy` (one byte a voxel, 0 free, else occupied, in grid order) the grid's,
  /// updating the field where it changes; returns how many voxels changed occupancy.
  std::size_t update(const std::vector<std::uint8_t>& occupancy);

  const VoxelGrid& grid() const { return grid_; }
  /// The current field (a copy), in `memory` when it is large enough (the values of a field
  /// no one needs any more, Esdf::release()).
  Esdf esdf(std::vector<float> memory = {}) const {
    memory.assign(values_.begin(), values_.end());
    return Esdf(grid_, std::move(memory));
  }
  /// Lines of the passes transformed in full since construction (a count of work, for tests
  /// and benchmarks; lines updated from their changed inputs alone do not count); a full build
  /// is columns + y-lines + x-lines, twice.
  std::size_t linesRecomputed() const { return lines_; }

 private:
  VoxelGrid grid_;
  // Per sign (0: to the occupied cubes, 1: to the free ones) the result of each pass.
  std::vector<std::int32_t> pass_[2][3];
  std::vector<float> values_;
  std::size_t lines_ = 0;
};

}  // namespace kinolab
