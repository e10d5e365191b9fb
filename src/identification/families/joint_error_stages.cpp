// Step 2's joint-error stages and a pose's step-2 values
// (identification/joint_errors.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/joint_errors.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/families/family.hpp"

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
  int feature = s.dof;
  for (const detail::JointErrorFamily* family : detail::joint_error_families()) {
    family->add_stages(
        model, [&](int link, int slot, int count, double nominal, const Transmission* formed) {
          JointErrorStage e;
          e.link = link;
          e.slot = slot;
          e.count = count;
          e.nominal = nominal;
          e.geometry = family->bends();
          e.joint_column = joint_value_column(model, s, link);
          if (formed) {
            e.harmonic = *formed;
          } else {
            e.feature = feature;
            feature += count;
          }
          stages.push_back(std::move(e));
        });
  }
  // In slot order: the rows move the joint values in the parameter vector's order.
  std::stable_sort(
      stages.begin(), stages.end(),
      [](const JointErrorStage& a, const JointErrorStage& b) { return a.slot < b.slot; });
  return stages;
}

StepTwoJoints::StepTwoJoints(const DeviceModel& model)
    : model_(model), prepared_(std::make_unique<const PreparedModel>(model)) {
  // Each family's stored features, from its first index on (in the registry's
  // order, as joint_error_stages numbers them).
  for (const detail::JointErrorFamily* family : detail::joint_error_families()) {
    int count = 0;
    family->add_stages(model, [&](int, int, int n, double, const Transmission* formed) {
      if (!formed) count += n;
    });
    if (count == 0) continue;
    features_.push_back({family->pose_features(model), static_cast<int>(model.dof()) + stored_});
    stored_ += count;
  }
  if (model.laterally_compliant()) {
    gravity_ = std::make_unique<const GravityModel>(model);
    bends_ = model.dof() + stored_;
  }
  if (model.tree()) tip_ = model.dof() + stored_ + (bends_ ? model.dof() : 0);
}

StepTwoJoints::~StepTwoJoints() = default;

Eigen::VectorXd StepTwoJoints::operator()(const Eigen::VectorXd& q,
                                          const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                                          int tip) const {
  const int n = model_.dof();
  Eigen::VectorXd joint(n);
  prepared_->compensate(q.data(), joint.data());
  model_.apply_backlash(direction, joint);
  return with_features(joint, q, direction, tip);
}

Eigen::VectorXd StepTwoJoints::row(const Log& log, int r) const {
  return (*this)(log.q.row(r).transpose(), direction_row(log, r),
                 log.tip.empty() ? 0 : log.tip[static_cast<size_t>(r)]);
}

Eigen::VectorXd StepTwoJoints::with_features(const Eigen::VectorXd& values,
                                             const Eigen::VectorXd& q,
                                             const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                                             int tip) const {
  const int n = model_.dof();
  Eigen::VectorXd joint(n + stored_ + (bends_ ? n : 0) + (tip_ ? 1 : 0));
  if (tip_) joint[*tip_] = tip;
  joint.head(n) = values;
  for (const auto& [features, first] : features_)
    (*features)(joint.data(), q, direction, joint.data() + first);
  if (bends_) {  // from the joint values before any deflection (the readings')
    std::array<double, kMaxDof> rigid;
    if (q.size() == n) {
      prepared_->rigid_joints(q.data(), rigid.data());
    } else {
      std::copy(values.data(), values.data() + n, rigid.begin());
    }
    gravity_->bends(rigid.data(), joint.data() + *bends_);
  }
  return joint;
}

void StepTwoJoints::refresh(Eigen::VectorXd& values) const {
  for (const auto& [features, first] : features_) {
    if (features->of_joint_values())
      (*features)(values.data(), Eigen::VectorXd(), Eigen::RowVectorXd(), values.data() + first);
  }
  if (bends_) gravity_->bends(values.data(), values.data() + *bends_);
}

Eigen::RowVectorXd direction_row(const Log& log, int r) {
  if (!log.any_direction()) return {};
  return log.direction.row(r);
}

}  // namespace hapticcal
