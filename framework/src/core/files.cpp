#include "kinolab/core/files.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <pthread.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <mutex>
#include <system_error>
#include <utility>

#include "kinolab/core/error.hpp"
#include "kinolab/core/version.hpp"

namespace kinolab {

bool isRegularFile(const std::string& path) {
  std::error_code error;
  return std::filesystem::is_regular_file(path, error) && !error;
}

std::string frameworkLibraryDirectory() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&frameworkLibraryDirectory), &info) == 0 || !info.dli_fname) {
    return "";
  }
  std::error_code error;
  return std::filesystem::absolute(info.dli_fname, error).parent_path().string();
}

std::string installedDataDirectory() {
  namespace fs = std::filesystem;
  // <prefix>/lib[/<multiarch>]/libkinolab_framework.so -> <prefix>/share/kinolab
  std::error_code error;
  for (fs::path up = frameworkLibraryDirectory(); up.has_relative_path(); up = up.parent_path()) {
    if (up.filename() == "lib") {
      const fs::path share = up.parent_path() / "share/kinolab";
      return fs::is_directory(share, error) ? share.string() : "";
    }
  }
  return "";
}

std::string analysisDirectory() {
  namespace fs = std::filesystem;
  if (const char* set = std::getenv("KINOLAB_ANALYSIS_DIR"); set && *set) return set;
  std::error_code error;
  const fs::path source = fs::path(kSourceDir) / "analysis";
  if (fs::is_directory(source / "kinolab_analysis", error)) return source.string();
  const std::string installed = installedDataDirectory();
  if (!installed.empty() && fs::is_directory(installed + "/analysis/kinolab_analysis", error)) {
    return installed + "/analysis";
  }
  throw FileError("the analysis package (kinolab_analysis) is in neither " + source.string() +
                  " nor an installation's share/kinolab/analysis; set KINOLAB_ANALYSIS_DIR");
}

namespace {

/// The refusal of a link where kinolab writes `what` (its lock file, an output file).
FileError linkRefused(const std::string& path, const std::string& what) {
  return FileError(path + ": " + what +
                   " is a symbolic link; kinolab does not write through links: remove it, or "
                   "choose another directory");
}

}  // namespace

OutputFile::OutputFile(const std::string& path) : path_(path) {
  // O_NONBLOCK: a pipe planted at the path is refused below rather than waited on.
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
  if (fd < 0 && errno == ELOOP) throw linkRefused(path, "the output file");
  const FileError not_regular(path +
                              ": not a regular file: remove it, or choose another directory");
  if (fd < 0 && errno == ENXIO) throw not_regular;  // a pipe nobody reads
  if (fd < 0) throw FileError(path + ": cannot write (" + std::strerror(errno) + ")");
  struct stat status {};
  if (fstat(fd, &status) != 0 || !S_ISREG(status.st_mode)) {
    ::close(fd);
    throw not_regular;
  }
  if (ftruncate(fd, 0) != 0 || !(file_ = fdopen(fd, "wb"))) {
    const int reason = errno;
    ::close(fd);
    throw FileError(path + ": cannot write (" + std::strerror(reason) + ")");
  }
}

OutputFile::~OutputFile() {
  if (file_) std::fclose(file_);
}

void OutputFile::write(const void* data, std::size_t size) {
  if (size > 0 && std::fwrite(data, 1, size, file_) != size) {
    throw FileError(path_ + ": cannot write (" + std::strerror(errno) + ")");
  }
}

void OutputFile::close() {
  std::FILE* file = std::exchange(file_, nullptr);
  if (std::fclose(file) != 0) {
    throw FileError(path_ + ": cannot write (" + std::strerror(errno) + ")");
  }
}

void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    OutputFile out(temporary);
    out.write(text.data(), text.size());
    out.close();
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) throw FileError(path + ": cannot write (" + error.message() + ")");
}

namespace {

/// The descriptors of the locks this process holds, plus one (0: a free slot), closed in every
/// child it forks (the runner's workers): a lock shared with a child would outlive a killed
/// holder until the child died too, and refuse the holder's next run. Fixed slots, so that the
/// child's handler does nothing but close().
std::array<std::atomic<int>, 16> held_locks{};

void closeHeldLocksInChild() {
  for (auto& slot : held_locks) {
    const int held = slot.load();
    if (held > 0) close(held - 1);
  }
}

void holdLock(int fd) {
  static std::once_flag once;
  std::call_once(once, [] { pthread_atfork(nullptr, nullptr, closeHeldLocksInChild); });
  for (auto& slot : held_locks) {
    int free = 0;
    if (slot.compare_exchange_strong(free, fd + 1)) return;
  }
  // More locks than slots: this one is shared with children, which only delays its release.
}

void releaseLock(int fd) {
  for (auto& slot : held_locks) {
    int held = fd + 1;
    if (slot.compare_exchange_strong(held, 0)) return;
  }
}

}  // namespace

DirectoryLock::DirectoryLock(const std::string& directory, const std::string& purpose) {
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error && !std::filesystem::is_directory(directory)) {
    throw FileError(directory + ": cannot create the directory (" + error.message() + ")");
  }
  const std::string path = (std::filesystem::path(directory) / ".kinolab.lock").string();
  // Never through a link: a planted .kinolab.lock pointing elsewhere would have the lock's
  // text written into whatever it names.
  fd_ = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd_ < 0 && errno == ELOOP) throw linkRefused(path, "the lock file");
  if (fd_ < 0) {
    throw FileError(path + ": cannot open the lock file (" + std::strerror(errno) + ")");
  }
  struct stat status {};
  if (fstat(fd_, &status) != 0 || !S_ISREG(status.st_mode)) {
    close(fd_);
    throw FileError(path + ": the lock file is not a regular file: remove it");
  }
  if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int reason = errno;
    std::string holder(512, '\0');
    const ssize_t n = pread(fd_, holder.data(), holder.size(), 0);
    holder.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    while (!holder.empty() && (holder.back() == '\n' || holder.back() == '\0')) holder.pop_back();
    close(fd_);
    if (reason == EWOULDBLOCK) {
      throw FileError(directory + " is in use by another process (" +
                      (holder.empty() ? std::string("unknown") : holder) +
                      "); wait for it to finish, or choose another directory");
    }
    throw FileError(path + ": cannot lock (" + std::strerror(reason) + ")");
  }
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  const std::time_t now = std::time(nullptr);
  char started[32];
  std::strftime(started, sizeof(started), "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  const std::string text =
      purpose + ", pid " + std::to_string(getpid()) + " on " + host + ", since " + started + "\n";
  if (ftruncate(fd_, 0) != 0 || pwrite(fd_, text.data(), text.size(), 0) < 0) {
    close(fd_);
    throw FileError(path + ": cannot write the lock file (" + std::strerror(errno) + ")");
  }
  holdLock(fd_);
}

DirectoryLock::~DirectoryLock() {
  if (fd_ < 0) return;
  releaseLock(fd_);
  close(fd_);  // closing releases the lock
}

}  // namespace kinolab
