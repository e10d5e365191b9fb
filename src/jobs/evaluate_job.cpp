// `evaluate` as one job (jobs/evaluate_job.hpp).
#include "hapticcal/jobs/evaluate_job.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/iso9283_report.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"
#include "hapticcal/study/iso9283.hpp"

namespace hapticcal {
namespace {

// A model file: a URDF with the request's chain, a device file as it is. A
// calibrated URDF without --root is read from the measurement frame its
// calibration wrote (the calibrated model in the tracker's frame, as
// calibrated.yaml), said in `said`.
DeviceModel load_evaluated_model(const EvaluateRequest& request, const std::string& path,
                                 std::string* said = nullptr) {
  if (!is_urdf_path(path)) return load_model(path);
  std::string root = request.root;
  const std::string text = read_file(path, FileKind::kUrdf);
  const std::string frame = measurement_frame_link(text, path);
  // A measurement frame hapticcal wrote as the root (a converted device file's),
  // calibrated: its root chain is the calibrated model.
  const bool frame_is_root =
      frame.empty() && text.find("<link name=\"hapticcal_measurement\"") != std::string::npos &&
      text.find("hapticcal: calibrated joint origins") != std::string::npos;
  const std::string fitted_in = frame_is_root ? "hapticcal_measurement" : frame;
  if (!root.empty() && !fitted_in.empty() && root != fitted_in && said) {
    *said = fmt::format(
        "{}: warning: --root {} leaves out the measurement frame its calibration was fitted in "
        "(link '{}'): this chain is the robot alone, not the calibrated model in the "
        "measurement frame",
        path, root, fitted_in);
  }
  if (root.empty()) {
    root = frame;
    if (!root.empty() && said) {
      *said = fmt::format(
          "{}: read from its measurement frame, link '{}' (the frame its calibration "
          "was fitted in; --root ROOT reads another chain)",
          path, root);
    } else if (frame_is_root && said) {
      *said = fmt::format(
          "{}: read from its root, link 'hapticcal_measurement', the measurement frame its "
          "calibration was fitted in",
          path);
    }
    if (const size_t at = text.find(kLeftOut); at != std::string::npos && said) {
      const size_t end = text.find(" -->", at);
      const size_t from = at + std::strlen(kLeftOut);
      *said +=
          (said->empty() ? path + ": " : "; ") + "warning: the calibration's " +
          text.substr(from, end == std::string::npos ? 0 : end - from) +
          " is left out of this URDF (URDF cannot express it): its calibrated.yaml predicts better";
    }
  }
  return load_model(path, request.tip, root);
}

// --tip and --root apply to URDF models: given without one, a usage error.
void check_chain_used(const EvaluateRequest& request) {
  if (request.tip.empty() && request.root.empty()) return;
  for (const std::string& path : {request.model, request.reference}) {
    if (!path.empty() && is_urdf_path(path)) return;
  }
  if (request.given || request.given_reference) return;  // models loaded by the caller
  throw InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                               request.tip.empty() ? "--root" : "--tip"));
}

// The tree of a URDF path at these tips, as one model (tree_model); a
// calibrated URDF without --root read from the measurement frame its
// calibration wrote (said in `said`), as a chain's is. A device file holds its
// own tree: `tips` empty or its tips.
DeviceModel evaluated_tree(const EvaluateRequest& request, const std::string& path,
                           const std::vector<std::string>& tips, std::string* said = nullptr) {
  if (!is_urdf_path(path)) {
    DeviceModel model = load_model(path);
    std::vector<std::string> own;
    for (int t = 0; t < model.tips() && model.tree(); ++t) own.push_back(model.tip_name(t));
    if (own.empty() || (!tips.empty() && tips != own))
      throw InputError(path, 0, "--tip",
                       own.empty() ? std::string("several tips (a tree) need URDF models or a "
                                                 "device file of a tree")
                                   : fmt::format("the device file's tree has the tips {}: give "
                                                 "no --tip",
                                                 fmt::join(own, ", ")));
    return model;
  }
  std::string root = request.root;
  const std::string text = read_file(path, FileKind::kUrdf);
  if (root.empty()) {
    root = measurement_frame_link(text, path);
    if (!root.empty() && said)
      *said = fmt::format(
          "{}: read from its measurement frame, link '{}' (the frame its calibration was "
          "fitted in; --root ROOT reads another tree)",
          path, root);
  }
  return load_model(path, tips, root, &text);
}

