#include "kinolab/world/world_cache.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/process.hpp"

namespace kinolab {
namespace {

constexpr char kMagic[8] = {'K', 'I', 'N', 'O', 'W', 'R', 'L', 'D'};
// 2: the ESDF measures to voxel cubes; 3: generated worlds are the same on every compiler (a
// clang build drew other worlds from the same seeds, and may have cached them); 4: arrays start
// at multiples of kAlignment, so that a mapped file is read in place, and sparse worlds too
constexpr std::uint32_t kFormatVersion = 4;
constexpr std::size_t kAlignment = 64;
constexpr std::uint32_t kDenseFile = 0;
constexpr std::uint32_t kBrickedFile = 1;

struct Header {
  char magic[8];
  std::uint32_t format_version;
  std::uint32_t layout;  // kDenseFile or kBrickedFile
  std::uint64_t spec_hash;
  std::int32_t dims[3];
  std::int32_t padding;
  double resolution;
  double origin[3];
  std::uint64_t voxel_count;
};
static_assert(sizeof(Header) == 80, "the header layout is part of the file format");

/// What a sparse world's file holds after the header.
struct BrickedHeader {
  std::uint64_t bricks;      // the grid's and the field's, x-major, z fastest
  std::uint64_t mask_words;  // the grid's masks, 8 words a brick
  std::uint64_t own_bricks;  // the field's bricks of their own, 512 codes each
  double truncation;
};
static_assert(sizeof(BrickedHeader) == 32, "the header layout is part of the file format");

// A dense file: Header, occupancy (a byte a voxel), ESDF values (a float a voxel). A sparse
// one: Header, BrickedHeader, brick states (4 bytes a brick), masks (8 bytes a word), the
// field's slot of every brick (4 bytes: -1 +T, -2 -T, else an index), the codes (2 bytes a
// voxel of each brick of its own). Every array starts at a multiple of kAlignment (zeros
// between); the last 8 bytes are the XXH3 checksum of everything before them.

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Writes a cache file piece by piece from the world's own memory, the checksum taken on the
/// way.
class FileWriter {
 public:
  /// Throws FileError naming `path` when it cannot be created (or is a link, core/files.hpp).
  explicit FileWriter(const std::string& path) : out_(path) {}
  template <typename T>
  void put(const T* data, std::size_t count) {
    write(data, count * sizeof(T));
  }
  /// Zeros up to the next multiple of kAlignment.
  void align() {
    static constexpr char kZeros[kAlignment] = {};
    write(kZeros, (kAlignment - offset_ % kAlignment) % kAlignment);
  }
  /// Appends the checksum and closes the file; FileError when anything failed.
  void finish() {
    const std::uint64_t digest = checksum_.digest();
    out_.write(&digest, sizeof(digest));
    out_.close();
  }

 private:
  void write(const void* data, std::size_t bytes) {
    checksum_.update(data, bytes);
    out_.write(data, bytes);
    offset_ += bytes;
  }
  OutputFile out_;
  StreamHash checksum_;
  std::uint64_t offset_ = 0;
};

/// Reads a mapped cache file in order; every piece is checked to lie inside the file.
class FileReader {
 public:
  FileReader(const std::string& path, std::shared_ptr<const void> file, std::size_t size)
      : path_(path),
        file_(std::move(file)),
        bytes_(static_cast<const char*>(file_.get())),
        end_(size - sizeof(std::uint64_t)) {}
  const std::shared_ptr<const void>& file() const { return file_; }
  /// The next `count` values of T (after aligning when `aligned`).
  template <typename T>
  const T* take(std::uint64_t count, bool aligned = true) {
    if (aligned) offset_ = (offset_ + kAlignment - 1) / kAlignment * kAlignment;
    if (count > (end_ - std::min(offset_, end_)) / sizeof(T)) {
      throw FileError(path_ + ": truncated or padded (size does not match its header)");
    }
    const T* data = reinterpret_cast<const T*>(bytes_ + offset_);
    offset_ += count * sizeof(T);
    return data;
  }
  template <typename T>
  T read() {
    T value;
    std::memcpy(&value, take<char>(sizeof(T), false), sizeof(T));
    return value;
  }
  /// Throws unless everything up to the checksum was read.
  void expectEnd() const {
    if (offset_ != end_) {
      throw FileError(path_ + ": truncated or padded (size does not match its header)");
    }
  }

