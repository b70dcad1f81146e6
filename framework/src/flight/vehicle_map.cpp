#include "kinolab/flight/vehicle_map.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <queue>

#include "column_cells.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/esdf.hpp"

namespace kinolab {

KINOLAB_DEFINE_PLUGIN_REGISTRY(VehicleMap, "vehicle_map", "vehicle_maps",
                               "what a flying vehicle knows of the world: its sensor model (the "
                               "flight's `map`)",
                               8)

VehicleMap::~VehicleMap() = default;

void VehicleMap::setup(const Box& bounds, const MapModel& model) {
  const Eigen::Vector3d cells = (bounds.max - bounds.min) / model.resolution;
  // A byte a voxel; map kinds index voxels in 32-bit keys (OctoMap: 2^15 either side).
  if (!(cells.maxCoeff() < 32000.0 && cells.prod() < 4e8)) {
    throw ConfigError("flight: a map of " + formatPoint(bounds.max - bounds.min) + " m at " +
                      formatNumber(model.resolution) +
                      " m is too many voxels (at most 32,000 per axis and 4e8 in all): use a "
                      "coarser map_resolution");
  }
  model_ = model;
  bounds_ = bounds;
  lattice_ = VoxelGrid(bounds, model.resolution);
  state_.assign(lattice_.size(), 0);
  window_field_.reset();
  window_world_.reset();
  guardPluginCall(plugin_name_, "setup()", [&] { doSetup(); });
}

void VehicleMap::insert(const SensorFrame& frame, double max_range) {
  if (!isSetup()) throw InvalidArgument("VehicleMap::insert before setup()");
  guardPluginCall(plugin_name_, "insert()", [&] { doInsert(frame, max_range); });
}

void VehicleMap::doMarkFree(std::size_t index, const Eigen::Vector3d& /*center*/) {
  setState(index, Voxel::kFree);
}

void VehicleMap::markFree(const Eigen::Vector3d& center, double radius,
                          const std::function<bool(const Eigen::Vector3d&)>& only) {
  if (!isSetup()) throw InvalidArgument("VehicleMap::markFree before setup()");
  guardPluginCall(plugin_name_, "markFree()", [&] {
    lattice_.forEachVoxelIn(center.array() - radius, center.array() + radius, [&](std::size_t i) {
      const Eigen::Vector3d c = voxelCenter(i);
      // Only unseen voxels: what the sensor saw (an obstacle beside the body) stays as seen.
      if ((c - center).norm() <= radius && state_[i] == 0 && (!only || only(c))) {
        doMarkFree(i, c);
      }
    });
  });
}

double VehicleMap::unvouchedDistance(const Eigen::Vector3d& p, double limit,
                                     Eigen::Vector3d* nearest) const {
  if (!isSetup()) throw InvalidArgument("VehicleMap::unvouchedDistance before setup()");
  const double r = model_.resolution;
  const Eigen::Vector3d local = (p - lattice_.origin()) / r;  // in voxels
  const Eigen::Vector3i& n = lattice_.dims();
  Eigen::Vector3i low;
  Eigen::Vector3i high;
  for (int axis = 0; axis < 3; ++axis) {
    low[axis] = std::max(0, static_cast<int>(std::floor(local[axis] - limit / r)));
    high[axis] = std::min(n[axis] - 1, static_cast<int>(std::floor(local[axis] + limit / r)));
    if (low[axis] > high[axis]) return limit;  // nothing of the map within the limit
  }
  const auto gap2 = [&](int axis, int i) {
    const double lo = lattice_.origin()[axis] + i * r;
    const double d = std::max({lo - p[axis], 0.0, p[axis] - (lo + r)});
    return d * d;
  };
  const auto kFree = static_cast<std::uint8_t>(Voxel::kFree);
  double best2 = limit * limit;
  for (int x = low.x(); x <= high.x(); ++x) {
    const double dx = gap2(0, x);
    if (dx >= best2) continue;
    for (int y = low.y(); y <= high.y(); ++y) {
      const double dxy = dx + gap2(1, y);
      if (dxy >= best2) continue;
      const std::uint8_t* column = &state_[lattice_.index(x, y, 0)];
      for (int z = low.z(); z <= high.z(); ++z) {
        if (column[z] == kFree) continue;
        const double d2 = dxy + gap2(2, z);
        if (d2 >= best2) continue;
        best2 = d2;
        if (nearest != nullptr) {
          const Eigen::Vector3d low_corner = lattice_.origin() + Eigen::Vector3d(x, y, z) * r;
          *nearest = p.cwiseMax(low_corner).cwiseMin(low_corner + Eigen::Vector3d::Constant(r));
        }
      }
    }
  }
  return std::min(std::sqrt(best2), limit);
}

Box VehicleMap::latticeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& half) const {
  const double r = model_.resolution;
  Box box;
  for (int axis = 0; axis < 3; ++axis) {
    const double low = std::max(bounds_.min[axis], center[axis] - half[axis]);
    const double high = std::min(bounds_.max[axis], center[axis] + half[axis]);
    box.min[axis] = bounds_.min[axis] + std::floor((low - bounds_.min[axis]) / r + 1e-9) * r;
    box.max[axis] = bounds_.min[axis] + std::ceil((high - bounds_.min[axis]) / r - 1e-9) * r;
    box.max[axis] = std::max(box.max[axis], box.min[axis] + r);
  }
  return box;
}

