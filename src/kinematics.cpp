#include "hapticcal/kinematics.hpp"

namespace hapticcal {

Eigen::Vector3d matrix_rpy(const Eigen::Matrix3d& R) {
  // R = Rz(y) Ry(p) Rx(r): R(2,0) = -sin p, R(2,1) = cos p sin r, R(1,0) = sin y cos p.
  const double pitch = std::atan2(-R(2, 0), std::hypot(R(0, 0), R(1, 0)));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return {roll, pitch, yaw};
}

PreparedModel::PreparedModel(const DeviceModel& model) : structure_(model.structure()) {
  assert(structure_.dof <= kMaxDof);
  const Eigen::VectorXd params = model.kinematic_parameters();
  base_ = base_frame(structure_, params.data());
  tool_ = tool_frame(structure_, params.data());
  for (int i = 0; i < structure_.dof; ++i) {
    links_.push_back(link_constants(structure_.convention, params.data() + structure_.link_slot(i)));
    transmissions_.emplace_back(model.links[i].transmission);
  }
}

void PreparedModel::compensate(const double* q, double* joint) const {
  for (int i = 0; i < structure_.dof; ++i) joint[i] = q[i] + transmissions_[i].error(q[i]);
}

Frame<double> PreparedModel::chain(const double* q, Frame<double>* frames) const {
  Frame<double> F = base_;
  frames[0] = F;
  for (int i = 0; i < structure_.dof; ++i) {
    const LinkConstants<double>& k = links_[i];
    const double theta = q[i] + transmissions_[i].error(q[i]) + k.theta_offset;
    F = compose_link(structure_.convention, F, k, std::cos(theta), std::sin(theta));
    frames[i + 1] = F;
  }
  return F * tool_;
}

Frame<double> PreparedModel::forward(const double* q) const {
  std::array<Frame<double>, kMaxDof + 1> frames;
  return chain(q, frames.data());
}

Frame<double> PreparedModel::forward_jacobian(const double* q, JacobianFrame expressed_in,
                                              Jacobian6<double>& J) const {
  std::array<Frame<double>, kMaxDof + 1> frames;
  const Frame<double> T_meas_tool = chain(q, frames.data());
  geometric_jacobian(structure_, frames.data(), T_meas_tool, expressed_in, J);
  return T_meas_tool;
}

}  // namespace hapticcal
