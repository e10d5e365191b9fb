// Joint errors in step 2: the families (families/) offered to the fit and
// folded into the calibrated model.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <utility>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

// The joint-error families of step 2 (CalibrationOptions::joint_errors), each
// offering its parameters (families/), in the registry's order.
void offer_joint_errors(CalibrationRun& run) {
  const std::vector<std::string>& named = run.options.joint_errors;
  if (named.empty() || named.front() == "none") return;
  run.fit().joint_error_families = named;
  for (const JointErrorFamily* family : joint_error_families()) {
    if (std::find(named.begin(), named.end(), family->name()) == named.end()) continue;
    FamilyOffer offer{run.model, run.step2_nominal, run.poses, run.result.notes};
    family->offer(offer);
  }
}

CalibrationResult conclude_with_geometry(CalibrationRun& run) {
  const CalibrationOptions geometry = geometry_options(run);
  CalibrationResult result = conclude_model(run);
  if (!result.kinematics.joint_error_families.empty())
    result.geometry =
        std::make_shared<const CalibrationResult>(calibrate(run.nominal, run.log, geometry));
  return result;
}

CalibrationOptions geometry_options(const CalibrationRun& run) {
  CalibrationOptions geometry = run.options;
  geometry.joint_errors = {"none"};
  // Options naming the families' parameters name nothing in the geometry.
  std::vector<std::string> families;
  for (const ParameterInfo& pi : run.problem.model.parameter_info()) {
    if (pi.block == ParameterBlock::kJointError) families.push_back(pi.name);
  }
  const auto family = [&](const std::string& name) {
    return std::find(families.begin(), families.end(), name) != families.end();
  };
  std::erase_if(geometry.fix, family);
  std::erase_if(geometry.free, family);
  std::erase_if(geometry.tolerances.by_name, [&](const auto& item) { return family(item.first); });
  return geometry;
}

// The joint-error stages as fitted, folded into the calibrated model's
// transmissions (after the link's own: the angle v becomes v + stage(v)); a
// stage whose coefficients all stayed zero is left out.
std::string fold_joint_errors(DeviceModel& model) {
  std::string refused;
  for (const JointErrorFamily* family : joint_error_families()) {
    const std::string why = family->fold(model);
    if (refused.empty()) refused = why;
  }
  return refused;
}

bool coupled_between(const DeviceModel& m) {
  for (int i = 0; i < m.dof() && m.coupled(); ++i) {
    for (int k = 0; k < m.dof(); ++k) {
      if (i != k && m.coupling(i, k) != 0) return true;
    }
  }
  return false;
}

// Whether a pose's step-2 values depend on the start's geometry beyond its
// readings: a compliance compensate applies, a held lateral bend, or a
// family's features of the joint values (its gravity torques).
bool geometry_features(const DeviceModel& model) {
  if (model.compliant() || model.laterally_compliant()) return true;
  for (const JointErrorFamily* family : joint_error_families()) {
    if (!model.fitted_block(family->name())) continue;
    const std::unique_ptr<PoseFeatures> features = family->pose_features(model);
    if (features && features->of_joint_values()) return true;
  }
  return false;
}

// The torques' own error (of the start's geometry against the device's)
// would otherwise stay in the fit: on a compliant 6-joint arm measured at 10
// um (tests/lateral_compliance_test.cpp's), held-out 1.08 (joint compliance)
// and 1.12 (joint and lateral) times the noise floor with the torques of the
// start's geometry, 1.04 once formed again on the fit's.
void reform_on_fit(CalibrationRun& run) {
  KinematicProblem& problem = run.problem;
  if (run.solution.termination != SolveTermination::kConverged ||
      static_cast<int>(problem.joints.size()) != run.poses.rows ||
      !geometry_features(problem.model)) {
    return;
  }
  DeviceModel at = problem.model;
  at.set_kinematic_parameters(run.solution.parameters);
  const StepTwoJoints step_two(at);
  const std::vector<Eigen::VectorXd> start = problem.joints;
  for (int i = 0; i < run.poses.rows; ++i) problem.joints[i] = step_two.row(run.poses, i);
  Eigen::VectorXd initial = run.solution.parameters;
  std::swap(initial, problem.initial);
  KinematicSolution again = solve_kinematics(problem, run.identified, run.iterations);
  std::swap(initial, problem.initial);
  if (again.termination != SolveTermination::kConverged) {
    problem.joints = start;
    return;
  }
  again.iterations += run.solution.iterations;
  run.solution = std::move(again);
}

std::vector<std::string> applicable_families(const CalibrationRun& run) {
  std::vector<std::string> out;
  for (const JointErrorFamily* family : joint_error_families()) {
    if (family->applies(run.model, run.poses)) out.emplace_back(family->name());
  }
  return out;
}

}  // namespace hapticcal::detail

namespace hapticcal {

const CalibrationResult& geometry_model(const CalibrationResult& result) {
  return result.geometry ? *result.geometry : result;
}

}  // namespace hapticcal