void VehicleMap::windowOccupancy(const VoxelGrid& grid, const Eigen::Vector3d& center,
                                 std::span<std::uint8_t> occupancy) const {
  const Eigen::Vector3i& n = grid.dims();
  const VoxelGrid& lattice = lattice_;
  // The window's first voxel in the map (both on the map's lattice).
  const Eigen::Vector3i first =
      ((grid.origin() - lattice.origin()) / model_.resolution).array().round().cast<int>();
  const double near2 = model_.free_beyond * model_.free_beyond;
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      // One z column of the window is a run of the map's column (both z fastest).
      const VoxelIndex column(first.x() + x, first.y() + y, first.z());
      const bool inside = lattice.inside(column);
      const std::uint8_t* states = inside ? &state_[lattice.index(column)] : nullptr;
      const int known = inside ? std::min(n.z(), lattice.dims().z() - first.z()) : 0;
      std::uint8_t* out = &occupancy[grid.index(x, y, 0)];
      // Known voxels as the map has them (vectorised loops: this runs every frame), then the
      // unknown ones as `unknown` says.
      const auto kOccupied = static_cast<std::uint8_t>(Voxel::kOccupied);
      const std::uint8_t unknown_value = model_.unknown == UnknownSpace::kOccupied ? 1 : 0;
      for (int z = 0; z < known; ++z) {
        out[z] = states[z] == kOccupied ? 1 : (states[z] == 0 ? unknown_value : 0);
      }
      std::fill(out + known, out + n.z(), unknown_value);
      if (model_.unknown != UnknownSpace::kFreeBeyond) continue;
      for (int z = 0; z < n.z(); ++z) {
        if (z >= known || states[z] == 0) {
          out[z] = (grid.center(VoxelIndex(x, y, z)) - center).squaredNorm() < near2 ? 1 : 0;
        }
      }
    }
  }
}

