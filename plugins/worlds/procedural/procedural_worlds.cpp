// The procedural world generators: empty, forest, boxes, walls (a maze of walls with gaps),
// box_list and city. The OctoMap file generator is plugins/worlds/octomap.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>

#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/world_generator.hpp"

namespace kinolab {

namespace {

constexpr double kMaxLength = 1e4;  // metres; anything larger is surely a typo

using Interval = std::array<double, 2>;

Interval intervalOf(const ParameterSet& parameters, std::string_view name) {
  const std::vector<double>& values = parameters.reals(name);
  return {values[0], values[1]};
}

Eigen::Vector3d pointOf(const ParameterSet& parameters, std::string_view name) {
  const std::vector<double>& values = parameters.reals(name);
  return {values[0], values[1], values[2]};
}

/// An optional horizontal sub-rectangle of the bounds that a generator fills.
struct Region {
  bool given = false;
  Eigen::Vector2d min = Eigen::Vector2d::Zero();
  Eigen::Vector2d max = Eigen::Vector2d::Zero();

  static ParameterSpecs declared() {
    return ParameterSpecs()
        .interval("x", {-kMaxLength, kMaxLength}, -kMaxLength, kMaxLength, "x extent, m")
        .interval("y", {-kMaxLength, kMaxLength}, -kMaxLength, kMaxLength, "y extent, m");
  }
  static Region of(const ParameterSet& parameters) {
    Region region;
    region.given = parameters.boolean("region");
    const ParameterSet& inner = parameters.nested("region");
    const Interval x = intervalOf(inner, "x");
    const Interval y = intervalOf(inner, "y");
    region.min = {x[0], y[0]};
    region.max = {x[1], y[1]};
    return region;
  }
  /// The region clipped to the grid.
  std::pair<Eigen::Vector2d, Eigen::Vector2d> within(const Box& bounds) const {
    Eigen::Vector2d low = bounds.min.head<2>();
    Eigen::Vector2d high = bounds.max.head<2>();
    if (given) {
      low = low.cwiseMax(min);
      high = high.cwiseMin(max);
    }
    return {low, high};
  }
};

ParameterSpecs withRegion(ParameterSpecs specs) {
  return specs.group(
      "region", Region::declared(),
      "fill only this horizontal rectangle of the bounds: {x: [lo, hi], y: [lo, hi]}");
}

/// Marks voxels whose centres lie in a vertical cylinder.
void fillCylinder(VoxelGrid& grid, const Eigen::Vector2d& center, double radius, double z_low,
                  double z_high) {
  const Eigen::Vector3d low(center.x() - radius, center.y() - radius, z_low);
  const Eigen::Vector3d high(center.x() + radius, center.y() + radius, z_high);
  Eigen::Vector3i first;
  Eigen::Vector3i last;
  if (!grid.voxelRange(low, high, first, last)) return;
  const double radius_squared = radius * radius;
  for (int ix = first.x(); ix <= last.x(); ++ix) {
    for (int iy = first.y(); iy <= last.y(); ++iy) {
      const Eigen::Vector3d c = grid.center({ix, iy, 0});
      if ((c.head<2>() - center).squaredNorm() > radius_squared) continue;
      for (int iz = first.z(); iz <= last.z(); ++iz) grid.setOccupied(VoxelIndex(ix, iy, iz), true);
    }
  }
}

class EmptyGenerator final : public WorldGenerator {
 public:
  explicit EmptyGenerator(const ParameterSet&) {}
  void apply(VoxelGrid&, Rng&) const override {}
};

/// Tree trunks as vertical cylinders standing on the floor of the bounds, optional disc
/// canopies at their tops, and an optional ground plane.
class ForestGenerator final : public WorldGenerator {
 public:
  static ParameterSpecs declared() {
    return withRegion(
        ParameterSpecs()
            .real("density", 0.05, 0.0, 10.0, "trees per square metre")
            .interval("trunk_radius", {0.15, 0.3}, 0.0, 100.0, "trunk radius range, m")
            .interval("trunk_height", {4.0, 6.0}, 0.0, kMaxLength, "trunk height range, m")
            .real("min_spacing", 1.0, 0.0, kMaxLength, "least gap between trunks, m")
            .boolean("ground_plane", true, "the lowest voxel layer occupied")
            .group("canopy",
                   ParameterSpecs()
                       .real("probability", 0.5, 0.0, 1.0, "share of trees with a canopy")
                       .interval("radius", {0.8, 1.5}, 0.0, 100.0, "canopy radius range, m")
                       .interval("thickness", {0.4, 1.0}, 0.0, 100.0, "canopy thickness range, m"),
                   "disc canopies at the trunk tops: {probability, radius, thickness}"));
  }
  explicit ForestGenerator(const ParameterSet& p)
      : density_(p.real("density")),
        trunk_radius_(intervalOf(p, "trunk_radius")),
        trunk_height_(intervalOf(p, "trunk_height")),
        min_spacing_(p.real("min_spacing")),
        ground_plane_(p.boolean("ground_plane")),
        region_(Region::of(p)),
        has_canopy_(p.boolean("canopy")),
        canopy_probability_(p.nested("canopy").real("probability")),
        canopy_radius_(intervalOf(p.nested("canopy"), "radius")),
        canopy_thickness_(intervalOf(p.nested("canopy"), "thickness")) {}
  void apply(VoxelGrid& grid, Rng& rng) const override {
    const Box bounds = grid.bounds();
    const auto [low, high] = region_.within(bounds);
    const Eigen::Vector2d extent = (high - low).cwiseMax(0.0);
    const auto target = static_cast<std::size_t>(std::llround(density_ * extent.prod()));
    struct Trunk {
      Eigen::Vector2d center;
      double radius;
    };
    std::vector<Trunk> trunks;
    // Dart throwing: a bounded number of attempts keeps dense requests finite; the result
    // depends only on the seed.
    const std::size_t attempts = 30 * target + 100;
    for (std::size_t attempt = 0; attempt < attempts && trunks.size() < target; ++attempt) {
      const auto center = drawLastFirst<Eigen::Vector2d>(
          [&, &low = low, &high = high](int i) { return rng.uniform(low[i], high[i]); });
      const double radius = rng.uniform(trunk_radius_[0], trunk_radius_[1]);
      const bool clear = std::all_of(trunks.begin(), trunks.end(), [&](const Trunk& other) {
        const double gap = radius + other.radius + min_spacing_;
        return (other.center - center).squaredNorm() >= gap * gap;
      });
      if (clear) trunks.push_back({center, radius});
    }
    const double floor = bounds.min.z();
    for (const Trunk& trunk : trunks) {
      const double height = rng.uniform(trunk_height_[0], trunk_height_[1]);
      fillCylinder(grid, trunk.center, trunk.radius, floor, floor + height);
      if (has_canopy_ && rng.uniform01() < canopy_probability_) {
        const double radius = rng.uniform(canopy_radius_[0], canopy_radius_[1]);
        const double thickness = rng.uniform(canopy_thickness_[0], canopy_thickness_[1]);
        fillCylinder(grid, trunk.center, radius, floor + height - thickness, floor + height);
      }
    }
    if (ground_plane_) {
      // The lowest layer of voxels: its centres are half a voxel up, the next layer's a voxel
      // and a half, so a bound of one voxel picks exactly one layer without rounding doubts.
      grid.fillBox(bounds.min, {bounds.max.x(), bounds.max.y(), floor + grid.resolution()});
    }
  }

