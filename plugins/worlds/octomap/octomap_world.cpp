// The `octomap` world generator: occupied leaves of an OctoMap file become occupied voxels.
#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <tuple>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/world_generator.hpp"

namespace kinolab {
namespace {

/// Checks a .bt file's bytes before OctoMap parses them, whose reader trusts them: the header
/// (the first line OctoMap writes, then `id OcTree`, `size N`, `res R`, `data`, comment lines
/// anywhere) and the node stream it would read, walked as OctoMap walks it (two bytes of child
/// flags a node, an inner child's flags after its parent's): every flag from the file, at most
/// OctoMap's 16 levels, and as many nodes as the header says. Throws FileError naming the
/// file and the first problem.
void validateBinaryOcTree(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const auto refuse = [&](const std::string& problem) {
    throw FileError(path + ": not a readable OctoMap OcTree (" + problem + ")");
  };
  std::size_t at = 0;
  const auto line = [&]() -> std::optional<std::string> {
    if (at >= bytes.size()) return std::nullopt;
    const std::size_t end = std::min(bytes.find('\n', at), bytes.size());
    std::string text = bytes.substr(at, end - at);
    at = end + 1;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    return text;
  };
  const auto first = line();
  if (!first || first->rfind("# Octomap OcTree binary file", 0) != 0) {
    refuse("its first line is not '# Octomap OcTree binary file'");
  }
  std::string id;
  long long size = -1;
  for (bool data = false; !data;) {
    const auto text = line();
    if (!text) refuse("the header ends before its 'data' line");
    if (text->empty() || (*text)[0] == '#') continue;
    std::istringstream words(*text);
    std::string key;
    words >> key;
    if (key == "data") {
      data = true;
    } else if (key == "id") {
      words >> id;
    } else if (key == "size") {
      if (!(words >> size) || size < 1) refuse("its size is not a positive count");
    } else if (key != "res") {
      refuse("unknown header line '" + text->substr(0, 40) + "'");
    }
  }
  if (id != "OcTree") refuse("its id is '" + id + "', expected OcTree");
  if (size < 1) refuse("its header has no size");
  // Each node two bytes, so no more than the bytes left allow; then the walk.
  const std::size_t left = bytes.size() - std::min(at, bytes.size());
  if (static_cast<unsigned long long>(size) > 8ULL * (left / 2) + 1) {
    refuse("its header's " + std::to_string(size) + " nodes cannot fit in the " +
           std::to_string(left) + " bytes after it");
  }
  long long nodes = 1;  // the root
  const std::function<void(int)> walk = [&](int depth) {
    if (at + 2 > bytes.size()) refuse("the node data ends inside a node");
    const auto low = static_cast<unsigned char>(bytes[at]);
    const auto high = static_cast<unsigned char>(bytes[at + 1]);
    at += 2;
    int count = 0;  // inner children: their flags follow, in child order
    for (int child = 0; child < 8; ++child) {
      const unsigned flags = ((child < 4 ? low : high) >> (2 * (child % 4))) & 3u;
      if (flags != 0) ++nodes;
      if (flags == 3) ++count;
    }
    if (nodes > size) refuse("more nodes than its header's " + std::to_string(size));
    if (count > 0 && depth >= 16) refuse("a node deeper than OctoMap's 16 levels");
    for (int k = 0; k < count; ++k) walk(depth + 1);
  };
  walk(0);
  if (nodes != size) {
    refuse("its header says " + std::to_string(size) + " nodes, the data holds " +
           std::to_string(nodes));
  }
}

/// Reads a .bt (binary, occupancy bits) or .ot (full, log-odds) OcTree; throws FileError
/// naming the file when it is missing, of another tree type, or corrupt.
std::shared_ptr<const octomap::OcTree> readOcTree(const std::string& path) {
  if (!isRegularFile(path)) throw FileError(path + ": no such map file");
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension != ".bt" && extension != ".ot") {
    throw FileError(path + ": unknown map file type '" + extension + "'; expected .bt or .ot");
  }
  // OctoMap reports parse problems on stderr and through its return values; we turn the
  // latter into errors and keep its chatter out of kinolab's output, restoring std::cerr on
  // every way out (OctoMap may also throw on a corrupt file).
  std::ostringstream chatter;
  const std::unique_ptr<std::streambuf, void (*)(std::streambuf*)> restore_cerr(
      std::cerr.rdbuf(chatter.rdbuf()), [](std::streambuf* saved) { std::cerr.rdbuf(saved); });
  std::shared_ptr<octomap::OcTree> tree;
  if (extension == ".bt") {
    validateBinaryOcTree(path);
    auto binary = std::make_shared<octomap::OcTree>(0.1);
    std::ifstream in(path, std::ios::binary);
    if (binary->readBinary(in) && in) tree = binary;
  } else {
    std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(path));
    if (auto* ocTree = dynamic_cast<octomap::OcTree*>(any.get())) {
      any.release();
      tree.reset(ocTree);
    }
  }
  if (tree && !(tree->getResolution() >= 1e-4 && tree->getResolution() <= 100.0)) {
    throw FileError(path + ": its header says a resolution of " +
                    formatNumber(tree->getResolution()) + " m; expected 0.0001 to 100 m");
  }
  if (!tree || tree->size() == 0) {
    std::string detail = chatter.str();
    while (!detail.empty() && (detail.back() == '\n' || detail.back() == ' ')) detail.pop_back();
    throw FileError(path + ": not a readable OctoMap OcTree (corrupt or truncated)" +
                    (detail.empty() ? std::string() : ": " + detail));
  }
  return tree;
}