std::shared_ptr<const World> VehicleMap::window(const Eigen::Vector3d& center, bool rebuild) {
  if (!isSetup()) throw InvalidArgument("VehicleMap::window before setup()");
  const double half_side = 0.5 * model_.window;
  const double half_height = 0.5 * model_.window_height;
  const auto contains = [](const Box& outer, const Box& inner) {
    return (outer.min.array() <= inner.min.array() + 1e-9).all() &&
           (inner.max.array() <= outer.max.array() + 1e-9).all();
  };
  // The planning domain keeps model_.inset inside the map's box (the grid reaches the box),
  // but always holds the vehicle (a start within the inset is still a start).
  const Eigen::Vector3d inset = Eigen::Vector3d::Constant(model_.inset);
  const Eigen::Vector3d inside = center.cwiseMax(bounds_.min).cwiseMin(bounds_.max);
  const Box domain_limit{(bounds_.min + inset).cwiseMin(bounds_.max).cwiseMin(inside),
                         (bounds_.max - inset).cwiseMax(bounds_.min).cwiseMax(inside)};
  const auto domainBox = [&](const Eigen::Vector3d& middle, const Eigen::Vector3d& half) {
    Box box = latticeBox(middle, half);
    box.min = box.min.cwiseMax(domain_limit.min);
    box.max = box.max.cwiseMin(domain_limit.max).cwiseMax(box.min);
    return box;
  };
  const bool kept = !rebuild && window_field_ && window_world_ &&
                    contains(window_world_->bounds(),
                             domainBox(center, Eigen::Vector3d(half_side, half_side, 0.0))) &&
                    std::abs(center.z() - window_middle_.z()) <= 0.5 * half_height;
  const Eigen::Vector3d half(half_side + model_.window_margin, half_side + model_.window_margin,
                             half_height);
  if (!kept) {
    window_middle_ = center;
    VoxelGrid grid(latticeBox(center, half.array() + model_.reach), model_.resolution);
    windowOccupancy(grid, center, grid.mutableOccupancy());
    if (window_field_) {
      window_field_->rebuild(std::move(grid));
    } else {
      window_field_ = std::make_unique<IncrementalEsdf>(std::move(grid));
    }
  } else {
    window_occupancy_.resize(window_field_->grid().size());
    windowOccupancy(window_field_->grid(), center, window_occupancy_);
    if (window_field_->update(window_occupancy_) == 0) return window_world_;
  }
  // The World is a copy, so that one a planner holds never changes under it; when no one
  // holds the last any more, its memory takes the copy (no new pages to fault in a frame).
  VoxelGrid grid;
  std::vector<float> values;
  if (window_world_ && window_world_.use_count() == 1) {
    auto [last_grid, last_field] = std::move(*window_world_).release();
    grid = std::move(last_grid);
    values = std::move(last_field).release();
  }
  // Spent or out of date: a throw below leaves none, and the next call builds anew.
  window_world_.reset();
  grid = window_field_->grid();
  window_world_ = std::make_shared<World>("known_window", 0, std::move(grid),
                                          window_field_->esdf(std::move(values)),
                                          domainBox(window_middle_, half));
  return window_world_;
}

