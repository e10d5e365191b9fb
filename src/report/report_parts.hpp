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

// The poses in the workspace: the tool point (every tip's, of a tree) of each
// row of `readings` (poses x dof) through `model`, in mm in its base frame (the
// measurement frame), as a 3-D figure named "poses", each point's shadow on the
// floor in grey; `path`: the points joined in their order (a plan's path).
FigureSpec poses_figure(const DeviceModel& model, const Eigen::MatrixXd& readings,
                        const std::string& title, const std::string& label, bool path);

// The parameters held at nominal, with why.
std::string held_table(const KinematicFit& k);

// How the terminal's and the reports' tables print a kinematic parameter: the
// angles of a pose (a joint's offset or twist, the base's or the tool's roll,
// pitch, yaw) in deg as values (-90.0000 deg, not -1570.7963 mrad), their
// changes and sd in mrad; lengths in mm throughout; a joint-error family's or
// an instrument's terms (small by nature) as display_unit gives them.
struct ParameterUnits {
  DisplayUnit value;   // nominal and identified
  DisplayUnit change;  // deviation and sd
};
ParameterUnits parameter_units(const ParameterEstimate& e, const DeviceModel& nominal);
// A change of a kinematic parameter in words: "1.234 mm", "12.34 mrad", or for
// an angle of 0.1 rad or more "5.73 deg" (a pose's turn, not a small error).
std::string change_text(double change, ParameterUnit unit);
// Why the data do not determine an identifiable parameter
// (ParameterEstimate::determined): "sd 211 mrad above its tolerance 5 mrad",
// "correlated +0.996 with j7.y: their combination is determined, not each".
std::string undetermined_text(const ParameterEstimate& e, const DeviceModel& nominal);
// A parameter that moved beyond kLargeChangeLength / kLargeChangeAngle, in a
// line (without its "note: " or "warning: "): how far, whether the data
// determine it, its largest correlation and the evidence that judged the model.
std::string large_change_text(const ParameterEstimate& e, const KinematicFit& k);
// The evidence that chose the model: the model search's held-out error, else
// the tolerance prior's evidence, the significance cut or least squares.
std::string evidence_text(const KinematicFit& k);
// "repeatability 0.0019 mm RMS", or why there is none: no pose was left and
// reached again (a device at rest streaming one reading is one visit).
std::string repeatability_text(double repeatability);

}  // namespace hapticcal::detail
