#include "hapticcal/identification/information.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace hapticcal {

Eigen::MatrixXd fisher_information(const Eigen::MatrixXd& J, double sigma) {
  return J.transpose() * J / (sigma * sigma);
}

Eigen::MatrixXd parameter_covariance(const Eigen::MatrixXd& J, double sigma) {
  const Eigen::Index k = J.cols();
  if (k == 0) return Eigen::MatrixXd(0, 0);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> normal(J.transpose() * J);
  Eigen::VectorXd inverse = normal.eigenvalues();
  for (Eigen::Index c = 0; c < k; ++c) inverse[c] = inverse[c] > 0 ? 1 / inverse[c] : INFINITY;
  return sigma * sigma * normal.eigenvectors() * inverse.asDiagonal() *
         normal.eigenvectors().transpose();
}

Conditioning conditioning(const Eigen::MatrixXd& J, double measurements) {
  Conditioning out;
  const Eigen::Index k = J.cols();
  if (k == 0) return out;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> normal(J.transpose() * J, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd s = normal.eigenvalues().cwiseMax(0).cwiseSqrt().reverse();  // descending
  out.condition_number = s[k - 1] > 0 ? s[0] / s[k - 1] : INFINITY;
  double log_sum = 0;
  for (Eigen::Index c = 0; c < k; ++c) log_sum += std::log(s[c]);
  out.observability = {std::exp(log_sum / static_cast<double>(k)) / std::sqrt(measurements),
                       s[k - 1] / s[0], s[k - 1], s[k - 1] * s[k - 1] / s[0]};
  return out;
}

TwoStepBound two_step_crlb(const Eigen::MatrixXd& Jk,
                           const std::vector<std::string>& kinematic_names, double sigma_m,
                           const std::vector<StepOneSensitivity>& step_one, double sigma_e) {
  TwoStepBound out;
  const Eigen::Index k = Jk.cols();
  const Eigen::MatrixXd Nk_inverse =
      (Jk.transpose() * Jk).ldlt().solve(Eigen::MatrixXd::Identity(k, k));
  Eigen::MatrixXd kinematic = sigma_m * sigma_m * Nk_inverse;
  std::vector<double> variance;
  for (const StepOneSensitivity& t : step_one) {
    const Eigen::Index np = t.encoder.cols() - 1;
    const Eigen::MatrixXd step1 =
        sigma_e * sigma_e *
        (t.encoder.transpose() * t.encoder).ldlt().solve(Eigen::MatrixXd::Identity(np + 1, np + 1));
    for (Eigen::Index c = 0; c < np; ++c) {
      out.names.push_back(t.names[c]);
      variance.push_back(step1(c, c));
    }
    const Eigen::MatrixXd G = -Nk_inverse * (Jk.transpose() * t.measurement);
    kinematic += G * step1.topLeftCorner(np, np) * G.transpose();
  }
  for (Eigen::Index c = 0; c < k; ++c) {
    out.names.push_back(kinematic_names[c]);
    variance.push_back(kinematic(c, c));
  }
  out.variance =
      Eigen::Map<Eigen::VectorXd>(variance.data(), static_cast<Eigen::Index>(variance.size()));
  return out;
}

}  // namespace hapticcal