namespace {

/// Per x-y cell of `lattice` (x slowest): 1 where a column with an obstacle (`obstacles`) in
/// the voxel layers [z0, z1] lies within `radius` of the cell's centre.
std::vector<std::uint8_t> blockedCells(const VoxelGrid& lattice, const ObstacleColumns& obstacles,
                                       int z0, int z1, double radius) {
  const Eigen::Vector3i& n = lattice.dims();
  const double r = lattice.resolution();
  std::vector<std::uint8_t> blocked(static_cast<std::size_t>(n.x()) * n.y(), 0);
  std::vector<std::uint8_t> row(static_cast<std::size_t>(n.y()));
  const int reach = static_cast<int>(std::ceil(radius / r));
  for (int x = 0; x < n.x(); ++x) {
    obstacles(x, z0, z1, row.data());
    for (int y = 0; y < n.y(); ++y) {
      if (row[static_cast<std::size_t>(y)] == 0) continue;
      for (int dx = -reach; dx <= reach; ++dx) {
        for (int dy = -reach; dy <= reach; ++dy) {
          const int cx = x + dx;
          const int cy = y + dy;
          // Cells whose centre is within the radius of the obstacle column's cube.
          const double gx = std::max(0.0, std::abs(dx) - 0.5);
          const double gy = std::max(0.0, std::abs(dy) - 0.5);
          if (cx < 0 || cy < 0 || cx >= n.x() || cy >= n.y() ||
              (gx * gx + gy * gy) * r * r >= radius * radius) {
            continue;
          }
          blocked[static_cast<std::size_t>(cx) * n.y() + cy] = 1;
        }
      }
    }
  }
  return blocked;
}

/// A shortest 8-connected path of cells (indices x * ny + y) from `start` to `goal` over the
/// cells not `blocked`: A* with the octile distance. Empty when there is none.
std::vector<std::size_t> cellPath(const std::vector<std::uint8_t>& blocked, int nx, int ny,
                                  const Eigen::Vector2i& start, const Eigen::Vector2i& goal) {
  const auto id = [&](const Eigen::Vector2i& c) {
    return static_cast<std::size_t>(c.x()) * ny + c.y();
  };
  const auto octile = [&](const Eigen::Vector2i& c) {
    const Eigen::Vector2i d = (c - goal).cwiseAbs();
    return static_cast<double>(std::max(d.x(), d.y())) + (M_SQRT2 - 1.0) * std::min(d.x(), d.y());
  };
  std::vector<double> cost(blocked.size(), INFINITY);
  std::vector<std::int64_t> parent(blocked.size(), -1);
  using Entry = std::pair<double, std::size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  cost[id(start)] = 0.0;
  open.emplace(octile(start), id(start));
  while (!open.empty()) {
    const auto [f, at] = open.top();
    open.pop();
    const Eigen::Vector2i c(static_cast<int>(at / ny), static_cast<int>(at % ny));
    if (f > cost[at] + octile(c) + 1e-9) continue;  // stale
    if (c == goal) {
      return column_cells::wayTo(parent, at);
    }
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        const Eigen::Vector2i next = c + Eigen::Vector2i(dx, dy);
        if ((dx == 0 && dy == 0) || next.x() < 0 || next.y() < 0 || next.x() >= nx ||
            next.y() >= ny || blocked[id(next)]) {
          continue;
        }
        const double step = dx != 0 && dy != 0 ? M_SQRT2 : 1.0;
        if (cost[at] + step < cost[id(next)]) {
          cost[id(next)] = cost[at] + step;
          parent[id(next)] = static_cast<std::int64_t>(at);
          open.emplace(cost[id(next)] + octile(next), id(next));
        }
      }
    }
  }
  return {};
}

}  // namespace

std::vector<Eigen::Vector3d> VehicleMap::guide(const Eigen::Vector3d& from,
                                               const Eigen::Vector3d& to, double radius,
                                               double z_low, double z_high) const {
  return std::move(guides({&from, 1}, to, radius, z_low, z_high).front());
}

std::vector<std::vector<Eigen::Vector3d>> VehicleMap::guides(
    std::span<const Eigen::Vector3d> froms, const Eigen::Vector3d& to, double radius, double z_low,
    double z_high, double room, std::span<const Eigen::Vector3d> trail) const {
  return columnGuides(lattice_, obstacleColumns(), froms, to, radius, z_low, z_high, room,
                      model_.inset, trail);
}

ObstacleColumns VehicleMap::obstacleColumns() const {
  return [this](int x, int z0, int z1, std::uint8_t* row) {
    for (int y = 0; y < lattice_.dims().y(); ++y) {
      const std::uint8_t* column = &state_[lattice_.index(x, y, 0)];
      row[y] = std::any_of(column + z0, column + z1 + 1, [](std::uint8_t v) {
        return v == static_cast<std::uint8_t>(Voxel::kOccupied);
      });
    }
  };
}

std::vector<Eigen::Vector3d> columnGuide(const VoxelGrid& lattice, const ObstacleColumns& obstacles,
                                         const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                         double radius, double z_low, double z_high) {
  return std::move(columnGuides(lattice, obstacles, {&from, 1}, to, radius, z_low, z_high).front());
}

