// A newcomer's measurement kind whose instrument reads an unknown zero of its
// own: a second cable encoder anchored at a known point A of the measurement
// frame reads |p - A| + d0. The kind declares the zero (reads_zero, add_zero,
// and its rows' derivative 1 w.r.t. it); calibrate then offers
// "instrument.zero" as it does for the built-in distance, and estimates it.
// Checked against the zero the log was made with.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/simulation.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// The truth: every length and twist of the arm moved by up to 0.5 mm / 0.5 mrad.
DeviceModel moved_meca500(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  DeviceModel truth = testing::meca500();
  for (Link& l : truth.links) {
    std::uniform_real_distribution<double> u(-5e-4, 5e-4);
    l.a += u(rng);
    l.d += u(rng);
    l.alpha += u(rng);
    l.theta += u(rng);
  }
  return truth;
}

const Eigen::Vector3d kAnchor(0.12, -0.08, 0.02);

class Anchored : public MeasurementKind {
 public:
  Anchored()
      : MeasurementKind({.name = "anchored",
                         .plural = "anchored distances",
                         .dimension = 1,
                         .width = 1,
                         .length_rows = 1,
                         .error_title = "Anchored distance error per sample",
                         .error_axis = "|l_model - l_measured| [mm]",
                         .tip = "anchored distance",
                         .columns = {"anchored"}}) {}
  void predict(const Frame<double>& tool, double* values) const override {
    values[0] = (tool.p - kAnchor).norm();
  }
  bool reads_zero() const override { return true; }
  void add_zero(double zero, double* values) const override { values[0] += zero; }
  void rows(const ChainStructure& s, const ChainConstants<double>& constants, const double* params,
            const double* joint, const double* measured, double, double* residual,
            Eigen::Ref<Eigen::MatrixXd> J) const override {
    Eigen::Matrix<double, 3, Eigen::Dynamic> J_p;
    const Eigen::Vector3d v =
        position_parameter_jacobian(s, constants, params, joint, J_p) - kAnchor;
    residual[0] = v.norm() - measured[0];
    J = (v / v.norm()).transpose() * J_p;
    if (s.instrument) {  // the instrument reads its zero on top
      residual[0] += params[s.instrument_slot()];
      J(0, s.instrument_slot()) = 1;
    }
  }
  void joint_rows(const Frame<double>& tool, const Jacobian6<double>& J_tool_q, double,
                  Eigen::Ref<Eigen::MatrixXd> rows) const override {
    rows = (tool.p - kAnchor).normalized().transpose() * J_tool_q.topRows<3>();
  }
};

// The registration line.
const MeasurementType kAnchored = register_measurement_kind(std::make_unique<Anchored>());

TEST(InstrumentZeroKind, ItsZeroIsOfferedAndEstimated) {
  const DeviceModel nominal = testing::meca500(), truth = moved_meca500(31);
  constexpr double kZero = 1e-3, kSigma = 5e-6;  // m
  std::mt19937_64 rng(17);
  std::normal_distribution<double> gauss(0.0, kSigma);
  SimulationNoise exact;
  exact.sigma_position = 0;
  Log log = simulate_measurement_log(truth, kAnchored, 300, {}, exact, 15);
  MeasuredValues read(log.rows, 1);
  const PreparedModel prepared(truth);
  for (int r = 0; r < log.rows; ++r) {  // the anchor's distance by hand, then the zero and noise
    const Eigen::VectorXd q = log.q.row(r).transpose();
    read(r, 0) = (prepared.forward(q.data()).p - kAnchor).norm() + kZero + gauss(rng);
  }
  kind_of(kAnchored).to_log(read, log);
  CalibrationOptions options;
  options.transmissions = false;
  const CalibrationResult result = calibrate(nominal, log, options);
  ASSERT_EQ(result.status, CalibrationStatus::kConverged) << result.status_reason;
  EXPECT_EQ(result.kinematics.type, kAnchored);
  const auto zero =
      std::find_if(result.kinematics.parameters.begin(), result.kinematics.parameters.end(),
                   [](const ParameterEstimate& e) { return e.name == "instrument.zero"; });
  ASSERT_NE(zero, result.kinematics.parameters.end()) << "the kind's zero was not offered";
  ASSERT_TRUE(zero->identifiable) << zero->reason;
  std::printf("anchored encoder's zero: %.4f mm (sd %.4f mm), truth %.4f mm\n", zero->value * 1e3,
              zero->sd * 1e3, kZero * 1e3);
  EXPECT_NEAR(zero->value, kZero, std::max(4 * zero->sd, 2 * kSigma));
  // With the zero turned off (as --fix instrument.zero does) the same log has
  // no such parameter.
  options.instrument_zero = false;
  const CalibrationResult without = calibrate(nominal, log, options);
  EXPECT_TRUE(std::none_of(without.kinematics.parameters.begin(),
                           without.kinematics.parameters.end(),
                           [](const ParameterEstimate& e) { return e.name == "instrument.zero"; }));
}

}  // namespace
}  // namespace hapticcal
