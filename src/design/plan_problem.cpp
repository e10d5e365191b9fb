// The linearised two-step problem of experiment design (PlanProblem, plan.hpp):
// the parameters a plan is for, their Fisher rows, the exact two-step
// covariance of a design and what it predicts over the workspace.
#include <Eigen/Dense>
#include <algorithm>
#include <map>

#include "hapticcal/core/error.hpp"
#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

namespace {

// Capstans with both eccentricities zero get kPlanCapstanEccentricity * D (see plan.hpp).
void linearisable(Transmission& t) {
  if (auto* c = std::get_if<Capstan>(&t.model())) {
    if (c->r_out == 0 && c->r_in == 0) {
      c->r_out = c->r_in = kPlanCapstanEccentricity * c->drum_distance;
    }
  } else if (auto* chain = std::get_if<Chain>(&t.model())) {
    for (Transmission& stage : chain->stages) linearisable(stage);
  }
}

// The rows of each sample's tip point (a distance: the sample's one row); a
// tree's pose is a sample a tip, each `d` rows.
Eigen::MatrixXd tip_rows(const Eigen::MatrixXd& G, int d) {
  if (d == 1) return G;
  const Eigen::Index samples = G.cols() / d;
  Eigen::MatrixXd out(G.rows(), samples * 3);
  for (Eigen::Index r = 0; r < samples; ++r) out.middleCols(3 * r, 3) = G.middleCols(d * r, 3);
  return out;
}

// The log of the model's predicted measurements at `readings`: a tree's, its
// tips' points as one sample a tip (tip_samples).
Log predicted_log(const DeviceModel& model, MeasurementType type, const Eigen::MatrixXd& readings) {
  Log log;
  log.origin = "plan candidates";
  log.rows = static_cast<int>(readings.rows());
  log.q = readings;
  log.ext.setZero(log.rows, model.dof());
  log.has_ext.assign(model.dof(), false);
  for (int r = 0; r < log.rows; ++r) log.line.push_back(r + 2);
  if (!model.tree()) {
    kind_of(type).to_log(predicted_measurements(model, type, readings), log);
    return log;
  }
  if (type != MeasurementType::kPosition)
    throw InputError("--measurement: a tree's plan measures its tips' points: position");
  const PreparedModel prepared(model);
  log.marker_count = model.tips();
  log.markers.resize(log.rows, 3 * model.tips());
  for (int r = 0; r < log.rows; ++r) {
    const Eigen::VectorXd q = readings.row(r).transpose();
    for (int t = 0; t < model.tips(); ++t)
      log.markers.row(r).segment<3>(3 * t) = prepared.forward(q.data(), t).p.transpose();
  }
  return tip_samples(model, log);
}

// step_one_model for one transmission (chains stage by stage).
void cap_order(Transmission& t, int order) {
  if (auto* p = std::get_if<Polynomial>(&t.model())) {
    if (p->order() > order) p->coefficients.resize(order + 1);
  } else if (auto* chain = std::get_if<Chain>(&t.model())) {
    for (Transmission& stage : chain->stages) cap_order(stage, order);
  }
}

}  // namespace

DeviceModel step_one_model(DeviceModel model, int samples) {
  const int order = std::max(1, step_one_supported_order(samples));
  for (Link& l : model.links) cap_order(l.transmission, order);
  return model;
}

PlanProblem::PlanProblem(const DeviceModel& model, MeasurementType type, double sigma_m,
                         double sigma_e, const Eigen::MatrixXd& analysis,
                         const std::vector<std::string>& fix, const std::vector<std::string>& free)
    : model_(model),
      type_(type),
      d_(traits(type).dimension * model.tips()),
      sigma_m_(sigma_m),
      sigma_e_(sigma_e) {
  for (Link& l : model_.links) linearisable(l.transmission);
  // The kinematic parameters these candidates can identify.
  const Log log = predicted_log(model_, type, analysis);
  const KinematicProblem problem = kinematic_problem(model_, log, {}, CalibrationOptions{});
  length_scale_ = problem.length_scale;
  rotation_scale_ = problem.rotation_scale;
  const std::vector<int> candidates = candidate_slots(model_, fix, free);
  const IdentifiabilityAnalysis ia = analyze_identifiability(problem, candidates);
  slots_ = ia.identified;
  const std::vector<ParameterInfo> info = model_.parameter_info();
  std::map<int, std::string> name;
  for (const ParameterInfo& p : info) name[p.slot] = p.name;
  for (const auto& [slot, why] : ia.reason) held_[name[slot]] = why;

  for (int j = 0; j < model_.dof(); ++j) {
    const Transmission& t = model_.links[j].transmission;
    if (t.is_none() || t.num_parameters() == 0) continue;
    StepOneModel s;
    s.joint = j;
    s.transmission = t;
    for (const std::string& p : t.parameter_names())
      s.names.push_back(model_.links[j].name + "." + p);
    step_one_offset_.push_back(static_cast<int>(names_.size()));
    names_.insert(names_.end(), s.names.begin(), s.names.end());
    names_.push_back(model_.links[j].name + ".encoder_zero");
    step_one_.push_back(std::move(s));
  }
  kinematic_offset_ = static_cast<int>(names_.size());
  for (int slot : slots_) names_.push_back(name[slot]);
}

