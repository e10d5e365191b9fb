#include <nlohmann/json.hpp>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"

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

}  // namespace

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
  j["measurement"] = traits(k.type).name;
  if (k.type == MeasurementType::kPose) j["rotation_scale"] = k.rotation_scale;
  j["frame_registered"] = k.frame_registered;
  j["rows_used"] = k.rows;
  j["poses"] = k.poses;
  j["repeatability"] = number_or_null(k.repeatability);
  j["samples"] = options.samples;
  j["seed"] = options.seed;
  j["transmission_step"] = options.transmissions;
  j["sigma"] = {{"value", k.sigma}, {"source", k.sigma_given ? "given" : "residual"}};
  j["rms_before"] = k.rms_before;
  j["rms_after"] = k.rms_after;
  j["cross_validation"] = {{"folds", k.cv_folds},
                           {"rms", number_or_null(k.cv_rms)},
                           {"seed", options.seed},
                           {"note", k.cv_note}};
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
  j["model_selection"] = selection;
  const RobustFit& robust = k.robust;
  j["robust"] = {
      {"loss", to_string(robust.loss)},
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
  json outliers = json::array();
  for (const OutlierPose& o : robust.outliers) {
    outliers.push_back({{"lines", o.lines},
                        {"residual", o.residual},
                        {"robust_sd", robust.robust_sd},
                        {"statistic", o.statistic},
                        {"weight", o.weight}});
  }
  j["outliers"] = outliers;
  const SuspectFit& suspect = k.suspect;
  j["suspect"] = {{"suspect", suspect.suspect},
                  {"reasons", suspect.reasons},
                  {"repeatability_ratio", number_or_null(suspect.repeatability_ratio)},
                  {"repeatability_limit", suspect.repeatability_limit},
                  {"nominal_base_fitted_rms", number_or_null(suspect.nominal_base_fitted_rms)},
                  {"cv_ratio", number_or_null(suspect.cv_ratio)},
                  {"strict", options.strict}};
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
            {"converged", t.converged},
            {"message", t.message}};
    if (!t.monomial.empty()) tj["monomial_coefficients"] = t.monomial;
    transmissions.push_back(tj);
  }
  j["parameters"] = params;
  j["transmissions"] = transmissions;
  j["notes"] = result.notes;
  // Paths are bytes on Linux: invalid UTF-8 is replaced, never a throw.
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

std::string evaluation_json(const EvaluationComparison* comparison, const Evaluation& ev) {
  const Evaluation* ref = comparison ? &comparison->reference : nullptr;
  nlohmann::ordered_json j;
  j["n"] = ev.n;
  if (ev.registered) j["registered"] = registration_json(*ev.registered);
  if (ev.distance) {
    j["rms_distance"] = ev.distance->rms;
    j["max_distance"] = ev.distance->max;
  }
  if (ev.orientation) {
    j["rms_orientation"] = ev.orientation->rms;
    j["max_orientation"] = ev.orientation->max;
  }
  if (ev.position) {
    j["rms_position"] = ev.position->rms;
    j["max_position"] = ev.position->max;
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
    if (ev.distance) {
      j["reference_rms_distance"] = ref->distance->rms;
      j["improvement_distance_pct"] = *comparison->improvement_distance_pct;
    }
    if (ev.position) {
      j["reference_rms_position"] = ref->position->rms;
      j["improvement_position_pct"] = *comparison->improvement_position_pct;
    }
  }
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace hapticcal
