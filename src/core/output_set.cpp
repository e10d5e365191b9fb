#include "hapticcal/core/output_set.hpp"

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
#include <shared_mutex>
#include <sstream>
#include <thread>

#include "core/interrupt.hpp"
#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

// State shared with the signal thread; never destroyed, so that a signal at
// exit does not meet a destroyed mutex.
struct Registry {
  std::mutex mutex;                    // held by commit() and, to the end, by the signal thread
  std::set<std::string> staging;       // staging folders of running sets
  std::set<std::string> created;       // --out folders made empty for the lock
  std::shared_mutex writes;            // WriteGuard: shared per write, exclusive on a signal
  std::atomic<bool> aborted{false};    // a signal is being handled
  std::atomic<bool> committed{false};  // some set was put in place
  std::mutex children_mutex;
  std::set<pid_t> children;  // programs we wait for
};
Registry& registry() {
  static Registry* r = new Registry;
  return *r;
}

// Removes `path` until it stays removed (a killed child may finish one last file).
void remove_for_good(const std::string& path) {
  using namespace std::chrono_literals;
  for (int attempt = 0; attempt < 200; ++attempt) {
    std::error_code ec;
    fs::remove_all(path, ec);
    if (!fs::exists(path, ec)) return;
    std::this_thread::sleep_for(5ms);
  }
}

std::string system_reason() { return std::strerror(errno); }

// The entries a set's marker lists (its first line is the command).
std::set<std::string> marker_entries(const fs::path& dir, std::string* command) {
  std::istringstream in(read_file((dir / kOutputMarker).string()));
  std::set<std::string> names;
  std::string line;
  if (std::getline(in, line) && command) *command = line;
  while (std::getline(in, line)) names.insert(line);
  return names;
}

// Why `dir` may not be replaced, or empty: it must be empty, or hold a set's
// marker and nothing the marker does not list.
std::string foreign_entry(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_empty(dir, ec)) return {};
  if (!fs::exists(dir / kOutputMarker, ec)) {
    return fmt::format("holds files hapticcal did not write (no {})", kOutputMarker);
  }
  const std::set<std::string> listed = marker_entries(dir, nullptr);
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name != kOutputMarker && !listed.count(name)) {
      return fmt::format("holds '{}', which its last run did not write", printable(name));
    }
  }
  return {};
}

// Stale staging folders of runs that were killed (SIGKILL, a power cut): a
// running set holds a lock on its staging folder.
void sweep_stale_staging(const fs::path& parent, const std::string& stem) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(parent, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(stem, 0) != 0 || name.size() != stem.size() + 6 || !entry.is_directory(ec) ||
        !fs::exists(entry.path() / kStagingMarker, ec)) {
      continue;  // not a staging folder of ours
    }
    const int fd = ::open(entry.path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) fs::remove_all(entry.path(), ec);
    ::close(fd);
  }
}

// Whether this file system exchanges two folders atomically (not NFS, FAT...):
// tried on two folders made in `dir` (the staging folder, so that a signal
// leaves neither behind).
bool exchange_supported(const fs::path& dir) {
  std::string a = (dir / "probe-XXXXXX").string(), b = a;
  if (::mkdtemp(a.data()) == nullptr) return false;
  if (::mkdtemp(b.data()) == nullptr) {
    ::rmdir(a.c_str());
    return false;
  }
  const bool ok = ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0;
  ::rmdir(a.c_str());
  ::rmdir(b.c_str());
  return ok;
}

}  // namespace

