#pragma once

#include <memory>
#include <string>

#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {

/// How loadOrBuild obtained a world.
enum class WorldSource { kBuilt, kCache, kRebuiltCorruptCache };

struct WorldLoad {
  std::shared_ptr<const World> world;
  WorldSource source = WorldSource::kBuilt;
  double seconds = 0.0;    // wall time of the load or build
  std::string cache_file;  // empty when caching is off
  std::string note;        // why a cache file was rejected, if one was
  /// Whether a cache file's checksum was computed (read whole) on this load; false when its
  /// stamp vouched for it (WorldCache).
  bool checksum_read = false;
};

/// Built worlds (grid + ESDF) on disk, one file per spec keyed by WorldSpec::hash(). A file
/// carries a magic, a format version, the spec hash, its sizes and a checksum over all of
/// it; a file failing any check is reported, rebuilt and replaced, never trusted. Files are
/// written to a temporary name and renamed, so concurrent builders never see half a file.
/// A file's checksum is computed on the first load after the file last changed; a stamp beside
/// it (`<file>.verified`: its device, inode, size, modification and change times then) lets
/// later loads skip it while the file keeps that identity, so that they read only the pages
/// they use. The stamp is written only once the file has not changed for half a second (a
/// change within the file system's clock tick could keep its times).
class WorldCache {
 public:
  /// `directory` is created on first write.
  explicit WorldCache(std::string directory);

  /// $KINOLAB_CACHE_DIR, else $XDG_CACHE_HOME/kinolab/worlds, else ~/.cache/kinolab/worlds.
  static std::string defaultDirectory();

  const std::string& directory() const { return directory_; }
  std::string fileFor(const WorldSpec& spec) const { return fileFor(spec.hash()); }
  std::string fileFor(std::uint64_t spec_hash) const;
  WorldLoad loadOrBuild(const WorldSpec& spec) const;

  /// Writes a world file (atomically). Throws FileError when the directory is not writable.
  static void write(const World& world, const std::string& path);
  /// Reads a world file; throws FileError naming what is wrong with it. `checksum_read`, when
  /// given, says whether the checksum was computed (no stamp vouched for the file).
  static std::shared_ptr<const World> read(const std::string& path, std::uint64_t expected_hash,
                                           const std::string& name, bool* checksum_read = nullptr);

 private:
  std::string directory_;
};

}  // namespace kinolab
