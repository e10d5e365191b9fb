// The results.json of each command, in one place. Metres and
// radians; the terminal and the reports show display units.
#pragma once

#include <string>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/control.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/study.hpp"

namespace hapticcal {

// results.json: every parameter by dotted name with nominal,
// value, sd and identifiable (transmission parameters included), the condition
// number, observability indices and RMS before / after. Metres and radians.
std::string calibration_json(const CalibrationResult& result, const DeviceModel& nominal,
                             const std::string& model_path, const std::string& log_path,
                             const CalibrationOptions& options);

// `evaluate --json`: one JSON object on one line, in metres: n, the RMS and max
// of each error the log measures, the fixture figures, and with a comparison
// (whose `model` is `ev`) the reference's figures and eq. (9)'s improvements.
std::string evaluation_json(const EvaluationComparison* comparison, const Evaluation& ev);

// results.json of a study.
std::string study_json(const Scenario& scenario, const StudyResult& result);

// results.json of `force` (format hapticcal-force/1): the model files, the
// scenario as run, the stable gain limit and the transverse force RMS before
// and after calibration.
std::string force_json(const std::string& actual, const std::string& nominal,
                       const std::string& calibrated, const ForceStudy& study, double gain_limit);

}  // namespace hapticcal