OutputSet::OutputSet(const std::string& out, const std::string& command)
    : shown_(out), command_(command) {
  if (out.empty()) throw InputError("--out: an empty path is not a folder");
  std::error_code ec;
  fs::path given = fs::absolute(out, ec).lexically_normal();
  if (!given.has_filename()) given = given.parent_path();  // "out/"
  // Symbolic links resolved: the folder they name is the one replaced.
  const fs::path target = fs::weakly_canonical(given, ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", printable(out), ec.message()));
  const fs::path cwd = fs::current_path(ec);
  if (!target.has_filename() || target == target.root_path() ||
      (!ec &&
       (cwd == target ||
        fmt::format("{}/", cwd.string()).rfind(fmt::format("{}/", target.string()), 0) == 0))) {
    throw InputError(fmt::format(
        "--out {}: the working folder or one of its parents cannot be an output folder (it is "
        "replaced as a whole); name a new folder",
        printable(out)));
  }
  target_ = target.string();
  const fs::path parent = target.parent_path();
  const std::string stem = fmt::format(".{}.tmp-", target.filename().string());
  if (fs::exists(target, ec) && !fs::is_directory(target, ec)) {
    throw InputError(fmt::format("--out {}: exists and is not a folder", printable(out)));
  }
  if (fs::is_directory(target, ec)) {
    const std::string why = foreign_entry(target);
    if (!why.empty()) {
      throw InputError(fmt::format(
          "--out {}: {}; a run replaces its output folder as a whole: name a new or empty "
          "folder, or move those files",
          printable(out), why));
    }
    struct stat own {
    }, up{};
    if (::stat(target.c_str(), &own) == 0 && ::stat(parent.c_str(), &up) == 0 &&
        own.st_dev != up.st_dev) {
      throw InputError(fmt::format(
          "--out {}: is a mount point, which cannot be replaced; name a folder inside it",
          printable(out)));
    }
  }
  fs::create_directories(parent, ec);
  if (ec) {
    throw IoError(fmt::format("--out {}: cannot create {}: {}", printable(out), parent.string(),
                              ec.message()));
  }
  try {
    acquire(parent, stem);
  } catch (...) {
    release();
    throw;
  }
}

void OutputSet::acquire(const std::filesystem::path& parent, const std::string& stem) {
  Registry& r = registry();
  const std::string& out = shown_;
  if (::mkdir(target_.c_str(), 0755) != 0 && errno != EEXIST) {
    throw IoError(
        fmt::format("--out {}: cannot create the folder: {}", printable(out), system_reason()));
  }
  lock_fd_ = ::open(target_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (lock_fd_ < 0) {
    throw IoError(fmt::format("--out {}: cannot open: {}", printable(out), system_reason()));
  }
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const std::string reason = errno == EWOULDBLOCK
                                   ? "another hapticcal run is writing into this folder; wait for "
                                     "it or name another folder"
                                   : system_reason();
    throw IoError(fmt::format("--out {}: {}", printable(out), reason));
  }
  {
    // Only the lock holder removes the folder if it is still empty when the
    // run fails: a refused second run must not remove it under the first.
    std::error_code ec;
    std::lock_guard<std::mutex> lock(r.mutex);
    created_ = fs::is_empty(target_, ec) && !ec;
    if (created_) r.created.insert(target_);
  }
  sweep_stale_staging(parent, stem);
  std::string staging = (parent / (stem + "XXXXXX")).string();
  {
    // Registered as it is made, so that a signal never leaves it behind.
    std::lock_guard<std::mutex> lock(r.mutex);
    if (::mkdtemp(staging.data()) == nullptr) {
      throw IoError(fmt::format("--out {}: cannot write in {}: {}", printable(out), parent.string(),
                                system_reason()));
    }
    r.staging.insert(staging);
  }
  staging_ = staging;
  ::chmod(staging_.c_str(), 0755);  // mkdtemp's 0700 would become --out's mode
  write_file_atomically(staging_ + "/" + kStagingMarker, "");
  exchange_ = exchange_supported(staging_);
  staging_fd_ = ::open(staging_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (staging_fd_ >= 0) ::flock(staging_fd_, LOCK_EX | LOCK_NB);  // "in use": not stale
}

OutputSet::~OutputSet() { release(); }

void OutputSet::release() {
  Registry& r = registry();
  if (!committed_ && !kept_ && !staging_.empty()) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
    std::lock_guard<std::mutex> lock(r.mutex);
    r.staging.erase(staging_);
  }
  if (created_) {
    if (!committed_) ::rmdir(target_.c_str());  // the empty folder made for the lock
    std::lock_guard<std::mutex> lock(r.mutex);
    r.created.erase(target_);
  }
  if (staging_fd_ >= 0) ::close(staging_fd_);
  if (lock_fd_ >= 0) ::close(lock_fd_);
  staging_fd_ = lock_fd_ = -1;
  created_ = false;
  staging_.clear();
}

std::string OutputSet::previous_command() const {
  std::error_code ec;
  if (!fs::exists(fs::path(target_) / kOutputMarker, ec)) return {};
  std::string command;
  marker_entries(target_, &command);
  return command.rfind("hapticcal ", 0) == 0 ? command.substr(10) : std::string();
}

bool OutputSet::keep_previous(const std::string& name) const {
  std::error_code ec;
  const fs::path from = fs::path(target_) / name;
  if (!fs::is_regular_file(from, ec)) return false;
  write_file_atomically(staging_ + "/" + name, read_file(from.string()));
  return true;
}

void OutputSet::commit() {
  throw_if_cancelled();  // a cancelled run leaves the previous set
  std::error_code ec;
  fs::remove(fs::path(staging_) / kStagingMarker, ec);
  // The marker lists what the set holds: a later run replaces nothing else.
  std::string marker = fmt::format("hapticcal {}\n", command_);
  std::set<std::string> names, shown;
  for (const auto& entry : fs::directory_iterator(staging_, ec)) {
    const std::string name = entry.path().filename().string();
    names.insert(name);
    shown.insert(entry.is_directory(ec) ? name + "/" : name);
  }
  for (const std::string& name : names) marker += name + "\n";
  write_file_atomically(staging_ + "/" + kOutputMarker, marker);
  // --out is locked: the set it holds now is the one the exchange replaces.
  std::string replaced;
  if (fs::exists(fs::path(target_) / kOutputMarker, ec)) {
    marker_entries(target_, &replaced);
    if (replaced.empty()) replaced = "hapticcal";
  }

  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  // A file the user saved into --out while this run went on is theirs: the new
  // set stays in its staging folder instead, named in the message.
  if (fs::is_directory(target_, ec)) {
    if (const std::string why = foreign_entry(target_); !why.empty()) {
      kept_ = true;
      r.staging.erase(staging_);
      throw IoError(fmt::format(
          "--out {}: {} (saved there while this run went on): it was not replaced; the new "
          "outputs are in {}",
          printable(shown_), why, staging_));
    }
  }
  // After the exchange the staging path holds the old set, which is removed:
  // it stays registered until then.
  if (exchange_) {
    if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) != 0) {
      throw IoError(fmt::format("--out {}: cannot put the new outputs in place: {}",
                                printable(shown_), system_reason()));
    }
  } else {
    // No atomic exchange here: the old set goes aside, then the new one in;
    // in between a reader finds no folder, never a mixed one.
    std::string aside = staging_ + ".old";
    if (::rename(target_.c_str(), aside.c_str()) != 0 ||
        ::rename(staging_.c_str(), target_.c_str()) != 0) {
      const std::string reason = system_reason();
      ::rename(aside.c_str(), target_.c_str());
      throw IoError(fmt::format("--out {}: cannot put the new outputs in place: {}",
                                printable(shown_), reason));
    }
    ::rename(aside.c_str(), staging_.c_str());
  }
  committed_ = true;
  r.committed = true;
  replaced_command_ = replaced;
  written_.assign(shown.begin(), shown.end());
  fs::remove_all(staging_, ec);
  r.staging.erase(staging_);
}

