// One run per output directory (issue 15, docs/reliability.md): a run holds an advisory
// flock(2) on DIR/.tsph-run.lock from before it looks at the directory until it ends. A
// second run into the same directory is refused at once; the kernel releases the lock
// when the process ends, however it ends (kill -9 included), so a stale lock file never
// blocks a later run. The lock file itself is left in place (removing it would let a
// third run lock a new file while the second still holds the old one).
#pragma once

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

namespace tsph {

inline constexpr const char* kRunLockName = ".tsph-run.lock";

class RunLock {
 public:
  RunLock() = default;
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;
  RunLock(RunLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  RunLock& operator=(RunLock&& other) noexcept {
    std::swap(fd_, other.fd_);
    return *this;
  }
  ~RunLock() {
    if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the flock
  }
  bool held() const { return fd_ >= 0; }

  /// Creates `dir` if needed and locks it. Returns the message for the user if another
  /// run holds the lock; nothing otherwise (also when the directory or the lock file
  /// cannot be created: the output checks that follow report that).
  std::optional<std::string> acquire(const std::string& dir) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    const std::string path = (std::filesystem::path(dir) / kRunLockName).string();
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return std::nullopt;
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      char pid[32] = {};
      const ssize_t n = ::pread(fd, pid, sizeof pid - 1, 0);
      ::close(fd);
      std::string holder = n > 0 ? std::string(pid, static_cast<std::size_t>(n)) : std::string();
      while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
      if (error != EWOULDBLOCK) return std::nullopt;
      return "out = '" + dir + "' is in use by another tsph run" + (holder.empty() ? "" : " (pid " + holder + ")") +
             ", which holds " + path + ": wait for it to end, or choose another directory with --out";
    }
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(fd, 0) == 0) (void)!::pwrite(fd, pid.data(), pid.size(), 0);
    fd_ = fd;
    return std::nullopt;
  }

 private:
  int fd_ = -1;
};

/// Whether `dir` holds nothing but the run lock file.
inline bool output_directory_empty(const std::string& dir) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec))
    if (entry.path().filename() != kRunLockName) return false;
  return true;
}

}  // namespace tsph
