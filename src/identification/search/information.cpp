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

Eigen::MatrixXd two_step_covariance(const Eigen::MatrixXd& Jk, double sigma_m,
                                    const std::vector<StepOneSensitivity>& step_one,
                                    double sigma_e) {
  const Eigen::Index k = Jk.cols();
  Eigen::Index t = 0;
  for (const StepOneSensitivity& s : step_one) t += s.encoder.cols() - 1;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(t + k, t + k);
  const Eigen::MatrixXd Nk_inverse =
      (Jk.transpose() * Jk).ldlt().solve(Eigen::MatrixXd::Identity(k, k));
  C.bottomRightCorner(k, k) = sigma_m * sigma_m * Nk_inverse;
  Eigen::Index at = 0;
  for (const StepOneSensitivity& s : step_one) {
    const Eigen::Index np = s.encoder.cols() - 1;
    const Eigen::MatrixXd step1 =
        sigma_e * sigma_e *
        (s.encoder.transpose() * s.encoder).ldlt().solve(Eigen::MatrixXd::Identity(np + 1, np + 1));
    const Eigen::MatrixXd C1 = step1.topLeftCorner(np, np);
    const Eigen::MatrixXd G = -Nk_inverse * (Jk.transpose() * s.measurement);
    C.block(at, at, np, np) = C1;
    const Eigen::MatrixXd GC1 = G * C1;
    C.block(t, at, k, np) = GC1;
    C.block(at, t, np, k) = GC1.transpose();
    C.bottomRightCorner(k, k) += GC1 * G.transpose();
    at += np;
  }
  return C;
}

TwoStepBound two_step_crlb(const Eigen::MatrixXd& Jk,
                           const std::vector<std::string>& kinematic_names, double sigma_m,
                           const std::vector<StepOneSensitivity>& step_one, double sigma_e) {
  TwoStepBound out;
  for (const StepOneSensitivity& t : step_one) {
    const size_t np = t.encoder.cols() - 1;
    out.names.insert(out.names.end(), t.names.begin(), t.names.begin() + np);
  }
  out.names.insert(out.names.end(), kinematic_names.begin(), kinematic_names.end());
  out.variance = two_step_covariance(Jk, sigma_m, step_one, sigma_e).diagonal();
  return out;
}

}  // namespace hapticcal
