// The built-in world generators: empty, forest, boxes, walls (a maze of walls with gaps) and
// box_list. The OctoMap generator lives in octomap_generator.cpp.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>

#include "kinolab/core/error.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/world/world_generator.hpp"

namespace kinolab {

std::unique_ptr<WorldGenerator> makeOctomapGenerator(const YamlReader& entry,
                                                     const std::string& spec_directory);

namespace {

constexpr double kMaxLength = 1e4;  // metres; anything larger is surely a typo

using Interval = std::array<double, 2>;

void writeValue(std::ostream& out, const char* key, double value) {
  out << ' ' << key << '=' << std::hexfloat << value << std::defaultfloat;
}
void writeValue(std::ostream& out, const char* key, const Interval& value) {
  out << ' ' << key << '=' << std::hexfloat << value[0] << ',' << value[1] << std::defaultfloat;
}
void writeValue(std::ostream& out, const char* key, const Eigen::Vector3d& value) {
  out << ' ' << key << '=' << std::hexfloat << value.x() << ',' << value.y() << ',' << value.z()
      << std::defaultfloat;
}

Eigen::Vector3d toVector(const std::array<double, 3>& value) {
  return {value[0], value[1], value[2]};
}

/// An optional horizontal sub-rectangle of the bounds that a generator fills.
struct Region {
  bool given = false;
  Eigen::Vector2d min = Eigen::Vector2d::Zero();
  Eigen::Vector2d max = Eigen::Vector2d::Zero();

  static Region read(const YamlReader& entry) {
    Region region;
    if (auto node = entry.optional("region")) {
      const auto low = node->getInterval("x", std::nullopt, -kMaxLength, kMaxLength);
      const auto high = node->getInterval("y", std::nullopt, -kMaxLength, kMaxLength);
      node->finish();
      region.given = true;
      region.min = {low[0], high[0]};
      region.max = {low[1], high[1]};
    }
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
  void write(std::ostream& out) const {
    if (given) {
      writeValue(out, "region_min", Eigen::Vector3d(min.x(), min.y(), 0.0));
      writeValue(out, "region_max", Eigen::Vector3d(max.x(), max.y(), 0.0));
    }
  }
};

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
      for (int iz = first.z(); iz <= last.z(); ++iz) grid.setOccupied(grid.index(ix, iy, iz), true);
    }
  }
}

class EmptyGenerator final : public WorldGenerator {
 public:
  explicit EmptyGenerator(const YamlReader& entry) { entry.finish(); }
  std::string type() const override { return "empty"; }
  void writeCanonical(std::ostream& out) const override { out << "empty"; }
  void apply(VoxelGrid&, Rng&) const override {}
};

/// Tree trunks as vertical cylinders standing on the floor of the bounds, optional disc
/// canopies at their tops, and an optional ground plane.
class ForestGenerator final : public WorldGenerator {
 public:
  explicit ForestGenerator(const YamlReader& entry)
      : density_(entry.getNumber("density", 0.05, 0.0, 10.0)),
        trunk_radius_(entry.getInterval("trunk_radius", Interval{0.15, 0.3}, 0.0, 100.0)),
        trunk_height_(entry.getInterval("trunk_height", Interval{4.0, 6.0}, 0.0, kMaxLength)),
        min_spacing_(entry.getNumber("min_spacing", 1.0, 0.0, kMaxLength)),
        ground_plane_(entry.get<bool>("ground_plane", true)),
        region_(Region::read(entry)) {
    if (auto canopy = entry.optional("canopy")) {
      has_canopy_ = true;
      canopy_probability_ = canopy->getNumber("probability", 0.5, 0.0, 1.0);
      canopy_radius_ = canopy->getInterval("radius", Interval{0.8, 1.5}, 0.0, 100.0);
      canopy_thickness_ = canopy->getInterval("thickness", Interval{0.4, 1.0}, 0.0, 100.0);
      canopy->finish();
    }
    entry.finish();
  }
  std::string type() const override { return "forest"; }
  void writeCanonical(std::ostream& out) const override {
    out << "forest";
    writeValue(out, "density", density_);
    writeValue(out, "trunk_radius", trunk_radius_);
    writeValue(out, "trunk_height", trunk_height_);
    writeValue(out, "min_spacing", min_spacing_);
    out << " ground_plane=" << ground_plane_;
    if (has_canopy_) {
      writeValue(out, "canopy_probability", canopy_probability_);
      writeValue(out, "canopy_radius", canopy_radius_);
      writeValue(out, "canopy_thickness", canopy_thickness_);
    }
    region_.write(out);
  }
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
      const Eigen::Vector2d center(rng.uniform(low.x(), high.x()), rng.uniform(low.y(), high.y()));
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
  bool has_canopy_ = false;
  double canopy_probability_ = 0.0;
  Interval canopy_radius_{0.0, 0.0};
  Interval canopy_thickness_{0.0, 0.0};
};