/// A map file read once per process: an experiment validates every sweep variant's worlds,
/// and reading and hashing a map each time cost 130 ms a variant for geb079. Keyed by path,
/// size and modification time, so an edited file is read again.
struct LoadedMap {
  std::shared_ptr<const octomap::OcTree> tree;
  std::uint64_t content_hash = 0;
  Box extent;  ///< the tree's metric bounds (OctoMap walks every leaf to find them)
};

LoadedMap readMap(const std::string& path) {
  LoadedMap map{readOcTree(path), hashFile(path), {}};
  double x0, y0, z0, x1, y1, z1;
  map.tree->getMetricMin(x0, y0, z0);
  map.tree->getMetricMax(x1, y1, z1);
  map.extent = Box{{x0, y0, z0}, {x1, y1, z1}};
  return map;
}

LoadedMap loadMap(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::tuple<std::string, std::uintmax_t, std::filesystem::file_time_type>,
                  LoadedMap>
      loaded;
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  const auto modified = std::filesystem::last_write_time(path, error);
  if (error) return readMap(path);  // it says what is wrong
  const std::lock_guard lock(mutex);
  const auto key = std::make_tuple(path, size, modified);
  if (const auto found = loaded.find(key); found != loaded.end()) return found->second;
  const LoadedMap map = readMap(path);
  loaded.emplace(key, map);
  return map;
}

class OctomapGenerator final : public WorldGenerator {
 public:
  static ParameterSpecs declared() {
    return ParameterSpecs()
        .path("file", "the OctoMap .bt or .ot file (relative: to the spec's directory)")
        .required()
        .choice("unknown", "free", {"free", "occupied"},
                "voxels no leaf of the map covers: free or occupied");
  }
  explicit OctomapGenerator(const ParameterSet& p)
      : path_(p.text("file")), unknown_occupied_(p.text("unknown") == "occupied") {
    const LoadedMap map = loadMap(path_);  // FileError naming the file when it cannot be read
    tree_ = map.tree;
    content_hash_ = map.content_hash;
    extent_ = map.extent;
  }
  void writeContentKey(std::ostream& out) const override {
    // The file's content, not its path: a moved map keeps its cache, an edited one does not.
    out << " content=" << toHex(content_hash_);
  }
  std::optional<Box> naturalBounds() const override { return extent_; }
  void apply(VoxelGrid& grid, Rng&) const override {
    // 0 = free, 1 = occupied, 2 = unknown (no free leaf covers the voxel centre). Occupied
    // leaves mark every voxel their cube overlaps, so resampling to another resolution or an
    // unaligned origin never loses an obstacle; free leaves only the voxels whose centre they
    // hold.
    std::vector<std::uint8_t> state(grid.size(), 2);
    for (auto leaf = tree_->begin_leafs(), end = tree_->end_leafs(); leaf != end; ++leaf) {
      const double half = 0.5 * leaf.getSize();
      const octomap::point3d c = leaf.getCoordinate();
      const Eigen::Vector3d low(c.x() - half, c.y() - half, c.z() - half);
      const Eigen::Vector3d high(c.x() + half, c.y() + half, c.z() + half);
      if (tree_->isNodeOccupied(*leaf)) {
        grid.forEachVoxelOverlapping(low, high, [&](std::size_t i) { state[i] = 1; });
      } else {
        grid.forEachVoxelIn(low, high, [&](std::size_t i) {
          if (state[i] != 1) state[i] = 0;
        });
      }
    }
    for (std::size_t i = 0; i < state.size(); ++i) {
      if (state[i] == 1 || (state[i] == 2 && unknown_occupied_)) grid.setOccupied(i, true);
    }
  }
  std::string resamplingNote(const Box& bounds, double resolution) const override {
    const double map_resolution = tree_->getResolution();
    const auto aligned = [&](double value) {
      const double steps = value / map_resolution;
      return std::abs(steps - std::round(steps)) < 1e-6;
    };
    const bool same = std::abs(resolution - map_resolution) < 1e-9 * map_resolution;
    if (same && aligned(bounds.min.x()) && aligned(bounds.min.y()) && aligned(bounds.min.z())) {
      return "";
    }
    return path_ + " (" + formatNumber(map_resolution) + " m voxels) resampled to " +
           formatNumber(resolution) + " m" + (same ? " on a shifted grid" : "") +
           ": a voxel is occupied when any occupied map voxel overlaps it";
  }

 private:
  std::string path_;
  bool unknown_occupied_ = false;
  std::shared_ptr<const octomap::OcTree> tree_;
  std::uint64_t content_hash_ = 0;
  Box extent_;
};

}  // namespace

}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<kinolab::WorldGenerator>(
      "octomap", "occupied leaves of an OctoMap .bt or .ot file",
      kinolab::OctomapGenerator::declared(), [](const kinolab::ParameterSet& parameters) {
        return std::make_unique<kinolab::OctomapGenerator>(parameters);
      });
}
