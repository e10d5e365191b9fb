// What the commands of the tool share: the exit codes, --tip and --root of a
// command that reads models, the report's lines and comma-separated lists.
#pragma once

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal::cli {

constexpr int kExitBadInput = 2;
constexpr int kExitUnusable = 3;

// --tip and --root of a command that takes several model files: they apply to
// each URDF among them; given without any URDF they are a usage error.
struct ChainOptions {
  std::string tip, root;

  void check_used(const std::vector<std::string>& paths) const {
    if (tip.empty() && root.empty()) return;
    for (const std::string& p : paths) {
      if (hapticcal::is_urdf_path(p)) return;
    }
    throw hapticcal::InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                                            tip.empty() ? "--root" : "--tip"));
  }
  hapticcal::DeviceModel load(const std::string& path) const {
    return hapticcal::is_urdf_path(path) ? hapticcal::load_model(path, tip, root)
                                         : hapticcal::load_model(path);
  }
};

inline void add_chain_options(CLI::App* command, ChainOptions& chain) {
  command->add_option("--tip", chain.tip,
                      "Tip link of a URDF model's chain (needed unless the URDF has one leaf)");
  command->add_option("--root", chain.root,
                      "Root link of a URDF model's chain (default: the URDF's root link)");
}

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

// "A,B,..." as `N` finite numbers, or InputError naming the option.
template <size_t N>
std::array<double, N> numbers(const std::string& text, const std::string& option) {
  std::vector<double> out;
  for (const std::string& part : hapticcal::split_columns(text)) {
    try {
      size_t used = 0;
      const double v = std::stod(part, &used);
      if (used != part.size() || !std::isfinite(v)) throw std::invalid_argument("");
      out.push_back(v);
    } catch (const std::exception&) {
      throw hapticcal::InputError(
          fmt::format("{} '{}': '{}' is not a number", option, printable(text), printable(part)));
    }
  }
  if (out.size() != N) {
    throw hapticcal::InputError(
        fmt::format("{} '{}': expected {} comma-separated numbers", option, printable(text), N));
  }
  std::array<double, N> a{};
  std::copy(out.begin(), out.end(), a.begin());
  return a;
}

// The items of a comma-separated list (none for "").
inline std::vector<std::string> names(const std::string& list) {
  return list.empty() ? std::vector<std::string>{} : hapticcal::split_columns(list);
}

}  // namespace hapticcal::cli