 private:
  double density_;
  Interval trunk_radius_;
  Interval trunk_height_;
  double min_spacing_;
  bool ground_plane_;
  Region region_;
  bool has_canopy_;
  double canopy_probability_;
  Interval canopy_radius_;
  Interval canopy_thickness_;
};

/// Random axis-aligned boxes, standing on the floor or floating.
class BoxesGenerator final : public WorldGenerator {
 public:
  static ParameterSpecs declared() {
    return withRegion(ParameterSpecs()
                          .integer("count", 20, 0, 1000000, "number of boxes")
                          .interval("size_x", {0.5, 2.0}, 0.0, kMaxLength, "x size range, m")
                          .interval("size_y", {0.5, 2.0}, 0.0, kMaxLength, "y size range, m")
                          .interval("size_z", {0.5, 3.0}, 0.0, kMaxLength, "z size range, m")
                          .boolean("on_ground", true, "standing on the floor (else floating)"));
  }
  explicit BoxesGenerator(const ParameterSet& p)
      : count_(p.integer("count")),
        size_x_(intervalOf(p, "size_x")),
        size_y_(intervalOf(p, "size_y")),
        size_z_(intervalOf(p, "size_z")),
        on_ground_(p.boolean("on_ground")),
        region_(Region::of(p)) {}
  void apply(VoxelGrid& grid, Rng& rng) const override {
    const Box bounds = grid.bounds();
    const auto [low, high] = region_.within(bounds);
    for (long long i = 0; i < count_; ++i) {
      const auto size = drawLastFirst<Eigen::Vector3d>([&](int axis) {
        const auto& range = axis == 0 ? size_x_ : (axis == 1 ? size_y_ : size_z_);
        return rng.uniform(range[0], range[1]);
      });
      const auto center = drawLastFirst<Eigen::Vector2d>(
          [&, &low = low, &high = high](int axis) { return rng.uniform(low[axis], high[axis]); });
      const double z_low =
          on_ground_ ? bounds.min.z() : rng.uniform(bounds.min.z(), bounds.max.z() - size.z());
      const Eigen::Vector3d min(center.x() - 0.5 * size.x(), center.y() - 0.5 * size.y(), z_low);
      grid.fillBox(min, min + size);
    }
  }