// Each tip of a tree evaluated on its samples (the log's x<k> its point), by
// the chain's evaluation of the tree model (`loaded`: a device file's tree
// already read, its own tips).
EvaluateJob tree_evaluate_job(const EvaluateRequest& request, std::vector<std::string> tips,
                              const DeviceModel* loaded = nullptr) {
  if (request.given || request.given_reference || !request.fixture.empty() ||
      !request.point_distances.empty() || request.registration)
    throw InputError(request.model, 0, "--tip",
                     "a tree is evaluated on its tips' points or marker bodies (no fixture, "
                     "--register or models in memory)");
  EvaluateJob job;
  std::string frame_said;
  const DeviceModel tree =
      loaded ? *loaded : evaluated_tree(request, request.model, tips, &frame_said);
  if (tips.empty()) {  // a device file's own tips
    for (int t = 0; t < tree.tips(); ++t) tips.push_back(tree.tip_name(t));
  }
  std::optional<DeviceModel> reference;
  if (!request.reference.empty()) reference = evaluated_tree(request, request.reference, tips);
  if (!frame_said.empty()) job.lines.push_back(frame_said);
  const Log log = read_log(request.log, request.columns);
  std::vector<Log> parts;
  for (size_t c = 0; c < tips.size(); ++c) {  // a marker body's: its poses (--markers)
    parts.push_back(tip_samples(tree, log, static_cast<int>(c)));
    if (parts.back().marker_count > 0)
      parts.back() = markers_to_poses(parts.back(), request.marker_body).poses;
  }
  job.rows = log.rows;
  job.tips = tips;
  nlohmann::ordered_json json;
  json["device"] = tree.name;
  for (size_t c = 0; c < tips.size(); ++c) {
    std::optional<EvaluationComparison> cmp;
    Evaluation e;
    if (reference) {
      cmp = compare_to_reference(tree, *reference, parts[c], {}, {}, {});
      e = cmp->model;
    } else {
      e = evaluate(tree, parts[c], {}, {});
    }
    json["tips"][tips[c]] =
        nlohmann::ordered_json::parse(evaluation_json(cmp ? &*cmp : nullptr, e));
    job.lines.push_back(fmt::format("tip {} ({} of {}):", tips[c], c + 1, tips.size()));
    for (const std::string& line : evaluation_lines(cmp ? &*cmp : nullptr, e, request.reference))
      job.lines.push_back("  " + line);
    job.tip_evaluations.push_back(e);
    job.tip_comparisons.push_back(cmp);
  }
  job.model = tree;
  job.evaluation = job.tip_evaluations[0];
  job.json = json.dump();
  if (!request.out) return job;
  job.out = std::make_unique<OutputSet>(*request.out, "evaluate");
  write_file_atomically(job.out->dir() + "/results.json", job.json + "\n");
  std::vector<const Evaluation*> references;
  for (const std::optional<EvaluationComparison>& cmp : job.tip_comparisons)
    references.push_back(cmp ? &cmp->reference : nullptr);
  const Report report =
      tree_evaluation_report(tree, request.model, tips, parts, job.tip_evaluations, references,
                             request.reference, log.origin, job.lines);
  job.figures = write_report(report, job.out->dir(), job.report_note);
  job.out->commit();
  return job;
}

// A second session's clocks: first in the lines, "clock" in the JSON.
void add_clock(const StreamAlignment& a, EvaluateJob& job) {
  const ClockEstimate& c = a.clock;
  std::vector<std::string> lines;
  lines.push_back(fmt::format(
      "clocks (the model held): offset {:.4f} ms +- {:.4f} ms{}; {} tracker samples scored",
      1e3 * c.clock.offset, 1e3 * c.offset_sd,
      c.drift_fitted
          ? fmt::format(", drift {:.3f} ppm +- {:.3f} ppm", 1e6 * c.clock.drift, 1e6 * c.drift_sd)
          : std::string(),
      c.fit_samples));
  lines.insert(lines.end(), a.notes.begin(), a.notes.end());
  job.lines.insert(job.lines.begin(), lines.begin(), lines.end());
  nlohmann::ordered_json json = nlohmann::ordered_json::parse(job.json);
  json["clock"] = {
      {"offset", c.clock.offset},
      {"offset_sd", c.offset_sd},
      {"drift", c.clock.drift},
      {"drift_sd", c.drift_fitted ? nlohmann::ordered_json(c.drift_sd) : nlohmann::ordered_json()},
      {"coarse_offset", c.coarse_offset},
      {"coarse_correlation", c.coarse_correlation},
      {"samples", c.fit_samples},
      {"tracker_rows", c.tracker_rows},
      {"glitch_lines", c.glitch_lines},
      {"notes", a.notes}};
  job.json = json.dump();
}

// The model as evaluated: registered to the log (its base and tool) if it was.
DeviceModel as_evaluated(DeviceModel model, const Evaluation& evaluation) {
  if (!evaluation.registered) return model;
  if (model.base_is_pose()) model.base = evaluation.registered->base;
  if (evaluation.registered->tool) model.tool = *evaluation.registered->tool;
  return model;
}

