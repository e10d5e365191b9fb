#include "hapticcal/identification/derivative_check.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

DerivativeCheck check_reading_derivative(const Transmission& t, double q, double step) {
  const double numeric = (t.error(q + step) - t.error(q - step)) / (2 * step);
  return {std::abs(t.derivative(q) - numeric) / (1 + std::abs(numeric)), ""};
}

DerivativeCheck check_parameter_jacobian(const Transmission& t, double q, double relative_step) {
  const Eigen::VectorXd p0 = t.parameters();
  Eigen::VectorXd analytic(p0.size());
  t.parameter_jacobian(q, analytic.data());
  Eigen::VectorXd steps(p0.size());
  for (int k = 0; k < p0.size(); ++k) steps[k] = relative_step * std::max(std::abs(p0[k]), 1e-3);
  Transmission work = t;
  const Eigen::MatrixXd numeric = central_difference(
      [&](const Eigen::VectorXd& p) {
        work.set_parameters(p.data());
        return Eigen::VectorXd::Constant(1, work.error(q));
      },
      p0, steps);
  DerivativeCheck result;
  const std::vector<std::string> names = t.parameter_names();
  for (int k = 0; k < p0.size(); ++k) {
    const double e = std::abs(analytic[k] - numeric(0, k)) / (1 + std::abs(numeric(0, k)));
    if (e > result.max_error) result = {e, names[k]};
  }
  return result;
}

namespace {

// The rotation vector w of R: R = exp([w]x), |w| <= pi.
Eigen::Vector3d rotation_log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// Central differences, 7 x num_slots: the tool position (rows 0-2), the rotation
// log of R(params) R(params0)^T (rows 3-5) and the distance |p| (row 6).
Eigen::MatrixXd numeric_pose_derivatives(const DeviceModel& model, const Eigen::VectorXd& joint,
                                         double step) {
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const Eigen::Matrix3d R0 = forward_kinematics(s, params.data(), joint.data()).R;
  return central_difference(
      [&](const Eigen::VectorXd& p) {
        const Frame<double> T = forward_kinematics(s, p.data(), joint.data());
        Eigen::Matrix<double, 7, 1> out;
        out << T.p, rotation_log(T.R * R0.transpose()), T.p.norm();
        return out;
      },
      params, Eigen::VectorXd::Constant(params.size(), step));
}

// The largest |analytic - numeric| over the rows of every meaningful slot, the
// slot named with `what` appended; columns of slots without meaning must be zero.
DerivativeCheck compare(const DeviceModel& model, const Eigen::MatrixXd& analytic,
                        const Eigen::MatrixXd& numeric, const std::string& what) {
  DerivativeCheck result;
  std::vector<bool> meaningful(analytic.cols(), false);
  for (const ParameterInfo& info : model.parameter_info()) {
    meaningful[info.slot] = true;
    const double e = (analytic.col(info.slot) - numeric.col(info.slot)).cwiseAbs().maxCoeff();
    if (e > result.max_error) result = {e, info.name + what};
  }
  for (int k = 0; k < analytic.cols(); ++k) {
    if (!meaningful[k] && analytic.col(k).norm() > result.max_error) {
      result = {analytic.col(k).norm(), "slot " + std::to_string(k) + what};
    }
  }
  return result;
}

DerivativeCheck worse(const DerivativeCheck& a, const DerivativeCheck& b) {
  return b.max_error > a.max_error ? b : a;
}

DerivativeCheck compare_pose(const DeviceModel& model,
                             const Eigen::Matrix<double, 6, Eigen::Dynamic>& J_pose_params,
                             const Eigen::MatrixXd& numeric) {
  return worse(
      compare(model, J_pose_params.topRows<3>(), numeric.topRows(3), ""),
      compare(model, J_pose_params.bottomRows<3>(), numeric.middleRows(3, 3), " (rotation)"));
}

}  // namespace

DerivativeCheck check_pose_parameter_jacobian(
    const DeviceModel& model, const Eigen::VectorXd& joint,
    const Eigen::Matrix<double, 6, Eigen::Dynamic>& J_pose_params, double step) {
  return compare_pose(model, J_pose_params, numeric_pose_derivatives(model, joint, step));
}

DerivativeCheck check_kinematic_derivatives(const DeviceModel& model, const Eigen::VectorXd& joint,
                                            double step) {
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  Eigen::Matrix<double, 6, Eigen::Dynamic> J_pose_params;
  Eigen::Matrix<double, 3, Eigen::Dynamic> J_p_params;
  Eigen::Matrix<double, 1, Eigen::Dynamic> J_delta_params;
  pose_parameter_jacobian<6>(s, chain_constants(s, params.data()), params.data(), joint.data(),
                             J_pose_params);
  position_parameter_jacobian(s, params.data(), joint.data(), J_p_params);
  distance_parameter_jacobian(s, params.data(), joint.data(), J_delta_params);
  const Eigen::MatrixXd numeric = numeric_pose_derivatives(model, joint, step);
  return worse(worse(compare_pose(model, J_pose_params, numeric),
                     compare(model, J_p_params, numeric.topRows(3), " (3 rows)")),
               compare(model, J_delta_params, numeric.bottomRows(1), " (distance)"));
}

}  // namespace hapticcal
