#include "kinolab/world/world_cache.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/huge_pages.hpp"
#include "kinolab/core/process.hpp"

namespace kinolab {
namespace {

constexpr char kMagic[8] = {'K', 'I', 'N', 'O', 'W', 'R', 'L', 'D'};
// 2: the ESDF measures to voxel cubes; 3: generated worlds are the same on every compiler (a
// clang build drew other worlds from the same seeds, and may have cached them)
constexpr std::uint32_t kFormatVersion = 3;

struct Header {
  char magic[8];
  std::uint32_t format_version;
  std::uint32_t reserved;
  std::uint64_t spec_hash;
  std::int32_t dims[3];
  std::int32_t padding;
  double resolution;
  double origin[3];
  std::uint64_t voxel_count;
};
static_assert(sizeof(Header) == 80, "the header layout is part of the file format");

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

WorldCache::WorldCache(std::string directory) : directory_(std::move(directory)) {}

std::string WorldCache::defaultDirectory() {
  if (const char* dir = std::getenv("KINOLAB_CACHE_DIR"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
    return std::string(xdg) + "/kinolab/worlds";
  }
  if (const char* home = std::getenv("HOME"); home && *home) {
    return std::string(home) + "/.cache/kinolab/worlds";
  }
  return (std::filesystem::temp_directory_path() / "kinolab-worlds").string();
}

std::string WorldCache::fileFor(std::uint64_t spec_hash) const {
  return (std::filesystem::path(directory_) / (toHex(spec_hash) + ".kworld")).string();
}

void WorldCache::write(const World& world, const std::string& path) {
  const VoxelGrid& grid = world.grid();
  Header header{};
  std::memcpy(header.magic, kMagic, sizeof(kMagic));
  header.format_version = kFormatVersion;
  header.spec_hash = world.specHash();
  for (int axis = 0; axis < 3; ++axis) {
    header.dims[axis] = grid.dims()[axis];
    header.origin[axis] = grid.origin()[axis];
  }
  header.resolution = grid.resolution();
  header.voxel_count = grid.size();

  const std::size_t occupancy_bytes = grid.size();
  const std::size_t esdf_bytes = grid.size() * sizeof(float);
  std::vector<char> buffer(sizeof(Header) + occupancy_bytes + esdf_bytes);
  std::memcpy(buffer.data(), &header, sizeof(Header));
  std::memcpy(buffer.data() + sizeof(Header), grid.occupancy().data(), occupancy_bytes);
  std::memcpy(buffer.data() + sizeof(Header) + occupancy_bytes, world.esdf().values().data(),
              esdf_bytes);
  const std::uint64_t checksum = hashBytes(buffer.data(), buffer.size());

  const std::filesystem::path target(path);
  std::error_code error;
  std::filesystem::create_directories(target.parent_path(), error);
  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  try {
    OutputFile out(temporary);
    out.write(buffer.data(), buffer.size());
    out.write(&checksum, sizeof(checksum));
    out.close();
  } catch (const FileError& failure) {
    std::filesystem::remove(temporary, error);
    throw FileError(path + ": cannot write world cache file (" + failure.what() + ")");
  }
  std::filesystem::rename(temporary, target, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw FileError(path + ": cannot move world cache file into place");
  }
}

std::shared_ptr<const World> WorldCache::read(const std::string& path, std::uint64_t expected_hash,
                                              const std::string& name) {
  if (!isRegularFile(path)) throw FileError(path + ": not a regular file");
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw FileError(path + ": cannot open");
  const std::streamoff end = in.tellg();
  if (end < 0) throw FileError(path + ": cannot read its size");
  const auto size = static_cast<std::size_t>(end);
  if (size < sizeof(Header) + sizeof(std::uint64_t)) throw FileError(path + ": truncated");
  std::vector<char> buffer(size);
  in.seekg(0);
  in.read(buffer.data(), static_cast<std::streamsize>(size));
  if (!in) throw FileError(path + ": read error");

  Header header{};
  std::memcpy(&header, buffer.data(), sizeof(Header));
  if (std::memcmp(header.magic, kMagic, sizeof(kMagic)) != 0) {
    throw FileError(path + ": not a kinolab world file");
  }
  if (header.format_version != kFormatVersion) {
    throw FileError(path + ": format version " + std::to_string(header.format_version) +
                    ", expected " + std::to_string(kFormatVersion));
  }
  if (header.spec_hash != expected_hash) throw FileError(path + ": built from another spec");
  const std::uint64_t voxels = header.voxel_count;
  if (voxels == 0 || voxels > (1ULL << 34) ||
      size != sizeof(Header) + voxels * (1 + sizeof(float)) + sizeof(std::uint64_t)) {
    throw FileError(path + ": truncated or padded (size does not match its header)");
  }
  std::uint64_t stored_checksum = 0;
  std::memcpy(&stored_checksum, buffer.data() + size - sizeof(std::uint64_t),
              sizeof(stored_checksum));
  if (hashBytes(buffer.data(), size - sizeof(std::uint64_t)) != stored_checksum) {
    throw FileError(path + ": checksum mismatch (corrupt)");
  }

  const Eigen::Vector3d origin(header.origin[0], header.origin[1], header.origin[2]);
  const Eigen::Vector3d extent =
      Eigen::Vector3d(header.dims[0], header.dims[1], header.dims[2]) * header.resolution;
  VoxelGrid grid(Box{origin, origin + extent}, header.resolution);
  if (grid.dims() != Eigen::Vector3i(header.dims[0], header.dims[1], header.dims[2]) ||
      grid.size() != voxels) {
    throw FileError(path + ": inconsistent grid dimensions");
  }
  const char* payload = buffer.data() + sizeof(Header);
  std::memcpy(grid.occupancy().data(), payload, voxels);
  std::vector<float> values = vectorOnHugePages<float>(voxels);
  std::memcpy(values.data(), payload + voxels, voxels * sizeof(float));
  Esdf esdf(grid, std::move(values));
  return std::make_shared<const World>(name, expected_hash, std::move(grid), std::move(esdf));
}

WorldLoad WorldCache::loadOrBuild(const WorldSpec& spec) const {
  const auto start = std::chrono::steady_clock::now();
  WorldLoad load;
  if (spec.layout == GridLayout::kBricked) {
    // The file format holds dense arrays: a sparse world is built each time (bricks on disk
    // are still to come).
    load.world = World::build(spec);
    load.note = "sparse worlds are not cached";
    load.seconds = secondsSince(start);
    return load;
  }
  const std::uint64_t hash = spec.hash();
  load.cache_file = fileFor(hash);
  if (std::filesystem::exists(load.cache_file)) {
    try {
      load.world = whileDoing("reading the world '" + spec.name + "' from " + load.cache_file,
                              [&] { return read(load.cache_file, hash, spec.name); });
      load.source = WorldSource::kCache;
      load.seconds = secondsSince(start);
      return load;
    } catch (const FileError& error) {
      load.note = std::string(error.what()) + "; rebuilt";
      load.source = WorldSource::kRebuiltCorruptCache;
    }
  }
  load.world = World::build(spec);
  try {
    whileDoing("writing the world '" + spec.name + "' to " + load.cache_file,
               [&] { write(*load.world, load.cache_file); });
  } catch (const FileError& error) {
    // An unwritable cache costs time on the next run, not correctness.
    load.note += (load.note.empty() ? "" : "; ") + std::string("not cached: ") + error.what();
  }
  load.seconds = secondsSince(start);
  return load;
}

}  // namespace kinolab
