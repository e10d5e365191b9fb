// `calibrate --tip A,B` on a URDF: several tips on one tree fitted at once
// (jobs/calibrate_job.hpp, identification/tree.hpp).
#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal {
namespace {

nlohmann::ordered_json tree_json(const TreeCalibration& fit, const CalibrateRequest& request) {
  nlohmann::ordered_json j;
  j["command"] = "calibrate";
  j["model"] = request.model;
  j["log"] = request.log;
  j["tree"] = {{"name", fit.calibrated.name},
               {"tips", fit.calibrated.tips},
               {"joints", fit.calibrated.joints}};
  j["status"] = to_string(fit.status);
  j["status_reason"] = fit.status_reason;
  j["poses"] = fit.poses;
  j["parameters_identified"] = fit.identified;
  j["condition_number"] = std::isfinite(fit.condition_number)
                              ? nlohmann::ordered_json(fit.condition_number)
                              : nlohmann::ordered_json(nullptr);
  j["sigma"] = fit.sigma;
  j["frame_registered"] = fit.frame_registered;
  j["iterations"] = fit.iterations;
  for (size_t c = 0; c < fit.calibrated.tips.size(); ++c) {
    j["rms_before"][fit.calibrated.tips[c]] = fit.rms_before[c];
    j["rms_after"][fit.calibrated.tips[c]] = fit.rms_after[c];
  }
  j["parameters"] = nlohmann::ordered_json::object();
  for (const ParameterEstimate& p : fit.parameters) {
    nlohmann::ordered_json e;
    e["unit"] = p.unit == ParameterUnit::kLength ? "m" : "rad";
    e["nominal"] = p.nominal;
    e["value"] = p.value;
    e["identifiable"] = p.identifiable;
    if (p.identifiable) {
      e["sd"] = p.sd;
      e["max_correlation"] = p.max_correlation;
      e["max_correlation_with"] = p.max_correlation_with;
    } else {
      e["reason"] = p.reason;
    }
    std::vector<std::string> tips;
    for (int c : fit.calibrated.chains_of[static_cast<size_t>(p.slot)])
      tips.push_back(fit.calibrated.tips[static_cast<size_t>(c)]);
    e["tips"] = tips;
    j["parameters"][p.name] = e;
  }
  j["notes"] = fit.notes;
  return j;
}

// The terminal's summary.
std::vector<std::string> tree_lines(const TreeCalibration& fit) {
  const DeviceTree& t = fit.calibrated;
  std::vector<std::string> out;
  int shared = 0;
  for (int j = 0; j < t.dof(); ++j) {
    int chains = 0;
    for (const auto& joints : t.joint_of)
      chains += static_cast<int>(std::count(joints.begin(), joints.end(), j));
    shared += chains > 1;
  }
  out.push_back(fmt::format("tree {}: tips {}; {} joints ({} shared), {} parameters", t.name,
                            fmt::join(t.tips, ", "), t.dof(), shared, t.num_slots()));
  out.push_back(fmt::format(
      "{} parameters identified from {} poses (condition number {:.3g}, "
      "sigma {:.4f} mm, {} iterations)",
      fit.identified, fit.poses, fit.condition_number, 1e3 * fit.sigma, fit.iterations));
  for (size_t c = 0; c < t.tips.size(); ++c)
    out.push_back(fmt::format("  {}: RMS position error {:.4f} mm -> {:.4f} mm", t.tips[c],
                              1e3 * fit.rms_before[c], 1e3 * fit.rms_after[c]));
  out.push_back(
      fmt::format("{:<28} {:>12} {:>12} {:>10}  tips", "parameter", "nominal", "calibrated", "sd"));
  for (const ParameterEstimate& p : fit.parameters) {
    if (!p.identifiable) continue;
    const bool mm = p.unit == ParameterUnit::kLength;
    const double f = mm ? 1e3 : 1e3;
    out.push_back(fmt::format(
        "{:<28} {:>12.4f} {:>12.4f} {:>10.4f}  {} [{}]", p.name, f * p.nominal, f * p.value,
        f * p.sd, t.chains_of[static_cast<size_t>(p.slot)].size() > 1 ? "shared" : "own",
        mm ? "mm" : "mrad"));
  }
  int held = 0;
  for (const ParameterEstimate& p : fit.parameters) held += !p.identifiable;
  out.push_back(fmt::format("{} parameters held at nominal (results.json says why)", held));
  for (const std::string& note : fit.notes) out.push_back("note: " + note);
  return out;
}

}  // namespace

CalibrateJob run_tree_calibrate_job(const CalibrateRequest& request,
                                    const std::vector<std::string>& tips) {
  const auto refuse = [&](const std::string& key, const std::string& why) {
    throw InputError(request.model, 0, key, why);
  };
  if (request.nominal || !is_urdf_path(request.model))
    refuse("--tip", "several tips (a tree) need a URDF model");
  if (!request.tracker.empty()) refuse("--tracker", "a tree is fitted on static poses");
  if (!request.fixture.empty() || !request.point_distances.empty())
    refuse("--fixture", "a tree's log measures its tips' points, not fixture points");
  if (request.options.marker_body.cols() > 0)
    refuse("--markers", "with several tips, x<k> is tip k's point, not a marker of one body");
  CalibrateJob job;
  const std::string text = read_file(request.model, FileKind::kUrdf);
  const DeviceTree nominal = parse_tree(text, request.model, tips, request.root);
  const Log log = read_log(request.log, request.columns);
  if (request.out) job.out = std::make_unique<OutputSet>(*request.out, "calibrate");
  TreeCalibration fit = calibrate_tree(nominal, log, request.options);
  job.nominal = nominal.chains[0];
  job.result.status = fit.status;
  job.result.status_reason = fit.status_reason;
  if (job.out) {
    if (fit.status == CalibrationStatus::kConverged) {
      write_file_atomically(
          job.out->dir() + "/calibrated.urdf",
          tree_urdf(text, request.model, request.root, tree_model(fit.calibrated), fit.notes));
      job.written.model_written = true;
    } else if (job.out->previous_command() == "calibrate") {
      job.written.previous_kept = job.out->keep_previous("calibrated.urdf");
      fit.notes.push_back(job.written.previous_kept
                              ? "calibrated.urdf is the previous run's model: not replaced"
                              : "no calibrated.urdf written: the calibration is not usable");
    }
  }
  job.results_json = tree_json(fit, request).dump(2) + "\n";
  job.lines = tree_lines(fit);
  if (job.out) {
    write_file_atomically(job.out->dir() + "/results.json", job.results_json);
    job.written.results_json = job.results_json;
    job.written.figures = write_report(tree_report(fit, request.model, request.log, job.lines),
                                       job.out->dir(), job.written.report_note);
    job.out->commit();
  }
  job.tree = std::move(fit);
  return job;
}

}  // namespace hapticcal
