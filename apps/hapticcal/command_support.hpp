// What the commands of the tool share: the exit codes and the report's lines.
#pragma once

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <string>

#include "hapticcal/report/report.hpp"

namespace hapticcal::cli {

constexpr int kExitBadInput = 2;
constexpr int kExitUnusable = 3;

// What to print once a set with a report of `drawn` figures is in `shown`.
inline std::string report_said(int drawn, const std::string& note, const std::string& shown) {
  std::string said =
      fmt::format("report: {}/report.html ({} figure{}, SVG and PNG in {}/figures)\n", shown, drawn,
                  drawn == 1 ? "" : "s", shown);
  if (!note.empty()) said += fmt::format("note: {}\n", note);
  return said;
}

// Writes report.html with its figures into `dir` (a staging folder that
// becomes `shown`); returns what to print once the set is in place.
inline std::string report(const hapticcal::Report& r, const std::string& dir,
                          const std::string& shown) {
  std::string note;
  const int drawn = hapticcal::write_report(r, dir, note);
  return report_said(drawn, note, shown);
}

}  // namespace hapticcal::cli
