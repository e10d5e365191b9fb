// Several markers on one rigid body (issue 26, item 4, the rigid body): the
// log's x1, y1, z1, ... columns, the body's poses from them, and positions
// alone identifying the tool's orientation.
#include "hapticcal/identification/markers.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// Three markers of a body, in its (the tool's) frame [m].
Eigen::Matrix3Xd body() {
  Eigen::Matrix3Xd b(3, 3);
  b << 0.03, 0.0, -0.01,  //
      0.0, 0.04, 0.01,    //
      0.01, 0.0, 0.05;
  return b;
}

// A log of `rows` random readings with the markers of `markers` (in the tool
// frame of `truth`) measured with noise `sigma` per coordinate.
Log marker_log(const DeviceModel& truth, const Eigen::Matrix3Xd& markers, int rows, double sigma,
               std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, sigma);
  const PreparedModel prepared(truth);
  const int n = truth.dof(), k = static_cast<int>(markers.cols());
  Log log = testing::blank_marker_log("markers.csv", rows, n, k);
  for (int r = 0; r < rows; ++r) {
    const Eigen::VectorXd q = testing::random_readings(truth, rng);
    log.q.row(r) = q.transpose();
    const Frame<double> T = prepared.forward(q.data());
    for (int m = 0; m < k; ++m) {
      const Eigen::Vector3d p = T.R * markers.col(m) + T.p;
      for (int c = 0; c < 3; ++c) log.markers(r, 3 * m + c) = p[c] + gauss(rng);
    }
  }
  return log;
}

// The Touch with its tool (the marker body's frame) turned by 20-30 mrad and
// its geometry off by 0.3 mm / 3 mrad.
// The Touch with its base at the origin, not the driver's: the length scale
// (the tool's distance from the base origin) decides which of a dependent pair
// (the tool's and the roll joint's turn about one axis) the rank test holds,
// and the truth below turns the tool.
DeviceModel touch_at_origin() {
  DeviceModel m = testing::builtin("geomagic-touch");
  m.base = {};
  return m;
}

DeviceModel touch_truth() {
  DeviceModel m = touch_at_origin();
  std::mt19937_64 rng(8);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (Link& l : m.links) {
    for (int k = 0; k < 3; ++k) l.origin[k] += 3e-4 * gauss(rng);
    // The last joint's origin turns as the tool does (calibrate holds it as
    // dependent): the tool's turn is the truth to recover.
    if (&l == &m.links.back()) continue;
    for (int k = 3; k < 6; ++k) l.origin[k] += 3e-3 * gauss(rng);
  }
  m.tool = {0.002, -0.001, 0.003, 0.02, -0.025, 0.03};
  return m;
}

const ParameterEstimate& estimate(const CalibrationResult& r, const std::string& name) {
  for (const ParameterEstimate& e : r.kinematics.parameters)
    if (e.name == name) return e;
  throw std::runtime_error("no parameter " + name);
}

TEST(Markers, ColumnsAreReadAndWrittenBack) {
  const Log log = parse_log("q1,q2,x1,y1,z1,x2[mm],y2[mm],z2[mm]\n0.1,0.2,1,2,3,4,5,6\n", "m.csv");
  ASSERT_EQ(log.marker_count, 2);
  EXPECT_FALSE(log.has_position);
  EXPECT_DOUBLE_EQ(log.markers(0, 2), 3);
  EXPECT_DOUBLE_EQ(log.markers(0, 3), 4e-3);
  const Log back = parse_log(log_to_csv(log), "back.csv");
  EXPECT_EQ(back.markers, log.markers);
  EXPECT_THROW(parse_log("q1,x1,y1,z1,x3,y3,z3\n0,1,2,3,4,5,6\n", "gap.csv"), InputError);
  EXPECT_THROW(parse_log("q1,x1,y1\n0,1,2\n", "partial.csv"), InputError);
  EXPECT_THROW(parse_log("q1,x,y,z,x1,y1,z1\n0,1,2,3,4,5,6\n", "both.csv"), InputError);
  EXPECT_THROW(parse_log("q1,x0,y0,z0\n0,1,2,3\n", "zero.csv"), InputError);
}

// The body's poses: with the body given, each row's pose is the truth's tool
// frame within the noise; estimated, the body's shape (its markers' distances)
// is the truth's.
TEST(Markers, PosesOfTheBodyMatchTheTruth) {
  const DeviceModel truth = touch_truth();
  const Log log = marker_log(truth, body(), 200, 2e-5, 3);
  const MarkerPoses given = markers_to_poses(log, body());
  const PreparedModel prepared(truth);
  double worst_p = 0, worst_angle = 0;
  for (int r = 0; r < log.rows; ++r) {
    const Eigen::VectorXd q = log.q.row(r).transpose();
    const Frame<double> T = prepared.forward(q.data());
    worst_p = std::max(worst_p, (given.poses.position.row(r).transpose() - T.p).norm());
    const Eigen::Quaterniond qm(given.poses.orientation(r, 0), given.poses.orientation(r, 1),
                                given.poses.orientation(r, 2), given.poses.orientation(r, 3));
    worst_angle =
        std::max(worst_angle, Eigen::AngleAxisd(qm.toRotationMatrix() * T.R.transpose()).angle());
  }
  EXPECT_LT(worst_p, 1e-4);
  EXPECT_LT(worst_angle, 3e-3);
  EXPECT_LT(given.fit_rms, 5e-5);
  const MarkerPoses estimated = markers_to_poses(log);
  ASSERT_TRUE(estimated.estimated);
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      EXPECT_NEAR((estimated.body.col(a) - estimated.body.col(b)).norm(),
                  (body().col(a) - body().col(b)).norm(), 1e-5);
    }
  }
  // The body listed in another order than the log's markers: refused, the
  // order that fits named (the given body's second marker is the log's first).
  Eigen::Matrix3Xd swapped = body();
  swapped.col(0) = body().col(1);
  swapped.col(1) = body().col(0);
  try {
    markers_to_poses(log, swapped);
    ADD_FAILURE() << "a body in another order was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--markers' markers in the order 2, 1, 3"),
              std::string::npos)
        << e.what();
  }
  Log two = log;
  two.marker_count = 2;
  two.markers = log.markers.leftCols(6);
  EXPECT_THROW(markers_to_poses(two), InputError);
}

