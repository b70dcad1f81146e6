#pragma once

#include <string>

namespace kinolab {

/// True when `path` names a regular file; never throws (a name too long, a loop of links or
/// a path through a file are all "no").
bool isRegularFile(const std::string& path);

/// Writes `text` to a temporary file beside `path` and renames it over `path`, so a reader
/// never sees half a file. Throws FileError naming the path when it cannot.
void writeFileAtomically(const std::string& path, const std::string& text);

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
/// by another process is a FileError naming that holder.
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