 private:
  long long count_;
  Interval size_x_;
  Interval size_y_;
  Interval size_z_;
  bool on_ground_;
  Region region_;
};

/// A maze of walls with gaps: the region is cut into square cells, a random spanning tree
/// of the cells (depth-first carving) decides which walls get a gap, and a fraction of the
/// remaining walls get one too so that there are loops. A gap is a doorway of `gap_width`
/// at a random place along the wall, or the whole wall when the gap is wider than a cell.
class WallsGenerator final : public WorldGenerator {
 public:
  static ParameterSpecs declared() {
    return withRegion(
        ParameterSpecs()
            .real("cell_size", 4.0, 0.1, kMaxLength, "side of the maze's square cells, m")
            .real("thickness", 0.3, 0.0, kMaxLength, "wall thickness, m")
            .interval("height", {3.0, 3.0}, 0.0, kMaxLength, "wall height range, m")
            .real("gap_width", 1.5, 0.0, kMaxLength, "doorway width, m")
            .real("extra_openings", 0.2, 0.0, 1.0, "share of the other walls given a gap too")
            .boolean("border", false, "closed walls around the region"));
  }
  explicit WallsGenerator(const ParameterSet& p)
      : cell_size_(p.real("cell_size")),
        thickness_(p.real("thickness")),
        height_(intervalOf(p, "height")),
        gap_width_(p.real("gap_width")),
        extra_openings_(p.real("extra_openings")),
        border_(p.boolean("border")),
        region_(Region::of(p)) {}
  void apply(VoxelGrid& grid, Rng& rng) const override {
    const Box bounds = grid.bounds();
    const auto [low, high] = region_.within(bounds);
    const int cells_x = std::max(1, static_cast<int>((high.x() - low.x()) / cell_size_));
    const int cells_y = std::max(1, static_cast<int>((high.y() - low.y()) / cell_size_));
    const Eigen::Vector2d cell((high.x() - low.x()) / cells_x, (high.y() - low.y()) / cells_y);

    const int vertical = (cells_x - 1) * cells_y;
    const std::vector<bool> open = mazeOpenings(cells_x, cells_y, rng);

    const double floor = bounds.min.z();
    const double half = 0.5 * thickness_;
    // A wall segment from `a` to `b` (axis-aligned in xy), with an optional doorway.
    auto buildWall = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool with_gap) {
      const double height = rng.uniform(height_[0], height_[1]);
      const int along = a.x() == b.x() ? 1 : 0;
      const double length = b[along] - a[along];
      std::vector<std::pair<double, double>> pieces{{a[along], b[along]}};
      if (with_gap) {
        if (gap_width_ >= length) {
          pieces.clear();
        } else {
          const double start = a[along] + rng.uniform(0.0, length - gap_width_);
          pieces = {{a[along], start}, {start + gap_width_, b[along]}};
        }
      }
      for (const auto& [from, to] : pieces) {
        Eigen::Vector3d min(a.x() - half, a.y() - half, floor);
        Eigen::Vector3d max(a.x() + half, a.y() + half, floor + height);
        min[along] = from - half;
        max[along] = to + half;
        grid.fillBox(min, max);
      }
    };
    for (int j = 0; j < cells_y; ++j) {
      for (int i = 0; i + 1 < cells_x; ++i) {
        const double x = low.x() + (i + 1) * cell.x();
        buildWall({x, low.y() + j * cell.y()}, {x, low.y() + (j + 1) * cell.y()},
                  open[static_cast<std::size_t>(j * (cells_x - 1) + i)]);
      }
    }
    for (int j = 0; j + 1 < cells_y; ++j) {
      for (int i = 0; i < cells_x; ++i) {
        const double y = low.y() + (j + 1) * cell.y();
        buildWall({low.x() + i * cell.x(), y}, {low.x() + (i + 1) * cell.x(), y},
                  open[static_cast<std::size_t>(vertical + j * cells_x + i)]);
      }
    }
    if (border_) {
      buildWall({low.x(), low.y()}, {high.x(), low.y()}, false);
      buildWall({low.x(), high.y()}, {high.x(), high.y()}, false);
      buildWall({low.x(), low.y()}, {low.x(), high.y()}, false);
      buildWall({high.x(), low.y()}, {high.x(), high.y()}, false);
    }
  }

