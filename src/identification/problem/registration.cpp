#include "hapticcal/identification/registration.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

#include "hapticcal/core/error.hpp"

namespace hapticcal {
namespace {

// Below this ratio of the second to the first singular value of the centred points, the points
// lie on a line as far as double precision and measurement can tell: the rotation about it is
// not determined.
constexpr double kCollinear = 1e-9;

template <typename Derived>
void check_finite(const Eigen::MatrixBase<Derived>& m, const char* name) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (!std::isfinite(m(i, j))) {
        throw InputError(
            fmt::format("register_points: {}({}, {}) = {} is not finite", name, i, j, m(i, j)));
      }
    }
  }
}

// centred: the points minus their weighted mean, column i scaled by sqrt(w_i).
void check_spread(const Eigen::Matrix3Xd& centred, const char* name) {
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::MatrixXd>(centred).singularValues();
  if (!(s[1] > kCollinear * s[0])) {
    throw InputError(fmt::format(
        "register_points: the points of {} are {}: the rotation is not determined (singular "
        "values of the centred points {:.3g}, {:.3g}, {:.3g})",
        name, s[0] == 0 ? "all at one place" : "(near-)collinear", s[0], s[1], s[2]));
  }
}

}  // namespace

Registration register_points(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b,
                             const Eigen::VectorXd& weights) {
  const Eigen::Index n = a.cols();
  if (b.cols() != n) {
    throw InputError(
        fmt::format("register_points: a has {} points but b has {}", a.cols(), b.cols()));
  }
  if (weights.size() != 0 && weights.size() != n) {
    throw InputError(
        fmt::format("register_points: {} weights for {} points", weights.size(), a.cols()));
  }
  if (n < 3) {
    throw InputError(
        fmt::format("register_points: {} points; a rigid transform needs at least 3", n));
  }
  check_finite(a, "a");
  check_finite(b, "b");
  check_finite(weights, "weights");
  const Eigen::VectorXd w = weights.size() == 0 ? Eigen::VectorXd::Ones(n) : weights;
  Eigen::Index positive = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (w[i] < 0) {
      throw InputError(fmt::format("register_points: weights({}) = {} is negative", i, w[i]));
    }
    positive += w[i] > 0;
  }
  if (positive < 3) {
    throw InputError(fmt::format(
        "register_points: {} points have a positive weight; a rigid transform needs at least 3",
        positive));
  }

  // Weighted means, and the centred points scaled by sqrt(w) so that products of them are the
  // weighted sums of Horn (1987) eqs. (25)-(27).
  const double w_sum = w.sum();
  const Eigen::Vector3d a_mean = a * w / w_sum;
  const Eigen::Vector3d b_mean = b * w / w_sum;
  const Eigen::VectorXd sqrt_w = w.cwiseSqrt();
  const Eigen::Matrix3Xd a_c = (a.colwise() - a_mean) * sqrt_w.asDiagonal();
  const Eigen::Matrix3Xd b_c = (b.colwise() - b_mean) * sqrt_w.asDiagonal();
  if (!std::isfinite(w_sum) || !a_c.allFinite() || !b_c.allFinite()) {
    throw InputError("register_points: coordinates or weights too large to square and sum");
  }
  check_spread(a_c, "a");
  check_spread(b_c, "b");

  // Sigma_ba = sum w_i (b_i - b_mean)(a_i - a_mean)^T = U S V^T; R = U diag(1, 1, det(U V^T)) V^T
  // maximises trace(R^T Sigma_ba) over rotations (Umeyama 1991, eqs. (39)-(40)).
  const Eigen::Matrix3d sigma_ba = b_c * a_c.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma_ba, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  Eigen::Vector3d d(1, 1, 1);
  if (U.determinant() * V.determinant() < 0) d[2] = -1;  // a reflection: flip the weakest axis

  Registration out;
  out.R = U * d.asDiagonal() * V.transpose();
  out.t = b_mean - out.R * a_mean;
  const Eigen::Matrix3Xd residual = (out.R * a).colwise() + out.t - b;
  out.rms = std::sqrt(residual.colwise().squaredNorm().dot(w) / w_sum);
  return out;
}

}  // namespace hapticcal
