// Driver files: the Touch's sawSensablePhantom configuration. The driver's
// formula, restated here from its source (jhu-saw/sawSensablePhantom
// mtsSensableHD.cpp: q = joint-scales .* raw + joint-offsets, then the waist
// negated and the elbow made relative), applied with the file's scales and
// offsets, gives readings at which the nominal model is the calibrated one
// (to 1e-12 where the calibration changed only joint zeros and a scale); what
// the file cannot hold is said with its size; calibrate writes the file.
#include "hapticcal/model_io/driver_files.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/simulation.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// The Touch calibrated in its joints' zeros only, each written one of the ways
// a calibration may hold it: a URDF joint's offset, or its origin turned about
// the joint's axis (the shoulder's axis is -x: a roll of -0.02 turns it +0.02;
// the yaw's is +y: a pitch); and joint 5's reading read 0.3 % long (a linear
// transmission error, as a polynomial of order 1).
DeviceModel zeros_moved(const DeviceModel& touch) {
  DeviceModel m = touch;
  m.links[1].origin[3] -= 0.02;  // shoulder: +0.02 rad about its axis
  m.links[2].offset += -0.015;   // elbow
  m.links[3].origin[4] += 0.01;  // yaw: +0.01 rad about +y
  m.links[4].offset += 0.03;     // pitch
  m.links[5].offset += -0.025;   // roll
  Polynomial p;
  p.basis = PolynomialBasis::kMonomial;  // dtheta = 0.003 q
  p.lower = m.links[4].lower;
  p.upper = m.links[4].upper;
  p.coefficients = {0, 0.003};
  m.links[4].transmission = Transmission(p);
  return m;
}

// The driver's corrected readings from its file's scales and offsets (before
// it negates the waist and subtracts the shoulder from the elbow, which its
// published joint states do for any file).
Eigen::VectorXd driver_readings(const nlohmann::json& file, const Eigen::VectorXd& raw) {
  const nlohmann::json& device = file["devices"][0];
  Eigen::VectorXd q(6);
  for (int i = 0; i < 6; ++i)
    q[i] =
        device["joint-scales"][i].get<double>() * raw[i] + device["joint-offsets"][i].get<double>();
  return q;
}

TEST(DriverFiles, TheTouchsScalesAndOffsetsReproduceTheCalibratedReadings) {
  const DeviceModel touch = testing::builtin("geomagic-touch");
  const DeviceModel calibrated = zeros_moved(touch);
  const std::optional<DriverFile> f = driver_file(calibrated, touch);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->name, "sawSensablePhantom.json");
  const nlohmann::json file = nlohmann::json::parse(f->text);
  ASSERT_EQ(file["devices"][0]["joint-scales"].size(), 6u);
  ASSERT_EQ(file["devices"][0]["joint-offsets"].size(), 6u);
  const PreparedModel nominal_model(touch), calibrated_model(calibrated);
  std::mt19937_64 rng(57);
  double worst_p = 0, worst_R = 0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::VectorXd raw = testing::random_readings(touch, rng);
    const Eigen::VectorXd q = driver_readings(file, raw);
    const Frame<double> a = nominal_model.forward(q.data()),
                        b = calibrated_model.forward(raw.data());
    worst_p = std::max(worst_p, (a.p - b.p).norm());
    worst_R = std::max(worst_R, (a.R - b.R).norm());
  }
  EXPECT_LT(worst_p, 1e-12);
  EXPECT_LT(worst_R, 1e-12);
  // The elbow's zero is the joint's (q3 - q2): its reading's offset holds the
  // shoulder's too.
  const ReadingMap map = reading_map(calibrated, touch);
  EXPECT_NEAR(map.offset[1], 0.02, 1e-12);
  EXPECT_NEAR(map.offset[2], 0.02 - 0.015, 1e-12);
  EXPECT_NEAR(map.scale[4], 1.003, 1e-12);
  EXPECT_LT(map.left_out, 1e-12);

  // A length the driver cannot hold: the best map leaves part of it, said
  // with its size.
  DeviceModel longer = calibrated;
  longer.links[2].origin[2] += 1e-3;
  const ReadingMap with_length = reading_map(longer, touch);
  EXPECT_GT(with_length.left_out, 2e-4);
  EXPECT_LT(with_length.left_out, 1.5e-3);
  EXPECT_NE(driver_file(longer, touch)->note.find("not the lengths, axes and tool"),
            std::string::npos);
  // Another device: no driver file.
  EXPECT_FALSE(driver_file(testing::meca500(), testing::meca500()));
}

