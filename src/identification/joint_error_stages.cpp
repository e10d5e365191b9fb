// Step 2's joint-error stages and a pose's step-2 values
// (identification/joint_errors.hpp).
#include <fmt/format.h>

#include <array>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/joint_errors.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

// The slot whose Jacobian column is d rows / d joint i's value: a DH / MDH
// theta (d for a sliding joint), a URDF joint's offset.
int joint_value_column(const DeviceModel& model, const ChainStructure& s, int i) {
  const Link& l = model.links[i];
  return s.link_slot(i) + (!l.dh_parameters() ? kOriginOffset
                           : l.prismatic()    ? kLinkD
                                              : kLinkTheta);
}

}  // namespace

std::vector<JointErrorStage> joint_error_stages(const DeviceModel& model) {
  std::vector<JointErrorStage> stages;
  const ChainStructure s = model.structure();
  int slot = s.errors_slot(), feature = s.dof;
  auto add = [&](int link, int first, int count, double nominal) {
    stages.push_back({link, first, joint_value_column(model, s, link), count, feature, nominal});
    feature += count;
  };
  for (int i = 0; i < static_cast<int>(model.joint_errors.size()); ++i) {
    const Transmission& stage = model.joint_errors[i];
    if (stage.is_none()) continue;
    const Link& l = model.links[i];
    if (l.prismatic() || stage.kind() != TransmissionKind::kHarmonic) {
      throw InputError(
          fmt::format("{}: a joint-error stage must be harmonics of a turning joint", l.name));
    }
    stages.push_back(
        {i, slot, joint_value_column(model, s, i), stage.num_parameters(), -1, 0.0, stage});
    slot += stage.num_parameters();
  }
  slot = s.compliance_slot();
  for (int i = 0; i < model.dof(); ++i) {
    if (model.compliance_fitted(i)) add(i, slot++, 1, 0.0);
  }
  slot = s.coupling_slot();
  for (const auto& [i, k] : model.fitted_coupling) add(i, slot++, 1, model.coupling(i, k));
  slot = s.backlash_slot();
  for (const int i : model.fitted_backlash) add(i, slot++, 1, model.links[i].backlash);
  return stages;
}

StepTwoJoints::StepTwoJoints(const DeviceModel& model)
    : model_(model),
      prepared_(std::make_unique<const PreparedModel>(model)),
      stages_(joint_error_stages(model)) {
  for (int i = 0; i < model.dof(); ++i) {
    if (model.compliance_fitted(i) && !gravity_)
      gravity_ = std::make_unique<const GravityModel>(model);
  }
  for (const JointErrorStage& e : stages_) features_ += e.feature >= 0 ? e.count : 0;
}

StepTwoJoints::~StepTwoJoints() = default;

Eigen::VectorXd StepTwoJoints::operator()(
    const Eigen::VectorXd& q, const Eigen::Ref<const Eigen::RowVectorXd>& direction) const {
  const int n = model_.dof();
  Eigen::VectorXd joint(n);
  prepared_->compensate(q.data(), joint.data());
  model_.apply_backlash(direction, joint);
  return with_features(joint, q, direction);
}

Eigen::VectorXd StepTwoJoints::with_features(
    const Eigen::VectorXd& values, const Eigen::VectorXd& q,
    const Eigen::Ref<const Eigen::RowVectorXd>& direction) const {
  const DeviceModel& m = model_;
  const int n = m.dof();
  Eigen::VectorXd joint(n + features_);
  joint.head(n) = values;
  std::array<double, kMaxDof> tau;
  if (gravity_) gravity_->torques(joint.data(), tau.data());
  // The features in stage order: compliances, couplings, backlashes (after
  // the harmonics, whose features the rows form).
  size_t k = 0;
  while (k < stages_.size() && stages_[k].feature < 0) ++k;
  for (int i = 0; i < n; ++i) {
    if (m.compliance_fitted(i)) joint[stages_[k++].feature] = tau[i];
  }
  for (const auto& [i, r] : m.fitted_coupling)
    joint[stages_[k++].feature] = q[r] + m.links[r].transmission.error(q[r]);
  for (const int i : m.fitted_backlash)
    joint[stages_[k++].feature] = direction.size() == n ? direction[i] : 0.0;
  return joint;
}

Eigen::RowVectorXd direction_row(const Log& log, int r) {
  if (!log.any_direction()) return {};
  return log.direction.row(r);
}

}  // namespace hapticcal
