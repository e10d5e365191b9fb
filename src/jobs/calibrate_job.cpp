// `calibrate` as one job (jobs/calibrate_job.hpp).
#include "hapticcal/jobs/calibrate_job.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <memory>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/calibration_lines.hpp"
#include "hapticcal/report/results_json.hpp"

namespace hapticcal {

namespace {

// Several tips named (--tip A,B) are a URDF's: a device file holds its own.
void check_tree_request(const CalibrateRequest& request) {
  if (!request.nominal && !is_urdf_path(request.model))
    throw InputError(request.model, 0, "--tip",
                     "several tips (a tree) need a URDF model: a device file holding a "
                     "tree names its own tips");
}

// A tree's log refused as not from this device: does it fit the tips in
// another order (--tip's order is also the order of the log's joint columns)?
// The hint naming it, or "" (at most three tips are tried in every order).
std::string tip_order_hint(const CalibrateRequest& request, const std::string& urdf_text,
                           const std::vector<std::string>& tips, const Log& raw,
                           const CalibrationOptions& options) {
  if (tips.size() > 3 || urdf_text.empty()) return "";
  CalibrationOptions quick = options;  // one plain fit: the plausibility check is what counts
  quick.search = false;
  quick.keep_all = true;
  quick.folds = 0;
  std::vector<std::string> order = tips;
  std::sort(order.begin(), order.end());
  do {
    if (order == tips) continue;
    try {
      const DeviceModel other = load_model(request.model, order, request.root, &urdf_text);
      calibrate(other, tip_samples(other, raw), quick);
    } catch (const InputError&) {
      continue;
    }
    return fmt::format(" The log fits the tips in the order {}: give --tip {}.",
                       fmt::join(order, ", "), fmt::join(order, ","));
  } while (std::next_permutation(order.begin(), order.end()));
  return "";
}

}  // namespace

CalibrateJob run_calibrate_job(const CalibrateRequest& request) {
  const std::vector<std::string> tips = tip_names(request.tip);
  if (tips.size() > 1) check_tree_request(request);
  CalibrateJob job;
  const bool urdf = !request.model.empty() && is_urdf_path(request.model);
  const std::string urdf_text = urdf ? read_file(request.model, FileKind::kUrdf) : std::string();
  job.nominal = request.nominal ? *request.nominal
                                : load_model(request.model, request.tip, request.root,
                                             urdf ? &urdf_text : nullptr);
  // A URDF's tips named, or a device file's (or a model in memory) holding them.
  const bool tree = job.nominal.tree();
  if (tree && (request.tool_point || request.nominal_tool))
    throw InputError(request.model, 0, "--tool-point",
                     "a tree's calibrated.yaml keeps each tip's tool: no device.yaml is written");
  if (!request.tracker.empty() && (!request.fixture.empty() || !request.point_distances.empty())) {
    throw InputError(request.tracker, 0, "--tracker",
                     "a tracker's stream measures positions: it takes no fixture points");
  }
  Log log = read_log(request.log, request.columns);
  // A tree's: a sample a tip of each row (a tracker's stream: of each of its rows, once
  // aligned); the rows as read kept for the tip-order hint. A chain's log is not copied.
  Log raw;
  if (tree && request.tracker.empty()) {
    raw = std::move(log);
    log = tip_samples(job.nominal, raw);
  }
  const Log tracker = request.tracker.empty() ? Log() : read_log(request.tracker);
  if (request.out) job.out = std::make_unique<OutputSet>(*request.out, "calibrate");
  CalibrationOptions options = request.options;
  Fixture fixture = fixture_facts(request.fixture, request.point_distances);
  options.point_distances = std::move(fixture.distances);
  options.known_points = std::move(fixture.points);
  if (request.tracker.empty()) {
    try {
      job.result = calibrate(job.nominal, log, options);
    } catch (const InputError& e) {  // a tree's tips in another order than the log's?
      const std::string what = e.what();
      if (!tree || what.find("is this log from this device") == std::string::npos) throw;
      const std::string hint = tip_order_hint(request, urdf_text, tips, raw, options);
      if (hint.empty()) throw;
      throw InputError(what + hint);
    }
    // A marker log is reported as the body's poses it was fitted to.
    if (log.marker_count > 0) log = markers_to_poses(log, job.result.marker_body).poses;
  } else {
    StreamCalibration streams =
        calibrate_streams(job.nominal, log, tracker, options, request.stream);
    job.result = std::move(streams.result);
    log = std::move(streams.poses);  // the static log the fit read (the reports' rows)
  }
  if (job.out) {
    job.written =
        write_calibration_outputs(*job.out, job.result, job.nominal, log, options,
                                  {request.model, request.log, urdf_text, request.tip, request.root,
                                   request.tool_point, request.nominal_tool});
    job.results_json = job.written.results_json;
    job.device_frame = job.written.device_frame;
  } else {
    // results.json as the command line would write it into a fresh folder.
    if (!job.usable()) {
      job.result.notes.push_back("no calibrated.yaml written: the calibration is not usable");
    } else if (!tree) {
      job.device_frame =
          device_frame_outputs(job.result, job.nominal,
                               {request.model, request.log, urdf_text, request.tip, request.root,
                                request.tool_point, request.nominal_tool});
      add_device_frame_notes(job.result, *job.device_frame, urdf);
    }
    job.results_json =
        calibration_json(job.result, job.nominal, request.model, request.log, options);
  }
  job.lines = calibration_lines(job.result, job.nominal);
  return job;
}

}  // namespace hapticcal
