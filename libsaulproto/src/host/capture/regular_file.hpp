// A regular file opened for reading, closed at the end (private to the host library: the block readers of
// capture_blocks.cpp and report/fast_decode.cpp).
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <string>

namespace saul::host::detail {

struct RegularFile {
  int fd = -1;  ///< -1 when `path` cannot be opened or is no regular file (a pipe, a directory, a device)
  std::uint64_t size = 0;
  explicit RegularFile(const std::string& path) : fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {
    struct stat st {};
    if (fd >= 0 && (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))) {
      ::close(fd);
      fd = -1;
    }
    if (fd >= 0) size = static_cast<std::uint64_t>(st.st_size);
  }
  ~RegularFile() {
    if (fd >= 0) ::close(fd);
  }
  RegularFile(const RegularFile&) = delete;
  RegularFile& operator=(const RegularFile&) = delete;
  /// Hands the descriptor over: it is no longer closed here.
  int release() noexcept {
    const int released = fd;
    fd = -1;
    return released;
  }
};

}  // namespace saul::host::detail
