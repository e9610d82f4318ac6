/// @file pipe_io.h
/// @brief Whole reads and writes on a pipe, for the readers that run a library in a child process (mesh_file.cpp,
/// texture_file.cpp).
#pragma once

#include <cerrno>
#include <cstddef>
#include <cstring>
#include <string>
#include <utility>

#include <fcntl.h>
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

/// Forks a child joined to this process by a pipe: the child runs `child(writeEnd)`, which must end the child
/// (_exit) and never return; the parent gets the pipe's reading end and the child's process id. `bufferBytes` > 0
/// asks for a pipe buffer that large (best effort). Call it before starting threads (see mesh_file.h).
/// @throws Error(what + the system's reason) when the pipe or the process cannot be made.
template <class Error, class Child>
std::pair<int, pid_t> forkWithPipe(const std::string& what, Child&& child, int bufferBytes = 0)
{
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw Error(what + std::strerror(errno));
#ifdef F_SETPIPE_SZ
  if (bufferBytes > 0)
    ::fcntl(fds[1], F_SETPIPE_SZ, bufferBytes);
#endif
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int error = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(what + std::strerror(error));
  }
  if (pid == 0) {
    ::close(fds[0]);
    child(fds[1]); // never returns
  }
  ::close(fds[1]);
  return {fds[0], pid};
}

} // namespace raylife
