// Pieces that the calibrate and simulate reports share: a figure's frame, one
// look per role of a series, and the tables and transmission figures both
// draw. Internal.
#pragma once

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/transmission.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal::detail {

inline FigureSpec figure(std::string name, std::string title, std::string xlabel,
                         std::string ylabel, std::vector<std::vector<double>> columns = {}) {
  FigureSpec f;
  f.name = std::move(name);
  f.title = std::move(title);
  f.xlabel = std::move(xlabel);
  f.ylabel = std::move(ylabel);
  f.columns = std::move(columns);
  return f;
}

// One look per role in every figure (Okabe-Ito colours, told apart in grey
// print too): measurements grey points, identified a solid colour, truth black
// dashed; before / nominal vermillion, after / calibrated blue.
inline Series measured_points(std::string label, int x, int y) {
  return {std::move(label), x, y, "points", -1, "gray50", 0, 0, 7};
}
inline Series identified_line(std::string label, int x, int y) {
  return {std::move(label), x, y, "lines", -1, "#0072b2", 1, 2.5, 0};
}
inline Series truth_line(std::string label, int x, int y) {
  return {std::move(label), x, y, "lines", -1, "black", 2, 1.5, 0};
}
// Rows sorted by x, so that model curves draw as lines.
inline std::vector<int> order_by(const std::vector<double>& x) {
  std::vector<int> idx(x.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](int a, int b) { return x[a] < x[b]; });
  return idx;
}

// Transmission fit (Fig. 9-like) and its residuals for one joint, in mrad against deg.
void transmission_figures(const TransmissionFit& t, const std::string& link, const Log& log,
                          const std::vector<int>& rows, const Transmission& fitted,
                          const Transmission* truth, std::vector<FigureSpec>& figures);

// The parameters held at nominal, with why.
std::string held_table(const KinematicFit& k);

}  // namespace hapticcal::detail
