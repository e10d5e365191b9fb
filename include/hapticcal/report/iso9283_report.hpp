// ISO 9283's test in the reports (docs/iso9283.md).
#pragma once

#include <string>

#include "hapticcal/model/model.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/iso9283.hpp"
#include "hapticcal/study/iso9283_cube.hpp"

namespace hapticcal {

// plan --iso9283: the test poses' table and the cube drawn with its measuring
// plane and the poses.
Report iso_plan_report(const DeviceModel& model, const IsoCubePlan& plan);

// evaluate --iso9283: the test conditions as the user states them, a table of
// the poses' characteristics (AP, AP_x/y/z, RP, and with orientations
// AP_a/b/c, RP_a/b/c; the reference's AP beside the model's) and one of the
// distances' (AD, RD), laid out as the standard's report.
void add_iso_section(const IsoCriteria& model, const IsoCriteria* reference,
                     const std::string& conditions, Report& report);

// simulate with an ISO test (a scenario's iso9283): a table of each pose's AP
// over the trials, the nominal model's, the calibrated model's and the one
// predicted from the calibrations' covariance, the cube, and a figure of each
// trial's simulated AP against its prediction; a headline line.
void add_iso_study_section(const IsoSimulation& iso, const IsoStudy& study, Report& report);

}  // namespace hapticcal
