/// @file pipe_io.h
/// @brief Whole reads and writes on a pipe, for the readers that run a library in a child process (mesh_file.cpp,
/// texture_file.cpp).
#pragma once

#include <cerrno>
#include <cstddef>

#include <unistd.h>

namespace raylife {

/// Writes all `size` bytes of `data` to file descriptor `fd`, retrying after EINTR. @return false if a write failed
/// (the reader stopped reading) before all were written.
inline bool writeAll(int fd, const void* data, std::size_t size)
{
  const char* at = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, at, size);
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
      return false;
    at += n;
    size -= std::size_t(n);
  }
  return true;
}

/// Reads exactly `size` bytes from file descriptor `fd` into `data`, retrying after EINTR. @return false if the
/// stream ended (or failed) first.
inline bool readAll(int fd, void* data, std::size_t size)
{
  char* at = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, at, size);
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
      return false;
    at += n;
    size -= std::size_t(n);
  }
  return true;
}

} // namespace raylife
