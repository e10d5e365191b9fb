#include "hapticcal/derivative_check.hpp"

#include <cmath>

#include "hapticcal/kinematics.hpp"

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

DerivativeCheck check_kinematic_derivatives(const DeviceModel& model, const Eigen::VectorXd& joint,
                                            double step) {
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  Eigen::Matrix<double, 3, Eigen::Dynamic> J_p_params;
  Eigen::Matrix<double, 1, Eigen::Dynamic> J_delta_params;
  position_parameter_jacobian(s, params.data(), joint.data(), J_p_params);
  distance_parameter_jacobian(s, params.data(), joint.data(), J_delta_params);
  const Eigen::MatrixXd numeric = central_difference(
      [&](const Eigen::VectorXd& p) {
        const Eigen::Vector3d tool = forward_kinematics(s, p.data(), joint.data()).p;
        return Eigen::Vector4d(tool[0], tool[1], tool[2], tool.norm()).eval();
      },
      params, Eigen::VectorXd::Constant(params.size(), step));
  DerivativeCheck result;
  std::vector<bool> meaningful(s.num_slots(), false);
  for (const ParameterInfo& info : model.parameter_info()) {
    meaningful[info.slot] = true;
    const double e = std::max(
        (J_p_params.col(info.slot) - numeric.col(info.slot).head<3>()).cwiseAbs().maxCoeff(),
        std::abs(J_delta_params[info.slot] - numeric(3, info.slot)));
    if (e > result.max_error) result = {e, info.name};
  }
  for (int k = 0; k < s.num_slots(); ++k) {  // slots without meaning must stay out
    if (!meaningful[k] && J_p_params.col(k).norm() > result.max_error) {
      result = {J_p_params.col(k).norm(), "slot " + std::to_string(k)};
    }
  }
  return result;
}

}  // namespace hapticcal
