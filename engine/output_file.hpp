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
#include <stdexcept>
#include <string>
#include <string_view>

#include <fcntl.h>
#include <unistd.h>

namespace tsph {

class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline void write_file_atomically(const std::filesystem::path& path, std::string_view text) {
  const std::filesystem::path partial = path.string() + ".partial";
  auto fail = [&](const char* what, int error, int fd) {
    if (fd >= 0) ::close(fd);
    ::unlink(partial.c_str());
    throw OutputError("cannot write '" + path.string() + "' (" + what + ": " +
                      std::strerror(error) + "); free space or choose a writable output "
                      "directory; files written before are kept");
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
