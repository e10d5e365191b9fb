#include "hapticcal/output_set.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>
#include <thread>

#include "hapticcal/error.hpp"
#include "hapticcal/io.hpp"
#include "interrupt.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

// Staging folders of the running sets, removed by the signal thread.
std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::set<std::string>& registry() {
  static std::set<std::string> paths;
  return paths;
}

std::atomic<bool> aborted{false};

std::mutex& children_mutex() {
  static std::mutex m;
  return m;
}
std::set<pid_t>& children() {
  static std::set<pid_t> pids;
  return pids;
}

// Removes `path` until it stays removed: a thread may still be finishing a
// write into it (every new write is refused once `aborted` is set).
void remove_for_good(const std::string& path) {
  using namespace std::chrono_literals;
  for (int round = 0; round < 2; ++round) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      std::error_code ec;
      fs::remove_all(path, ec);
      if (!fs::exists(path, ec)) break;
      std::this_thread::sleep_for(5ms);
    }
    std::this_thread::sleep_for(20ms);  // a write that passed its check before the signal
  }
}

void forget_staging(const std::string& path) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  registry().erase(path);
}

std::string system_reason() { return std::strerror(errno); }

// Whether `dir` may be replaced: empty, or written by hapticcal before.
bool replaceable(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_empty(dir, ec)) return true;
  return fs::exists(dir / kOutputMarker, ec) || fs::exists(dir / "results.json", ec);
}

}  // namespace

OutputSet::OutputSet(const std::string& out, const std::string& command) : target_(out) {
  if (out.empty()) throw InputError("--out: an empty path is not a folder");
  std::error_code ec;
  const fs::path target = fs::weakly_canonical(fs::absolute(out), ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", out, ec.message()));
  const fs::path cwd = fs::current_path(ec);
  if (!target.has_filename() || target == target.root_path() ||
      (!ec &&
       (cwd == target ||
        fmt::format("{}/", cwd.string()).rfind(fmt::format("{}/", target.string()), 0) == 0))) {
    throw InputError(fmt::format(
        "--out {}: the working folder or one of its parents cannot be an output folder (it is "
        "replaced as a whole); name a new folder",
        out));
  }
  const fs::path parent = target.parent_path();
  if (fs::exists(target, ec) && !fs::is_directory(target, ec)) {
    throw InputError(fmt::format("--out {}: exists and is not a folder", out));
  }
  if (fs::is_directory(target, ec) && !replaceable(target)) {
    throw InputError(fmt::format(
        "--out {}: holds files hapticcal did not write (no {} or results.json); a run replaces its "
        "output folder as a whole: name a new or empty folder",
        out, kOutputMarker));
  }
  fs::create_directories(parent, ec);
  if (ec)
    throw IoError(
        fmt::format("--out {}: cannot create {}: {}", out, parent.string(), ec.message()));
  if (::mkdir(target.c_str(), 0755) == 0) {
    created_ = true;
  } else if (errno != EEXIST) {
    throw IoError(fmt::format("--out {}: cannot create the folder: {}", out, system_reason()));
  }
  lock_fd_ = ::open(target.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (lock_fd_ < 0) throw IoError(fmt::format("--out {}: cannot open: {}", out, system_reason()));
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const std::string reason = errno == EWOULDBLOCK
                                   ? "another hapticcal run is writing into this folder; wait for "
                                     "it or name another folder"
                                   : system_reason();
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw IoError(fmt::format("--out {}: {}", out, reason));
  }
  std::string staging =
      (parent / fmt::format(".{}.tmp-XXXXXX", target.filename().string())).string();
  {
    // Registered before it exists, so that a signal never leaves it behind.
    std::lock_guard<std::mutex> lock(registry_mutex());
    if (::mkdtemp(staging.data()) == nullptr) {
      const std::string reason = system_reason();
      ::close(lock_fd_);
      throw IoError(fmt::format("--out {}: cannot write in {}: {}", out, parent.string(), reason));
    }
    registry().insert(staging);
  }
  staging_ = staging;
  ::chmod(staging_.c_str(), 0755);  // mkdtemp's 0700 would become --out's mode
  write_file_atomically(staging_ + "/" + kOutputMarker, fmt::format("hapticcal {}\n", command));
}

OutputSet::~OutputSet() {
  if (!committed_ && !staging_.empty()) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
    forget_staging(staging_);
    if (created_) ::rmdir(target_.c_str());  // the empty folder made for the lock
  }
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

bool OutputSet::keep_previous(const std::string& name) const {
  std::error_code ec;
  const fs::path from = fs::path(target_) / name;
  if (!fs::is_regular_file(from, ec)) return false;
  write_file_atomically(staging_ + "/" + name, read_file(from.string()));
  return true;
}

void OutputSet::commit() {
  std::lock_guard<std::mutex> lock(registry_mutex());
  // After the exchange the staging path holds the old set, which is removed:
  // it stays registered until then.
  if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) != 0) {
    throw IoError(
        fmt::format("--out {}: cannot put the new outputs in place: {}", target_, system_reason()));
  }
  committed_ = true;
  std::error_code ec;
  fs::remove_all(staging_, ec);
  registry().erase(staging_);
}

void remove_staging_on_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  std::thread([set] {
    int sig = 0;
    if (sigwait(&set, &sig) != 0) return;
    registry_mutex().lock();  // held until exit: no set is committed after this
    aborted = true;           // write_file_atomically refuses from now on
    {
      std::lock_guard<std::mutex> lock(children_mutex());
      for (pid_t pid : children()) ::kill(pid, SIGKILL);
    }
    for (const std::string& path : registry()) remove_for_good(path);
    const char* message = "hapticcal: interrupted; no partial output was left\n";
    [[maybe_unused]] const ssize_t n = ::write(2, message, std::strlen(message));
    ::_exit(128 + sig);
  }).detach();
}

void finish_if_interrupted() {
  while (aborted.load()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
}

namespace detail {

bool output_aborted() { return aborted.load(); }

void track_child(pid_t pid) {
  std::lock_guard<std::mutex> lock(children_mutex());
  children().insert(pid);
}

void untrack_child(pid_t pid) {
  std::lock_guard<std::mutex> lock(children_mutex());
  children().erase(pid);
}

}  // namespace detail
}  // namespace hapticcal
