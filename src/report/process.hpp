// Runs another program without a shell: an argument vector, not a command
// line, so no character of a path or name is ever interpreted. Internal.
#pragma once

#include <string>
#include <vector>

namespace hapticcal::detail {

struct ProcessStatus {
  // The program's exit status, 128 + the signal number when a signal ended it,
  // or -1 when it could not be started (then `error` says why, from strerror).
  int exit_code = -1;
  std::string error;
  bool ok() const { return exit_code == 0; }
};

// Runs argv[0] (looked up on PATH when it holds no '/') with arguments argv and
// waits for it. Standard input is /dev/null; standard output and error go to
// the file `output_path` (created or truncated; /dev/null when empty). The
// program runs in the folder `cwd` when it is not empty; `output_path` is
// opened before changing folder, so a relative path is relative to ours.
ProcessStatus run_program(const std::vector<std::string>& argv, const std::string& output_path,
                          const std::string& cwd = "");

}  // namespace hapticcal::detail