void remove_staging_on_signals() {
  // A closed pipe on stdout makes writes fail (an error, exit 1) instead of
  // killing the process with its staging folder in place.
  std::signal(SIGPIPE, SIG_IGN);
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  std::thread([set] {
    int sig = 0;
    if (sigwait(&set, &sig) != 0) return;
    Registry& r = registry();
    r.mutex.lock();  // held until exit: no set is committed after this
    {
      // Every write in flight ends first; none starts after.
      std::unique_lock<std::shared_mutex> writes(r.writes);
      r.aborted = true;
      writes.release();  // held until exit
    }
    {
      std::lock_guard<std::mutex> lock(r.children_mutex);
      for (pid_t pid : r.children) ::kill(pid, SIGKILL);
    }
    for (const std::string& path : r.staging) remove_for_good(path);
    for (const std::string& path : r.created) ::rmdir(path.c_str());
    const char* message = r.committed ? "hapticcal: interrupted after its outputs were complete\n"
                                      : "hapticcal: interrupted; no partial output was left\n";
    [[maybe_unused]] const ssize_t n = ::write(2, message, std::strlen(message));
    ::_exit(128 + sig);
  }).detach();
}

void finish_if_interrupted() {
  while (registry().aborted.load()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
}

namespace detail {

WriteGuard::WriteGuard() : lock_(registry().writes) {}

bool WriteGuard::aborted() const { return registry().aborted.load(); }

pid_t spawn_tracked(const std::function<pid_t()>& spawn) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.children_mutex);
  if (r.aborted.load()) return -1;
  const pid_t pid = spawn();
  if (pid > 0) r.children.insert(pid);
  return pid;
}

void untrack_child(pid_t pid) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.children_mutex);
  r.children.erase(pid);
}

}  // namespace detail
}  // namespace hapticcal