namespace column_cells {

Eigen::Vector2i cellOf(const VoxelGrid& lattice, const Eigen::Vector3d& p) {
  const Eigen::Vector3i& n = lattice.dims();
  const Eigen::Vector3d local = (p - lattice.origin()) / lattice.resolution();
  return {std::clamp(static_cast<int>(std::floor(local.x())), 0, n.x() - 1),
          std::clamp(static_cast<int>(std::floor(local.y())), 0, n.y() - 1)};
}

void openRound(const VoxelGrid& lattice, std::span<std::uint8_t> cells, const Eigen::Vector3d& at,
               double room) {
  const Eigen::Vector3i& n = lattice.dims();
  const Eigen::Vector2i c = cellOf(lattice, at);
  cells[static_cast<std::size_t>(c.x()) * n.y() + c.y()] = 0;
  const int reach = static_cast<int>(std::ceil(room / lattice.resolution()));
  for (int x = std::max(0, c.x() - reach); x <= std::min(n.x() - 1, c.x() + reach); ++x) {
    for (int y = std::max(0, c.y() - reach); y <= std::min(n.y() - 1, c.y() + reach); ++y) {
      const Eigen::Vector3d centre = lattice.center(VoxelIndex(x, y, 0));
      if ((centre.head<2>() - at.head<2>()).norm() <= room) {
        cells[static_cast<std::size_t>(x) * n.y() + y] = 0;
      }
    }
  }
}

void openTrail(const VoxelGrid& lattice, std::span<std::uint8_t> cells,
               std::span<const Eigen::Vector3d> trail, double z_low, double z_high) {
  for (const Eigen::Vector3d& p : trail) {
    if (p.z() < z_low || p.z() > z_high) continue;
    const Eigen::Vector2i c = cellOf(lattice, p);
    cells[static_cast<std::size_t>(c.x()) * lattice.dims().y() + c.y()] = 0;
  }
}

std::vector<std::uint8_t> closedCells(const VoxelGrid& lattice, const ObstacleColumns& obstacles,
                                      double radius, double z_low, double z_high, double inset) {
  const Eigen::Vector3i& n = lattice.dims();
  const double r = lattice.resolution();
  const auto layer = [&](double z) {
    return std::clamp(static_cast<int>(std::floor((z - lattice.origin().z()) / r)), 0, n.z() - 1);
  };
  std::vector<std::uint8_t> blocked =
      blockedCells(lattice, obstacles, layer(z_low), layer(z_high), radius);
  if (inset <= 0.0) return blocked;
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      const double cx = (x + 0.5) * r;
      const double cy = (y + 0.5) * r;
      if (std::min({cx, cy, n.x() * r - cx, n.y() * r - cy}) < inset) {
        blocked[static_cast<std::size_t>(x) * n.y() + y] = 1;
      }
    }
  }
  return blocked;
}

std::vector<std::size_t> wayTo(std::span<const std::int64_t> parent, std::size_t at) {
  std::vector<std::size_t> way;
  for (auto node = static_cast<std::int64_t>(at); node >= 0;
       node = parent[static_cast<std::size_t>(node)]) {
    way.push_back(static_cast<std::size_t>(node));
  }
  std::reverse(way.begin(), way.end());
  return way;
}

}  // namespace column_cells

using namespace column_cells;

std::vector<std::vector<Eigen::Vector3d>> columnGuides(
    const VoxelGrid& lattice, const ObstacleColumns& obstacles,
    std::span<const Eigen::Vector3d> froms, const Eigen::Vector3d& to, double radius, double z_low,
    double z_high, double room, double inset, std::span<const Eigen::Vector3d> trail) {
  const Eigen::Vector3i& n = lattice.dims();
  std::vector<std::uint8_t> blocked = closedCells(lattice, obstacles, radius, z_low, z_high, inset);
  if (room > 0.0) openRound(lattice, blocked, to, room);
  openTrail(lattice, blocked, trail, z_low, z_high);
  const Eigen::Vector2i goal = cellOf(lattice, to);
  std::vector<std::vector<Eigen::Vector3d>> paths(froms.size());
  if (blocked[static_cast<std::size_t>(goal.x()) * n.y() + goal.y()]) return paths;
  for (std::size_t i = 0; i < froms.size(); ++i) {
    const Eigen::Vector3d& from = froms[i];
    std::vector<std::uint8_t> open = blocked;
    openRound(lattice, open, from, room);  // the vehicle is here
    const std::vector<std::size_t> cells =
        cellPath(open, n.x(), n.y(), cellOf(lattice, from), goal);
    std::vector<Eigen::Vector3d>& path = paths[i];
    for (const std::size_t cell : cells) {
      const Eigen::Vector3d centre = lattice.center(
          VoxelIndex(static_cast<int>(cell / n.y()), static_cast<int>(cell % n.y()), 0));
      path.emplace_back(centre.x(), centre.y(), 0.0);
    }
    if (path.empty()) continue;
    path.front().head<2>() = from.head<2>();
    path.back().head<2>() = to.head<2>();
    for (std::size_t k = 0; k < path.size(); ++k) {
      path[k].z() = from.z() + (to.z() - from.z()) * static_cast<double>(k) /
                                   static_cast<double>(std::max<std::size_t>(1, path.size() - 1));
    }
  }
  return paths;
}

