#include "hapticcal/identification/two_step.hpp"

#include <Eigen/Geometry>
#include <optional>

#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/problem/measurement_cost.hpp"

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
  // A tree's pose measures each tip: its rows are tip 0's, then tip 1's, ...
  const int tips = model.tips(), per_tip = traits(type).dimension, d = per_tip * tips;
  const Eigen::Index m = readings.rows();
  const int k = static_cast<int>(slots.size());
  TwoStepJacobians out;
  out.dimension = d;
  out.kinematic.resize(m * d, k);
  out.joint.resize(m * d, n);
  Eigen::VectorXd q(n), joint(n);
  Eigen::MatrixXd J_all(per_tip, s.num_slots());
  Jacobian6<double> Jg(6, n);
  double measured[7], residual[6];
  detail::TipChain chain;
  for (Eigen::Index r = 0; r < m; ++r) {
    q = readings.row(r).transpose();
    prepared.compensate(q.data(), joint.data());
    // At the predicted values: zero residual (a pose's rotation rows then turn by w).
    const std::optional<ChainConstants<double>> bent = prepared.bent_constants(q.data());
    const ChainConstants<double>& c = bent ? *bent : constants;
    for (int t = 0; t < tips; ++t) {
      const Frame<double> tool =
          prepared.forward_jacobian(q.data(), t, JacobianFrame::kMeasurement, Jg.data());
      predicted_values(type, tool, measured);
      if (tips == 1) {
        measurement_rows(type, s, c, p.data(), joint.data(), measured, rotation_scale, residual,
                         J_all);
      } else {  // tip t's chain in the tree's vector
        detail::tip_chain(s, c, p.data(), joint.data(), t, chain);
        measurement_rows(type, chain.s, chain.constants, p.data(), chain.joint.data(), measured,
                         rotation_scale, residual, J_all);
      }
      const Eigen::Index row = r * d + t * per_tip;
      for (int col = 0; col < k; ++col)
        out.kinematic.block(row, col, per_tip, 1) = J_all.col(slots[col]);
      kind_of(type).joint_rows(tool, Jg, rotation_scale, out.joint.block(row, 0, per_tip, n));
    }
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
