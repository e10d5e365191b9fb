// Internal: the step-1 capstan cost (paper eq. (1)) with its analytic Jacobian,
// in a header so that tests can check the Jacobian against central differences.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <cmath>

#include "hapticcal/model/transmission.hpp"

namespace hapticcal::detail {

// ext - q = c + capstan_error(q; p): residuals and analytic Jacobian over all
// samples, parameters [Re, ro, bo, ri, bi, c].
class CapstanCost : public ceres::CostFunction {
 public:
  CapstanCost(const Capstan& constants, const Eigen::VectorXd& q, const Eigen::VectorXd& target)
      : constants_(constants), q_(q), target_(target) {
    set_num_residuals(static_cast<int>(q.size()));
    mutable_parameter_block_sizes()->push_back(6);
  }

  // Eq. (1) and its analytic derivatives (as Transmission::error and
  // parameter_jacobian) with the home terms computed once per call and one
  // sincos per drum per sample.
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* p = parameters[0];
    const double Re = p[0], ro = p[1], bo = p[2], ri = p[3], bi = p[4], c = p[5];
    const double R = constants_.ratio, D = constants_.drum_distance;
    const double slope = -Re / (Re + R), dslope = -R / ((Re + R) * (Re + R));
    Drum out0 = drum(ro, bo, D), in0 = drum(ri, bi, D);
    for (int i = 0; i < q_.size(); ++i) {
      const Drum out = drum(ro, q_[i] + bo, D), in = drum(ri, R * q_[i] + bi, D);
      residuals[i] = c + slope * q_[i] + (out.g - out0.g) + (in.g - in0.g) - target_[i];
      if (jacobians && jacobians[0]) {
        double* row = jacobians[0] + 6 * i;
        row[0] = dslope * q_[i];
        row[1] = out.dr - out0.dr;
        row[2] = out.du - out0.du;
        row[3] = in.dr - in0.dr;
        row[4] = in.du - in0.du;
        row[5] = 1.0;
      }
    }
    return true;
  }

  // g(u) = atan2(r sin u, D - r cos u) and its partial derivatives.
  struct Drum {
    double g, dr, du;
  };
  static Drum drum(double r, double u, double D) {
    double su, cu;
    ::sincos(u, &su, &cu);
    const double x = D - r * cu, y = r * su, den = x * x + y * y;
    return {std::atan2(y, x), D * su / den, (r * D * cu - r * r) / den};
  }

 private:
  Capstan constants_;
  Eigen::VectorXd q_, target_;
};

}  // namespace hapticcal::detail
