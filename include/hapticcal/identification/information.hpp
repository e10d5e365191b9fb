// What a set of measurements says about the parameters: the
// Fisher information, the covariance of the least-squares estimate, the
// conditioning and observability indices of the identification Jacobian, and
// the Cramer-Rao bound of the two-step procedure (paper Fig. 6), in which the
// step-1 transmission estimates carry into step 2 through the compensated
// joint angles.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace hapticcal {

// Borm & Menq's O1 = (s_1 ... s_L)^(1/L) / sqrt(m), O2 = s_L / s_1 (inverse
// condition number), O3 = s_L, and Nahvi & Hollerbach's noise amplification
// index O4 = s_L^2 / s_1, of the scaled identification Jacobian.
struct ObservabilityIndices {
  double O1 = 0, O2 = 0, O3 = 0, O4 = 0;
};

// J^T J / sigma^2 of a Jacobian whose rows have noise sd sigma.
Eigen::MatrixXd fisher_information(const Eigen::MatrixXd& J, double sigma);

// sigma^2 (J^T J)^-1 through the eigen-decomposition of J^T J: a direction the
// rows do not see has infinite variance (not a huge finite one).
Eigen::MatrixXd parameter_covariance(const Eigen::MatrixXd& J, double sigma);

struct Conditioning {
  double condition_number = 0;  // s_1 / s_L
  ObservabilityIndices observability;
};
// Of a (column-scaled) Jacobian with `measurements` residual rows behind it (for
// O1; J may be a compressed R factor with the same column geometry).
Conditioning conditioning(const Eigen::MatrixXd& J, double measurements);

// Step 1 of one joint, for the two-step bound: the sensitivity of the external
// encoder's reading to the transmission parameters and the constant c
// (m x (np + 1), the last column c's), and that of step 2's measurements to
// the transmission parameters through the joint angle (m x np).
struct StepOneSensitivity {
  std::vector<std::string> names;  // np transmission parameter names
  Eigen::MatrixXd encoder;         // d (c + error(q)) / d [params, c]
  Eigen::MatrixXd measurement;     // d measurement / d params
};

struct TwoStepBound {
  std::vector<std::string> names;  // step-1 names, then the kinematic ones
  Eigen::VectorXd variance;        // in that order
};

// Cramer-Rao variances of the two-step estimate: each step-1 fit from its
// encoder (information J_e^T J_e / sigma_e^2), the kinematic parameters from the
// measurements (J_k^T J_k / sigma_m^2) plus the step-1 uncertainty carried in,
// G C_1 G^T with G = -(J_k^T J_k)^-1 J_k^T J_t.
TwoStepBound two_step_crlb(const Eigen::MatrixXd& J_kinematic,
                           const std::vector<std::string>& kinematic_names,
                           double sigma_measurement,
                           const std::vector<StepOneSensitivity>& step_one, double sigma_encoder);

// The full covariance behind two_step_crlb, in the order of its names (each
// joint's step-1 parameters with c marginalised, then the kinematic ones):
//   C_1j = sigma_e^2 (J_ej^T J_ej)^-1 (its parameter block; joints independent),
//   C_k  = sigma_m^2 (J_k^T J_k)^-1 + sum_j G_j C_1j G_j^T,  Cov(k, t_j) = G_j C_1j,
// so that the variance of any prediction g^T [t; k] of the calibrated model is
// g^T C g.
Eigen::MatrixXd two_step_covariance(const Eigen::MatrixXd& J_kinematic, double sigma_measurement,
                                    const std::vector<StepOneSensitivity>& step_one,
                                    double sigma_encoder);

}  // namespace hapticcal
