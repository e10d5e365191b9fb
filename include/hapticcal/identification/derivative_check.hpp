// Numerical derivative checks, public so that a user adding a transmission model
// or a kinematic variant can test its analytic derivatives as the tests do.
#pragma once

#include <Eigen/Core>
#include <string>

#include "hapticcal/model/model.hpp"
#include "hapticcal/model/transmission.hpp"

namespace hapticcal {

// Central differences of f: R^n -> R^m at x, one column per variable:
// (f(x + h_k e_k) - f(x - h_k e_k)) / (2 h_k).
template <typename F>
Eigen::MatrixXd central_difference(F&& f, const Eigen::VectorXd& x, const Eigen::VectorXd& steps) {
  Eigen::MatrixXd J;
  for (int k = 0; k < x.size(); ++k) {
    Eigen::VectorXd plus = x, minus = x;
    plus[k] += steps[k];
    minus[k] -= steps[k];
    const Eigen::VectorXd d = (f(plus) - f(minus)) / (2 * steps[k]);
    if (k == 0) J.resize(d.size(), x.size());
    J.col(k) = d;
  }
  return J;
}

// The largest disagreement between an analytic derivative and central
// differences, and where it is ("" or a parameter name).
struct DerivativeCheck {
  double max_error = 0;  // absolute, or relative to 1 + |numeric| where stated
  std::string worst;
};

// d error / dq at q (step in rad); error relative to 1 + |numeric|.
DerivativeCheck check_reading_derivative(const Transmission& t, double q, double step = 1e-6);
// d error / d parameters at q; step relative to max(|p_k|, 1e-3); error relative
// to 1 + |numeric|.
DerivativeCheck check_parameter_jacobian(const Transmission& t, double q,
                                         double relative_step = 1e-6);
// A given d (p, w) / d params (6 x num_slots: tool position, then the tool's
// small rotation w in the measurement frame, R(params + dp) ~ (I + [w]x) R)
// against central differences of forward_kinematics at the joint angles `joint`
// (q + dtheta(q)); w's differences are those of log(R(params +- h) R(params)^T).
// Absolute; a rotation row's slot is named with " (rotation)" appended.
DerivativeCheck check_pose_parameter_jacobian(
    const DeviceModel& model, const Eigen::VectorXd& joint,
    const Eigen::Matrix<double, 6, Eigen::Dynamic>& J_pose_params, double step = 1e-6);
// The analytic d (p, w) / d params (pose_parameter_jacobian<6>), d p / d params
// (<3>, " (3 rows)") and d |p| / d params (paper eq. 5, " (distance)") of every
// meaningful kinematic parameter at the joint angles `joint`; absolute.
DerivativeCheck check_kinematic_derivatives(const DeviceModel& model, const Eigen::VectorXd& joint,
                                            double step = 1e-6);

}  // namespace hapticcal
