// A newcomer's measurement kind (issue 24): the tool point's height above a
// known plane (a touch probe read against a height gauge on the table),
// h = n . p_meas - c, one row. It is one class and one registration line; the
// fit, the identifiability analysis and the statistics take it as they take the
// built-in kinds. Checked against independent results: central differences of
// its own rows, and the calibrated model's height error on poses the fit never
// saw, against the truth that made the log.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const Eigen::Vector3d kNormal = Eigen::Vector3d(0.3, -0.2, 0.93).normalized();
constexpr double kOffset = 0.05;  // c [m]: the plane's distance from the measurement origin

class Height : public MeasurementKind {
 public:
  Height()
      : MeasurementKind({.name = "height",
                         .plural = "heights",
                         .dimension = 1,
                         .width = 1,
                         .length_rows = 1,
                         .error_title = "Height error per sample",
                         .error_axis = "|h_model - h_measured| [mm]",
                         .tip = "height"}) {}
  bool in_log(const Log& log) const override { return log.columns.count("height") > 0; }
  void from_log(const Log& log, int row, double* values) const override {
    values[0] = log.columns.at("height")(row, 0);
  }
  void to_log(const MeasuredValues& values, Log& log) const override {
    log.columns["height"] = values;
  }
  void predict(const Frame<double>& tool, double* values) const override {
    values[0] = kNormal.dot(tool.p) - kOffset;
  }
  void rows(const ChainStructure& s, const ChainConstants<double>& constants, const double* params,
            const double* joint, const double* measured, double, double* residual,
            Eigen::Ref<Eigen::MatrixXd> J) const override {
    Eigen::Matrix<double, 3, Eigen::Dynamic> J_p;
    const Eigen::Vector3d p = position_parameter_jacobian(s, constants, params, joint, J_p);
    residual[0] = kNormal.dot(p) - kOffset - measured[0];
    J = kNormal.transpose() * J_p;
  }
  void joint_rows(const Frame<double>&, const Jacobian6<double>& J_tool_q, double,
                  Eigen::Ref<Eigen::MatrixXd> rows) const override {
    rows = kNormal.transpose() * J_tool_q.topRows<3>();
  }
};

// The registration line.
const MeasurementType kHeight = register_measurement_kind(std::make_unique<Height>());

// A log of heights at uniform readings within the joint limits, from `truth`
// (no transmissions: the readings are the joint values), with noise sd `sigma`.
Log height_log(const DeviceModel& truth, int poses, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, sigma);
  Log log;
  log.origin = "height log";
  log.rows = poses;
  log.q.resize(poses, truth.dof());
  log.ext.setZero(poses, truth.dof());
  log.has_ext.assign(truth.dof(), false);
  MeasuredValues h(poses, 1);
  const PreparedModel prepared(truth);
  for (int r = 0; r < poses; ++r) {
    for (int j = 0; j < truth.dof(); ++j) {
      const Link& l = truth.links[j];
      log.q(r, j) = std::uniform_real_distribution<double>(l.lower, l.upper)(rng);
    }
    const Eigen::VectorXd q = log.q.row(r).transpose();
    predicted_values(kHeight, prepared.forward(q.data()), h.row(r).data());
    h(r, 0) += gauss(rng);
    log.line.push_back(r + 2);
  }
  kind_of(kHeight).to_log(h, log);
  return log;
}

// RMS height error of `model` on `log`.
double rms_height_error(const DeviceModel& model, const Log& log) {
  const PreparedModel prepared(model);
  double sum = 0;
  for (int r = 0; r < log.rows; ++r) {
    const Eigen::VectorXd q = log.q.row(r).transpose();
    double h = 0, measured = 0;
    predicted_values(kHeight, prepared.forward(q.data()), &h);
    measured_values(kHeight, log, r, &measured);
    sum += (h - measured) * (h - measured);
  }
  return std::sqrt(sum / log.rows);
}

TEST(MeasurementKind, ANewKindIsFoundByNameAndInItsLog) {
  EXPECT_EQ(measurement_type_named("height"), kHeight);
  EXPECT_EQ(traits(kHeight).dimension, 1);
  const Log log = height_log(testing::meca500(), 5, 0, 1);
  EXPECT_EQ(measurement_type(log), kHeight);
  // A second kind of the same name is refused.
  EXPECT_THROW(register_measurement_kind(std::make_unique<Height>()), std::invalid_argument);
}

TEST(MeasurementKind, ItsRowsMatchCentralDifferences) {
  const DeviceModel model = testing::meca500();
  const ChainStructure s = model.structure();
  Eigen::VectorXd p = model.kinematic_parameters();
  const Log log = height_log(model, 10, 0, 2);
  constexpr double kStep = 1e-6;
  for (int r = 0; r < log.rows; ++r) {
    const Eigen::VectorXd joint = log.q.row(r).transpose();
    const double measured = 0.01 * r;
    double residual = 0;
    Eigen::MatrixXd J(1, s.num_slots());
    measurement_rows(kHeight, s, chain_constants(s, p.data()), p.data(), joint.data(), &measured,
                     1.0, &residual, J);
    for (int k = 0; k < s.num_slots(); ++k) {
      double plus = 0, minus = 0;
      Eigen::MatrixXd unused(1, s.num_slots());
      Eigen::VectorXd q = p;
      q[k] += kStep;
      measurement_rows(kHeight, s, chain_constants(s, q.data()), q.data(), joint.data(), &measured,
                       1.0, &plus, unused);
      q[k] -= 2 * kStep;
      measurement_rows(kHeight, s, chain_constants(s, q.data()), q.data(), joint.data(), &measured,
                       1.0, &minus, unused);
      EXPECT_NEAR(J(0, k), (plus - minus) / (2 * kStep), 1e-7) << "slot " << k << " row " << r;
    }
  }
}

TEST(MeasurementKind, CalibratesEndToEndAndPredictsUnseenHeights) {
  const DeviceModel nominal = testing::meca500();
  // The truth: every length and twist of the arm moved by up to 0.5 mm / 0.5 mrad.
  std::mt19937_64 rng(24);
  DeviceModel truth = nominal;
  for (Link& l : truth.links) {
    std::uniform_real_distribution<double> u(-5e-4, 5e-4);
    l.a += u(rng);
    l.d += u(rng);
    l.alpha += u(rng);
    l.theta += u(rng);
  }
  constexpr double kSigma = 5e-6;  // m: the probe's noise
  const Log log = height_log(truth, 300, kSigma, 7);
  const Log unseen = height_log(truth, 500, 0, 8);
  CalibrationOptions options;
  options.transmissions = false;  // the readings are the joint values
  const CalibrationResult result = calibrate(nominal, log, options);
  ASSERT_EQ(result.status, CalibrationStatus::kConverged) << result.status_reason;
  EXPECT_EQ(result.kinematics.type, kHeight);
  EXPECT_GT(result.kinematics.identified, 5);
  // One row a pose: the residual is the probe's noise.
  EXPECT_NEAR(result.kinematics.rms_after, kSigma, 0.3 * kSigma);
  const double before = rms_height_error(nominal, unseen);
  const double after = rms_height_error(result.calibrated, unseen);
  std::printf("height RMS on 500 unseen poses: %.4f mm nominal, %.4f mm calibrated\n", before * 1e3,
              after * 1e3);
  EXPECT_GT(before, 1e-4);
  EXPECT_LT(after, 5 * kSigma) << "before " << before;
}

}  // namespace
}  // namespace hapticcal
