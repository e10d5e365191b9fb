#include "hapticcal/report/results_json.hpp"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/study.hpp"

namespace hapticcal {
namespace {

nlohmann::ordered_json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

// evaluate --register's fit, in SI units.
nlohmann::ordered_json registration_json(const FrameFit& fit) {
  nlohmann::ordered_json j;
  j["what"] = to_string(fit.what);
  j["base"] = fit.base;
  j["change"] = fit.change;
  j["moved"] = fit.moved;
  j["turned"] = fit.turned;
  if (fit.tool) {
    j["tool"] = *fit.tool;
    j["tool_offset"] = {fit.tool_offset.x(), fit.tool_offset.y(), fit.tool_offset.z()};
    j["tool_turned"] = fit.tool_turned;
  }
  j["rms_position_before_registration"] = fit.rms_position_before;
  return j;
}

// The model selection's rule, its settings and its path.
nlohmann::ordered_json selection_json(const KinematicFit& k, const CalibrationOptions& options) {
  using json = nlohmann::ordered_json;
  json selection{
      {"enabled", k.model_selection},
      {"rule", k.model_selection ? "backward elimination while the change from nominal is not "
                                   "significant (Student t, Bonferroni over the parameters fitted)"
                                 : k.selection_note},
      {"alpha", options.selection_alpha},
      {"folds", k.selection_folds},
      {"identifiable", k.structurally_identified},
      {"kept", k.identified}};
  json path = json::array();
  for (const SelectionStep& step : k.selection_path) {
    path.push_back({{"parameters", step.parameters},
                    {"rms", step.rms},
                    {"cv_rms", number_or_null(step.cv_rms)},
                    {"next_held", step.removed},
                    {"next_t", number_or_null(step.removed_t)},
                    {"threshold", number_or_null(step.threshold)}});
  }
  selection["path"] = path;
  return selection;
}

// The tolerance prior: its tolerances, the scale and weight chosen, the
// effective parameters and the evidence curve (log10 lambda, log evidence).
nlohmann::ordered_json prior_json(const PriorFit& prior, const Tolerances& t) {
  using json = nlohmann::ordered_json;
  json curve = json::array();
  for (const auto& [x, value] : prior.curve) curve.push_back({x, value});
  return json{{"used", prior.used},
              {"note", prior.note},
              {"tolerance_length", t.length},
              {"tolerance_angle", t.angle},
              {"tolerances", t.by_name},
              {"scale", number_or_null(prior.scale)},
              {"scale_source", prior.scale_given ? "given" : "evidence"},
              {"lambda", prior.lambda},
              {"sigma", number_or_null(prior.sigma)},
              {"log_evidence", number_or_null(prior.log_evidence)},
              {"effective_parameters", prior.effective_parameters},
              {"fitted", prior.fitted},
              {"rounds", prior.rounds},
              {"evidence_curve", curve}};
}

// The outlier test: its rule and settings.
nlohmann::ordered_json robust_json(const RobustFit& robust, const CalibrationOptions& options) {
  return {{"loss", to_string(robust.loss)},
          {"tested", robust.tested},
          {"rule",
           "a pose is an outlier when its residual (weighted by sqrt(repeats)) exceeds the "
           "chi-square quantile (d dof) at 1 - alpha / poses in robust sds (1.4826 MAD of every "
           "component)"},
          {"alpha", options.outlier_alpha},
          {"robust_sd", number_or_null(robust.robust_sd)},
          {"threshold", number_or_null(robust.threshold)},
          {"reweighted", robust.reweighted},
          {"iterations", robust.iterations},
          {"note", robust.note}};
}

// The poses the outlier test flagged.
nlohmann::ordered_json outliers_json(const RobustFit& robust) {
  using json = nlohmann::ordered_json;
  json outliers = json::array();
  for (const OutlierPose& o : robust.outliers) {
    outliers.push_back({{"lines", o.lines},
                        {"residual", o.residual},
                        {"robust_sd", robust.robust_sd},
                        {"statistic", o.statistic},
                        {"weight", o.weight}});
  }
  return outliers;
}

// The model search (docs/calibrate.md, "The model search"): every candidate compared, SI.
nlohmann::ordered_json search_json(const ModelSearch& s) {
  using json = nlohmann::ordered_json;
  json candidates = json::array();
  for (const SearchCandidate& c : s.candidates) {
    candidates.push_back({{"families", c.families},
                          {"instrument_zero", c.zero},
                          {"estimator", to_string(c.estimator)},
                          {"cv_rms", number_or_null(c.cv_rms)},
                          {"se", number_or_null(c.se)},
                          {"difference_se", number_or_null(c.difference_se)},
                          {"parameters", c.parameters},
                          {"usable", c.usable},
                          {"allowed", c.allowed},
                          {"note", c.note}});
  }
  return {{"ran", s.ran},
          {"note", s.note},
          {"rule", "the fewest parameters within one standard error of the lowest held-out RMS"},
          {"folds", s.folds},
          {"repeats", s.repeats},
          {"seed", s.seed},
          {"units", s.units},
          {"unit", s.unit},
          {"nominal_rms", number_or_null(s.nominal_rms)},
          {"nominal_fitted", s.nominal_fitted},
          {"best", s.best},
          {"kept", s.kept},
          {"candidates", candidates}};
}

// The checks of a fit: suspect, what the joint-error families bought (docs/joint-errors.md), the
// model search (docs/calibrate.md, "The model search").
void checks_json(const KinematicFit& k, const CalibrationOptions& options,
                 nlohmann::ordered_json& j) {
  using json = nlohmann::ordered_json;
  const SuspectFit& suspect = k.suspect;
  j["suspect"] = {{"suspect", suspect.suspect},
                  {"reasons", suspect.reasons},
                  {"repeatability_ratio", number_or_null(suspect.repeatability_ratio)},
                  {"repeatability_limit", suspect.repeatability_limit},
                  {"nominal_base_fitted_rms", number_or_null(suspect.nominal_base_fitted_rms)},
                  {"cv_ratio", number_or_null(suspect.cv_ratio)},
                  {"strict", options.strict}};
  j["joint_errors"] = k.joint_error_families.empty()
                          ? json(nullptr)
                          : json{{"families", k.joint_error_families},
                                 {"cv_rms", number_or_null(k.cv_rms)},
                                 {"cv_rms_without", number_or_null(k.cv_rms_without_joint_errors)}};
  j["model_search"] = search_json(k.search);
}

// A tree's tips: the joints on each one's path (a log's q<j>) and its RMS
// error before and after.
nlohmann::ordered_json tips_json(const KinematicFit& k, const DeviceModel& nominal) {
  using json = nlohmann::ordered_json;
  json tips = json::object();
  for (int t = 0; t < nominal.tips(); ++t) {
    json joints = json::array();
    for (int i : nominal.path(t)) joints.push_back(nominal.links[static_cast<size_t>(i)].name);
    json tip{{"joints", joints}};
    if (static_cast<size_t>(t) < k.tip_rms_after.size()) {
      tip["rms_before"] = k.tip_rms_before[static_cast<size_t>(t)];
      tip["rms_after"] = k.tip_rms_after[static_cast<size_t>(t)];
    }
    tips[nominal.tip_name(t)] = tip;
  }
  return tips;
}

// What calibrated.urdf (a URDF model's) and the geometry-only formats hold:
// the geometry alone fitted as such, beside the whole model.
nlohmann::ordered_json geometry_model_json(const CalibrationResult& result) {
  const KinematicFit& g = result.geometry->kinematics;
  return {{"status", to_string(result.geometry->status)},
          {"status_reason", result.geometry->status_reason},
          {"usable", result.geometry->status == CalibrationStatus::kConverged},
          {"estimator", to_string(g.estimator)},
          {"rms_after", g.rms_after},
          {"cv_rms", number_or_null(g.cv_rms)},
          {"families_add", number_or_null(g.cv_rms - result.kinematics.cv_rms)}};
}

}  // namespace

// Two streams' clocks (calibrate --tracker): SI (s; the drift dimensionless).
nlohmann::ordered_json clock_json(const ClockEstimate& c) {
  using json = nlohmann::ordered_json;
  json curve = json::array();
  for (const auto& [offset, rms] : c.curve) curve.push_back({offset, rms});
  return {{"model", "device time = tracker time + offset + drift (tracker time - reference)"},
          {"offset", c.clock.offset},
          {"offset_sd", number_or_null(c.offset_sd)},
          {"drift", c.clock.drift},
          {"drift_sd", c.drift_fitted ? number_or_null(c.drift_sd) : json(nullptr)},
          {"drift_fitted", c.drift_fitted},
          {"reference", c.clock.reference},
          {"converged", c.converged},
          {"iterations", c.iterations},
          {"coarse_offset", c.coarse_offset},
          {"coarse_correlation", c.coarse_correlation},
          {"search_range", c.search_range},
          {"device_rows", c.device_rows},
          {"tracker_rows", c.tracker_rows},
          {"overlapping", c.overlapping},
          {"dropped_in_gaps", c.dropped_gap},
          {"dropped_fast", c.dropped_speed},
          {"fit_samples", c.fit_samples},
          {"glitch_lines", c.glitch_lines},
          {"residual_against_offset", curve}};
}

std::string calibration_json(const CalibrationResult& result, const DeviceModel& nominal,
                             const std::string& model_path, const std::string& log_path,
                             const CalibrationOptions& options) {
  using json = nlohmann::ordered_json;
  const KinematicFit& k = result.kinematics;
  json j;
  j["format"] = "hapticcal-results/1";
  j["status"] = to_string(result.status);
  j["status_reason"] = result.status_reason;
  j["usable"] = result.status == CalibrationStatus::kConverged;
  j["model"] = model_path;
  j["log"] = log_path;
  j["device"] = nominal.name;
  j["step_one_only"] = result.step_one_only;
  j["measurement"] = result.step_one_only ? json(nullptr) : json(traits(k.type).name);
  if (traits(k.type).rotation) j["rotation_scale"] = k.rotation_scale;
  j["frame_registered"] = k.frame_registered;
  j["rows_used"] = k.rows;
  j["poses"] = k.poses;
  j["repeatability"] = number_or_null(k.repeatability);
  j["samples"] = options.samples;
  j["seed"] = options.seed;
  j["transmission_step"] = options.transmissions;
  j["sigma"] = result.step_one_only
                   ? json(nullptr)
                   : json{{"value", k.sigma}, {"source", k.sigma_given ? "given" : "residual"}};
  // Step 1 alone fits no kinematics: no measurement error to report.
  const auto measured = [&](double v) { return result.step_one_only ? json(nullptr) : json(v); };
  j["rms_before"] = measured(k.rms_before);
  j["rms_after"] = measured(k.rms_after);
  if (nominal.tree()) j["tips"] = tips_json(k, nominal);
  j["cross_validation"] = {{"folds", k.cv_folds},
                           {"rms", number_or_null(k.cv_rms)},
                           {"seed", options.seed},
                           {"note", k.cv_note}};
  if (result.geometry) j["geometry_model"] = geometry_model_json(result);
  j["model_selection"] = selection_json(k, options);
  j["prior"] = prior_json(k.prior, options.tolerances);
  j["parameter_choice"] = k.choice;
  j["robust"] = robust_json(k.robust, options);
  j["outliers"] = outliers_json(k.robust);
  checks_json(k, options, j);
  j["condition_number"] = number_or_null(k.condition_number);
  j["observability"] = {{"O1", k.observability.O1},
                        {"O2", k.observability.O2},
                        {"O3", k.observability.O3},
                        {"O4", k.observability.O4}};
  j["length_scale"] = k.length_scale;
  j["identified"] = k.identified;
  j["rank_deficient"] = k.rank_deficient;
  j["solver"] = {
      {"converged", k.converged}, {"iterations", k.iterations}, {"message", k.termination}};
  json params = json::object();
  for (const ParameterEstimate& e : k.parameters) {
    json p{{"nominal", e.nominal},
           {"value", e.value},
           {"sd", e.identifiable ? number_or_null(e.sd) : json(nullptr)},
           {"identifiable", e.identifiable}};
    if (e.identifiable) {
      p["max_correlation"] = e.max_correlation;
      p["max_correlation_with"] = e.max_correlation_with;
      p["large_change"] = e.large_change;
      p["determined"] = e.determined;
      if (std::isfinite(e.tolerance)) p["tolerance"] = e.tolerance;
      if (std::isfinite(e.prior_sd)) {
        p["prior_sd"] = e.prior_sd;
        p["data_share"] = e.data_share;
        p["set_by_prior"] = e.set_by_prior;
      }
    } else {
      p["reason"] = e.reason;
      p["held_by_selection"] = e.held_by_selection;
    }
    params[e.name] = p;
  }
  json transmissions = json::array();
  for (const TransmissionFit& t : result.transmissions) {
    const std::string link = nominal.links[t.joint].name;
    for (size_t i = 0; i < t.names.size(); ++i) {
      params[t.names[i]] = {{"nominal", t.nominal[i]},
                            {"value", t.value[i]},
                            {"sd", number_or_null(t.sd[i])},
                            {"identifiable", true}};
    }
    json tj{{"joint", link},
            {"type", t.type},
            {"n", t.n},
            {"rms_before", t.rms_before},
            {"rms_after", t.rms_after},
            {"offset", {{"value", t.offset}, {"sd", number_or_null(t.offset_sd)}}},
            {"held_out_rms", number_or_null(t.held_out_rms)},
            {"model_choice", t.model_choice},
            {"flagged", t.flagged},
            {"converged", t.converged},
            {"message", t.message}};
    if (t.requested_order > 0) tj["requested_order"] = t.requested_order;
    json candidates = json::array();
    for (const StepOneCandidate& c : t.candidates) {
      candidates.push_back({{"model", c.label},
                            {"parameters", c.parameters},
                            {"held_out_rms", number_or_null(c.held_out_rms)},
                            {"gcv_rms", number_or_null(c.gcv_rms)}});
    }
    tj["candidates"] = candidates;
    if (!t.monomial.empty()) tj["monomial_coefficients"] = t.monomial;
    transmissions.push_back(tj);
  }
  j["parameters"] = params;
  j["transmissions"] = transmissions;
  if (result.clock) j["clock"] = clock_json(*result.clock);
  if (result.marker_body.cols() > 0) {
    json markers = json::array();
    for (Eigen::Index k = 0; k < result.marker_body.cols(); ++k)
      markers.push_back(
          {result.marker_body(0, k), result.marker_body(1, k), result.marker_body(2, k)});
    j["markers"] = markers;  // in the tool frame [m]: --markers X1,Y1,Z1,... for evaluate
  }
  j["notes"] = result.notes;
  // Paths are bytes on Linux: invalid UTF-8 is replaced, never a throw.
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

std::string evaluation_json(const EvaluationComparison* comparison, const Evaluation& ev) {
  const Evaluation* ref = comparison ? &comparison->reference : nullptr;
  nlohmann::ordered_json j;
  j["n"] = ev.n;
  if (ev.registered) j["registered"] = registration_json(*ev.registered);
  for (const Evaluation::FigureErrors& f : ev.figures) {
    j[fmt::format("rms_{}", f.figure.name)] = f.stats.rms;
    j[fmt::format("max_{}", f.figure.name)] = f.stats.max;
  }
  if (ev.mean_point_deviation) {
    j["mean_point_deviation"] = *ev.mean_point_deviation;
    j["rms_point_deviation"] = *ev.rms_point_deviation;
  }
  if (ev.max_point_distance_error) j["max_point_distance_error"] = *ev.max_point_distance_error;
  if (ev.rms_known_point_error) j["rms_known_point_error"] = *ev.rms_known_point_error;
  if (ev.rms_plane_distance) j["rms_plane_distance"] = *ev.rms_plane_distance;
  if (!ev.labels.empty()) {
    nlohmann::ordered_json labels = nlohmann::ordered_json::object();
    for (const auto& l : ev.labels) {
      labels[l.name] = {{"samples", l.samples},
                        {"centre", {l.centre.x(), l.centre.y(), l.centre.z()}},
                        {"mean_deviation", l.mean_deviation},
                        {"rms_deviation", l.rms_deviation}};
      if (l.rms_known_error) labels[l.name]["rms_known_error"] = *l.rms_known_error;
    }
    j["labels"] = labels;
  }
  if (ref) {
    if (ref->registered) j["reference_registered"] = registration_json(*ref->registered);
    if (ref->mean_point_deviation) {
      j["reference_mean_point_deviation"] = *ref->mean_point_deviation;
    }
    if (ref->rms_plane_distance) j["reference_rms_plane_distance"] = *ref->rms_plane_distance;
    for (const Evaluation::FigureErrors& f : ev.figures) {
      const Evaluation::FigureErrors* theirs = ref->figure(f.figure.name);
      if (!theirs) continue;
      j[fmt::format("reference_rms_{}", f.figure.name)] = theirs->stats.rms;
      j[fmt::format("improvement_{}_pct", f.figure.name)] =
          rms_improvement_pct(f.stats.rms, theirs->stats.rms);
    }
    if (comparison->setup_only) j["setup_only"] = true;  // the improvement is the set-up's
  }
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

namespace {

// results.json beyond the paper's study: no paper figures; what the truth is
// and each parameter's assigned and identified deviation, and its error in
// Cramer-Rao standard deviations.
void general_study_json(const Scenario& sc, const StudyResult& r, nlohmann::ordered_json& j) {
  using json = nlohmann::ordered_json;
  if (!sc.tip.empty()) j["tip"] = sc.tip;
  if (!sc.root.empty()) j["root"] = sc.root;
  j["measurement"] = traits(sc.measurement).name;
  if (traits(sc.measurement).rotation) j["noise"]["sigma_r"] = sc.noise.sigma_orientation;
  json truth = {{"transmissions", sc.paper_transmissions ? "paper" : "device"},
                {"kinematics", sc.random.enabled() ? "random"
                               : sc.paper_device   ? "paper Table 3"
                                                   : "nominal"}};
  if (sc.random.enabled()) {
    truth["random_deviations"] = {
        {"lengths", sc.random.lengths}, {"angles", sc.random.angles}, {"seed", sc.random.seed}};
  }
  truth["deviations"] = sc.deviations;
  j["truth"] = truth;
  for (auto& [name, p] : j["parameters"].items()) {
    p.erase("paper_improvement_pct");
    const double assigned = p["assigned"], identified = p["identified"];
    const auto mc = r.monte_carlo.find(name);
    const double sd = mc != r.monte_carlo.end() ? mc->second.crlb_sd : 0;
    p["error_in_crlb_sd"] = sd > 0 ? json((identified - assigned) / sd) : json(nullptr);
  }
  j["trajectory"].erase("paper_improvement_full_pct");
  j["trajectory"].erase("paper_improvement_kinematic_only_pct");
}

// A study's ISO 9283 tests (StudyResult::iso): the test as simulated, each
// pose's AP over the trials, and all of them.
nlohmann::ordered_json iso_study_json(const IsoSimulation& iso, const IsoStudy& study) {
  using json = nlohmann::ordered_json;
  const auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json poses = json::array();
  for (const IsoPoseSummary& p : study.poses) {
    poses.push_back({{"label", p.label},
                     {"position", {p.point.x(), p.point.y(), p.point.z()}},
                     {"ap_nominal", number(p.ap_nominal)},
                     {"ap_calibrated", number(p.ap_calibrated)},
                     {"ap_predicted", number(p.ap_predicted)},
                     {"rp", number(p.rp)}});
  }
  return {{"cycles", iso.plan.cycles},
          {"scatter", iso.scatter},
          {"cube",
           {{"centre", {iso.plan.centre.x(), iso.plan.centre.y(), iso.plan.centre.z()}},
            {"size", iso.plan.size}}},
          {"trials", study.trials.size()},
          {"poses", poses},
          {"ap_nominal", number(study.ap_nominal)},
          {"ap_calibrated", number(study.ap_calibrated)},
          {"ap_predicted", number(study.ap_predicted)},
          {"csv", "iso9283.csv"}};
}

}  // namespace

std::string study_json(const Scenario& sc, const StudyResult& r) {
  using json = nlohmann::ordered_json;
  const TrialResult& t = r.first;
  json j;
  j["format"] = "hapticcal-study/1";
  j["device"] = sc.device_path;
  j["seed"] = sc.seed;
  j["trials"] = r.trials;
  j["noise"] = {{"sigma_e", sc.noise.sigma_ext},
                {"sigma_m", sc.noise.sigma_distance},
                {"sigma_m_formula", sc.sigma_m_formula},
                {"motor_counts_per_rev", sc.noise.motor_counts_per_rev}};
  j["poses"] = {{"identification", sc.identification_poses}, {"validation", sc.validation_poses}};
  if (!sc.identification_plan.empty()) j["identification_plan"] = sc.identification_plan;
  // Only when not the paper's procedure (the default study's file is unchanged).
  if (!sc.keep_all || !sc.fix.empty())
    j["calibration"] = {{"keep_all", sc.keep_all}, {"fix", sc.fix}};
  json params = json::object();
  std::map<std::string, StudyRow> by_name;  // results.json lists them alphabetically
  for (const StudyRow& row : study_rows(sc, t.full)) {
    if (row.held.empty()) by_name[row.name] = row;
  }
  for (const auto& [name, row] : by_name) {
    const auto paper = paper_improvement_pct(name);
    const auto mc = r.monte_carlo.find(name);
    params[name] = {
        {"assigned", row.assigned},
        {"nominal", row.nominal},
        {"identified", row.identified},
        {"assigned_deviation", row.assigned - row.nominal},
        {"identified_deviation", row.identified - row.nominal},
        {"improvement_pct", row.improvement_pct},
        {"paper_improvement_pct", paper ? json(*paper) : json(nullptr)},
        {"crlb_sd", mc != r.monte_carlo.end() ? json(mc->second.crlb_sd) : json(nullptr)}};
  }
  j["parameters"] = params;
  j["held"] = json::object();
  for (const ParameterEstimate& e : t.full.kinematics.parameters) {
    if (!e.identifiable) j["held"][e.name] = e.reason;
  }
  j["validation"] = {{"position_rms_before", t.position_rms_before},
                     {"position_rms_after", t.position_rms_after},
                     {"orientation_rms_before", t.orientation_rms_before},
                     {"orientation_rms_after", t.orientation_rms_after},
                     {"distance_rms_before", t.distance_rms_before},
                     {"distance_rms_after", t.distance_rms_after}};
  j["trajectory"] = {
      {"rms_before", t.trajectory_rms_before},
      {"rms_full", t.trajectory_rms_full},
      {"rms_kinematic_only", t.trajectory_rms_kinematic},
      {"improvement_full_pct", rms_improvement_pct(t.trajectory_rms_full, t.trajectory_rms_before)},
      {"improvement_kinematic_only_pct",
       rms_improvement_pct(t.trajectory_rms_kinematic, t.trajectory_rms_before)},
      {"paper_improvement_full_pct", kPaperImprovementFullPct},
      {"paper_improvement_kinematic_only_pct", kPaperImprovementKinematicOnlyPct}};
  if (r.trials > 1) {
    json mc = json::object();
    for (const auto& [name, m] : r.monte_carlo) {
      mc[name] = {{"assigned", m.assigned},
                  {"mean", m.mean},
                  {"mean_improvement_pct", m.mean_improvement_pct},
                  {"rmse", m.rmse},
                  {"crlb_sd", m.crlb_sd},
                  {"efficiency", m.efficiency},
                  {"improvement_p05", m.improvement_p05},
                  {"improvement_p95", m.improvement_p95},
                  {"trials", m.trials}};
    }
    j["monte_carlo"] = mc;
  }
  if (!sc.paper_comparison()) general_study_json(sc, r, j);
  if (r.iso) j["iso9283"] = iso_study_json(*sc.iso9283, *r.iso);
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

std::string force_json(const std::string& actual, const std::string& nominal,
                       const std::string& calibrated, const ForceStudy& study, double gain_limit) {
  const ForceScenario& sc = study.scenario;
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-force/1";
  j["actual"] = actual;
  j["nominal"] = nominal;
  j["calibrated"] = calibrated;
  j["stiffness"] = sc.stiffness;
  j["travel"] = sc.travel;
  j["gain"] = sc.gain;
  j["stable_gain_limit"] = gain_limit;
  j["sensor_noise"] = sc.sensor_noise;
  j["seed"] = sc.seed;
  j["posture"] = std::vector<double>(sc.posture.data(), sc.posture.data() + sc.posture.size());
  j["transverse_rms_nominal"] = study.nominal.transverse_rms;
  j["transverse_rms_calibrated"] = study.calibrated.transverse_rms;
  j["reduction_pct"] = study.reduction_pct;
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace hapticcal
