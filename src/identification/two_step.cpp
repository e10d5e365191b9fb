#include "hapticcal/identification/two_step.hpp"

#include <Eigen/Geometry>
#include <optional>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

MeasuredValues predicted_measurements(const DeviceModel& model, MeasurementType type,
                                      const Eigen::MatrixXd& readings) {
  const PreparedModel prepared(model);
  MeasuredValues out(readings.rows(), traits(type).width);
  Eigen::VectorXd q(model.dof());
  for (Eigen::Index r = 0; r < readings.rows(); ++r) {
    q = readings.row(r).transpose();
    predicted_values(type, prepared.forward(q.data()), out.row(r).data());
  }
  return out;
}

TwoStepJacobians two_step_jacobians(const DeviceModel& model, MeasurementType type,
                                    double rotation_scale, const std::vector<int>& slots,
                                    const std::vector<StepOneModel>& step_one,
                                    const Eigen::MatrixXd& readings) {
  const ChainStructure s = model.structure();
  const Eigen::VectorXd p = model.kinematic_parameters();
  const ChainConstants<double> constants = chain_constants(s, p.data());
  const PreparedModel prepared(model);
  const int n = model.dof();
  const int d = traits(type).dimension;
  const Eigen::Index m = readings.rows();
  const int k = static_cast<int>(slots.size());
  TwoStepJacobians out;
  out.dimension = d;
  out.kinematic.resize(m * d, k);
  out.joint.resize(m * d, n);
  Eigen::VectorXd q(n), joint(n);
  Eigen::MatrixXd J_all(d, s.num_slots());
  Jacobian6<double> Jg;
  double measured[7], residual[6];
  for (Eigen::Index r = 0; r < m; ++r) {
    q = readings.row(r).transpose();
    prepared.compensate(q.data(), joint.data());
    const Frame<double> tool = prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, Jg);
    predicted_values(type, tool, measured);
    // At the predicted values: zero residual (a pose's rotation rows then turn by w).
    const std::optional<ChainConstants<double>> bent = prepared.bent_constants(q.data());
    measurement_rows(type, s, bent ? *bent : constants, p.data(), joint.data(), measured,
                     rotation_scale, residual, J_all);
    for (int c = 0; c < k; ++c) out.kinematic.block(r * d, c, d, 1) = J_all.col(slots[c]);
    kind_of(type).joint_rows(tool, Jg, rotation_scale, out.joint.block(r * d, 0, d, n));
  }
  for (const StepOneModel& t : step_one) {
    const int np = t.transmission.num_parameters();
    StepOneSensitivity st;
    st.names = t.names;
    st.encoder.resize(m, np + 1);
    st.measurement.resize(m * d, np);
    Eigen::VectorXd e(np);
    for (Eigen::Index r = 0; r < m; ++r) {
      t.transmission.parameter_jacobian(readings(r, t.joint), e.data());
      st.encoder.row(r).head(np) = e.transpose();
      st.encoder(r, np) = 1.0;
      // d theta / d u_k: column k of a coupling's C (reading k moves every joint that uses it).
      const Eigen::MatrixXd column =
          model.coupled()
              ? Eigen::MatrixXd(out.joint.block(r * d, 0, d, n) * model.coupling.col(t.joint))
              : Eigen::MatrixXd(out.joint.block(r * d, t.joint, d, 1));
      st.measurement.middleRows(r * d, d) = column * e.transpose();
    }
    out.step_one.push_back(std::move(st));
  }
  return out;
}

}  // namespace hapticcal
