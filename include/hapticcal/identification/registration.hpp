// Closed-form registration of two corresponding point sets: the rigid transform
// that maps one onto the other in the least-squares sense. Used to register an
// unknown measurement frame before the iterative fit.
#pragma once

#include <Eigen/Core>

namespace hapticcal {

// b_i ~ R a_i + t, i.e. (R, t) is T_b_a when a and b are the same points in frames a and b.
struct Registration {
  Eigen::Matrix3d R;  // a rotation: orthonormal, det R = +1
  Eigen::Vector3d t;
  // sqrt(sum w_i |R a_i + t - b_i|^2 / sum w_i): the plain RMS when all weights are 1.
  double rms = 0;
};

// The rigid transform minimising sum w_i |R a_i + t - b_i|^2 (Horn 1987, Kabsch 1976): the SVD
// of the weighted cross-covariance of the centred points, with the reflection fixed so that
// det R = +1 (Umeyama 1991, eq. (39)). a and b are 3 x N; weights is empty (all 1) or N
// non-negative numbers, at least 3 of them positive.
// Throws InputError if N < 3, the sizes differ, a value is non-finite, a weight is negative, or
// the points of a (or of b) are (near-)collinear so that the rotation is not determined: the
// second singular value of the centred, weighted points is below 1e-9 of the first.
Registration register_points(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b,
                             const Eigen::VectorXd& weights = {});

}  // namespace hapticcal
