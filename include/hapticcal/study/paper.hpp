// The paper's material: Baser & Konukseven (2013)'s measurement noise, its
// "actual" device (Tables 2 and 3), its improvement percentages I % (Tables 2
// and 3, eq. 8) and the built-in device's default posture of the force study.
// Everything specific to that paper lives here; the rest of the library is
// general.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Measurement noise of the paper's simulation: external encoders of 20000 ppr,
// sigma_e = 2 pi / 20000 / 3 rad; the cable encoder sigma_m = 2 pi 0.015 sigma_e
// (the paper's formula) or 0.015 sigma_e (the dimensionally consistent one).
constexpr double kPaperSigmaE = 2 * 3.14159265358979323846 / 20000 / 3;
constexpr double paper_sigma_m(double sigma_e) {
  return 2 * 3.14159265358979323846 * 0.015 * sigma_e;
}
constexpr double consistent_sigma_m(double sigma_e) { return 0.015 * sigma_e; }
constexpr double kPaperSigmaMPaper = paper_sigma_m(kPaperSigmaE);
constexpr double kPaperSigmaMConsistent = consistent_sigma_m(kPaperSigmaE);

// The "actual" device of the paper's study from the built-in nominal one: Table 3
// deviations (mm, mrad), Table 2 capstans on joints 1-3 (radii read in mm), and
// joint 4 a capstan (Table 2's fourth drum) followed by a parallelogram with
// L1 = L3 = 0.05 m, L2 = L4 = 0.21 m and dL1 = -0.5 mm, dL2 = -0.7 mm.
DeviceModel paper_actual_device(const DeviceModel& nominal);

// The paper's I % of the trajectory's distance RMS (Fig. 10, eq. 9): after the
// full calibration and after the kinematic-only one.
constexpr double kPaperImprovementFullPct = 96.6;
constexpr double kPaperImprovementKinematicOnlyPct = 44.7;

// The paper's I % for a dotted name (Tables 2 and 3), if it gives one.
std::optional<double> paper_improvement_pct(const std::string& name);

// The default posture: home, with the wrist bent (j6 = 0.3 rad) for a 7-joint
// device, because home is a wrist singularity of the built-in model; where the
// limits exclude it, the middle of the limits (a coupled joint's range).
Eigen::VectorXd default_posture(const DeviceModel& model);

}  // namespace hapticcal
