// The lines that close a command writing an output set: whether it replaced
// the previous run's outputs, and every entry it wrote (issue 15).
#pragma once

#include <fmt/format.h>

#include <filesystem>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/output_set.hpp"

namespace hapticcal::cli {

// After out.commit(): "replaced the previous run's outputs in DIR (...)" when
// --out held a set, then "wrote DIR/: a, b, figures/ (N files)" with every
// entry of the set (the marker aside) and `tail` after it. `shown` is --out as
// given.
inline std::string output_summary(const OutputSet& out, const std::string& shown,
                                  const std::string& tail = "") {
  namespace fs = std::filesystem;
  std::string dir = shown;  // as the "report:" line shows it
  if (dir.empty() || dir.back() != '/') dir += '/';
  std::string said;
  if (out.replaced_previous()) {
    said += fmt::format("replaced the previous run's outputs in {} (written by {})\n", dir,
                        printable(out.replaced_command(), 200));
  }
  std::string entries;
  for (const std::string& name : out.written()) {
    entries += entries.empty() ? "" : ", ";
    entries += name;  // names this program chose
    if (name.empty() || name.back() != '/') continue;
    int files = 0;
    std::error_code ec;
    for (fs::recursive_directory_iterator it(fs::path(out.target()) / name, ec), end;
         !ec && it != end; it.increment(ec)) {
      if (it->is_regular_file(ec)) ++files;
    }
    entries += fmt::format(" ({} file{})", files, files == 1 ? "" : "s");
  }
  said += fmt::format("wrote {}: {}{}\n", dir, entries, tail);
  return said;
}

}  // namespace hapticcal::cli
