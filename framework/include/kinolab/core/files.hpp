#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

namespace kinolab {

/// True when `path` names a regular file; never throws (a name too long, a loop of links or
/// a path through a file are all "no").
bool isRegularFile(const std::string& path);

/// A file kinolab writes (created, or emptied), never reached through a link: a symbolic link,
/// a pipe or a device at its path is a FileError naming it before anything is written, so a
/// link planted in a results directory never gets kinolab's output written into its target.
class OutputFile {
 public:
  explicit OutputFile(const std::string& path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  /// The open stream (for writers such as libpng that take one).
  std::FILE* stream() const { return file_; }
  /// Appends `size` bytes; FileError naming the path when they cannot be written.
  void write(const void* data, std::size_t size);
  /// Flushes and closes; FileError naming the path when the data did not reach the file.
  void close();

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

/// Writes `text` to a temporary file beside `path` (an OutputFile) and renames it over `path`,
/// so a reader never sees half a file and a link at `path` is replaced, never written through.
/// Throws FileError naming the path when it cannot.
void writeFileAtomically(const std::string& path, const std::string& text);

/// The folder of the framework library this code runs in (the build tree's framework/ or the
/// installed lib/), absolute; "" when the library's path cannot be found.
std::string frameworkLibraryDirectory();

/// <prefix>/share/kinolab of the installed framework library this code runs in (found from
/// the library's own path), or "" when it does not run from an installation.
std::string installedDataDirectory();

/// The folder holding the analysis package (kinolab_analysis, with papers.yaml):
/// $KINOLAB_ANALYSIS_DIR, the source tree's analysis/, or share/kinolab/analysis of the
/// installation. Throws FileError naming where it looked.
std::string analysisDirectory();

/// An exclusive lock on a directory, held by one process for as long as this object lives
/// (and released by the kernel when the process dies, even of SIGKILL): the lock file
/// `<directory>/.kinolab.lock` holds the holder's pid, host and start time. A directory held
/// by another process is a FileError naming that holder. Children the holder forks do not
/// share the lock (their copy of its descriptor is closed at fork), so it goes with the holder.
class DirectoryLock {
 public:
  /// Creates the directory if needed; `purpose` ("kinolab run") goes into the lock file.
  DirectoryLock(const std::string& directory, const std::string& purpose);
  ~DirectoryLock();
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace kinolab
