// Where a device's readings become its joint values: DeviceModel::compensate
// (the transmissions, the joint effects, the coupling, then the compliance's
// deflection) and its slope, DeviceModel::reading_jacobian.
#include <cassert>

#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/joint_effect.hpp"

namespace hapticcal {

Eigen::VectorXd DeviceModel::compensate(const Eigen::VectorXd& q) const {
  assert(q.size() == dof());
  Eigen::VectorXd joint(dof());
  for (int i = 0; i < dof(); ++i)
    joint[i] = q[i] + links[i].transmission.error(q[i]) + effects_error(links[i], q[i]);
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
  for (int k = 0; k < dof(); ++k)
    slope[k] = 1 + links[k].transmission.derivative(q[k]) + effects_slope(links[k], q[k]);
  if (coupled()) return coupling * slope.asDiagonal();
  return slope.asDiagonal();
}

}  // namespace hapticcal
