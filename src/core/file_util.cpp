#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/interrupt.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"

namespace hapticcal {
namespace {

std::string hex(unsigned char byte) { return fmt::format("\\x{:02x}", byte); }

// The length of the UTF-8 sequence at text[i] when it is the shortest encoding
// of a Unicode scalar value (RFC 3629), else 0; its code point in `cp`.
std::size_t utf8_sequence(const std::string& text, std::size_t i, char32_t& cp) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) {
    cp = b0;
    return 1;
  }
  std::size_t n = 0;
  char32_t min = 0;
  if ((b0 & 0xe0) == 0xc0) {
    n = 2, cp = b0 & 0x1f, min = 0x80;
  } else if ((b0 & 0xf0) == 0xe0) {
    n = 3, cp = b0 & 0x0f, min = 0x800;
  } else if ((b0 & 0xf8) == 0xf0) {
    n = 4, cp = b0 & 0x07, min = 0x10000;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
    cp = (cp << 6) | (byte(i + k) & 0x3f);
  }
  if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return n;
}

// Control characters, and the byte-order mark, which prints as nothing.
bool is_control(char32_t cp) { return cp < 0x20 || (cp >= 0x7f && cp <= 0x9f) || cp == 0xfeff; }

// `text` with every byte that is not printable UTF-8 (C0 and C1 control
// characters, DEL, the byte-order mark, a binary file's bytes) as \xNN, and '\\'
// too if `backslash`; cut after `max_chars` characters (`*cut` says whether).
std::string escaped(const std::string& text, std::size_t max_chars, bool backslash, bool* cut) {
  std::string out;
  out.reserve(std::min(text.size(), max_chars));
  std::size_t i = 0, chars = 0;
  while (i < text.size() && chars < max_chars) {
    char32_t cp = 0;
    const std::size_t n = utf8_sequence(text, i, cp);
    if (n == 0 || is_control(cp) || (backslash && cp == '\\')) {
      for (std::size_t k = 0; k < std::max<std::size_t>(n, 1); ++k)
        out += hex(static_cast<unsigned char>(text[i + k]));
      i += std::max<std::size_t>(n, 1);
    } else {
      out.append(text, i, n);
      i += n;
    }
    ++chars;
  }
  if (cut) *cut = i < text.size();
  return out;
}

// what() stays one printable line.
std::string one_line(const std::string& text) {
  return escaped(text, std::string::npos, false, nullptr);
}

std::string compose(const std::string& file, int line, const std::string& key,
                    const std::string& message) {
  std::string where = file;
  if (line > 0) where += fmt::format(":{}", line);
  if (!key.empty()) where += (where.empty() ? "" : ": ") + key;
  return one_line(where.empty() ? message : where + ": " + message);
}

}  // namespace

std::string markup_escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string printable(const std::string& text, std::size_t max_chars) {
  bool cut = false;
  std::string out = escaped(text, max_chars, true, &cut);
  if (cut) out += "...";
  return out;
}

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); !from.empty() && at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

std::string text_problem(const std::string& text) {
  for (std::size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const std::size_t n = utf8_sequence(text, i, cp);
    if (n == 0) return fmt::format("invalid UTF-8 at byte {}", i + 1);
    if (is_control(cp)) {
      std::string bytes;
      for (std::size_t k = 0; k < n; ++k) bytes += hex(static_cast<unsigned char>(text[i + k]));
      return fmt::format("control character {} at byte {}", bytes, i + 1);
    }
    i += n;
  }
  return {};
}

InputError::InputError(const std::string& file, int line, const std::string& key,
                       const std::string& message)
    : std::invalid_argument(compose(file, line, key, message)),
      file_(file),
      line_(line),
      key_(key),
      message_(message) {}

InputError::InputError(const std::string& message)
    : std::invalid_argument(one_line(message)), message_(message) {}

std::size_t max_file_bytes(FileKind kind) {
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  switch (kind) {
    case FileKind::kDevice:
    case FileKind::kFixture:
    case FileKind::kScenario:
      return kMiB / 4;  // yaml-cpp: up to 240 bytes a byte (a dense flow list): 60 MB
    case FileKind::kUrdf:
      return 3 * kMiB;  // tinyxml + urdfdom: up to 50 bytes a byte (tiny elements): 150 MB
    case FileKind::kLog:
      return 2048 * kMiB;
    case FileKind::kOwn:
      break;
  }
  return 256 * kMiB;
}

