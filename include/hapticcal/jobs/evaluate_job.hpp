// `evaluate` as one job (issue 24): the request the command line and the
// Python module fill in, and what they print or return.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/iso9283.hpp"

namespace hapticcal {

struct EvaluateRequest {
  std::string model;                 // a device file or a URDF
  std::optional<DeviceModel> given;  // a model in memory instead (Python's Model)
  std::string reference;             // a second model file ("": none)
  std::optional<DeviceModel> given_reference;
  std::string tip, root;  // the chain of each URDF among them
  std::string log;
  std::vector<std::string> columns;          // the log's columns, if it has no header line
  std::string fixture;                       // a fixture file ("": none)
  std::vector<std::string> point_distances;  // "A:B=METRES"
  std::optional<RegisterWhat> registration;  // --register
  std::optional<std::string> out;            // the output folder; none: nothing written
  // A marker log's body (3 x K in the tool frame, m; --markers); empty: estimated.
  Eigen::Matrix3Xd marker_body;
  // A second session (--tracker): `log` is the device's stream, this the
  // tracker's on its own clock; the clocks are aligned with the model held
  // (align_streams) and the model scored on the tracker's samples.
  std::string tracker;
  StreamOptions stream;
  // An ISO 9283 test (--iso9283 PLAN): the plan's plan.csv (plan --iso9283),
  // which the log follows row by row; its pose and distance characteristics
  // are added to the lines and the JSON ("iso9283").
  std::string iso9283;
  std::string conditions;  // the test's conditions as the user states them (load, speed, ...)
};

struct EvaluateJob {
  DeviceModel model;
  Evaluation evaluation;                           // the model's (registered if asked)
  std::optional<EvaluationComparison> comparison;  // with a reference
  int rows = 0;                                    // the log's
  std::string json;                                // `evaluate --json`, one line
  std::vector<std::string> lines;                  // evaluation_lines
  std::unique_ptr<OutputSet> out;                  // with an output folder: committed
  int figures = 0;                                 // drawn into its report
  std::string report_note;                         // write_report's note, or empty
  // Several tips (--tip A,B on a URDF: a tree): each tip's evaluation on its
  // point (x<k>), in the order of tips; `model` and `evaluation` are then the
  // first tip's.
  std::vector<std::string> tips;
  std::vector<Evaluation> tip_evaluations;
  std::vector<std::optional<EvaluationComparison>> tip_comparisons;
  std::optional<StreamAlignment> alignment;  // with --tracker
  // With --iso9283: the model's characteristics and the reference's.
  std::optional<IsoCriteria> iso, iso_reference;
};

// --tip / --root given without a URDF among the models is bad input, as every
// other problem with the request (InputError).
EvaluateJob run_evaluate_job(const EvaluateRequest& request);

// evaluate's options, bound by the command line and the Python module alike.
const CommandOptions<EvaluateRequest>& evaluate_options();

}  // namespace hapticcal