 private:
  /// Which interior walls get a gap: vertical walls between cells (i, j) and (i + 1, j) first
  /// (index j (cells_x - 1) + i), then horizontal ones between (i, j) and (i, j + 1). A random
  /// spanning tree of the cells (depth-first carving) opens one wall per tree edge, then each
  /// closed wall opens with probability extra_openings, so that there are loops.
  std::vector<bool> mazeOpenings(int cells_x, int cells_y, Rng& rng) const {
    const int vertical = (cells_x - 1) * cells_y;
    const int horizontal = cells_x * (cells_y - 1);
    std::vector<bool> open(static_cast<std::size_t>(vertical + horizontal), false);
    auto cellId = [&](int i, int j) { return j * cells_x + i; };
    std::vector<bool> visited(static_cast<std::size_t>(cells_x * cells_y), false);
    std::vector<std::pair<int, int>> stack{{0, 0}};
    visited[0] = true;
    while (!stack.empty()) {
      const auto [i, j] = stack.back();
      // (neighbour i, neighbour j, wall id)
      std::vector<std::array<int, 3>> options;
      if (i > 0 && !visited[cellId(i - 1, j)])
        options.push_back({i - 1, j, j * (cells_x - 1) + i - 1});
      if (i + 1 < cells_x && !visited[cellId(i + 1, j)])
        options.push_back({i + 1, j, j * (cells_x - 1) + i});
      if (j > 0 && !visited[cellId(i, j - 1)])
        options.push_back({i, j - 1, vertical + (j - 1) * cells_x + i});
      if (j + 1 < cells_y && !visited[cellId(i, j + 1)])
        options.push_back({i, j + 1, vertical + j * cells_x + i});
      if (options.empty()) {
        stack.pop_back();
        continue;
      }
      const auto& pick = options[static_cast<std::size_t>(
          rng.uniformInt(0, static_cast<std::int64_t>(options.size()) - 1))];
      open[static_cast<std::size_t>(pick[2])] = true;
      visited[cellId(pick[0], pick[1])] = true;
      stack.push_back({pick[0], pick[1]});
    }
    for (std::size_t w = 0; w < open.size(); ++w) {
      if (!open[w] && rng.uniform01() < extra_openings_) open[w] = true;
    }
    return open;
  }