/// Random axis-aligned boxes, standing on the floor or floating.
class BoxesGenerator final : public WorldGenerator {
 public:
  explicit BoxesGenerator(const YamlReader& entry)
      : count_(entry.getInteger("count", 20, 0, 1000000)),
        size_x_(entry.getInterval("size_x", Interval{0.5, 2.0}, 0.0, kMaxLength)),
        size_y_(entry.getInterval("size_y", Interval{0.5, 2.0}, 0.0, kMaxLength)),
        size_z_(entry.getInterval("size_z", Interval{0.5, 3.0}, 0.0, kMaxLength)),
        on_ground_(entry.get<bool>("on_ground", true)),
        region_(Region::read(entry)) {
    entry.finish();
  }
  std::string type() const override { return "boxes"; }
  void writeCanonical(std::ostream& out) const override {
    out << "boxes count=" << count_;
    writeValue(out, "size_x", size_x_);
    writeValue(out, "size_y", size_y_);
    writeValue(out, "size_z", size_z_);
    out << " on_ground=" << on_ground_;
    region_.write(out);
  }
  void apply(VoxelGrid& grid, Rng& rng) const override {
    const Box bounds = grid.bounds();
    const auto [low, high] = region_.within(bounds);
    for (long long i = 0; i < count_; ++i) {
      const Eigen::Vector3d size(rng.uniform(size_x_[0], size_x_[1]),
                                 rng.uniform(size_y_[0], size_y_[1]),
                                 rng.uniform(size_z_[0], size_z_[1]));
      const Eigen::Vector2d center(rng.uniform(low.x(), high.x()), rng.uniform(low.y(), high.y()));
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
  explicit WallsGenerator(const YamlReader& entry)
      : cell_size_(entry.getNumber("cell_size", 4.0, 0.1, kMaxLength)),
        thickness_(entry.getNumber("thickness", 0.3, 0.0, kMaxLength)),
        height_(entry.getInterval("height", Interval{3.0, 3.0}, 0.0, kMaxLength)),
        gap_width_(entry.getNumber("gap_width", 1.5, 0.0, kMaxLength)),
        extra_openings_(entry.getNumber("extra_openings", 0.2, 0.0, 1.0)),
        border_(entry.get<bool>("border", false)),
        region_(Region::read(entry)) {
    entry.finish();
  }
  std::string type() const override { return "walls"; }
  void writeCanonical(std::ostream& out) const override {
    out << "walls";
    writeValue(out, "cell_size", cell_size_);
    writeValue(out, "thickness", thickness_);
    writeValue(out, "height", height_);
    writeValue(out, "gap_width", gap_width_);
    writeValue(out, "extra_openings", extra_openings_);
    out << " border=" << border_;
    region_.write(out);
  }
  void apply(VoxelGrid& grid, Rng& rng) const override {
    const Box bounds = grid.bounds();
    const auto [low, high] = region_.within(bounds);
    const int cells_x = std::max(1, static_cast<int>((high.x() - low.x()) / cell_size_));
    const int cells_y = std::max(1, static_cast<int>((high.y() - low.y()) / cell_size_));
    const Eigen::Vector2d cell((high.x() - low.x()) / cells_x, (high.y() - low.y()) / cells_y);

    // Interior walls: vertical walls between (i, j) and (i + 1, j), horizontal walls between
    // (i, j) and (i, j + 1). open[w] says the wall gets a gap.
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
  explicit BoxListGenerator(const YamlReader& entry) {
    for (const YamlReader& item : entry["boxes"].items()) {
      Box box{toVector(item.getVector3("min")), toVector(item.getVector3("max"))};
      if ((box.max.array() < box.min.array()).any()) item.fail("expected min <= max per axis");
      item.finish();
      boxes_.push_back(box);
    }
    entry.finish();
  }
  std::string type() const override { return "box_list"; }
  void writeCanonical(std::ostream& out) const override {
    out << "box_list";
    for (const Box& box : boxes_) {
      writeValue(out, "min", box.min);
      writeValue(out, "max", box.max);
    }
  }
  void apply(VoxelGrid& grid, Rng&) const override {
    for (const Box& box : boxes_) grid.fillBox(box.min, box.max);
  }

 private:
  std::vector<Box> boxes_;
};

using Factory =
    std::function<std::unique_ptr<WorldGenerator>(const YamlReader&, const std::string&)>;

struct GeneratorType {
  std::string description;
  Factory make;
};

template <typename T>
Factory plain() {
  return [](const YamlReader& entry, const std::string&) { return std::make_unique<T>(entry); };
}

const std::map<std::string, GeneratorType>& generatorTypes() {
  static const std::map<std::string, GeneratorType> types = {
      {"empty", {"nothing (free space)", plain<EmptyGenerator>()}},
      {"forest",
       {"tree trunks as vertical cylinders, optional canopies and ground plane",
        plain<ForestGenerator>()}},
      {"boxes", {"random axis-aligned boxes", plain<BoxesGenerator>()}},
      {"walls", {"a maze of walls with gaps (corridors)", plain<WallsGenerator>()}},
      {"box_list", {"explicit boxes (overhangs, bridges, ceilings)", plain<BoxListGenerator>()}},
      {"octomap", {"occupied leaves of an OctoMap .bt or .ot file", &makeOctomapGenerator}},
  };
  return types;
}

}  // namespace

std::unique_ptr<WorldGenerator> makeWorldGenerator(const YamlReader& entry,
                                                   const std::string& spec_directory) {
  const auto type_node = entry["type"];
  const std::string type = type_node.as<std::string>();
  const auto& types = generatorTypes();
  const auto found = types.find(type);
  if (found == types.end()) {
    std::string known;
    for (const auto& [name, unused] : types) known += (known.empty() ? "" : ", ") + name;
    type_node.fail("unknown world generator '" + type + "'; expected one of: " + known);
  }
  return found->second.make(entry, spec_directory);
}

std::vector<std::pair<std::string, std::string>> worldGeneratorTypes() {
  std::vector<std::pair<std::string, std::string>> result;
  for (const auto& [name, type] : generatorTypes()) result.emplace_back(name, type.description);
  return result;
}

}  // namespace kinolab
