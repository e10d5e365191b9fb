// Fixture files (issue 13: "known distances between labelled points from
// --point-distance or a fixture file; known positions optional"): known
// positions pin the fixture, so the base pose becomes visible; a file's
// distances are the command line's.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "nlohmann/json.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

std::string scratch(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/hapticcal_fixture_file_" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// The projected rows with known positions: their Jacobian w.r.t. the raw tool
// points (raw_J = I) against central differences (step 1e-6 m, within 1e-7).
TEST(FixtureFile, KnownPositionRowsHaveTheirNumericalJacobian) {
  Log log;
  log.origin = "rows";
  log.label = {"a", "a", "a", "b", "b", "c", "c", "c"};
  log.rows = static_cast<int>(log.label.size());
  std::vector<int> rows(log.rows);
  for (int r = 0; r < log.rows; ++r) rows[r] = r;
  std::vector<KnownPoint> known(1);
  known[0].label = "b";
  known[0].p_meas = Eigen::Vector3d(0.1, 0.2, 0.3);
  const FixtureLabels labels = fixture_labels(MeasurementType::kPoint, log, rows,
                                              {{"a", "b", 0.05}, {"a", "c", 0.07}}, known);
  ASSERT_EQ(labels.known_points(), 1);
  EXPECT_EQ(labels.unknowns(), 6);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  Eigen::VectorXd raw(3 * log.rows), w(log.rows);
  for (Eigen::Index i = 0; i < raw.size(); ++i) raw[i] = 0.2 + u(rng);
  for (Eigen::Index i = 0; i < w.size(); ++i) w[i] = 1 + 5 * std::abs(u(rng));
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(raw.size(), raw.size());
  const int n = fixture_rows(MeasurementType::kPoint, labels, log.rows);
  Eigen::VectorXd r0(n), plus(n), minus(n);
  Eigen::MatrixXd J;
  fixture_residuals(MeasurementType::kPoint, labels, w, raw, &I, r0.data(), &J);
  // b's rows are w_i (p_i - k_b): its known position, not its mean.
  EXPECT_NEAR(r0[9], w[3] * (raw[9] - 0.1), 1e-15);
  constexpr double h = 1e-6;
  for (Eigen::Index c = 0; c < raw.size(); ++c) {
    Eigen::VectorXd x = raw;
    x[c] += h;
    fixture_residuals(MeasurementType::kPoint, labels, w, x, nullptr, plus.data(), nullptr);
    x[c] -= 2 * h;
    fixture_residuals(MeasurementType::kPoint, labels, w, x, nullptr, minus.data(), nullptr);
    EXPECT_LT((J.col(c) - (plus - minus) / (2 * h)).cwiseAbs().maxCoeff(), 1e-7) << c;
  }
}

// Simulated sockets, noise-free, on the PHANToM: with three of five sockets'
// positions known (the truth's measurement frame), the base pose is
// identifiable and recovered, and a held-out socket with a known position is
// predicted to a micrometre. Without them the base is held (a rigid motion).
TEST(FixtureFile, KnownPositionsRecoverTheBasePose) {
  const DeviceModel nominal = testing::builtin("phantom-premium-1.5");
  const Eigen::Vector3d a = default_sockets(nominal)[0].second;
  const std::vector<std::pair<std::string, Eigen::Vector3d>> sockets = {
      {"s0", a},
      {"s1", a + Eigen::Vector3d(0.05, 0, 0)},
      {"s2", a + Eigen::Vector3d(0, 0.04, 0.0)},
      {"s3", a + Eigen::Vector3d(0.02, 0.02, -0.03)},
      {"s4", a + Eigen::Vector3d(-0.03, 0.01, 0.03)}};
  const std::vector<std::pair<std::string, Eigen::Vector3d>> train(sockets.begin(),
                                                                   sockets.begin() + 4);
  const std::vector<std::pair<std::string, Eigen::Vector3d>> held_out = {sockets[4]};
  std::vector<KnownPoint> known;
  for (int k = 0; k < 3; ++k) {
    KnownPoint p;
    p.label = sockets[k].first;
    p.p_meas = sockets[k].second;
    known.push_back(p);
  }
  CalibrationOptions options;
  options.keep_all = true;
  options.search = false;  // one model
  options.folds = 0;
  options.known_points = known;
  // What these sockets identify: the rank test on exact data of the nominal device.
  const CalibrationResult exact =
      calibrate(nominal, simulate_fixture_log(nominal, train, 15, 0, 7), options);
  ASSERT_EQ(exact.status, CalibrationStatus::kConverged) << exact.status_reason;
  const int base_slots = nominal.structure().base_slots();
  ASSERT_GT(base_slots, 0);
  std::vector<int> slots;
  for (const ParameterEstimate& e : exact.kinematics.parameters) {
    if (e.slot < base_slots) {
      EXPECT_TRUE(e.identifiable) << e.name << ": " << e.reason;
    }
    if (e.identifiable) slots.push_back(e.slot);
  }
  // The truth: 1 mm / 1 mrad off in each of them, the base pose included.
  DeviceModel truth = nominal;
  Eigen::VectorXd p = truth.kinematic_parameters();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> deviation(-1e-3, 1e-3);
  for (int slot : slots) p[slot] += deviation(rng);
  truth.set_kinematic_parameters(p);
  const Log log = simulate_fixture_log(truth, train, 15, 0, 8);
  const CalibrationResult r = calibrate(nominal, log, options);
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  const Eigen::VectorXd estimate = r.calibrated.kinematic_parameters();
  double base_error = 0, worst = 0;
  for (int slot : slots) {
    const double e = std::abs(estimate[slot] - p[slot]);
    worst = std::max(worst, e);
    if (slot < base_slots) base_error = std::max(base_error, e);
  }
  // The held-out socket, its position known: predicted by the calibrated model.
  const Log test = simulate_fixture_log(truth, held_out, 10, 0, 9);
  KnownPoint s4;
  s4.label = "s4";
  s4.p_meas = sockets[4].second;
  const Evaluation before = evaluate(nominal, test, {}, {s4});
  const Evaluation after = evaluate(r.calibrated, test, {}, {s4});
  std::printf(
      "PHANToM, 3 of 4 sockets known: %zu parameters (%d base), largest error %.3g (base %.3g); "
      "held-out known socket RMS %.4f -> %.3g mm\n",
      slots.size(), base_slots, worst, base_error, *before.rms_known_point_error * 1e3,
      *after.rms_known_point_error * 1e3);
  EXPECT_LT(base_error, 1e-6);
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(*before.rms_known_point_error, 1e-4);
  EXPECT_LT(*after.rms_known_point_error, 1e-6);
  ASSERT_EQ(after.labels.size(), 1u);
  ASSERT_TRUE(after.labels[0].rms_known_error.has_value());

  // The same log without the known positions: the base pose is a rigid motion
  // the fixture absorbs, held at nominal.
  CalibrationOptions unknown = options;
  unknown.known_points.clear();
  const CalibrationResult u = calibrate(nominal, log, unknown);
  for (const ParameterEstimate& e : u.kinematics.parameters) {
    if (e.slot < base_slots) {
      EXPECT_FALSE(e.identifiable) << e.name;
    }
  }
}

// The MUKCa log of one placement's two sockets as a CSV file.
std::string write_mukca(const std::string& dir, const std::vector<std::string>& placements) {
  const std::string csv = testing::mukca_csv(placements);
  const std::string path = dir + "/mukca.csv";
  std::ofstream(path) << csv;
  return path;
}

// A fixture file's distances are --point-distance's: on the MUKCa data the
// two calibrations give the same parameters (to 1e-12).
TEST(FixtureFile, FileDistancesEqualThePointDistanceOptions) {
  const std::string dir = scratch("mukca");
  const std::string log = write_mukca(dir, {"front", "right"});
  const std::string fixture = dir + "/fixture.yaml";
  std::ofstream(fixture) << "# the MUKCa fixture: two sockets 50 mm apart at each place\n"
                            "distances:\n  - [front_0, front_1, 0.05]\n"
                            "  - [right_0, right_1, 0.05]\n";
  const std::vector<std::string> common = {
      "calibrate", "--model", testing::real_data_path("mukca/panda.urdf"), "--tip", "ball_link",
      "--log",     log};
  std::vector<std::string> with_file = common, with_options = common;
  with_file.insert(with_file.end(), {"--fixture", fixture, "--out", dir + "/file"});
  with_options.insert(with_options.end(),
                      {"--point-distance", "front_0:front_1=0.05", "--point-distance",
                       "right_0:right_1=0.05", "--out", dir + "/options"});
  const testing::CliResult a = testing::run_cli(with_file);
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const testing::CliResult b = testing::run_cli(with_options);
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const Eigen::VectorXd pa = load_model(dir + "/file/calibrated.yaml").kinematic_parameters();
  const Eigen::VectorXd pb = load_model(dir + "/options/calibrated.yaml").kinematic_parameters();
  std::printf("MUKCa front + right: --fixture vs --point-distance: largest difference %.3g\n",
              (pa - pb).cwiseAbs().maxCoeff());
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_LT((pa - pb).cwiseAbs().maxCoeff(), 1e-12);

  // Both at once: a distance given twice, or two different ones, is refused.
  std::vector<std::string> twice = with_file;
  twice.insert(twice.end(), {"--point-distance", "front_1:front_0=0.05"});
  const testing::CliResult t = testing::run_cli(twice);
  EXPECT_EQ(t.exit_code, 2);
  EXPECT_NE(t.err.find("--point-distance: front_1:front_0 given twice (also at " + fixture + ":3)"),
            std::string::npos)
      << t.err;
  std::vector<std::string> contradicts = with_file;
  contradicts.insert(contradicts.end(), {"--point-distance", "right_0:right_1=0.051"});
  const testing::CliResult c = testing::run_cli(contradicts);
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("right_0:right_1 = 0.051 m contradicts 0.05 m given at " + fixture + ":4"),
            std::string::npos)
      << c.err;
  std::filesystem::remove_all(dir);
}