nlohmann::ordered_json iso_json(const IsoCriteria& c) {
  const auto number = [](double v) {
    return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json();
  };
  nlohmann::ordered_json poses = nlohmann::ordered_json::array(), distances = poses;
  for (const IsoPoseCriteria& p : c.poses) {
    nlohmann::ordered_json j = {{"pose", p.label},
                                {"cycles", p.cycles},
                                {"AP", number(p.ap)},
                                {"AP_x", number(p.ap_xyz.x())},
                                {"AP_y", number(p.ap_xyz.y())},
                                {"AP_z", number(p.ap_xyz.z())},
                                {"RP", number(p.rp)}};
    if (p.orientation) {
      j["AP_a"] = number(p.ap_abc[0]), j["AP_b"] = number(p.ap_abc[1]);
      j["AP_c"] = number(p.ap_abc[2]), j["RP_a"] = number(p.rp_abc[0]);
      j["RP_b"] = number(p.rp_abc[1]), j["RP_c"] = number(p.rp_abc[2]);
    }
    poses.push_back(j);
  }
  for (const IsoDistanceCriteria& d : c.distances) {
    distances.push_back({{"from", d.from},
                         {"to", d.to},
                         {"cycles", d.cycles},
                         {"commanded", d.commanded},
                         {"AD", number(d.ad)},
                         {"RD", number(d.rd)}});
  }
  return {{"poses", poses}, {"distances", distances}};
}

// --iso9283: the log follows the test plan row by row; the characteristics of
// the model (and the reference) into the lines and the JSON. Values in m and
// rad in the JSON, mm and mrad in the lines.
void add_iso(const std::string& plan_path, const std::string& conditions, const Log& log,
             const DeviceModel& model, const DeviceModel* reference, EvaluateJob& job) {
  const Log plan = read_log(plan_path);
  if (!holds(plan, MeasurementType::kPoint)) {
    throw InputError(plan_path, 0, "--iso9283",
                     "not a test plan: no point column naming each row's pose (plan --iso9283 "
                     "writes one)");
  }
  if (plan.dof() != log.dof()) {
    throw InputError(plan_path, 0, "--iso9283",
                     fmt::format("a plan of {} joints for a log of {}: is this log from this "
                                 "test plan?",
                                 plan.dof(), log.dof()));
  }
  check_iso_labels(plan, log);
  if (plan.rows == log.rows) {
    for (int r = 0; r < log.rows; ++r) {
      const double off = (log.q.row(r) - plan.q.row(r)).cwiseAbs().maxCoeff();
      if (off > 0.05) {
        throw InputError(
            log.origin, log.line[static_cast<size_t>(r)], "--iso9283",
            fmt::format("the readings are {:.3f} (rad or m) from the plan's pose {}: is "
                        "this log from this test plan?",
                        off, plan.label[static_cast<size_t>(r)]));
      }
    }
  }
  const std::vector<IsoPoseRuns> runs = iso_runs(model, log, plan.label);
  check_iso_positions(model, log, runs);
  const IsoCriteria mine = iso_criteria(runs);
  std::optional<IsoCriteria> theirs;
  if (reference) theirs = iso_criteria(iso_runs(*reference, log, plan.label));
  const auto mm = [](double v) { return std::isfinite(v) ? fmt::format("{:.4f}", v * 1e3) : "-"; };
  const auto both = [&](double m, double r, double scale) {
    return theirs ? fmt::format("{:8.4f} ({:.4f})", m * scale, r * scale)
                  : fmt::format("{:8.4f}", m * scale);
  };
  job.lines.push_back(
      fmt::format("ISO 9283 pose characteristics (commanded: the model's pose at each pose's mean "
                  "readings{}):",
                  theirs ? "; in brackets the reference's" : ""));
  for (size_t k = 0; k < mine.poses.size(); ++k) {
    const IsoPoseCriteria& p = mine.poses[k];
    const IsoPoseCriteria* q = theirs ? &theirs->poses[k] : nullptr;
    std::string line = fmt::format("  {:<4} n {:2}  AP {} mm  RP {} mm", p.label, p.cycles,
                                   both(p.ap, q ? q->ap : 0, 1e3), mm(p.rp));
    if (p.orientation) {
      line +=
          fmt::format("  AP_a/b/c {:.3f} {:.3f} {:.3f} mrad  RP_a/b/c {:.3f} {:.3f} {:.3f} mrad",
                      p.ap_abc[0] * 1e3, p.ap_abc[1] * 1e3, p.ap_abc[2] * 1e3, p.rp_abc[0] * 1e3,
                      p.rp_abc[1] * 1e3, p.rp_abc[2] * 1e3);
    }
    job.lines.push_back(line);
  }
  for (size_t k = 0; k < mine.distances.size(); ++k) {
    const IsoDistanceCriteria& d = mine.distances[k];
    job.lines.push_back(fmt::format("  {}-{} n {:2}  AD {} mm  RD {} mm", d.from, d.to, d.cycles,
                                    both(d.ad, theirs ? theirs->distances[k].ad : 0, 1e3),
                                    mm(d.rd)));
  }
  nlohmann::ordered_json json = nlohmann::ordered_json::parse(job.json);
  json["iso9283"] = {{"plan", plan_path}, {"conditions", conditions}, {"model", iso_json(mine)}};
  if (theirs) json["iso9283"]["reference"] = iso_json(*theirs);
  job.json = json.dump();
  job.iso = mine;
  job.iso_reference = theirs;
}

}  // namespace

