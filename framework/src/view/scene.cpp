#include "kinolab/view/scene.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/version.hpp"

namespace kinolab::view {
namespace {

/// A coordinate rounded to the millimetre: the scene is for eyes, and half the size.
double mm(double value) { return std::round(value * 1000.0) / 1000.0; }

nlohmann::ordered_json point(const Eigen::Vector3d& p) { return {mm(p.x()), mm(p.y()), mm(p.z())}; }

void appendPoint(nlohmann::ordered_json& flat, const Eigen::Vector3d& p) {
  for (int axis = 0; axis < 3; ++axis) flat.push_back(mm(p[axis]));
}

}  // namespace

std::vector<VoxelBox> obstacleBoxes(const VoxelGrid& grid, int stride) {
  if (stride < 1) throw InvalidArgument("obstacleBoxes: stride must be at least 1");
  const Eigen::Vector3i& n = grid.dims();
  const Eigen::Vector3i c = (n.array() + stride - 1) / stride;
  const auto at = [&c](int x, int y, int z) {
    return (static_cast<std::size_t>(x) * c.y() + y) * c.z() + z;
  };
  // The coarse grid: 1 occupied, 2 already in a box.
  std::vector<std::uint8_t> cells(static_cast<std::size_t>(c.x()) * c.y() * c.z(), 0);
  grid.forEachOccupied(
      [&](const VoxelIndex& v) { cells[at(v.x() / stride, v.y() / stride, v.z() / stride)] = 1; });
  // Greedy: from each occupied cell not yet covered, grow a box along z, then y, then x over
  // cells that are occupied and not covered (a floor becomes one box, a trunk a few).
  const auto free_of = [&](int x0, int x1, int y0, int y1, int z0, int z1) {
    for (int x = x0; x < x1; ++x) {
      for (int y = y0; y < y1; ++y) {
        for (int z = z0; z < z1; ++z) {
          if (cells[at(x, y, z)] != 1) return false;
        }
      }
    }
    return true;
  };
  std::vector<VoxelBox> boxes;
  for (int x = 0; x < c.x(); ++x) {
    for (int y = 0; y < c.y(); ++y) {
      for (int z = 0; z < c.z(); ++z) {
        if (cells[at(x, y, z)] != 1) continue;
        int z1 = z + 1;
        while (z1 < c.z() && cells[at(x, y, z1)] == 1) ++z1;
        int y1 = y + 1;
        while (y1 < c.y() && free_of(x, x + 1, y1, y1 + 1, z, z1)) ++y1;
        int x1 = x + 1;
        while (x1 < c.x() && free_of(x1, x1 + 1, y, y1, z, z1)) ++x1;
        for (int bx = x; bx < x1; ++bx) {
          for (int by = y; by < y1; ++by) {
            for (int bz = z; bz < z1; ++bz) cells[at(bx, by, bz)] = 2;
          }
        }
        VoxelBox box;
        box.lo = {x * stride, y * stride, z * stride};
        box.hi = {std::min(n.x(), x1 * stride), std::min(n.y(), y1 * stride),
                  std::min(n.z(), z1 * stride)};
        boxes.push_back(box);
      }
    }
  }
  return boxes;
}

std::pair<std::vector<VoxelBox>, int> viewerBoxes(const VoxelGrid& grid, std::size_t max_boxes) {
  int first = 1;
  while (((grid.dims().array() + first - 1) / first).cast<double>().prod() >
         static_cast<double>(kMostViewerCells)) {
    first *= 2;
  }
  for (int stride = first;; stride *= 2) {
    std::vector<VoxelBox> boxes = obstacleBoxes(grid, stride);
    if (boxes.size() <= max_boxes || stride >= grid.dims().maxCoeff()) {
      return {std::move(boxes), stride};
    }
  }
}

struct Scene::Impl {
  nlohmann::ordered_json document;
  nlohmann::ordered_json& query(int index) {
    auto& queries = document["queries"];
    if (index < 0 || index >= static_cast<int>(queries.size())) {
      throw InvalidArgument("Scene: no query " + std::to_string(index));
    }
    return queries[static_cast<std::size_t>(index)];
  }
};

Scene::Scene(const std::string& title) : impl_(std::make_unique<Impl>()) {
  impl_->document = {{"format", "kinolab-scene"},
                     {"version", 1},
                     {"title", title},
                     {"world", nullptr},
                     {"queries", nlohmann::ordered_json::array()}};
}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

void Scene::setWorld(const World& world) {
  const VoxelGrid& grid = world.grid();
  const auto [boxes, stride] = viewerBoxes(grid);
  nlohmann::ordered_json flat = nlohmann::ordered_json::array();
  for (const VoxelBox& box : boxes) {
    for (int axis = 0; axis < 3; ++axis) flat.push_back(box.lo[static_cast<std::size_t>(axis)]);
    for (int axis = 0; axis < 3; ++axis) flat.push_back(box.hi[static_cast<std::size_t>(axis)]);
  }
  impl_->document["world"] = {{"name", world.name()},
                              {"spec_hash", toHex(world.specHash())},
                              {"resolution", grid.resolution()},
                              {"origin", point(grid.origin())},
                              {"dims", {grid.dims().x(), grid.dims().y(), grid.dims().z()}},
                              {"stride", stride},
                              {"boxes", std::move(flat)}};
}

int Scene::addQuery(const std::string& name, const Eigen::Vector3d& start,
                    const Eigen::Vector3d& goal) {
  auto& queries = impl_->document["queries"];
  queries.push_back({{"name", name},
                     {"start", point(start)},
                     {"goal", point(goal)},
                     {"trajectories", nlohmann::ordered_json::array()},
                     {"trees", nlohmann::ordered_json::array()},
                     {"flights", nlohmann::ordered_json::array()}});
  return static_cast<int>(queries.size()) - 1;
}

void Scene::addTrajectory(int query, const std::string& planner, const Trajectory& trajectory,
                          double step) {
  nlohmann::ordered_json flat = nlohmann::ordered_json::array();
  if (!trajectory.empty()) {
    for (const TrajectorySample& sample : trajectory.sample(step))
      appendPoint(flat, sample.position);
  }
  impl_->query(query)["trajectories"].push_back(
      {{"planner", planner}, {"points", std::move(flat)}});
}

void Scene::addTree(int query, const std::string& planner, const SearchTree& tree) {
  // Per evaluation state, line segments as flat point pairs (what WebGL's LineSegments draws).
  nlohmann::ordered_json edges = nlohmann::ordered_json::object();
  for (const auto state : {SearchTreeEdge::State::kPartial, SearchTreeEdge::State::kFull,
                           SearchTreeEdge::State::kCertified, SearchTreeEdge::State::kRejected}) {
    edges[std::string(toString(state))] = nlohmann::ordered_json::array();
  }
  for (const SearchTreeEdge& edge : tree) {
    auto& flat = edges[std::string(toString(edge.state))];
    for (std::size_t k = 1; k < edge.points.size(); ++k) {
      appendPoint(flat, edge.points[k - 1]);
      appendPoint(flat, edge.points[k]);
    }
  }
  impl_->query(query)["trees"].push_back({{"planner", planner}, {"edges", std::move(edges)}});
}

void Scene::addFlight(int query, const std::string& planner, const Trajectory& flown,
                      const std::vector<std::pair<double, Eigen::Vector3d>>& known_voxels,
                      double voxel_size, double step) {
  nlohmann::ordered_json times = nlohmann::ordered_json::array();
  nlohmann::ordered_json flat = nlohmann::ordered_json::array();
  if (!flown.empty()) {
    for (const TrajectorySample& sample : flown.sample(step)) {
      times.push_back(mm(sample.time));
      appendPoint(flat, sample.position);
    }
  }
  nlohmann::ordered_json known = nullptr;
  if (!known_voxels.empty()) {
    nlohmann::ordered_json points = nlohmann::ordered_json::array();
    for (const auto& [time, center] : known_voxels) {
      appendPoint(points, center);
      points.push_back(mm(time));
    }
    known = {{"size", voxel_size}, {"points", std::move(points)}};
  }
  impl_->query(query)["flights"].push_back({{"planner", planner},
                                            {"t", std::move(times)},
                                            {"points", std::move(flat)},
                                            {"known", known}});
}

std::string Scene::json() const { return impl_->document.dump(); }

std::string viewerTemplatePath() {
  namespace fs = std::filesystem;
  if (const char* set = std::getenv("KINOLAB_VIEWER"); set && *set) {
    if (!fs::is_regular_file(set)) {
      throw FileError(std::string("KINOLAB_VIEWER=") + set + ": no such viewer file");
    }
    return set;
  }
  std::vector<fs::path> candidates;
  if (const std::string installed = installedDataDirectory(); !installed.empty()) {
    candidates.push_back(fs::path(installed) / "viewer.html");
  }
  candidates.push_back(fs::path(kBinaryDir) / "share/kinolab/viewer.html");
  for (const fs::path& candidate : candidates) {
    if (fs::is_regular_file(candidate)) return candidate.string();
  }
  throw FileError("the 3D viewer (viewer.html) is in none of " +
                  (candidates.size() > 1 ? candidates[0].string() + ", " : std::string()) +
                  candidates.back().string() + "; build kinolab or set KINOLAB_VIEWER");
}

std::string viewHtml(const std::string& scene_json) {
  const std::string template_path = viewerTemplatePath();
  std::ifstream file(template_path, std::ios::binary);
  std::string page((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (!file) throw FileError(template_path + ": cannot read the viewer");
  static constexpr std::string_view kPlaceholder = "__KINOLAB_SCENE__";
  const std::size_t at = page.find(kPlaceholder);
  if (at == std::string::npos) {
    throw FileError(template_path + ": not a kinolab viewer (no scene placeholder)");
  }
  // Inside <script type="application/json">: "</" would end the element; "<\/" is the same
  // JSON string.
  std::string scene;
  scene.reserve(scene_json.size());
  for (std::size_t i = 0; i < scene_json.size(); ++i) {
    scene += scene_json[i];
    if (scene_json[i] == '<' && i + 1 < scene_json.size() && scene_json[i + 1] == '/')
      scene += '\\';
  }
  page.replace(at, kPlaceholder.size(), scene);
  return page;
}

void writeViewHtml(const std::string& path, const std::string& scene_json) {
  writeFileAtomically(path, viewHtml(scene_json));
}

}  // namespace kinolab::view
