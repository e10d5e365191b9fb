// Writing to the terminal without ever throwing: a full disk, a closed pipe or
// a closed stderr (2>/dev/full, 2>&-) must end in exit 1, not in an exception
// thrown from a catch block (std::terminate, SIGABRT).
#pragma once

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

namespace hapticcal::cli {

// Set when a write to stdout or stderr failed.
inline bool& stream_failed() {
  static bool failed = false;
  return failed;
}

// Standard streams the program was started without (2>&- closes stderr):
// each is opened on /dev/null, so that no file the program opens takes its
// number and receives its messages, and remembered as a stream that failed.
inline bool& stdout_closed() {
  static bool closed = false;
  return closed;
}
inline bool& stderr_closed() {
  static bool closed = false;
  return closed;
}
inline void guard_standard_streams() {
  for (int fd = 0; fd <= 2; ++fd) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    const int opened = ::open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
    if (opened != fd && opened >= 0) ::close(opened);  // cannot happen: lowest free number
    if (fd == 1) stdout_closed() = true;
    if (fd == 2) stderr_closed() = true;
  }
}

// fmt::print to `stream` that records a failure instead of throwing.
template <typename... Args>
void say(std::FILE* stream, fmt::format_string<Args...> format, Args&&... args) {
  std::string text;
  try {
    text = fmt::format(format, std::forward<Args>(args)...);
  } catch (...) {
    stream_failed() = true;  // out of memory formatting a message
    return;
  }
  if (std::fwrite(text.data(), 1, text.size(), stream) != text.size()) stream_failed() = true;
  if (stream == stderr && stderr_closed()) stream_failed() = true;
}

// The exit code once stdout and stderr are flushed: a run that succeeded but
// whose output was lost (stdout on a full disk, stderr closed) exits 1, with a
// line on stderr if stderr can still take one.
inline int finish_streams(int code) {
  const bool out_failed = std::fflush(stdout) != 0 || std::ferror(stdout);
  const int out_errno = errno;
  const bool err_failed = std::fflush(stderr) != 0 || std::ferror(stderr);
  if (out_failed || err_failed || stdout_closed()) stream_failed() = true;
  if (!stream_failed() || code != 0) return code;
  const bool out = out_failed || stdout_closed();
  const std::string line = fmt::format(
      "hapticcal: cannot write the {}: {}\n", out ? "standard output" : "standard error",
      out_failed ? std::strerror(out_errno) : "it is closed or full");
  [[maybe_unused]] const ssize_t n = ::write(2, line.data(), line.size());
  return 1;
}

}  // namespace hapticcal::cli
