// Output files written whole or not at all (issue 6: a failed write must stop the run
// cleanly and lose nothing written before).
//
// The text goes to "<path>.partial", every byte is checked (short writes are retried,
// ENOSPC and EIO are reported), the file is synced and closed, and only then renamed
// over `path`. A failure at any point removes the partial file and leaves `path` as it
// was (the previous run's file, if any) and throws OutputError naming the file and the
// reason. fmt::output_file is not used for results: it ignores short writes and flushes
// in its destructor, where a full disk ends the program with std::terminate.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

namespace tsph {

class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bytes an unprivileged user may still write on the file system that holds `path`
/// (statvfs f_bavail x f_frsize) or, if `path` does not exist yet, its nearest existing
/// parent; nothing if unknown (or a file system without a size, like /proc).
inline std::optional<std::size_t> available_disk_bytes(const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::path p = std::filesystem::absolute(path, ec);
  while (!p.empty() && !std::filesystem::exists(p, ec) && p != p.parent_path()) p = p.parent_path();
  struct statvfs fs {};
  if (::statvfs(p.c_str(), &fs) != 0 || fs.f_blocks == 0) return std::nullopt;  // /proc: no size
  return static_cast<std::size_t>(fs.f_bavail) * static_cast<std::size_t>(fs.f_frsize);
}

/// The one message of a failed write: the file, the call that failed, the reason.
[[noreturn]] inline void throw_output_error(const std::string& path, const char* what, int error) {
  throw OutputError("cannot write '" + path + "' (" + what + ": " + std::strerror(error) +
                    "); free space or choose a writable output directory; files written "
                    "before are kept");
}

inline void write_file_atomically(const std::filesystem::path& path, std::string_view text) {
  const std::filesystem::path partial = path.string() + ".partial";
  auto fail = [&](const char* what, int error, int fd) {
    if (fd >= 0) ::close(fd);
    ::unlink(partial.c_str());
    throw_output_error(path.string(), what, error);
  };
  const int fd = ::open(partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("open", errno, -1);
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write", errno, fd);
    }
    if (n == 0) fail("write", ENOSPC, fd);
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 && errno != EINVAL) fail("fsync", errno, fd);
  if (::close(fd) != 0) fail("close", errno, -1);
  if (::rename(partial.c_str(), path.c_str()) != 0) fail("rename", errno, -1);
}

}  // namespace tsph
