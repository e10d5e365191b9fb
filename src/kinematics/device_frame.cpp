#include "hapticcal/kinematics/device_frame.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

Frame<double> first_joint_frame(const DeviceModel& model) {
  const ChainStructure s = model.structure();
  const Eigen::VectorXd p = model.kinematic_parameters();
  const Frame<double> base = base_frame(s, p.data());
  if (model.dof() == 0) return base;
  const JointStructure& joint = s.joints[0];
  LinkConstants<double> k = link_constants(joint, p.data() + s.link_slot(0));
  if (joint.geometry == Geometry::kDh) {  // Rz(theta) Tz(d) only: a, alpha, beta follow the motion
    k.a = 0;
    k.cos_alpha = k.cos_beta = 1;
    k.sin_alpha = k.sin_beta = 0;
  }
  Frame<double> frame;
  compose_joint(joint, base, k, 0.0, frame);
  return frame;
}

DeviceFrameSplit split_device_frame(const DeviceModel& calibrated, const DeviceModel& nominal,
                                    const std::optional<std::array<double, 6>>& tool) {
  if (calibrated.tree() || nominal.tree())
    throw std::invalid_argument(
        "a tree's device frame: every root link would need its own placement");
  if (calibrated.dof() != nominal.dof() || calibrated.base_kind != nominal.base_kind)
    throw std::invalid_argument("the calibrated and the nominal model differ in structure");
  for (int i = 0; i < calibrated.dof(); ++i) {
    if (calibrated.links[i].geometry != nominal.links[i].geometry ||
        calibrated.links[i].type != nominal.links[i].type)
      throw std::invalid_argument("the calibrated and the nominal model differ in structure");
  }
  DeviceFrameSplit split;
  split.measured_tool = calibrated.tool;
  split.device = calibrated;
  DeviceModel& device = split.device;
  device.base = nominal.base;
  if (device.dof() > 0) {
    Link& first = device.links[0];
    const Link& given = nominal.links[0];
    first.theta = given.theta;
    first.d = given.d;
    if (first.geometry == Geometry::kMdh) {
      first.alpha = given.alpha;
      first.a = given.a;
      first.beta = given.beta;
    } else if (first.geometry == Geometry::kOrigin) {
      first.origin = given.origin;
      first.offset = given.offset;
    }
  }
  if (tool) device.tool = *tool;
  const Frame<double> anchor_calibrated = first_joint_frame(calibrated);
  const Frame<double> anchor_device = first_joint_frame(device);
  split.device_in_measurement = anchor_calibrated * anchor_device.inverse();
  // Gravity is given in frame 0 (after the base): the device's frame 0 lies at
  // D B_device in the measurement frame, the calibrated model's at B_calibrated.
  const ChainStructure s = calibrated.structure();
  const Frame<double> base_calibrated = base_frame(s, calibrated.kinematic_parameters().data());
  const Frame<double> base_device = base_frame(s, device.kinematic_parameters().data());
  device.gravity = (split.device_in_measurement.R * base_device.R).transpose() *
                   (base_calibrated.R * calibrated.gravity);
  return split;
}

namespace {

Frame<double> turn_about(const Eigen::Vector3d& axis, double angle) {
  return {Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(), Eigen::Vector3d::Zero()};
}

std::array<double, 6> pose_array(const Frame<double>& f) {
  const Eigen::Vector3d rpy = matrix_rpy(f.R);
  return {f.p.x(), f.p.y(), f.p.z(), rpy[0], rpy[1], rpy[2]};
}

}  // namespace

double move_last_turn_into_tool(DeviceModel& calibrated, const DeviceModel& nominal) {
  if (calibrated.tree() || calibrated.dof() == 0 || calibrated.dof() != nominal.dof()) return 0;
  Link& last = calibrated.links.back();
  const Link& given = nominal.links.back();
  if (last.prismatic() || last.geometry != given.geometry) return 0;
  double turn = 0;
  Frame<double> after = Frame<double>::Identity();  // X: the joint's transform after its motion
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  if (last.geometry == Geometry::kOrigin) {
    axis = last.axis.normalized();
    // The twist about the axis of R_nominal^-1 R_calibrated (offsets included).
    const Eigen::Matrix3d relative =
        (pose_frame(given.origin) * turn_about(axis, given.offset)).R.transpose() *
        (pose_frame(last.origin) * turn_about(axis, last.offset)).R;
    const Eigen::Quaterniond q(relative);
    turn = 2 * std::atan2(q.vec().dot(axis), q.w());
    last.origin =
        pose_array(pose_frame(last.origin) * turn_about(axis, last.offset - given.offset - turn));
    last.offset = given.offset;
  } else {
    turn = last.theta - given.theta;
    last.theta = given.theta;
    if (last.geometry == Geometry::kDh) {
      after = Frame<double>{Eigen::Matrix3d::Identity(), Eigen::Vector3d(last.a, 0, 0)} *
              turn_about(Eigen::Vector3d::UnitX(), last.alpha) *
              turn_about(Eigen::Vector3d::UnitY(), last.beta);
    }
  }
  if (turn == 0) return 0;
  calibrated.tool =
      pose_array(after.inverse() * turn_about(axis, turn) * after * pose_frame(calibrated.tool));
  return turn;
}

}  // namespace hapticcal
