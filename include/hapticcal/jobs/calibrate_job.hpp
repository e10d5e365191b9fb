// `calibrate` as one job (issue 24): the request the command line and the
// Python module fill in, the stages run once, and what they print or return.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/report/calibration_outputs.hpp"

namespace hapticcal {

struct CalibrateRequest {
  std::string model;  // a device file or a URDF
  // A model in memory (Python's Model) instead of reading `model`, which then
  // only names it (results.json) and, a URDF, is the base of calibrated.urdf.
  std::optional<DeviceModel> nominal;
  // A URDF's chain ("": its own); several tips, comma-separated, are a tree
  // (identification/tree.hpp), fitted at once.
  std::string tip, root;
  std::string log;                           // the measurement log
  std::vector<std::string> columns;          // the log's columns, if it has no header line
  std::string fixture;                       // a fixture file ("": none)
  std::vector<std::string> point_distances;  // "A:B=METRES", besides the fixture file's
  // The output folder (OutputSet: checked before any work; "" is refused);
  // none: nothing written.
  std::optional<std::string> out;
  // Everything else; its point_distances and known_points are the fixture's.
  CalibrationOptions options;
  // A tracker's stream on its own clock (--tracker): `log` is then the
  // device's stream (t and readings), and the clocks are estimated with the
  // kinematics (identification/stream.hpp).
  std::string tracker;
  StreamOptions stream;
  // device.yaml's tool (CalibrationSource): a point in the last link's frame,
  // or the device file's tool; neither: the measured point.
  std::optional<std::array<double, 3>> tool_point;
  bool nominal_tool = false;
};

struct CalibrateJob {
  DeviceModel nominal;
  CalibrationResult result;
  std::unique_ptr<OutputSet> out;  // with an output folder: the set, committed
  CalibrationOutputs written;      // what write_calibration_outputs did
  std::string results_json;        // as written (or as it would be into a fresh folder)
  std::vector<std::string> lines;  // the summary (calibration_lines)
  // A usable chain's model in the device's own frame and the set-up
  // (device.yaml and setup.yaml, written or as they would be).
  std::optional<DeviceFrameOutputs> device_frame;
  bool usable() const { return result.status == CalibrationStatus::kConverged; }
};

// Reads the model (a URDF once: its text is also the base of calibrated.urdf)
// and the log, calibrates, and with `out` writes the output set
// (write_calibration_outputs). Several tips (request.tip "A,B") calibrate the
// URDF's tree (tree_model) on each row's tip points (tip_samples), through the
// same procedure and writers; its set holds calibrated.urdf, no device file.
// Throws InputError for bad input (a tree: a model that is not a URDF).
CalibrateJob run_calibrate_job(const CalibrateRequest& request);

// calibrate's options, bound by the command line and the Python module alike.
const CommandOptions<CalibrateRequest>& calibrate_options();

}  // namespace hapticcal
