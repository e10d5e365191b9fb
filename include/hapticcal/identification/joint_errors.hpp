// Step 2's joint-error stages: how each family's parameters move the joint
// values in the residual rows, and a pose's step-2 values with their features.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// One link's step-2 joint-error stage (DeviceModel::joint_errors) as the
// residual rows use it: the joint value v the kinematics turn by becomes
// v + sum_k p_k phi_k(v), phi the stage's parameter_jacobian (a Harmonic's
// sines and cosines: linear in p), so each parameter's Jacobian column is
// phi_k(v) times the column of the joint value: the DH / MDH theta's, a URDF
// joint's offset's (both add to v).
// Every stage has the same form: parameters p_c (slots slot .. slot + count - 1)
// that move joint `link`'s value by sum_c (p_c - nominal) x_c, the features x_c
// fixed per pose and carried in the pose's step-2 values after its dof joint
// values (from index `feature` on: step_two_joints), the joint values having
// been formed with p = nominal; each parameter's column is x_c times the joint
// value's. A harmonic stage's x are its parameter_jacobian at the pose's joint
// value (nominal 0), formed as the rows are (`harmonic`: many a joint, not
// stored per pose); a compliance stage's one x the link's gravity torque at
// the pose's joint values from the start's geometry and masses (nominal 0:
// compensate leaves a fitted compliance to the stage); a coupling stage's p is
// C_ik, the joint's coefficient on reading k (the coupling block in
// DeviceModel::fitted), x
// the reading through its own transmission, u_k = q_k + dtheta_k(q_k); a
// backlash stage's p is the link's backlash, x the side the joint approached
// the pose from (the log's dir<i>: +1, -1, 0).
class PreparedModel;  // kinematics.hpp
struct GravityModel;  // kinematics.hpp
class PoseFeatures;   // joint_error_family.hpp
struct JointErrorStage {
  int link = 0;
  int slot = 0;          // first slot of its parameters
  int joint_column = 0;  // the slot whose column is d rows / d joint value
  // It bends the link about its lateral axis per pose (turn_laterally:
  // alpha or roll) instead of moving the joint value; its columns are that
  // slot's.
  bool geometry = false;
  int count = 1;          // its parameters
  int feature = -1;       // index of its first feature in a pose's step-2 values
  double nominal = 0;     // its parameters' value in the joint values
  Transmission harmonic;  // a harmonic stage's (feature -1): its features' source
};
// The stages of a model's joint_errors (none for a link without one). Throws
// InputError for a stage on a prismatic joint or one not linear in its
// parameters (only a Harmonic is).
std::vector<JointErrorStage> joint_error_stages(const DeviceModel& model);
// A pose's values in step 2 from its readings q and approach directions (a log
// row's, dof values, or none): model.compensate(q) with the links' backlash,
// then each joint-error stage's features (JointErrorStage), in stage order.
class StepTwoJoints {
 public:
  explicit StepTwoJoints(const DeviceModel& model);
  ~StepTwoJoints();
  // A tree's pose measures one tip (`tip`, stored last: tip()).
  Eigen::VectorXd operator()(const Eigen::VectorXd& q,
                             const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                             int tip = 0) const;
  // Row r of a log: its readings, approach directions and tip.
  Eigen::VectorXd row(const Log& log, int r) const;
  // The same from given joint values (the readings' q are the couplings'
  // features).
  Eigen::VectorXd with_features(const Eigen::VectorXd& joint, const Eigen::VectorXd& q,
                                const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                                int tip = 0) const;
  // A pose's values whose joint values moved: the features of the joint values
  // formed again (a compliance's torque), the others kept.
  void refresh(Eigen::VectorXd& values) const;
  // Where a pose's values hold its links' lateral bends [rad] (dof values, after
  // the features) when the model has a lateral compliance step 2 holds
  // (DeviceModel::laterally_compliant), formed from the readings' joint values
  // before any deflection (GravityModel::bends); none without one.
  std::optional<int> bends() const { return bends_; }
  // Where a tree's pose's values hold the tip it measures; none: a chain.
  std::optional<int> tip() const { return tip_; }

 private:
  const DeviceModel& model_;
  std::unique_ptr<const PreparedModel> prepared_;
  std::unique_ptr<const GravityModel> gravity_;  // the held lateral compliance's
  std::optional<int> bends_;
  std::optional<int> tip_;
  // Each family's features of a pose and where they start in its values.
  std::vector<std::pair<std::unique_ptr<const PoseFeatures>, int>> features_;
  int stored_ = 0;  // features a pose
};
// Row r of the log's approach directions (dof values), or none.
Eigen::RowVectorXd direction_row(const Log& log, int r);

}  // namespace hapticcal