// Issue 26's acceptance: three markers on one body identify the tool's
// orientation from positions alone (within 3 sd of the truth); the estimated
// body predicts held-out markers to the noise.
TEST(Markers, ThreeMarkersIdentifyTheToolOrientationFromPositionsAlone) {
  const DeviceModel nominal = touch_at_origin();
  const DeviceModel truth = touch_truth();
  const double sigma = 5e-5;
  const Log log = marker_log(truth, body(), 300, sigma, 4);
  CalibrationOptions options;
  options.keep_all = true;
  options.search = false;  // one model
  options.marker_body = body();
  const CalibrationResult fit = calibrate(nominal, log, options);
  ASSERT_EQ(fit.status, CalibrationStatus::kConverged) << fit.status_reason;
  for (const char* name : {"tool.roll", "tool.pitch", "tool.yaw"}) {
    SCOPED_TRACE(name);
    const ParameterEstimate& e = estimate(fit, name);
    ASSERT_TRUE(e.identifiable) << e.reason;
    const int k = name[5] == 'r' ? 3 : name[5] == 'p' ? 4 : 5;
    EXPECT_LT(std::abs(e.value - truth.tool[k]), 3 * e.sd) << e.value << " vs " << truth.tool[k];
    std::printf("%s: %.4f mrad +- %.4f (truth %.4f)\n", name, 1e3 * e.value, 1e3 * e.sd,
                1e3 * truth.tool[k]);
  }
  // Unknown marker positions: estimated, the fit predicts held-out markers.
  CalibrationOptions unknown;
  unknown.keep_all = true;
  unknown.search = false;  // one model
  const CalibrationResult blind = calibrate(nominal, log, unknown);
  ASSERT_EQ(blind.status, CalibrationStatus::kConverged) << blind.status_reason;
  ASSERT_EQ(blind.marker_body.cols(), 3);
  const Log held = marker_log(truth, body(), 200, sigma, 5);
  const PreparedModel prepared(blind.calibrated);
  double sum = 0;
  for (int r = 0; r < held.rows; ++r) {
    const Eigen::VectorXd q = held.q.row(r).transpose();
    const Frame<double> T = prepared.forward(q.data());
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector3d predicted = T.R * blind.marker_body.col(m) + T.p;
      sum += (held.markers.row(r).segment<3>(3 * m).transpose() - predicted).squaredNorm();
    }
  }
  const double rms = std::sqrt(sum / (3 * held.rows));  // per marker, 3 coordinates
  EXPECT_LT(rms, 1.2 * std::sqrt(3.0) * sigma) << rms;
  std::printf("estimated body: held-out marker RMS %.4f mm (noise %.4f mm)\n", 1e3 * rms,
              1e3 * std::sqrt(3.0) * sigma);
}

// The command line: calibrate a marker log with its body, evaluate a held-out
// one with the same body; an estimated body is in results.json.
TEST(Markers, CalibrateAndEvaluateAMarkerLog) {
  const std::string dir = testing::fresh_folder("markers_cli");
  const DeviceModel truth = touch_truth();
  std::ofstream(dir + "/fit.csv") << log_to_csv(marker_log(truth, body(), 200, 5e-5, 6));
  std::ofstream(dir + "/held.csv") << log_to_csv(marker_log(truth, body(), 100, 5e-5, 7));
  const std::string markers = "0.03,0,0.01,0,0.04,0,-0.01,0.01,0.05";
  const testing::CliResult c =
      testing::run_cli({"calibrate", "--model", "geomagic-touch", "--log", dir + "/fit.csv",
                        "--markers", markers, "--out", dir + "/cal"});
  ASSERT_EQ(c.exit_code, 0) << c.err << c.out;
  EXPECT_NE(c.out.find("markers: 3 on one rigid body"), std::string::npos) << c.out;
  const auto j = nlohmann::json::parse(read_file(dir + "/cal/results.json"));
  EXPECT_EQ(j["markers"].size(), 3u);
  EXPECT_TRUE(j["parameters"]["tool.roll"]["identifiable"].get<bool>());
  const testing::CliResult e =
      testing::run_cli({"evaluate", "--model", dir + "/cal/calibrated.yaml", "--log",
                        dir + "/held.csv", "--markers", markers, "--json"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto ev = nlohmann::json::parse(e.out);
  EXPECT_LT(ev["rms_position"].get<double>(), 1e-4) << e.out;
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", "geomagic-touch", "--log", dir + "/fit.csv",
                        "--markers", "0.03,0,0.01", "--out", dir + "/bad"}),
      "--markers: 3 numbers");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