// evaluate --fixture: the known positions' error per label and over the rows
// (--json rms_known_point_error); without a known position no such figure.
TEST(FixtureFile, EvaluateReportsTheErrorAgainstKnownPositions) {
  const std::string dir = scratch("evaluate");
  const DeviceModel nominal = testing::builtin("phantom-premium-1.5");
  const auto sockets = default_sockets(nominal);
  const std::string log = dir + "/sockets.csv";
  std::ofstream(log) << log_to_csv(simulate_fixture_log(nominal, sockets, 5, 0, 3));
  const std::string fixture = dir + "/fixture.yaml";
  const Eigen::Vector3d a = sockets[0].second + Eigen::Vector3d(0.001, 0, 0);  // 1 mm off
  std::ofstream(fixture) << fmt::format("points:\n  a: [{:.17g}, {:.17g}, {:.17g}]\n", a.x(), a.y(),
                                        a.z());
  const testing::CliResult r = testing::run_cli(
      {"evaluate", "--model", testing::source_path("data/devices/phantom-premium-1.5.yaml"),
       "--log", log, "--fixture", fixture, "--point-distance", "a:b=0.05", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["rms_known_point_error"].get<double>(), 1e-3, 1e-9);
  EXPECT_NEAR(j["labels"]["a"]["rms_known_error"].get<double>(), 1e-3, 1e-9);
  EXPECT_FALSE(j["labels"]["b"].contains("rms_known_error"));
  EXPECT_LT(j["mean_point_deviation"].get<double>(), 1e-9);  // the spread is about the centre
  EXPECT_LT(j["max_point_distance_error"].get<double>(), 1e-9);
  const testing::CliResult text = testing::run_cli(
      {"evaluate", "--model", testing::source_path("data/devices/phantom-premium-1.5.yaml"),
       "--log", log, "--fixture", fixture});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("known positions: RMS error 1.0000 mm"), std::string::npos) << text.out;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
