#include "report/process.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/interrupt.hpp"
#include "hapticcal/core/cancel.hpp"

extern char** environ;

namespace hapticcal::detail {
namespace {

// Owns a posix_spawn_file_actions_t.
class FileActions {
 public:
  FileActions() { ok_ = posix_spawn_file_actions_init(&actions_) == 0; }
  ~FileActions() {
    if (ok_) posix_spawn_file_actions_destroy(&actions_);
  }
  FileActions(const FileActions&) = delete;
  FileActions& operator=(const FileActions&) = delete;
  bool ok() const { return ok_; }
  posix_spawn_file_actions_t* get() { return &actions_; }

 private:
  posix_spawn_file_actions_t actions_;
  bool ok_ = false;
};

ProcessStatus failed(const std::string& program, const char* what, int err) {
  ProcessStatus s;
  s.error = fmt::format("cannot run {}: {}{}", program, what, std::strerror(err));
  return s;
}

}  // namespace

ProcessStatus run_program(const std::vector<std::string>& argv, const std::string& output_path,
                          const std::string& cwd) {
  if (argv.empty() || argv[0].empty()) return failed("(nothing)", "", EINVAL);
  const std::string& program = argv[0];
  FileActions actions;
  if (!actions.ok()) return failed(program, "", ENOMEM);
  const char* out = output_path.empty() ? "/dev/null" : output_path.c_str();
  int err = posix_spawn_file_actions_addopen(actions.get(), STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  if (err == 0) {
    err = posix_spawn_file_actions_addopen(actions.get(), STDERR_FILENO, out,
                                           O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  if (err == 0) err = posix_spawn_file_actions_adddup2(actions.get(), STDERR_FILENO, STDOUT_FILENO);
  if (err == 0 && !cwd.empty())
    err = posix_spawn_file_actions_addchdir_np(actions.get(), cwd.c_str());
  if (err != 0) return failed(program, "", err);

  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  // glibc reports a failed open, chdir or exec in the child as the return value.
  // The child starts with no signal blocked (remove_staging_on_signals blocks
  // them in every thread of ours), so that an interrupt reaches it too.
  posix_spawnattr_t attr;
  sigset_t none;
  sigemptyset(&none);
  if (posix_spawnattr_init(&attr) != 0) return failed(program, "", ENOMEM);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK);
  pid = spawn_tracked([&]() -> pid_t {
    pid_t child = -1;
    err = posix_spawnp(&child, program.c_str(), actions.get(), &attr, args.data(), environ);
    return err == 0 ? child : -1;
  });
  posix_spawnattr_destroy(&attr);
  if (pid < 0) return failed(program, "", err != 0 ? err : EINTR);

  // Waited for in steps of 5 ms, so that a cancelled run (Python's Ctrl-C,
  // core/cancel.hpp) stops the program and unwinds at once.
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) {
      const int wait_err = errno;
      untrack_child(pid);
      return failed(program, "waiting: ", wait_err);
    }
    if (cancel_requested()) {
      ::kill(pid, SIGKILL);
      while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
      untrack_child(pid);
      throw Cancelled();
    }
    ::usleep(5000);
  }
  untrack_child(pid);
  ProcessStatus s;
  if (WIFEXITED(status)) {
    s.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    s.exit_code = 128 + WTERMSIG(status);
  }
  return s;
}

}  // namespace hapticcal::detail
