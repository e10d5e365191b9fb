// `hapticcal plan --iso9283` as a typed request (the command line's and the
// Python module's options): the test cube searched or given, its poses and
// cycles, and the plan's files (plan.csv, iso9283.json, the report) written.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/iso9283_cube.hpp"

namespace hapticcal {

struct IsoPlanRequest {
  std::string model, tip, root;
  std::optional<std::array<double, 3>> cube_centre;  // in the measurement frame [m]; none: searched
  double cube_size = 0;                              // the edge [m]; 0: the largest that fits
  int cycles = 30;                                   // the standard's
};

struct IsoPlanJob {
  DeviceModel model;
  IsoCubePlan plan;
  std::string json;                // iso9283.json's text
  std::vector<std::string> lines;  // the terminal's account of the cube and its poses
  std::unique_ptr<OutputSet> out;  // committed
  int figures = 0;                 // drawn into its report
  std::string report_note;         // write_report's note, or empty
};

// The cube planned on the request's model and written into `out`: plan.csv a
// row a pose visited (q1..qN and the pose's label in `point`, cycle after
// cycle), iso9283.json the cube, its search and the poses, report.html.
// Throws InputError for bad input (a cube that does not fit among it).
IsoPlanJob run_iso_plan_job(const IsoPlanRequest& request, const std::string& out);

}  // namespace hapticcal