  double cell_size_;
  double thickness_;
  Interval height_;
  double gap_width_;
  double extra_openings_;
  bool border_;
  Region region_;
};

/// Explicit boxes, e.g. overhangs, bridges or a ceiling: `boxes: [{min: [..], max: [..]}]`.
class BoxListGenerator final : public WorldGenerator {
 public:
  static ParameterSpecs declared() {
    return ParameterSpecs()
        .groupList("boxes",
                   ParameterSpecs()
                       .reals("min", {0.0, 0.0, 0.0}, -kMaxLength, kMaxLength, 3,
                              "low corner [x, y, z], m")
                       .required()
                       .reals("max", {0.0, 0.0, 0.0}, -kMaxLength, kMaxLength, 3,
                              "high corner [x, y, z], m")
                       .required(),
                   "the boxes: [{min: [x, y, z], max: [x, y, z]}, ...]")
        .required();
  }
  explicit BoxListGenerator(const ParameterSet& p) {
    for (const ParameterSet* item : p.items("boxes")) {
      const Box box{pointOf(*item, "min"), pointOf(*item, "max")};
      if ((box.max.array() < box.min.array()).any()) {
        throw ParameterConflict("boxes", "box " + std::to_string(boxes_.size()) +
                                             ": expected min " + "<= max per axis, got min " +
                                             formatPoint(box.min) + " and max " +
                                             formatPoint(box.max));
      }
      boxes_.push_back(box);
    }
  }
  void apply(VoxelGrid& grid, Rng&) const override {
    double writes = 0.0;
    for (const Box& box : boxes_) writes += grid.fillCost(box.min, box.max);
    if (writes > kMaxWrites) {
      throw ParameterConflict("boxes", std::to_string(boxes_.size()) + " boxes fill about " +
                                           formatNumber(writes) +
                                           " voxels in this grid (overlaps "
                                           "counted each time); at most " +
                                           formatNumber(kMaxWrites) +
                                           " (fewer or smaller boxes, or a coarser resolution)");
    }
    for (const Box& box : boxes_) grid.fillBox(box.min, box.max);
  }

 private:
  /// The voxel writes (overlaps counted each time) a box list may make, refused before any.
  static constexpr double kMaxWrites = 1e10;
  std::vector<Box> boxes_;
};

/// A city: a street grid cutting the region into blocks, each block cut into lots that carry a
/// building (a box of random height, set back from the lot's edges, so that alleys run between
/// neighbours) or stay open squares, and street trees (trunks with disc canopies) along the
/// sidewalks. Streets, alleys and squares are free from the ground up; buildings are solid to
/// their roofs, as a height map of a city (or a photogrammetry mesh filled in) gives them.
class CityGenerator final : public WorldGenerator {
 public:
  static ParameterSpecs declared() {
    return withRegion(
        ParameterSpecs()
            .interval("block_size", {40.0, 80.0}, 2.0, kMaxLength,
                      "side of a block between streets (drawn per row and column), m")
            .real("street_width", 15.0, 0.0, kMaxLength, "width of a street between blocks, m")
            .interval("lot_size", {12.0, 30.0}, 2.0, kMaxLength,
                      "side of a lot: a block is cut into columns of lots of random widths, each "
                      "column into lots of random depths, m")
            .real("setback", 2.0, 0.0, kMaxLength,
                  "a building's distance from its lot's edges (an alley between neighbours is "
                  "twice this), m")
            .interval("building_height", {8.0, 60.0}, 0.0, kMaxLength,
                      "building height range (uniform), m")
            .real("building_probability", 0.85, 0.0, 1.0,
                  "share of lots with a building (the others are open squares)")
            .real("tree_spacing", 12.0, 0.0, kMaxLength,
                  "street trees along every block's sidewalks this far apart (0: none), m")
            .real("tree_offset", 2.5, 0.0, kMaxLength,
                  "a street tree's distance from its block's edge, into the street, m")
            .interval("trunk_radius", {0.15, 0.3}, 0.0, 100.0, "street tree trunk radius range, m")
            .interval("tree_height", {5.0, 10.0}, 0.0, kMaxLength,
                      "street tree height range (to the canopy's top), m")
            .interval("canopy_radius", {1.5, 3.0}, 0.0, 100.0, "canopy radius range, m")
            .interval("canopy_thickness", {1.5, 3.0}, 0.0, 100.0, "canopy thickness range, m")
            .boolean("ground_plane", true, "the lowest voxel layer occupied"));
  }
  explicit CityGenerator(const ParameterSet& p)
      : block_size_(intervalOf(p, "block_size")),
        street_width_(p.real("street_width")),
        lot_size_(intervalOf(p, "lot_size")),
        setback_(p.real("setback")),
        building_height_(intervalOf(p, "building_height")),
        building_probability_(p.real("building_probability")),
        tree_spacing_(p.real("tree_spacing")),
        tree_offset_(p.real("tree_offset")),
        trunk_radius_(intervalOf(p, "trunk_radius")),
        tree_height_(intervalOf(p, "tree_height")),
        canopy_radius_(intervalOf(p, "canopy_radius")),
        canopy_thickness_(intervalOf(p, "canopy_thickness")),
        ground_plane_(p.boolean("ground_plane")),
        region_(Region::of(p)) {
    if (tree_spacing_ > 0.0 && tree_spacing_ < kMinTreeSpacing) {
      throw ParameterConflict("tree_spacing", "expected 0 (no street trees) or at least " +
                                                  formatNumber(kMinTreeSpacing) + " m, got " +
                                                  formatNumber(tree_spacing_));
    }
  }

