#pragma once

#include <string>

namespace kinolab {

/// True when `path` names a regular file; never throws (a name too long, a loop of links or
/// a path through a file are all "no").
bool isRegularFile(const std::string& path);

/// Writes `text` to a temporary file beside `path` and renames it over `path`, so a reader
/// never sees half a file. Throws FileError naming the path when it cannot.
void writeFileAtomically(const std::string& path, const std::string& text);

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
