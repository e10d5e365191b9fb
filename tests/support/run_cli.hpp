// Runs the hapticcal command line (or another program) and captures its exit
// code and output. No shell is involved: arguments are passed as a vector.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

extern char** environ;

namespace hapticcal::testing {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
  long peak_kb = 0;  // the program's peak resident memory [kB] (getrusage's ru_maxrss)
};

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Splits `args` at blanks (space, tab, newline). As a convenience a '...' or
// "..." groups characters (blanks included) into one argument and is removed;
// nothing else is special: no variables, globs, escapes or substitutions.
inline std::vector<std::string> split_arguments(const std::string& args) {
  std::vector<std::string> out;
  std::string current;
  bool in_word = false;
  char quote = 0;
  for (const char c : args) {
    if (quote) {
      if (c == quote) {
        quote = 0;
      } else {
        current += c;
      }
    } else if (c == '\'' || c == '"') {
      quote = c;
      in_word = true;
    } else if (c == ' ' || c == '\t' || c == '\n') {
      if (in_word) out.push_back(current);
      current.clear();
      in_word = false;
    } else {
      current += c;
      in_word = true;
    }
  }
  if (in_word) out.push_back(current);
  return out;
}

// Runs `program` with `args` (program's own name not included) and waits; in
// the folder `cwd` when it is not empty (then a relative `program` is relative
// to it).
inline CliResult run_program(const std::string& program, const std::vector<std::string>& args,
                             const std::string& cwd = "") {
  static int counter = 0;
  const std::string base = std::filesystem::temp_directory_path().string() + "/hapticcal_cli_" +
                           std::to_string(::getpid()) + "_" + std::to_string(counter++);
  const std::string out_path = base + ".out", err_path = base + ".err";
  std::vector<std::string> argv{program};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<char*> cargv;
  for (std::string& a : argv) cargv.push_back(a.data());
  cargv.push_back(nullptr);

  CliResult r;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out_path.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_path.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (!cwd.empty()) posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
  pid_t pid = 0;
  const int spawn_error =
      posix_spawn(&pid, program.c_str(), &actions, nullptr, cargv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawn_error != 0) {
    r.err = "cannot run " + program + ": " + std::strerror(spawn_error);
    return r;
  }
  int status = 0;
  struct rusage usage {};
  while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  r.peak_kb = usage.ru_maxrss;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = slurp(out_path);
  r.err = slurp(err_path);
  std::filesystem::remove(out_path);
  std::filesystem::remove(err_path);
  return r;
}

// `args` is split by split_arguments (no shell).
inline CliResult run_program(const std::string& program, const std::string& args) {
  return run_program(program, split_arguments(args));
}

inline CliResult run_cli(const std::vector<std::string>& args) {
  return run_program(HAPTICCAL_CLI, args);
}
inline CliResult run_cli(const std::string& args) { return run_program(HAPTICCAL_CLI, args); }
// The command line run in the folder `cwd` (its default --out is relative).
inline CliResult run_cli_in(const std::string& cwd, const std::vector<std::string>& args) {
  return run_program(HAPTICCAL_CLI, args, cwd);
}

// A fresh, empty folder `name` under the tests' temporary directory.
inline std::string fresh_folder(const std::string& name) {
  // TempDir() ends with a slash: no doubled one in the paths a report shows.
  const std::string dir =
      (std::filesystem::path(::testing::TempDir()) / name).lexically_normal().string();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Bad input: exit code 2, nothing on standard output, one line on standard
// error that starts "hapticcal: " and holds `expected`.
inline void expect_input_error(const CliResult& r, const std::string& expected) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(r.out, "");
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
  EXPECT_EQ(r.err.rfind("hapticcal: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(expected), std::string::npos)
      << "expected \"" << expected << "\" in: " << r.err;
}

}  // namespace hapticcal::testing