  void apply(VoxelGrid& grid, Rng& rng) const override {
    const Box bounds = grid.bounds();
    const auto [low, high] = region_.within(bounds);
    const double floor = bounds.min.z();
    refuseUnboundedWork((high - low).cwiseMax(0.0));
    // Blocks: rows and columns of random widths with a street after each.
    const std::vector<Interval> columns = cut(low.x(), high.x(), block_size_, street_width_, rng);
    const std::vector<Interval> rows = cut(low.y(), high.y(), block_size_, street_width_, rng);
    for (const Interval& bx : columns) {
      for (const Interval& by : rows) {
        // Lots: the block cut without gaps; a building keeps `setback` from its lot's edges.
        for (const Interval& lx : cut(bx[0], bx[1], lot_size_, 0.0, rng)) {
          for (const Interval& ly : cut(by[0], by[1], lot_size_, 0.0, rng)) {
            if (rng.uniform01() >= building_probability_) continue;
            const double height = rng.uniform(building_height_[0], building_height_[1]);
            const Eigen::Vector3d min(lx[0] + setback_, ly[0] + setback_, floor);
            const Eigen::Vector3d max(lx[1] - setback_, ly[1] - setback_, floor + height);
            if ((max.array() > min.array()).all()) grid.fillBox(min, max);
          }
        }
        if (tree_spacing_ > 0.0) plantStreetTrees(grid, bx, by, {low, high}, floor, rng);
      }
    }
    if (ground_plane_) {
      // The lowest layer of voxels (as the forest's).
      grid.fillBox(bounds.min, {bounds.max.x(), bounds.max.y(), floor + grid.resolution()});
    }
  }

 private:
  static constexpr double kMinTreeSpacing = 0.5;  ///< m
  static constexpr double kMaxPieces = 1e7;       ///< lots, and street trees, a world may have

  static std::string count(double value) { return std::to_string(std::llround(value)); }

  /// Refuses a region of `extent` (m) that could hold more than kMaxPieces lots or street
  /// trees (each a box or two cylinders to fill), with the estimate, before any is made.
  void refuseUnboundedWork(const Eigen::Vector2d& extent) const {
    // Per axis: a lot of at least lot_size[0] but the last of each block (every block has one).
    const double rows = std::ceil(extent.y() / (block_size_[0] + street_width_)) + 1.0;
    const double columns = std::ceil(extent.x() / (block_size_[0] + street_width_)) + 1.0;
    const double lots = (std::ceil(extent.x() / lot_size_[0]) + columns) *
                        (std::ceil(extent.y() / lot_size_[0]) + rows);
    if (lots > kMaxPieces) {
      throw ParameterConflict("lot_size", "up to " + count(lots) + " lots of " +
                                              formatNumber(lot_size_[0]) + " m in a region of " +
                                              formatNumber(extent.x()) + " x " +
                                              formatNumber(extent.y()) + " m; at most " +
                                              count(kMaxPieces) + " (larger lots)");
    }
    if (tree_spacing_ <= 0.0) return;
    // Every block side gets at most its length / spacing + 1 trees on each of its two sides.
    const double trees = 2.0 * rows * (extent.x() / tree_spacing_ + columns) +
                         2.0 * columns * (extent.y() / tree_spacing_ + rows);
    if (trees > kMaxPieces) {
      throw ParameterConflict("tree_spacing", "up to " + count(trees) + " street trees; at most " +
                                                  count(kMaxPieces) +
                                                  " (wider spacing or larger blocks)");
    }
  }

