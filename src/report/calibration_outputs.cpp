#include "hapticcal/report/calibration_outputs.hpp"

#include <fmt/format.h>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"

namespace hapticcal {
namespace {

// The previous run's calibrated.yaml (and calibrated.urdf of a URDF model),
// carried into a failed run's set only if that run calibrated the same device.
// A tree's calibrated.urdf alone (a device file holds one chain).
bool keep_previous_model(const OutputSet& out, const DeviceModel& nominal, bool urdf) {
  if (out.previous_command() != "calibrate") return false;
  if (nominal.tree()) return out.keep_previous("calibrated.urdf");
  try {
    if (load_device(out.target() + "/calibrated.yaml").name != nominal.name) return false;
  } catch (const InputError&) {
    return false;
  }
  if (urdf) out.keep_previous("calibrated.urdf");
  return out.keep_previous("calibrated.yaml");
}

// calibrated.yaml, and for a URDF model calibrated.urdf (its notes into
// result); a tree's calibrated.urdf alone.
void write_models(const std::string& dir, CalibrationResult& result,
                  const CalibrationSource& source) {
  if (result.calibrated.tree()) {
    write_file_atomically(dir + "/calibrated.urdf",
                          tree_urdf(source.urdf_text, source.model_path, source.root,
                                    result.calibrated, result.notes));
    return;
  }
  save_device(result.calibrated, dir + "/calibrated.yaml");
  if (source.urdf_text.empty()) return;
  write_file_atomically(dir + "/calibrated.urdf",
                        calibrated_urdf(source.urdf_text, source.model_path, source.tip,
                                        source.root, result.calibrated, &result.notes));
}

}  // namespace

CalibrationOutputs write_calibration_outputs(OutputSet& out, CalibrationResult& result,
                                             const DeviceModel& nominal, const Log& log,
                                             const CalibrationOptions& options,
                                             const CalibrationSource& source) {
  CalibrationOutputs written;
  if (result.status == CalibrationStatus::kConverged) {
    write_models(out.dir(), result, source);
    written.model_written = true;
  } else {
    written.previous_kept = keep_previous_model(out, nominal, !source.urdf_text.empty());
    const char* file = nominal.tree() ? "calibrated.urdf" : "calibrated.yaml";
    result.notes.push_back(written.previous_kept
                               ? fmt::format("{} is the previous run's model: not replaced", file)
                               : fmt::format("no {} written: the calibration is not usable", file));
  }
  written.results_json =
      calibration_json(result, nominal, source.model_path, source.log_path, options);
  write_file_atomically(out.dir() + "/results.json", written.results_json);
  written.figures = write_report(
      calibration_report(result, nominal, log, options.point_distances, options.known_points),
      out.dir(), written.report_note);
  out.commit();
  return written;
}

}  // namespace hapticcal
