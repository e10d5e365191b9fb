// `force` and `convert` as jobs (issue 24): the requests the command line and
// the Python module fill in, and what they print or return.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/control.hpp"

namespace hapticcal {

struct ForceRequest {
  std::string actual, nominal, calibrated;     // model files (device files or URDFs)
  std::string tip, root;                       // the chain of each URDF among them
  std::optional<int> lock;                     // 1-based; 0: none; none: ForceScenario's default
  std::optional<std::vector<double>> posture;  // q [rad or m]; none: the default posture
  ForceScenario scenario;                      // the wall, the gain, the noise, the seed
  std::string out = "hapticcal-out/force";
};

struct ForceJob {
  DeviceModel actual;
  ForceStudy study;       // its scenario as run (the posture and lock resolved)
  double gain_limit = 0;  // |G| below it is stable
  std::string results_json;
  std::unique_ptr<OutputSet> out;  // committed
  int figures = 0;
  std::string report_note;
};

// Loads the three models, resolves the lock and the posture, refuses a gain
// outside the stable range (InputError), runs the study and writes
// force_nominal.csv, force_calibrated.csv, results.json and the report.
ForceJob run_force_job(const ForceRequest& request);

// force's options, bound by the command line and the Python module alike.
const CommandOptions<ForceRequest>& force_options();

struct ConvertRequest {
  std::string in, out;  // a device file and a URDF, either way round
  std::string tip, root;
};

struct ConvertJob {
  DeviceModel model;
  bool to_urdf = false;
  // Links with a transmission, which a URDF holds only as comments.
  std::vector<std::string> with_transmission;
  // Joint compliance, lateral compliance, backlash: the model's parts besides
  // transmissions that a URDF holds only as comments (empty: none).
  std::string families_left_out;
};

// Reads `in`, writes `out` (atomically). InputError for a pair that is not a
// device file and a URDF, or a tree to a URDF (a URDF is written from one chain).
ConvertJob run_convert_job(const ConvertRequest& request);

// convert's options, bound by the command line and the Python module alike.
const CommandOptions<ConvertRequest>& convert_options();

}  // namespace hapticcal