EvaluateJob run_evaluate_job(const EvaluateRequest& request) {
  check_chain_used(request);
  if (const std::vector<std::string> tips = tip_names(request.tip); tips.size() > 1) {
    if (!request.tracker.empty())
      throw InputError(request.tracker, 0, "--tracker",
                       "a tree's second session is not aligned: give one tip");
    if (!request.iso9283.empty())
      throw InputError(request.iso9283, 0, "--iso9283", "a test of one tool point: give one tip");
    return tree_evaluate_job(request, tips);
  }
  EvaluateJob job;
  std::string frame_said;
  job.model =
      request.given ? *request.given : load_evaluated_model(request, request.model, &frame_said);
  if (job.model.tree() && !request.given) {  // a device file's own tree
    if (!request.tracker.empty() || !request.iso9283.empty())
      throw InputError(request.model, 0, "", "a tree: no --tracker or --iso9283 (give one tip)");
    return tree_evaluate_job(request, {}, &job.model);
  }
  // An ISO 9283 test log may keep its plan's `point` column: the poses' names.
  Log log = read_log(request.log, request.columns,
                     request.iso9283.empty() ? PointColumn::kFixture : PointColumn::kPoseName);
  if (!request.tracker.empty()) {
    if (request.registration || !request.fixture.empty() || !request.point_distances.empty()) {
      throw InputError(request.tracker, 0, "--tracker",
                       "a second session is scored in the calibrated model's frame: no --register, "
                       "fixture or point distances");
    }
    job.alignment = align_streams(job.model, log, read_log(request.tracker), request.stream,
                                  request.marker_body);
    log = job.alignment->poses;
  }
  if (log.marker_count > 0) log = markers_to_poses(log, request.marker_body).poses;
  job.rows = log.rows;
  const Fixture known = fixture_facts(request.fixture, request.point_distances);
  const bool referenced = request.given_reference || !request.reference.empty();
  std::optional<DeviceModel> reference;
  if (referenced) {
    reference = request.given_reference ? *request.given_reference
                                        : load_evaluated_model(request, request.reference);
    job.comparison = compare_to_reference(job.model, *reference, log, known.distances, known.points,
                                          request.registration);
    job.evaluation = job.comparison->model;
  } else if (request.registration) {
    job.evaluation =
        evaluate_registered(job.model, log, *request.registration, known.distances, known.points);
  } else {
    job.evaluation = evaluate(job.model, log, known.distances, known.points);
  }
  const EvaluationComparison* cmp = job.comparison ? &*job.comparison : nullptr;
  job.json = evaluation_json(cmp, job.evaluation);
  job.lines = evaluation_lines(cmp, job.evaluation, request.reference);
  if (job.alignment) add_clock(*job.alignment, job);
  if (!request.conditions.empty() && request.iso9283.empty())
    throw InputError("--conditions: applies to an ISO 9283 test (--iso9283)");
  if (!request.iso9283.empty()) {
    if (job.alignment)
      throw InputError(request.iso9283, 0, "--iso9283",
                       "a test's log is static poses: no --tracker");
    const DeviceModel reference_used =
        reference ? as_evaluated(*reference, cmp->reference) : DeviceModel();
    add_iso(request.iso9283, request.conditions, log, as_evaluated(job.model, job.evaluation),
            reference ? &reference_used : nullptr, job);
  }
  if (!frame_said.empty()) job.lines.insert(job.lines.begin(), frame_said);
  if (!request.out) return job;
  job.out = std::make_unique<OutputSet>(*request.out, "evaluate");
  write_file_atomically(job.out->dir() + "/results.json", job.json + "\n");
  Report report = evaluation_report(job.model, request.model, log, job.evaluation,
                                    cmp ? &cmp->reference : nullptr, request.reference, job.lines);
  if (job.alignment) clock_section(job.alignment->clock, "model held", report);
  if (job.iso) {
    add_iso_section(*job.iso, job.iso_reference ? &*job.iso_reference : nullptr, request.conditions,
                    report);
  }
  job.figures = write_report(report, job.out->dir(), job.report_note);
  job.out->commit();
  return job;
}

}  // namespace hapticcal
