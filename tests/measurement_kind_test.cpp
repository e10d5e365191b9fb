// A newcomer's measurement kind (issue 24): the tool point's height above a
// known plane (a 1-D laser distance sensor looking at a fixed plate, a touch
// probe read against a height gauge), h = n . p_meas - c, one row. It is one
// class and one registration line: its log column ("height", a length) is read
// and written by the log files; the fit, the identifiability analysis, the
// statistics, evaluate, the simulation and the pose planner take it as they take
// the built-in kinds. Checked against independent results: central differences
// of its own rows, a CSV written here by hand, the calibrated model's height
// error on poses the fit never saw against the truth that made the log, and
// the noise the simulation was given.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const Eigen::Vector3d kNormal = Eigen::Vector3d(0.3, -0.2, 0.93).normalized();
constexpr double kOffset = 0.05;  // c [m]: the plane's distance from the measurement origin

class Height : public MeasurementKind {
 public:
  explicit Height(const char* name = "height", const char* column = "height")
      : MeasurementKind({.name = name,
                         .plural = "heights",
                         .dimension = 1,
                         .width = 1,
                         .length_rows = 1,
                         .error_title = "Height error per sample",
                         .error_axis = "|h_model - h_measured| [mm]",
                         .tip = "height",
                         .columns = {column}}) {}
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
  // So is a kind whose column is one of the log's own (it would read the tracker's x).
  EXPECT_THROW(register_measurement_kind(std::make_unique<Height>("x_height", "x")),
               std::invalid_argument);
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

// The truth of the end-to-end tests: every length and twist of the arm moved
// by up to 0.5 mm / 0.5 mrad.
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

TEST(MeasurementKind, CalibratesEndToEndAndPredictsUnseenHeights) {
  const DeviceModel nominal = testing::meca500(), truth = moved_meca500(24);
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

// The height of the tool point by the plane's equation, from the forward
// kinematics alone (not through the kind).
double true_height(const PreparedModel& model, const Eigen::VectorXd& q) {
  return kNormal.dot(model.forward(q.data()).p) - kOffset;
}

TEST(MeasurementKind, ALogFileWithItsColumnIsReadAndWrittenBack) {
  // Written by hand: two joints' readings in degrees and the height in mm.
  const DeviceModel model = testing::meca500();
  std::string csv = "q1[deg],q2[deg],q3[deg],q4[deg],q5[deg],q6[deg],height[mm]\n";
  for (int r = 0; r < 4; ++r) csv += fmt::format("{},0,0,0,{},0,{}\n", 10 * r, -5 * r, 12.5 + r);
  const Log log = parse_log(csv, "heights.csv", {});
  ASSERT_EQ(log.rows, 4);
  EXPECT_EQ(measurement_type(log), kHeight);
  for (int r = 0; r < 4; ++r) {
    double h = 0;
    measured_values(kHeight, log, r, &h);
    EXPECT_DOUBLE_EQ(h, (12.5 + r) * 1e-3);
    EXPECT_NEAR(log.q(r, 0), 10 * r * M_PI / 180, 1e-15);
  }
  const Log back = parse_log(log_to_csv(log), "back.csv", {});
  ASSERT_EQ(back.columns.count("height"), 1u);
  EXPECT_EQ(back.columns.at("height"), log.columns.at("height"));
  // A column of a kind named twice, or with a unit that is not a length, is refused.
  EXPECT_THROW(parse_log("q1,height,height\n0,1,2\n", "twice.csv", {}), InputError);
  EXPECT_THROW(parse_log("q1,height[deg]\n0,1\n", "deg.csv", {}), InputError);
}

TEST(MeasurementKind, ItsSimulatedLogCarriesTheNoiseItWasGiven) {
  const DeviceModel truth = moved_meca500(3);
  SimulationNoise noise;
  noise.sigma_position = 2e-5;  // the kind's own sd: a tracker-like length's (the default)
  const Log log = simulate_measurement_log(truth, kHeight, 2000, {}, noise, 11);
  ASSERT_EQ(measurement_type(log), kHeight);
  const PreparedModel prepared(truth);
  double sum = 0, sum2 = 0;
  for (int r = 0; r < log.rows; ++r) {
    double h = 0;
    measured_values(kHeight, log, r, &h);
    const double e = h - true_height(prepared, log.q.row(r).transpose());
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / log.rows, sd = std::sqrt(sum2 / log.rows - mean * mean);
  EXPECT_NEAR(sd, noise.sigma_position, 0.05 * noise.sigma_position);  // 2000 draws: 1.6 %
  EXPECT_NEAR(mean, 0, 4 * noise.sigma_position / std::sqrt(log.rows));
  // The same seed, the same log.
  const Log again = simulate_measurement_log(truth, kHeight, 2000, {}, noise, 11);
  EXPECT_EQ(again.columns.at("height"), log.columns.at("height"));
}

TEST(MeasurementKind, EvaluateScoresItsValues) {
  const DeviceModel truth = moved_meca500(5), nominal = testing::meca500();
  SimulationNoise noise;
  noise.sigma_position = 0;
  const Log log = simulate_measurement_log(truth, kHeight, 200, {}, noise, 12);
  const PreparedModel prepared(nominal);
  double sum2 = 0, worst = 0;
  for (int r = 0; r < log.rows; ++r) {
    double h = 0;
    measured_values(kHeight, log, r, &h);
    const double e = true_height(prepared, log.q.row(r).transpose()) - h;
    sum2 += e * e;
    worst = std::max(worst, std::abs(e));
  }
  const Evaluation ev = evaluate(nominal, log);
  ASSERT_EQ(ev.figures.size(), 1u);  // its own figure, not a distance's or a position's
  EXPECT_EQ(ev.figures[0].type, kHeight);
  EXPECT_STREQ(ev.figures[0].figure.name, "height");
  EXPECT_NEAR(ev.figures[0].stats.rms, std::sqrt(sum2 / log.rows), 1e-12);
  EXPECT_NEAR(ev.figures[0].stats.max, worst, 1e-12);
  EXPECT_GT(ev.figures[0].stats.rms, 1e-5);  // the nominal model is off
  const EvaluationComparison c = compare_to_reference(truth, nominal, log);
  EXPECT_LT(c.model.figures[0].stats.rms, 1e-12);  // the truth made the log
  const std::vector<std::string> lines = evaluation_lines(&c, c.model, "nominal");
  EXPECT_NE(std::find_if(lines.begin(), lines.end(),
                         [](const std::string& l) {
                           return l.find("height RMS") != std::string::npos &&
                                  l.find("improvement 100.0 %") != std::string::npos;
                         }),
            lines.end());
}

// A height does not hold the tool point in the sensor's frame: nothing for
// evaluate --register to align, which it says.
TEST(MeasurementKind, RegistrationNeedsAKindThatMeasuresThePoint) {
  EXPECT_FALSE(kind_of(kHeight).measures_point());
  EXPECT_TRUE(kind_of(MeasurementType::kPosition).measures_point());
  const Log log =
      simulate_measurement_log(moved_meca500(9), kHeight, 50, {}, SimulationNoise{}, 16);
  try {
    register_for_evaluation(testing::meca500(), log, RegisterWhat::kFrame);
    ADD_FAILURE() << "a log of heights was registered";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("registration needs measured positions"),
              std::string::npos)
        << e.what();
  }
}

TEST(MeasurementKind, APlanOfItsPosesBeatsRandomOnesAndCalibrates) {
  const DeviceModel nominal = testing::meca500(), truth = moved_meca500(7);
  constexpr double kSigma = 5e-6;
  const PlanProblem problem(nominal, kHeight, kSigma, 1e-4, random_readings(nominal, 300, 21));
  EXPECT_EQ(problem.dimension(), 1);
  PlanOptions options;
  options.poses = 60;
  options.pool = 1500;
  options.seed = 4;
  options.refine_passes = 1;
  options.evaluation_poses = 500;
  options.random_draws = 5;
  const Plan plan = plan_poses(problem, options);
  ASSERT_EQ(plan.readings.rows(), 60);
  EXPECT_LT(plan.planned.rms_sd, plan.random_median_rms_sd);
  // Measured at the planned poses, the calibration predicts unseen heights
  // about as well as the plan said it would.
  SimulationNoise noise;
  noise.sigma_position = kSigma;
  const Log log = simulate_measurement_log(truth, kHeight, 0, plan.readings, noise, 13);
  CalibrationOptions calibration;
  calibration.transmissions = false;
  const CalibrationResult result = calibrate(nominal, log, calibration);
  ASSERT_EQ(result.status, CalibrationStatus::kConverged) << result.status_reason;
  const Log unseen = simulate_measurement_log(truth, kHeight, 500, {}, SimulationNoise{}, 14);
  const double after = rms_height_error(result.calibrated, unseen);
  std::printf("planned 60 poses: predicted sd %.4f mm, unseen RMS %.4f mm\n",
              plan.planned.rms_sd * 1e3, after * 1e3);
  EXPECT_LT(after, 4 * plan.planned.rms_sd + kSigma);
}

}  // namespace
}  // namespace hapticcal
