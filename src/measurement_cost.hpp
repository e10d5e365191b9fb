// Internal: the step-2 measurement cost (predicted - measured distance or
// position) with its analytic Jacobian, in a header so that tests can check the
// Jacobian against central differences.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "hapticcal/identification.hpp"
#include "hapticcal/kinematics.hpp"

namespace hapticcal::detail {

// Measured values, one row per sample (1 distance or 3 coordinates), contiguous.
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

inline int residuals_per_row(MeasurementKind kind) {
  return kind == MeasurementKind::kPosition ? 3 : 1;
}

// Rows: predicted - measured; J: d residuals / d params (all slots).
inline void measurement_rows(const ChainStructure& s, const ChainConstants<double>& constants,
                             const double* params, const double* joint, MeasurementKind kind,
                             const double* measured, double* residual,
                             Eigen::Ref<Eigen::MatrixXd> J) {
  Eigen::Matrix<double, 3, Eigen::Dynamic> J_p_params;
  const Eigen::Vector3d p = position_parameter_jacobian(s, constants, params, joint, J_p_params);
  if (kind == MeasurementKind::kPosition) {
    for (int k = 0; k < 3; ++k) residual[k] = p[k] - measured[k];
    J = J_p_params;
  } else {
    const double delta = p.norm();
    residual[0] = delta - measured[0];
    J = (p / delta).transpose() * J_p_params;
  }
}

// Ceres cost over a set of poses: residuals_per_row(kind) rows per pose,
// parameters all slots of `s`.
class MeasurementCost : public ceres::CostFunction {
 public:
  MeasurementCost(ChainStructure s, std::vector<Eigen::VectorXd> joints, MeasurementKind kind,
                  RowMatrix measured)
      : s_(s), joints_(std::move(joints)), kind_(kind), measured_(std::move(measured)) {
    set_num_residuals(static_cast<int>(joints_.size()) * residuals_per_row(kind));
    mutable_parameter_block_sizes()->push_back(s.num_slots());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int d = residuals_per_row(kind_);
    const int n = s_.num_slots();
    Eigen::MatrixXd J(d, n);
    const ChainConstants<double> constants = chain_constants(s_, parameters[0]);
    for (size_t i = 0; i < joints_.size(); ++i) {
      measurement_rows(s_, constants, parameters[0], joints_[i].data(), kind_,
                       measured_.row(i).data(), residuals + d * i, J);
      if (jacobians && jacobians[0]) {
        Eigen::Map<RowMatrix>(jacobians[0] + static_cast<size_t>(d) * i * n, d, n) = J;
      }
    }
    return true;
  }

 private:
  ChainStructure s_;
  std::vector<Eigen::VectorXd> joints_;
  MeasurementKind kind_;
  RowMatrix measured_;
};

}  // namespace hapticcal::detail
