// The linearised two-step identification problem (paper Fig. 6) at given
// readings: what step 2's measurements say about the kinematic parameters, and
// what each step-1 encoder says about its joint's transmission parameters and
// how their errors carry into step 2 through the compensated joint angle. The
// Cramer-Rao bound of a simulation study and the experiment design of `plan`
// are both built from it (information.hpp: two_step_crlb, two_step_covariance).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// A joint's transmission as step 1 fits it (for a polynomial: in its basis).
struct StepOneModel {
  int joint = 0;  // zero-based
  Transmission transmission;
  std::vector<std::string> names;  // dotted, num_parameters() of them
};

struct TwoStepJacobians {
  int dimension = 1;  // rows a pose (traits(type).dimension)
  // d measurement / d kinematic parameter (poses * dimension x slots), pose by
  // pose: rows [r * dimension, (r + 1) * dimension).
  Eigen::MatrixXd kinematic;
  // d measurement / d joint angle theta_j (poses * dimension x dof).
  Eigen::MatrixXd joint;
  // One a step-1 model: encoder rows d (c + error(q_j)) / d [params, c] (poses x
  // np + 1) and measurement rows d measurement / d params = d measurement /
  // d theta_j * d error / d params (poses * dimension x np).
  std::vector<StepOneSensitivity> step_one;
};

// At `readings` (poses x dof, the device's own q), linearised at the predicted
// measurements of `model` (its kinematics and its transmissions compensate the
// readings): the kinematic columns `slots`, and the step-1 sensitivities of
// `step_one`. A pose's rotation rows are scaled by `rotation_scale` [m/rad] as
// the measurement family does.
TwoStepJacobians two_step_jacobians(const DeviceModel& model, MeasurementType type,
                                    double rotation_scale, const std::vector<int>& slots,
                                    const std::vector<StepOneModel>& step_one,
                                    const Eigen::MatrixXd& readings);

// The measured values (traits(type).width a pose) the model predicts at
// `readings` (poses x dof): distance, position, or position and quaternion
// (qw, qx, qy, qz).
MeasuredValues predicted_measurements(const DeviceModel& model, MeasurementType type,
                                      const Eigen::MatrixXd& readings);

}  // namespace hapticcal
