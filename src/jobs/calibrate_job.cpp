// `calibrate` as one job (jobs/calibrate_job.hpp).
#include "hapticcal/jobs/calibrate_job.hpp"

#include <fmt/format.h>

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

std::vector<std::string> tip_names(const std::string& tip) {
  std::vector<std::string> out;
  if (tip.empty()) return out;
  size_t from = 0;
  for (size_t comma = tip.find(','); comma != std::string::npos; comma = tip.find(',', from)) {
    out.push_back(tip.substr(from, comma - from));
    from = comma + 1;
  }
  out.push_back(tip.substr(from));
  for (const std::string& name : out) {
    if (name.empty()) throw InputError("--tip: an empty tip name in '" + tip + "'");
  }
  return out;
}

namespace {

// Several tips (a tree) are a URDF's; a tree in memory (Python's calibrated
// Model) needs it too for calibrated.urdf.
void check_tree_request(const CalibrateRequest& request) {
  if (request.nominal && !is_urdf_path(request.model) && request.out)
    throw InputError(request.model, 0, "--tip",
                     "a tree in memory is written back as calibrated.urdf: give its URDF's path");
  if (!request.nominal && !is_urdf_path(request.model))
    throw InputError(request.model, 0, "--tip", "several tips (a tree) need a URDF model");
}

}  // namespace

CalibrateJob run_calibrate_job(const CalibrateRequest& request) {
  const std::vector<std::string> tips = tip_names(request.tip);
  const bool tree = tips.size() > 1 || (request.nominal && request.nominal->tree());
  if (tree) check_tree_request(request);
  CalibrateJob job;
  const bool urdf = !request.model.empty() && is_urdf_path(request.model);
  const std::string urdf_text = urdf ? read_file(request.model, FileKind::kUrdf) : std::string();
  if (request.nominal) {
    job.nominal = *request.nominal;
  } else if (tree) {
    job.nominal = tree_model(parse_tree(urdf_text, request.model, tips, request.root));
  } else {
    job.nominal = urdf ? parse_urdf(urdf_text, request.model, request.tip, request.root)
                       : load_model(request.model, request.tip, request.root);
  }
  if (!request.tracker.empty() && (!request.fixture.empty() || !request.point_distances.empty())) {
    throw InputError(request.tracker, 0, "--tracker",
                     "a tracker's stream measures positions: it takes no fixture points");
  }
  if (!request.tracker.empty() && request.options.marker_body.cols() > 0) {
    throw InputError(request.tracker, 0, "--markers",
                     "a tracker's stream is fitted on positions: markers are not aligned in "
                     "time yet");
  }
  Log log = read_log(request.log, request.columns);
  // A sample a tip of each row (a tracker's stream: of each of its rows, once aligned).
  if (tree && request.tracker.empty()) log = tip_samples(job.nominal, log);
  const Log tracker = request.tracker.empty() ? Log() : read_log(request.tracker);
  if (request.out) job.out = std::make_unique<OutputSet>(*request.out, "calibrate");
  CalibrationOptions options = request.options;
  Fixture fixture = fixture_facts(request.fixture, request.point_distances);
  options.point_distances = std::move(fixture.distances);
  options.known_points = std::move(fixture.points);
  if (request.tracker.empty()) {
    job.result = calibrate(job.nominal, log, options);
    // A marker log is reported as the body's poses it was fitted to.
    if (log.marker_count > 0) log = markers_to_poses(log, job.result.marker_body).poses;
  } else {
    StreamCalibration streams =
        calibrate_streams(job.nominal, log, tracker, options, request.stream);
    job.result = std::move(streams.result);
    log = std::move(streams.poses);  // the static log the fit read (the reports' rows)
  }
  if (job.out) {
    job.written = write_calibration_outputs(
        *job.out, job.result, job.nominal, log, options,
        {request.model, request.log, urdf_text, request.tip, request.root});
    job.results_json = job.written.results_json;
  } else {
    // results.json as the command line would write it into a fresh folder.
    if (!job.usable()) {
      job.result.notes.push_back(fmt::format("no {} written: the calibration is not usable",
                                             tree ? "calibrated.urdf" : "calibrated.yaml"));
    }
    job.results_json =
        calibration_json(job.result, job.nominal, request.model, request.log, options);
  }
  job.lines = calibration_lines(job.result, job.nominal);
  return job;
}

}  // namespace hapticcal