Eigen::MatrixXd PlanProblem::prediction_rows(const Eigen::MatrixXd& readings) const {
  const TwoStepJacobians J =
      two_step_jacobians(model_, type_, rotation_scale_, slots_, step_one_, readings);
  const Eigen::Index rows = J.kinematic.rows();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(parameters(), rows);
  G.bottomRows(slots_.size()) = J.kinematic.transpose();
  for (size_t t = 0; t < step_one_.size(); ++t) {
    G.middleRows(step_one_offset_[t], J.step_one[t].measurement.cols()) =
        J.step_one[t].measurement.transpose();
  }
  return G;
}

Eigen::MatrixXd PlanProblem::fisher_rows(const Eigen::MatrixXd& readings) const {
  const TwoStepJacobians J =
      two_step_jacobians(model_, type_, rotation_scale_, slots_, step_one_, readings);
  const Eigen::Index m = readings.rows();
  const int r = rows_per_pose();
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(parameters(), m * r);
  for (Eigen::Index i = 0; i < m; ++i) {
    auto block = F.middleCols(i * r, r);
    block.bottomLeftCorner(slots_.size(), d_) =
        J.kinematic.middleRows(i * d_, d_).transpose() / sigma_m_;
    for (size_t t = 0; t < step_one_.size(); ++t) {
      const StepOneSensitivity& s = J.step_one[t];
      const Eigen::Index np = s.measurement.cols();
      block.block(step_one_offset_[t], 0, np, d_) =
          s.measurement.middleRows(i * d_, d_).transpose() / sigma_m_;
      block.block(step_one_offset_[t], d_ + t, np + 1, 1) = s.encoder.row(i).transpose() / sigma_e_;
    }
  }
  return F;
}

Eigen::MatrixXd PlanProblem::covariance(const Eigen::MatrixXd& design) const {
  const TwoStepJacobians J =
      two_step_jacobians(model_, type_, rotation_scale_, slots_, step_one_, design);
  const Eigen::MatrixXd C = two_step_covariance(J.kinematic, sigma_m_, J.step_one, sigma_e_);
  // C's order: each joint's parameters (no encoder zero), then the kinematic ones.
  std::vector<int> index;
  for (size_t t = 0; t < step_one_.size(); ++t) {
    for (int c = 0; c < step_one_[t].transmission.num_parameters(); ++c)
      index.push_back(step_one_offset_[t] + c);
  }
  for (size_t c = 0; c < slots_.size(); ++c) index.push_back(kinematic_offset_ + c);
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(parameters(), parameters());
  for (size_t a = 0; a < index.size(); ++a) {
    for (size_t b = 0; b < index.size(); ++b) out(index[a], index[b]) = C(a, b);
  }
  return out;
}

double PlanProblem::rms_sd_of(const Eigen::MatrixXd& C, const Eigen::MatrixXd& G) const {
  const int per_tip = d_ / model_.tips();
  const Eigen::MatrixXd T = tip_rows(G, per_tip);
  const Eigen::Index samples = G.cols() / per_tip;
  const double total = (T.transpose() * C).cwiseProduct(T.transpose()).sum();
  return std::sqrt(std::max(total, 0.0) / static_cast<double>(samples));
}

double PlanProblem::predicted_rms_sd(const Eigen::MatrixXd& design,
                                     const Eigen::MatrixXd& validation) const {
  return rms_sd_of(covariance(design), prediction_rows(validation));
}

Conditioning PlanProblem::conditioning(const Eigen::MatrixXd& design) const {
  const TwoStepJacobians J = two_step_jacobians(model_, type_, rotation_scale_, slots_, {}, design);
  Eigen::MatrixXd Js = J.kinematic;
  const std::vector<ParameterInfo> info = model_.parameter_info();
  for (size_t c = 0; c < slots_.size(); ++c) {
    if (info[slots_[c]].unit == ParameterUnit::kAngle) Js.col(c) /= length_scale_;
  }
  return hapticcal::conditioning(Js, static_cast<double>(Js.rows()));
}

}  // namespace hapticcal