 private:
  std::string path_;
  std::shared_ptr<const void> file_;
  const char* bytes_;
  std::uint64_t end_;
  std::uint64_t offset_ = 0;
};

/// What tells one content of a file from another while it lives: a write or a truncation
/// changes its size or times (the change time cannot be set from user space), a replacement its
/// inode.
struct FileIdentity {
  std::uint64_t device = 0;
  std::uint64_t inode = 0;
  std::uint64_t size = 0;
  std::int64_t modified_ns = 0;
  std::int64_t changed_ns = 0;
  bool operator==(const FileIdentity&) const = default;
};

std::int64_t nanoseconds(const timespec& time) {
  return static_cast<std::int64_t>(time.tv_sec) * 1000000000 + time.tv_nsec;
}

/// A cache file whose checksum was verified, and its identity then: beside the file as
/// `<file>.verified`. While the file keeps that identity, its content is the one verified.
struct VerifiedStamp {
  char magic[8];
  FileIdentity identity;
  std::uint64_t checksum;
};
constexpr char kStampMagic[8] = {'K', 'I', 'N', 'O', 'V', 'E', 'R', '1'};

/// Whether the stamp beside `path` vouches for a file of `identity` ending in `checksum`.
bool stampVouches(const std::string& path, const FileIdentity& identity, std::uint64_t checksum) {
  VerifiedStamp stamp{};
  std::FILE* in = std::fopen((path + ".verified").c_str(), "rb");
  if (in == nullptr) return false;
  const bool whole = std::fread(&stamp, sizeof(stamp), 1, in) == 1 && std::fgetc(in) == EOF;
  std::fclose(in);
  return whole && std::memcmp(stamp.magic, kStampMagic, sizeof(kStampMagic)) == 0 &&
         stamp.identity == identity && stamp.checksum == checksum;
}

/// Records that the file of `identity` at `path` was verified, when it last changed at least
/// kSettled before now: a change within the file system's clock tick of the last one would
/// leave its times as they were, and a file that old cannot have one any more. Best effort
/// (an unwritable cache verifies every time).
void stampVerified(const std::string& path, const FileIdentity& identity, std::uint64_t checksum) {
  constexpr std::int64_t kSettled = 500000000;  // ns
  timespec now{};
  if (::clock_gettime(CLOCK_REALTIME, &now) != 0 ||
      nanoseconds(now) - identity.changed_ns < kSettled) {
    return;
  }
  VerifiedStamp stamp{};
  std::memcpy(stamp.magic, kStampMagic, sizeof(kStampMagic));
  stamp.identity = identity;
  stamp.checksum = checksum;
  try {
    writeFileAtomically(path + ".verified",
                        std::string(reinterpret_cast<const char*>(&stamp), sizeof(stamp)));
  } catch (const FileError&) {
    // Unwritable: the next load computes the checksum again.
  }
}

/// A cache file mapped read-only (unmapped when the last owner lets go), its identity, its
/// stored checksum, and whether a stamp vouches for it. Files of the cache are replaced by
/// renaming, never rewritten in place, so a mapping stays valid while it lives.
struct MappedFile {
  std::shared_ptr<const void> data;
  FileIdentity identity;
  std::uint64_t stored_checksum = 0;
  bool vouched = false;
};

/// Maps the cache file at `path`: a file its stamp vouches for is mapped page by page as it is
/// read; any other is populated at once (one pass over the page cache, not a fault a page), to
/// be read whole for its checksum.
MappedFile mapFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw FileError(path + ": cannot open: " + std::strerror(errno));
  MappedFile file;
  try {
    struct stat status {};
    if (::fstat(fd, &status) != 0 || !S_ISREG(status.st_mode) || status.st_size < 0) {
      throw FileError(path + ": not a regular file");
    }
    FileIdentity& identity = file.identity;
    identity = {static_cast<std::uint64_t>(status.st_dev),
                static_cast<std::uint64_t>(status.st_ino),
                static_cast<std::uint64_t>(status.st_size), nanoseconds(status.st_mtim),
                nanoseconds(status.st_ctim)};
    const std::size_t size = identity.size;
    if (size < sizeof(Header) + sizeof(std::uint64_t)) throw FileError(path + ": truncated");
    const auto end = static_cast<off_t>(size - sizeof(std::uint64_t));
    if (::pread(fd, &file.stored_checksum, sizeof(std::uint64_t), end) !=
        static_cast<ssize_t>(sizeof(std::uint64_t))) {
      throw FileError(path + ": cannot read: " + std::strerror(errno));
    }
    file.vouched = stampVouches(path, identity, file.stored_checksum);
    void* data =
        ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | (file.vouched ? 0 : MAP_POPULATE), fd, 0);
    if (data == MAP_FAILED) throw FileError(path + ": cannot map: " + std::strerror(errno));
    file.data = {data, [size](const void* mapped) { ::munmap(const_cast<void*>(mapped), size); }};
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  return file;
}

/// The grid's box from the header.
Box boxOf(const Header& header) {
  const Eigen::Vector3d origin(header.origin[0], header.origin[1], header.origin[2]);
  const Eigen::Vector3d extent =
      Eigen::Vector3d(header.dims[0], header.dims[1], header.dims[2]) * header.resolution;
  return Box{origin, origin + extent};
}

/// The header's geometry, checked before anything is sized by it (a file with a valid checksum
/// may still have been made by hand): a positive finite resolution, a finite origin, dims of at
/// least one voxel whose product is the voxel count and which a grid of the header's box has.
void checkGeometry(const Header& header, const std::string& path) {
  const Eigen::Vector3i dims(header.dims[0], header.dims[1], header.dims[2]);
  const Eigen::Vector3d origin(header.origin[0], header.origin[1], header.origin[2]);
  if (!(header.resolution > 0.0 && std::isfinite(header.resolution)) || !origin.allFinite() ||
      (dims.array() < 1).any() ||
      dims.cast<double>().prod() != static_cast<double>(header.voxel_count) ||
      (VoxelGrid::voxelsAlong(boxOf(header), header.resolution).array() !=
       dims.cast<double>().array())
          .any()) {
    throw FileError(path + ": inconsistent grid dimensions");
  }
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
  const Esdf& esdf = world.esdf();
  const bool bricked = grid.layout() == GridLayout::kBricked;
  Header header{};
  std::memcpy(header.magic, kMagic, sizeof(kMagic));
  header.format_version = kFormatVersion;
  header.layout = bricked ? kBrickedFile : kDenseFile;
  header.spec_hash = world.specHash();
  for (int axis = 0; axis < 3; ++axis) {
    header.dims[axis] = grid.dims()[axis];
    header.origin[axis] = grid.origin()[axis];
  }
  header.resolution = grid.resolution();
  header.voxel_count = grid.size();

  const std::filesystem::path target(path);
  std::error_code error;
  std::filesystem::create_directories(target.parent_path(), error);
  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  try {
    FileWriter out(temporary);
    out.put(&header, 1);
    if (!bricked) {
      out.align();
      out.put(grid.occupancy().data(), grid.size());
      out.align();
      out.put(esdf.values().data(), grid.size());
    } else {
      // The field's bricks of their own are numbered in table order.
      std::vector<std::int32_t> slots(esdf.brickCount());
      std::int32_t own = 0;
      for (std::size_t i = 0; i < slots.size(); ++i) {
        int shared = 0;
        const std::int16_t* codes = esdf.brickCodes(i, shared);
        slots[i] = codes != nullptr ? own++ : (shared > 0 ? -1 : -2);
      }
      const BrickedHeader bricks{slots.size(), grid.brickMasks().size(),
                                 static_cast<std::uint64_t>(own), esdf.truncation()};
      out.put(&bricks, 1);
      out.align();
      out.put(grid.brickStates().data(), grid.brickStates().size());
      out.align();
      out.put(grid.brickMasks().data(), grid.brickMasks().size());
      out.align();
      out.put(slots.data(), slots.size());
      out.align();
      for (std::size_t i = 0; i < slots.size(); ++i) {
        int shared = 0;
        if (const std::int16_t* codes = esdf.brickCodes(i, shared)) out.put(codes, 512);
      }
    }
    out.finish();
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
                                              const std::string& name, bool* checksum_read) {
  if (!isRegularFile(path)) throw FileError(path + ": not a regular file");
  // A file whose stamp vouches for it (the identity it had when its checksum was verified) is
  // read only where it is used; any other is read whole, for its checksum.
  MappedFile file = mapFile(path);
  const std::size_t size = file.identity.size;
  if (checksum_read != nullptr) *checksum_read = !file.vouched;
  FileReader in(path, std::move(file.data), size);
  const auto* bytes = static_cast<const char*>(in.file().get());
  const auto header = in.read<Header>();
  if (std::memcmp(header.magic, kMagic, sizeof(kMagic)) != 0) {
    throw FileError(path + ": not a kinolab world file");
  }
  if (header.format_version != kFormatVersion) {
    throw FileError(path + ": format version " + std::to_string(header.format_version) +
                    ", expected " + std::to_string(kFormatVersion));
  }
  if (header.spec_hash != expected_hash) throw FileError(path + ": built from another spec");
  if (header.layout != kDenseFile && header.layout != kBrickedFile) {
    throw FileError(path + ": unknown layout " + std::to_string(header.layout));
  }
  checkGeometry(header, path);
  const bool dense = header.layout == kDenseFile;
  const std::uint64_t voxels = header.voxel_count;
  const Eigen::Vector3i dims(header.dims[0], header.dims[1], header.dims[2]);
  // Where the arrays lie (each within the file, the last ending at the checksum), then the
  // checksum, and only then anything built from them.
  const std::uint8_t* occupancy = nullptr;
  const float* values = nullptr;
  const std::uint32_t* states = nullptr;
  const std::uint64_t* masks = nullptr;
  const std::int32_t* slots = nullptr;
  const std::int16_t* codes = nullptr;
  BrickedHeader bricks{};
  if (dense) {
    occupancy = in.take<std::uint8_t>(voxels);
    values = in.take<float>(voxels);
  } else {
    bricks = in.read<BrickedHeader>();
    const Eigen::Vector3d brick_dims =
        ((dims.array() + VoxelGrid::kBrick - 1) / VoxelGrid::kBrick).cast<double>();
    if (brick_dims.prod() != static_cast<double>(bricks.bricks) ||
        bricks.own_bricks > bricks.bricks) {
      throw FileError(path + ": inconsistent brick counts");
    }
    states = in.take<std::uint32_t>(bricks.bricks);
    masks = in.take<std::uint64_t>(bricks.mask_words);
    slots = in.take<std::int32_t>(bricks.bricks);
    codes = in.take<std::int16_t>(bricks.own_bricks * 512);
  }
  in.expectEnd();
  if (!file.vouched) {
    if (hashBytes(bytes, size - sizeof(std::uint64_t)) != file.stored_checksum) {
      throw FileError(path + ": checksum mismatch (corrupt)");
    }
    stampVerified(path, file.identity, file.stored_checksum);
  }
  // The grid and the field read the mapped file where it lies (a sparse grid's bricks are
  // copied: 4 bytes a brick and the masks).
  try {
    const Box box = boxOf(header);
    if (dense) {
      VoxelGrid grid(box, header.resolution,
                     ValueArray<std::uint8_t>(in.file(), occupancy, voxels));
      Esdf esdf(grid, ValueArray<float>(in.file(), values, voxels));
      return std::make_shared<const World>(name, expected_hash, std::move(grid), std::move(esdf));
    }
    VoxelGrid grid(box, header.resolution,
                   std::vector<std::uint32_t>(states, states + bricks.bricks),
                   std::vector<std::uint64_t>(masks, masks + bricks.mask_words));
    Esdf esdf =
        Esdf::fromBricks(grid, bricks.truncation, {slots, bricks.bricks},
                         ValueArray<std::int16_t>(in.file(), codes, bricks.own_bricks * 512));
    return std::make_shared<const World>(name, expected_hash, std::move(grid), std::move(esdf));
  } catch (const InvalidArgument& error) {
    throw FileError(path + ": inconsistent contents (" + error.what() + ")");
  }
}

WorldLoad WorldCache::loadOrBuild(const WorldSpec& spec) const {
  const auto start = std::chrono::steady_clock::now();
  WorldLoad load;
  const std::uint64_t hash = spec.hash();
  load.cache_file = fileFor(hash);
  if (std::filesystem::exists(load.cache_file)) {
    try {
      load.world = whileDoing("reading the world '" + spec.name + "' from " + load.cache_file, [&] {
        return read(load.cache_file, hash, spec.name, &load.checksum_read);
      });
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
