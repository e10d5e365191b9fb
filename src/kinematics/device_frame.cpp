#include "hapticcal/kinematics/device_frame.hpp"

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

}  // namespace hapticcal
