#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hapticcal/error.hpp"
#include "hapticcal/io.hpp"

namespace hapticcal {
namespace {

std::string compose(const std::string& file, int line, const std::string& key,
                    const std::string& message) {
  std::string where = file;
  if (line > 0) where += fmt::format(":{}", line);
  if (!key.empty()) where += (where.empty() ? "" : ": ") + key;
  return where.empty() ? message : where + ": " + message;
}

}  // namespace

InputError::InputError(const std::string& file, int line, const std::string& key,
                       const std::string& message)
    : std::invalid_argument(compose(file, line, key, message)),
      file_(file),
      line_(line),
      key_(key),
      message_(message) {}

InputError::InputError(const std::string& message)
    : std::invalid_argument(message), message_(message) {}

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, 0, "", "is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "", fmt::format("cannot open: {}", std::strerror(errno)));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  if (ec) throw InputError(path, 0, "", "cannot create directory: " + ec.message());
  std::string tmp = path + ".tmp-XXXXXX";
  const int fd = mkstemp(tmp.data());
  if (fd < 0) throw InputError(path, 0, "", fmt::format("cannot write: {}", std::strerror(errno)));
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      std::remove(tmp.c_str());
      throw InputError(path, 0, "", fmt::format("cannot write: {}", std::strerror(err)));
    }
    done += static_cast<size_t>(n);
  }
  ::fchmod(fd, 0644);
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    std::remove(tmp.c_str());
    throw InputError(path, 0, "", "cannot write (sync failed)");
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw InputError(path, 0, "", "cannot write: " + ec.message());
  }
}

}  // namespace hapticcal
