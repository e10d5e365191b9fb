// Figures of the reports that tests check alone.
#pragma once

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <string>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal::detail {

// Long logs and runs are decimated to about this many points a figure, so that
// a report stays small (issue 10: 10^6 rows gave a 208 MB report).
constexpr size_t kMaxPlotted = 2000;
// The step between plotted rows of `rows` (at least `at_least`).
// A file as the user named it, without a doubled slash or "./" (a report's title).
inline std::string display_path(const std::string& path) {
  return std::filesystem::path(path).lexically_normal().string();
}

inline size_t plot_stride(size_t rows, size_t at_least = 1) {
  return std::max(at_least, (rows + kMaxPlotted - 1) / kMaxPlotted);
}

// calibrate's correlation map of the identified parameters, rows and columns
// in the order of the report's parameter table (KinematicFit::parameters).
FigureSpec correlation_figure(const KinematicFit& fit);

// Before (nominal, reference) orange and after (calibrated) blue, in every report.
inline Series before_series(std::string label, int x, int y, std::string style = "points") {
  return {std::move(label), x, y, std::move(style), -1, "#d55e00", 0, 1.5, 7};
}
inline Series after_series(std::string label, int x, int y, std::string style = "points") {
  return {std::move(label), x, y, std::move(style), -1, "#0072b2", 0, 1.5, 5};
}

}  // namespace hapticcal::detail