namespace {

const char* kind_name(FileKind kind) {
  switch (kind) {
    case FileKind::kDevice:
      return "a device file";
    case FileKind::kUrdf:
      return "a URDF";
    case FileKind::kLog:
      return "a log";
    case FileKind::kFixture:
      return "a fixture file";
    case FileKind::kScenario:
      return "a scenario";
    case FileKind::kOwn:
      break;
  }
  return "this file";
}

std::string size_text(std::size_t bytes) {
  return bytes >= (1u << 20) ? fmt::format("{} MiB", bytes >> 20)
                             : fmt::format("{} KiB", bytes >> 10);
}

// Closes a descriptor on every path out.
struct Descriptor {
  int fd;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

std::string read_file(const std::string& path, FileKind kind) {
  const std::size_t limit = max_file_bytes(kind);
  if (path.find('\0') != std::string::npos) {  // c_str() would name another file
    throw InputError(printable(path, 200), 0, "", "the file name holds a NUL byte");
  }
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below.
  const Descriptor file{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (file.fd < 0) {
    throw InputError(path, 0, "", fmt::format("cannot open: {}", std::strerror(errno)));
  }
  struct stat st {};
  if (::fstat(file.fd, &st) != 0) {
    throw InputError(path, 0, "", fmt::format("cannot read: {}", std::strerror(errno)));
  }
  if (S_ISDIR(st.st_mode)) throw InputError(path, 0, "", "is a directory");
  if (!S_ISREG(st.st_mode)) {
    throw InputError(path, 0, "", "is not a regular file (a device, FIFO or socket): give a file");
  }
  auto too_large = [&](const std::string& size) {
    return InputError(
        path, 0, "",
        fmt::format("{}, more than the {} {} may have", size, size_text(limit), kind_name(kind)));
  };
  if (static_cast<std::size_t>(st.st_size) > limit) {
    throw too_large(fmt::format("{} bytes", static_cast<long long>(st.st_size)));
  }
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(file.fd, buffer, sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError(path, 0, "", fmt::format("cannot read: {}", std::strerror(errno)));
    }
    if (n == 0) break;
    if (text.size() + static_cast<std::size_t>(n) > limit) {
      throw too_large("growing while read");  // a file still being written
    }
    text.append(buffer, static_cast<std::size_t>(n));
  }
  return text;
}

void write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  std::error_code ec;
  const detail::WriteGuard guard;
  if (guard.aborted()) throw IoError(path + ": not written: interrupted");
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  if (ec) throw IoError(path + ": cannot create directory: " + ec.message());
  std::string tmp = path + ".tmp-XXXXXX";
  const int fd = mkstemp(tmp.data());
  if (fd < 0) throw IoError(fmt::format("{}: cannot write: {}", path, std::strerror(errno)));
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      std::remove(tmp.c_str());
      throw IoError(fmt::format("{}: cannot write: {}", path, std::strerror(err)));
    }
    done += static_cast<size_t>(n);
  }
  ::fchmod(fd, 0644);
  int err = ::fsync(fd) == 0 ? 0 : errno;
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err != 0) {
    std::remove(tmp.c_str());
    throw IoError(fmt::format("{}: cannot write (sync failed): {}", path, std::strerror(err)));
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw IoError(path + ": cannot write: " + ec.message());
  }
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  // One row of the (|a| + 1) x (|b| + 1) table at a time.
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];  // the table's (i - 1, j - 1)
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string did_you_mean(const std::string& name, const std::vector<std::string>& known) {
  // Long input is not a typo of a short name: skip the table.
  if (name.empty() || name.size() > 200) return {};
  const std::string* best = nullptr;
  std::size_t best_distance = 0;
  const std::size_t close = std::max<std::size_t>(2, name.size() / 3);
  for (const std::string& k : known) {
    // At least the lengths' difference apart: never close, so not worth the
    // table (a recording's 100,000 long names cost nothing).
    const std::size_t apart =
        k.size() > name.size() ? k.size() - name.size() : name.size() - k.size();
    if (apart > close) continue;
    const std::size_t d = edit_distance(name, k);
    if (!best || d < best_distance) {
      best = &k;
      best_distance = d;
    }
  }
  if (!best || best_distance == 0) return {};
  if (best_distance > close) return {};
  return fmt::format(" (did you mean '{}'?)", printable(*best));
}

}  // namespace hapticcal
