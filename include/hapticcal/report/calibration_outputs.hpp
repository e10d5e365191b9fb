// The files of a calibration run (calibrate --out, Python's calibrate(out=)):
// one function writes the set, so that the command line and the module agree.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "hapticcal/core/log.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/device_frame.hpp"

namespace hapticcal {

// Where a calibration's model and log came from: results.json names the paths,
// and a URDF model's text is the base of calibrated.urdf.
struct CalibrationSource {
  std::string model_path, log_path;
  std::string urdf_text;  // the URDF model's text; empty for a device file
  std::string tip, root;  // the URDF chain, as parse_urdf was given them
  // device.yaml's tool (a chain's): this point (x, y, z in the last link's
  // frame, the measured orientation), or the device file's tool
  // (nominal_tool); neither: the calibrated tool, the point the instrument
  // measured.
  std::optional<std::array<double, 3>> tool_point;
  bool nominal_tool = false;
};

// What calibrate writes of a chain besides calibrated.yaml: the model of
// calibrated.urdf and device.yaml (where the measurements do not see the
// tool's orientation, the last joint's turn about its axis moved into the tool,
// move_last_turn_into_tool: `turn` [rad]) and its split into the device's
// frame (device.yaml) and the set-up (setup.yaml), ending at the tool that
// `source` asks for (`ends_at` says which, for a sentence).
struct DeviceFrameOutputs {
  DeviceModel written;
  double turn = 0;
  DeviceFrameSplit split;
  std::string ends_at;
};
DeviceFrameOutputs device_frame_outputs(const CalibrationResult& result, const DeviceModel& nominal,
                                        const CalibrationSource& source);

// The notes on device.yaml and setup.yaml (and the last joint's turn) that
// write_calibration_outputs adds; urdf: a URDF model (calibrated.urdf written too).
void add_device_frame_notes(CalibrationResult& result, const DeviceFrameOutputs& outputs,
                            bool urdf);

// What write_calibration_outputs did besides results.json.
struct CalibrationOutputs {
  bool model_written = false;  // calibrated.yaml (and .urdf) of this run
  // calibrated.urdf written: the geometry-only model (geometry_model) beat the
  // nominal with its set-up fitted; else a note says why there is none.
  bool urdf_written = false;
  bool previous_kept = false;  // not usable: the previous run's model is in the set
  int figures = 0;             // drawn into the report
  std::string report_note;     // write_report's note (gnuplot missing), or empty
  std::string results_json;    // the results.json written
  // A usable chain's device.yaml and setup.yaml as written (device_frame_outputs).
  std::optional<DeviceFrameOutputs> device_frame;
};

// Writes into out.dir() and commits the set: calibrated.yaml (and, for a URDF
// model, calibrated.urdf: the geometry-only model, geometry_model, fitted as
// such, written unless its status says it predicts held-out poses no better
// than the nominal with its set-up fitted) if the run is usable, and a chain's
// device.yaml (the model in the device's own frame, split_device_frame) and
// setup.yaml (the device's frame in the measurement frame, the measured point); else the previous
// run's model if --out held one of the same device (keep_previous), and a note
// saying which; results.json; report.html with its figures. The notes of
// calibrated_urdf and of the model kept are added to result.notes first, so
// that results.json and the report hold them.
CalibrationOutputs write_calibration_outputs(OutputSet& out, CalibrationResult& result,
                                             const DeviceModel& nominal, const Log& log,
                                             const CalibrationOptions& options,
                                             const CalibrationSource& source);

}  // namespace hapticcal
