// `compensate` as one job: a program's targets compensated for a controller
// that runs the nominal model (study/compensation.hpp), written as
// compensated.csv and results.json.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/study/compensation.hpp"

namespace hapticcal {

struct CompensateRequest {
  std::string model;      // the calibrated model (device.yaml: the robot's frame)
  std::string nominal;    // the controller's model (a file or a built-in device's name)
  std::string targets;    // the program: q1..qn [, x, y, z [, orientation]] (read_log)
  std::string columns;    // column names of a targets file without header
  std::string tip, root;  // the chain of either model if a URDF
  CompensationOptions options;
  std::string out = "hapticcal-out/compensate";
};

struct CompensateJob {
  std::vector<CompensatedTarget> targets;
  int usable = 0;                  // targets whose command may be sent
  std::vector<std::string> lines;  // the summary and each target not usable, named by its line
  std::string results_json;
  std::unique_ptr<OutputSet> out;  // committed
};

// Loads both models and the targets, compensates every target and writes
// compensated.csv (a row a target: its line, the readings to command, the pose
// to give the nominal controller, the outcome; a target that is not usable
// has no command: its values are empty) and results.json.
CompensateJob run_compensate_job(const CompensateRequest& request);

// compensate's options, bound by the command line and the Python module alike.
const CommandOptions<CompensateRequest>& compensate_options();

}  // namespace hapticcal