std::string VehicleMap::topView(double z_low, double z_high) const {
  const VoxelGrid& lattice = lattice_;
  const Eigen::Vector3i& n = lattice.dims();
  const double r = model_.resolution;
  const int z0 =
      std::clamp(static_cast<int>(std::floor((z_low - lattice.origin().z()) / r)), 0, n.z() - 1);
  const int z1 =
      std::clamp(static_cast<int>(std::floor((z_high - lattice.origin().z()) / r)), 0, n.z() - 1);
  std::string text = std::to_string(n.x()) + "," + std::to_string(n.y()) + "," +
                     formatNumber(lattice.origin().x()) + "," + formatNumber(lattice.origin().y()) +
                     "," + formatNumber(r) + "\n";
  text.reserve(text.size() + static_cast<std::size_t>(n.x()) * (n.y() + 1));
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      const std::uint8_t* column = &state_[lattice.index(x, y, 0)];
      const std::uint8_t top = *std::max_element(column + z0, column + z1 + 1);
      text += static_cast<char>('0' + top);
    }
    text += '\n';
  }
  return text;
}

std::size_t VehicleMap::knownFree() const {
  return static_cast<std::size_t>(std::count(state_.begin(), state_.end(), 1));
}

std::size_t VehicleMap::knownOccupied() const {
  return static_cast<std::size_t>(std::count(state_.begin(), state_.end(), 2));
}

std::vector<std::size_t> VehicleMap::occupiedVoxels() const {
  std::vector<std::size_t> voxels;
  for (std::size_t i = 0; i < state_.size(); ++i) {
    if (state_[i] == 2) voxels.push_back(i);
  }
  return voxels;
}

Eigen::Vector3d VehicleMap::voxelCenter(std::size_t index) const {
  const Eigen::Vector3i& n = lattice_.dims();
  const auto yz = static_cast<std::size_t>(n.y()) * n.z();
  return lattice_.center(VoxelIndex(static_cast<int>(index / yz),
                                    static_cast<int>(index % yz / n.z()),
                                    static_cast<int>(index % n.z())));
}

void VehicleMap::write(const std::string& path) const {
  // OctoMap writes its own frame: the known voxels (the mirror's) go into a tree in the
  // world's frame, and so does their state.
  octomap::OcTree shifted(model_.resolution);
  const VoxelGrid& lattice = lattice_;
  const Eigen::Vector3i& n = lattice.dims();
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      for (int z = 0; z < n.z(); ++z) {
        const std::uint8_t state = state_[lattice.index(x, y, z)];
        if (state == 0) continue;
        const Eigen::Vector3d c = lattice.center(VoxelIndex(x, y, z));
        shifted.updateNode(octomap::point3d(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                            static_cast<float>(c.z())),
                           state == 2, /*lazy_eval=*/true);
      }
    }
  }
  shifted.updateInnerOccupancy();
  if (!shifted.writeBinary(path)) throw FileError(path + ": cannot write the known map");
}

}  // namespace kinolab
