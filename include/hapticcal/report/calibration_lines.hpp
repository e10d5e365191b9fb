// The calibration's summary, a line each: what the terminal prints after
// `calibrate` and what its report carries (issue 24: written once).
#pragma once

#include <string>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Step 1's transmissions, step 2's parameters (the paper's Tables 2-5 units),
// the held ones with their reasons, the fit's statistics, outliers, suspect-fit
// warnings, large changes and the notes. No trailing newlines.
std::vector<std::string> calibration_lines(const CalibrationResult& result,
                                           const DeviceModel& nominal);
// The geometry-only model (CalibrationResult::geometry, what a URDF, a DH table
// or a driver's file holds) beside the whole model: each one's RMS error on the
// poses and held out, and what the joint-error families add; "" when the whole
// model is the geometry alone.
std::string geometry_model_line(const CalibrationResult& result);
// A tree's RMS error a tip, before and after ("left_hand: 3.2 mm before, ...");
// none for a chain.
std::vector<std::string> tip_rms_lines(const KinematicFit& fit, const DeviceModel& nominal);

}  // namespace hapticcal
