#include "hapticcal/identification/measurement.hpp"

#include <Eigen/Geometry>
#include <numeric>

namespace hapticcal {

const MeasurementTraits& traits(MeasurementType type) {
  static const MeasurementTraits table[] = {
      {"distance", "distances", 1, 1}, {"position", "positions", 3, 3}, {"pose", "poses", 6, 7}};
  return table[static_cast<int>(type)];
}

MeasurementType measurement_type(const Log& log) {
  if (log.has_orientation) return MeasurementType::kPose;
  return log.has_position ? MeasurementType::kPosition : MeasurementType::kDistance;
}

void measured_values(MeasurementType type, const Log& log, int row, double* out) {
  switch (type) {
    case MeasurementType::kDistance:
      out[0] = log.distance[row];
      return;
    case MeasurementType::kPose:
      for (int k = 0; k < 4; ++k) out[3 + k] = log.orientation(row, k);
      [[fallthrough]];
    case MeasurementType::kPosition:
      for (int k = 0; k < 3; ++k) out[k] = log.position(row, k);
      return;
  }
}

std::vector<MeasurementGroup> measurement_groups(const Log& log) {
  MeasurementGroup group;
  group.type = measurement_type(log);
  group.rows.resize(log.rows);
  std::iota(group.rows.begin(), group.rows.end(), 0);
  return {group};
}

Eigen::Matrix3d inverse_left_jacobian(const Eigen::Vector3d& phi) {
  const double a = phi.norm();
  Eigen::Matrix3d W;
  W << 0, -phi[2], phi[1], phi[2], 0, -phi[0], -phi[1], phi[0], 0;
  // J_l^-1 = I - W / 2 + (1 / a^2 - (1 + cos a) / (2 a sin a)) W^2 (Barfoot,
  // State Estimation for Robotics, eq. 7.64); the series 1/12 + a^2/720 near 0.
  const double c =
      a < 1e-4 ? 1.0 / 12 + a * a / 720 : 1 / (a * a) - (1 + std::cos(a)) / (2 * a * std::sin(a));
  return Eigen::Matrix3d::Identity() - W / 2 + c * W * W;
}

void measurement_rows(MeasurementType type, const ChainStructure& s,
                      const ChainConstants<double>& constants, const double* params,
                      const double* joint, const double* measured, double rotation_scale,
                      double* residual, Eigen::Ref<Eigen::MatrixXd> J) {
  if (type == MeasurementType::kPose) {
    Eigen::Matrix<double, 6, Eigen::Dynamic> J6;
    const Frame<double> tool = pose_parameter_jacobian<6>(s, constants, params, joint, J6);
    measurement_residual(type, tool, measured, rotation_scale, residual);
    const Eigen::Vector3d phi = Eigen::Map<Eigen::Vector3d>(residual + 3) / rotation_scale;
    J.topRows(3) = J6.topRows(3);
    // R -> exp(w) R turns log(R Rm^T) by J_l^-1(phi) w.
    J.bottomRows(3) = rotation_scale * inverse_left_jacobian(phi) * J6.bottomRows(3);
    return;
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> J_p;
  const Eigen::Vector3d p = position_parameter_jacobian(s, constants, params, joint, J_p);
  if (type == MeasurementType::kPosition) {
    for (int k = 0; k < 3; ++k) residual[k] = p[k] - measured[k];
    J = J_p;
  } else {
    const double delta = p.norm();
    residual[0] = delta - measured[0];
    J = (p / delta).transpose() * J_p;
  }
}

}  // namespace hapticcal