  /// [from, to] cut into pieces of random length in `size` with `gap` after each, in order;
  /// the last one cut off at `to` (as a city is at the edge of a map).
  static std::vector<Interval> cut(double from, double to, const Interval& size, double gap,
                                   Rng& rng) {
    std::vector<Interval> pieces;
    for (double at = from; at < to;) {
      const double end = std::min(to, at + rng.uniform(size[0], size[1]));
      pieces.push_back({at, end});
      at = end + gap;
    }
    return pieces;
  }

  /// Trees along the four sides of the block [bx] x [by], `tree_offset` out into the street,
  /// `tree_spacing` apart, starting half a spacing from each corner; not beyond `region`.
  void plantStreetTrees(VoxelGrid& grid, const Interval& bx, const Interval& by,
                        const std::pair<Eigen::Vector2d, Eigen::Vector2d>& region, double floor,
                        Rng& rng) const {
    const auto plant = [&](const Eigen::Vector2d& at) {
      if ((at.array() < region.first.array()).any() || (at.array() > region.second.array()).any()) {
        return;
      }
      const double radius = rng.uniform(trunk_radius_[0], trunk_radius_[1]);
      const double height = rng.uniform(tree_height_[0], tree_height_[1]);
      const double canopy = rng.uniform(canopy_radius_[0], canopy_radius_[1]);
      const double thickness = rng.uniform(canopy_thickness_[0], canopy_thickness_[1]);
      fillCylinder(grid, at, radius, floor, floor + height);
      fillCylinder(grid, at, canopy, floor + std::max(0.0, height - thickness), floor + height);
    };
    const double x0 = bx[0] - tree_offset_;
    const double x1 = bx[1] + tree_offset_;
    const double y0 = by[0] - tree_offset_;
    const double y1 = by[1] + tree_offset_;
    for (double x = bx[0] + 0.5 * tree_spacing_; x < bx[1]; x += tree_spacing_) {
      plant({x, y0});
      plant({x, y1});
    }
    for (double y = by[0] + 0.5 * tree_spacing_; y < by[1]; y += tree_spacing_) {
      plant({x0, y});
      plant({x1, y});
    }
  }

  Interval block_size_;
  double street_width_;
  Interval lot_size_;
  double setback_;
  Interval building_height_;
  double building_probability_;
  double tree_spacing_;
  double tree_offset_;
  Interval trunk_radius_;
  Interval tree_height_;
  Interval canopy_radius_;
  Interval canopy_thickness_;
  bool ground_plane_;
  Region region_;
};

template <typename Generator>
PluginFactory<WorldGenerator> factoryOf() {
  return [](const ParameterSet& parameters) { return std::make_unique<Generator>(parameters); };
}

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<WorldGenerator>("empty", "nothing (free space)", ParameterSpecs(),
                                factoryOf<EmptyGenerator>());
  registrar.add<WorldGenerator>(
      "forest", "tree trunks as vertical cylinders, optional canopies and ground plane",
      ForestGenerator::declared(), factoryOf<ForestGenerator>());
  registrar.add<WorldGenerator>("boxes", "random axis-aligned boxes", BoxesGenerator::declared(),
                                factoryOf<BoxesGenerator>());
  registrar.add<WorldGenerator>("walls", "a maze of walls with gaps (corridors)",
                                WallsGenerator::declared(), factoryOf<WallsGenerator>());
  registrar.add<WorldGenerator>("box_list", "explicit boxes (overhangs, bridges, ceilings)",
                                BoxListGenerator::declared(), factoryOf<BoxListGenerator>());
  registrar.add<WorldGenerator>(
      "city", "a street grid of blocks of buildings of varied heights, with street trees",
      CityGenerator::declared(), factoryOf<CityGenerator>());
}
