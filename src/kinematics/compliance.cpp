// Joint compliance (issue 25, item 2a): gravity torques from the links' masses
// and the deflection k tau they cause, in the one place readings become joint
// values (DeviceModel::compensate is defined here, beside the kinematics its
// compliance needs).
#include <array>
#include <cassert>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

void gravity_torques(const ChainStructure& s, const Frame<double>* frames, const double* mass,
                     const Eigen::Vector3d* com, const Eigen::Vector3d& gravity, double* tau) {
  const Eigen::Vector3d g = frames[0].R * gravity;  // in the measurement frame
  double M = 0;                                     // mass of links i..n
  Eigen::Vector3d S = Eigen::Vector3d::Zero();      // their first moment
  for (int i = s.dof - 1; i >= 0; --i) {
    M += mass[i];
    S += mass[i] * (frames[i + 1].R * com[i] + frames[i + 1].p);
    Vec3<double> axis, point;
    joint_axis(s, frames, i, axis, point);
    tau[i] = s.joints[i].prismatic() ? M * axis.dot(g) : axis.dot((S - M * point).cross(g));
  }
}

GravityModel::GravityModel(const DeviceModel& model) : structure(model.structure()) {
  const Eigen::VectorXd p = model.kinematic_parameters();
  constants = chain_constants(structure, p.data());
  gravity = model.gravity;
  for (int i = 0; i < model.dof(); ++i) {
    mass[i] = model.links[i].mass;
    com[i] = model.links[i].com;
    compliance[i] = model.compliance_fitted(i) ? 0.0 : model.links[i].compliance;
  }
}

void GravityModel::torques(const double* joint, double* tau) const {
  std::array<Frame<double>, kMaxDof + 1> frames;
  forward_kinematics(structure, constants, joint, frames.data());
  gravity_torques(structure, frames.data(), mass.data(), com.data(), gravity, tau);
}

void GravityModel::deflect(double* joint) const {
  std::array<double, kMaxDof> tau;
  torques(joint, tau.data());
  for (int i = 0; i < structure.dof; ++i) joint[i] += compliance[i] * tau[i];
}

Eigen::VectorXd DeviceModel::compensate(const Eigen::VectorXd& q) const {
  assert(q.size() == dof());
  Eigen::VectorXd joint(dof());
  for (int i = 0; i < dof(); ++i) joint[i] = q[i] + links[i].transmission.error(q[i]);
  if (coupled()) joint = coupling * joint;
  if (compliant()) GravityModel(*this).deflect(joint.data());
  return joint;
}

Eigen::MatrixXd DeviceModel::reading_jacobian(const Eigen::VectorXd& q) const {
  assert(q.size() == dof());
  if (compliant()) {  // the deflection's slope by central differences
    const double h = 1e-6;
    Eigen::MatrixXd D(dof(), dof());
    for (int k = 0; k < dof(); ++k) {
      Eigen::VectorXd plus = q, minus = q;
      plus[k] += h;
      minus[k] -= h;
      D.col(k) = (compensate(plus) - compensate(minus)) / (2 * h);
    }
    return D;
  }
  Eigen::VectorXd slope(dof());
  for (int k = 0; k < dof(); ++k) slope[k] = 1 + links[k].transmission.derivative(q[k]);
  if (coupled()) return coupling * slope.asDiagonal();
  return slope.asDiagonal();
}

}  // namespace hapticcal