// calibrate of the built-in Touch writes sawSensablePhantom.json beside
// device.yaml, from the model in the device's frame, and says what it holds.
TEST(DriverFiles, CalibrateWritesTheTouchsDriverFile) {
  const std::string dir = testing::fresh_folder("driver_files_cli");
  const DeviceModel touch = testing::builtin("geomagic-touch");
  DeviceModel truth = zeros_moved(touch);
  truth.links[4].transmission = Transmission();   // zeros alone: no family to fit
  truth.base = {0.3, -0.2, 0.1, 0.2, -0.1, 1.0};  // a tracker's frame
  SimulationNoise noise;
  noise.sigma_position = 1e-5;
  noise.sigma_orientation = 1e-5;
  const Log poses =
      simulate_measurement_log(truth, MeasurementType::kPose, 300, Eigen::MatrixXd(), noise, 3);
  write_file_atomically(dir + "/poses.csv", log_to_csv(poses));
  const testing::CliResult r =
      testing::run_cli({"calibrate", "--model", "geomagic-touch", "--log", dir + "/poses.csv",
                        "--joint-errors", "none", "--out", dir + "/out"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("sawSensablePhantom.json holds the calibrated joint zeros"),
            std::string::npos)
      << r.out;
  const nlohmann::json file =
      nlohmann::json::parse(testing::slurp(dir + "/out/sawSensablePhantom.json"));
  // The driver's readings put the nominal model where device.yaml puts the tool.
  const DeviceModel device = load_device(dir + "/out/device.yaml");
  const PreparedModel a(touch), b(device);
  std::mt19937_64 rng(58);
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    const Eigen::VectorXd raw = testing::random_readings(touch, rng);
    const Eigen::VectorXd q = driver_readings(file, raw);
    worst = std::max(worst, (a.forward(q.data()).p - b.forward(raw.data()).p).norm());
  }
  EXPECT_LT(worst, 1e-4);  // the calibration's own lengths, tenths of a millimetre at most
  EXPECT_NEAR(file["devices"][0]["joint-offsets"][4].get<double>(), 0.03, 1e-3);
}

// The dVRK MTM's kinematic file: its tool pose by cisst's standard DH
// (robDH: Rz(theta + offset + q), then (A cos, A sin, D), then Rx(alpha)),
// restated here, after base-offset, at the joints ActuatorToJointPosition
// makes of the actuators, is the calibrated model's to 1e-12 m; what it cannot
// hold (a link's beta, the tool) is said.
TEST(DriverFiles, TheMtmsKinematicFileIsTheCalibratedModel) {
  const DeviceModel mtm = testing::builtin("dvrk-mtm");
  std::mt19937_64 rng(59);
  DeviceModel calibrated = testing::perturbed(mtm, rng, 1e-3);
  calibrated.tool = {};
  for (Link& l : calibrated.links) l.beta = 0;
  const std::optional<DriverFile> f = driver_file(calibrated, mtm);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->name, "dvrk-mtm.json");
  const nlohmann::json file = nlohmann::json::parse(f->text);
  ASSERT_EQ(file["DH"]["convention"], "standard");
  const nlohmann::json& links = file["DH"]["links"];
  ASSERT_EQ(links.size(), 7u);
  Eigen::Matrix4d base;
  Eigen::MatrixXd C(7, 7);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) base(r, c) = file["base-offset"][r][c].get<double>();
  for (int r = 0; r < 7; ++r)
    for (int c = 0; c < 7; ++c) C(r, c) = file["coupling"]["ActuatorToJointPosition"][r][c];
  const PreparedModel model(calibrated);
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    const Eigen::VectorXd actuators = testing::random_readings(mtm, rng);
    const Eigen::VectorXd q = C * actuators;
    Eigen::Matrix4d T = base;
    for (int i = 0; i < 7; ++i) {
      const nlohmann::json& l = links[static_cast<size_t>(i)];
      const double theta = l["theta"].get<double>() + l["offset"].get<double>() + q[i];
      const double alpha = l["alpha"].get<double>(), a = l["A"].get<double>();
      const double ct = std::cos(theta), st = std::sin(theta), ca = std::cos(alpha),
                   sa = std::sin(alpha);
      Eigen::Matrix4d A;
      A << ct, -st * ca, st * sa, a * ct, st, ct * ca, -ct * sa, a * st, 0, sa, ca,
          l["D"].get<double>(), 0, 0, 0, 1;
      T = T * A;
    }
    const Frame<double> mine = model.forward(actuators.data());
    worst = std::max(worst, (T.topRightCorner<3, 1>() - mine.p).norm());
    worst = std::max(worst, (T.topLeftCorner<3, 3>() - mine.R).norm());
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(f->note.find("not the links' beta"), std::string::npos) << f->note;
  // A beta and a tool the file cannot hold: said.
  calibrated.links[1].beta = 2e-3;
  calibrated.tool[0] = 0.01;
  calibrated.tool[5] = 0.05;
  EXPECT_NE(driver_file(calibrated, mtm)
                ->note.find("not the links' beta (up to 2.000 mrad) or the "
                            "tool (10.000 mm, 50.000 mrad)"),
            std::string::npos);
}

}  // namespace
}  // namespace hapticcal
