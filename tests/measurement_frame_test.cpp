// The measurement frame of a calibration (issue 22): a robot measured by a
// tracker in the tracker's own frame, with a marker off its tip link. The frame
// and the marker are the set-up's unknowns: calibrate takes them without
// --force and without "large change" warnings, identifies the frame first, and
// writes it into calibrated.urdf, whose measurement root reproduces
// calibrated.yaml on held-out data while the robot's own root gives the robot
// alone. Checked against orocos KDL chains built from the written file.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/core/files.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "kdl_chain.hpp"
#include "kdl_urdf.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;
using testing::random_readings;
using testing::source_path;

constexpr double kNoise = 20e-6;  // m, per coordinate: a laser tracker's

std::string arm_path() { return source_path("tests/data/urdf/arm.urdf"); }

// The test arm (a prismatic joint among four revolute ones) as built: every
// joint origin off the drawing by up to 0.5 mm / 1 mrad, measured in a tracker
// frame 0.4 m and 4 deg from the robot's root, by a marker 60 mm off the tip.
DeviceModel measured_arm() {
  DeviceModel m = load_urdf(arm_path(), "tcp");
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Link& l : m.links) {
    for (int k = 0; k < 3; ++k) l.origin[k] += 0.5e-3 * u(rng);
    for (int k = 3; k < 6; ++k) l.origin[k] += 1e-3 * u(rng);
  }
  const Eigen::AngleAxisd turn(4 * M_PI / 180, Eigen::Vector3d(1, 2, 3).normalized());
  const Eigen::Vector3d rpy = matrix_rpy(Eigen::Matrix3d(turn.toRotationMatrix()));
  m.base = {0.32, -0.24, 0.0, rpy[0], rpy[1], rpy[2]};
  m.tool[0] += 0.0;
  m.tool[1] += 0.036;
  m.tool[2] += 0.048;  // 60 mm
  return m;
}

// A position log of `truth` (q1..qn, x, y, z) at random readings, with the
// tracker's noise.
std::string position_log(const DeviceModel& truth, int rows, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, kNoise);
  const PreparedModel prepared(truth);
  std::string csv;
  for (int i = 0; i < truth.dof(); ++i) csv += fmt::format("q{},", i + 1);
  csv += "x,y,z\n";
  for (int k = 0; k < rows; ++k) {
    const Eigen::VectorXd q = random_readings(truth, rng);
    const Frame<double> T = prepared.forward(q.data());
    for (int i = 0; i < truth.dof(); ++i) csv += fmt::format("{:.17g},", q[i]);
    csv += fmt::format("{:.17g},{:.17g},{:.17g}\n", T.p[0] + noise(rng), T.p[1] + noise(rng),
                       T.p[2] + noise(rng));
  }
  return csv;
}

std::string write_log(const std::string& path, const std::string& csv) {
  write_file_atomically(path, csv);
  return path;
}

double rms_position(const std::vector<std::string>& model_args, const std::string& log) {
  std::vector<std::string> args = {"evaluate"};
  args.insert(args.end(), model_args.begin(), model_args.end());
  args.insert(args.end(), {"--log", log, "--json"});
  const testing::CliResult r = testing::run_cli(args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.exit_code == 0 ? nlohmann::json::parse(r.out)["rms_position"].get<double>() : -1;
}

// Largest FK difference between a KDL chain and a model over random readings.
double kdl_difference(const KDL::Chain& chain, const DeviceModel& m) {
  KDL::ChainFkSolverPos_recursive fk(chain);
  const PreparedModel prepared(m);
  std::mt19937_64 rng(3);
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::VectorXd q = random_readings(m, rng);
    KDL::JntArray kq(m.dof());
    for (int i = 0; i < m.dof(); ++i) kq(i) = q[i];
    KDL::Frame f;
    EXPECT_GE(fk.JntToCart(kq, f), 0);
    const Frame<double> a = testing::from_kdl(f), b = prepared.forward(q.data());
    worst = std::max({worst, (a.p - b.p).cwiseAbs().maxCoeff(), (a.R - b.R).cwiseAbs().maxCoeff()});
  }
  return worst;
}

class MeasurementFrame : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = testing::fresh_folder("measurement_frame");
    const DeviceModel truth = measured_arm();
    train_ = dir_ + "/train.csv";
    held_out_ = dir_ + "/held-out.csv";
    write_file_atomically(train_, position_log(truth, 200, 1));
    write_file_atomically(held_out_, position_log(truth, 100, 2));
    out_ = dir_ + "/out";
    // The log named with a doubled slash and a "./", as a script may join paths.
    calibrate_ = testing::run_cli(std::vector<std::string>{"calibrate", "--model", arm_path(),
                                                           "--tip", "tcp", "--log",
                                                           dir_ + "//./train.csv", "--out", out_});
  }
  static inline std::string dir_, train_, held_out_, out_;
  static inline testing::CliResult calibrate_;
};

TEST_F(MeasurementFrame, AMocapLogWithAMarkerOffsetCalibratesWithoutForceOrWarnings) {
  ASSERT_EQ(calibrate_.exit_code, 0) << calibrate_.out << calibrate_.err;
  // The plausibility check fitted the frame, then the frame and the marker.
  EXPECT_NE(calibrate_.out.find("with its base pose and tool point fitted (below 5 % of the reach"),
            std::string::npos)
      << calibrate_.out;
  EXPECT_EQ(calibrate_.out.find("warning:"), std::string::npos) << calibrate_.out;
  EXPECT_NE(calibrate_.out.find("the set-up's unknowns"), std::string::npos) << calibrate_.out;
  const nlohmann::json j = nlohmann::json::parse(testing::slurp(out_ + "/results.json"));
  for (const auto& [name, p] : j["parameters"].items()) {
    EXPECT_FALSE(p.value("large_change", false)) << name;
  }
  // The frame is identified first: the six base parameters, not the first
  // joint's origin, carry it.
  for (const char* base : {"base.x", "base.y", "base.z", "base.roll", "base.pitch", "base.yaw"}) {
    EXPECT_TRUE(j["parameters"][base]["identifiable"].get<bool>()) << base;
  }
  for (const char* first : {"yaw.x", "yaw.y", "yaw.z", "yaw.roll", "yaw.pitch"}) {
    EXPECT_FALSE(j["parameters"][first]["identifiable"].get<bool>()) << first;
  }
}

TEST_F(MeasurementFrame, CalibratedUrdfFromItsMeasurementRootReproducesCalibratedYaml) {
  ASSERT_EQ(calibrate_.exit_code, 0) << calibrate_.out << calibrate_.err;
  EXPECT_NE(calibrate_.out.find(
                "--root hapticcal_measurement gives the calibrated model in the measurement frame"),
            std::string::npos)
      << calibrate_.out;
  const double yaml = rms_position({"--model", out_ + "/calibrated.yaml"}, held_out_);
  const double urdf = rms_position(
      {"--model", out_ + "/calibrated.urdf", "--root", "hapticcal_measurement", "--tip", "tcp"},
      held_out_);
  EXPECT_NEAR(urdf, yaml, 1e-9);
  EXPECT_LT(yaml, 5 * kNoise);  // and the calibration holds on poses it never saw
  // Without --root: the measurement frame the calibration wrote (as calibrated.yaml).
  EXPECT_NEAR(rms_position({"--model", out_ + "/calibrated.urdf", "--tip", "tcp"}, held_out_), yaml,
              1e-9);
  // The robot's own root: 0.4 m off, as the nominal model in the robot's frame.
  EXPECT_GT(rms_position({"--model", out_ + "/calibrated.urdf", "--root", "world", "--tip", "tcp"},
                         held_out_),
            0.3);
}

TEST_F(MeasurementFrame, BothRootsOfCalibratedUrdfAgreeWithKdl) {
  ASSERT_EQ(calibrate_.exit_code, 0) << calibrate_.out << calibrate_.err;
  const std::string text = read_file(out_ + "/calibrated.urdf");
  const DeviceModel yaml = load_device(out_ + "/calibrated.yaml");
  DeviceModel robot = yaml;  // the calibrated robot alone: no measurement frame
  robot.base = {};
  // The measurement root: hapticcal's reader puts the frame into the base.
  const DeviceModel measured = load_urdf(out_ + "/calibrated.urdf", "tcp", "hapticcal_measurement");
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(measured.base[k], yaml.base[k], 1e-12) << k;
  EXPECT_LT(
      kdl_difference(testing::kdl_chain_from_urdf(text, "hapticcal_measurement", "tcp"), yaml),
      1e-12);
  EXPECT_LT(
      kdl_difference(testing::kdl_chain_from_urdf(text, "hapticcal_measurement", "tcp"), measured),
      1e-12);
  // The robot's root: the robot's kinematics unchanged by the frame.
  const DeviceModel alone = load_urdf(out_ + "/calibrated.urdf", "tcp", "world");
  for (double b : alone.base) EXPECT_EQ(b, 0);
  EXPECT_LT(kdl_difference(testing::kdl_chain_from_urdf(text, "world", "tcp"), robot), 1e-12);
  EXPECT_LT(kdl_difference(testing::kdl_chain_from_urdf(text, "world", "tcp"), alone), 1e-12);
}

TEST_F(MeasurementFrame, RecalibratingFromTheMeasurementRootMovesThatJoint) {
  ASSERT_EQ(calibrate_.exit_code, 0) << calibrate_.out << calibrate_.err;
  // The tracker moved 50 mm for a second session: calibrating calibrated.urdf
  // again from its measurement root registers the new frame into the base, and
  // the new calibrated.urdf edits the measurement joint instead of adding a
  // second one.
  DeviceModel moved = measured_arm();
  moved.base[0] += 0.03;
  moved.base[1] += 0.04;
  const std::string train = write_log(dir_ + "/moved-train.csv", position_log(moved, 200, 3));
  const std::string held_out = write_log(dir_ + "/moved-held-out.csv", position_log(moved, 100, 4));
  const std::string again = dir_ + "/again";
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{
      "calibrate", "--model", out_ + "/calibrated.urdf", "--root", "hapticcal_measurement", "--tip",
      "tcp", "--log", train, "--out", again});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const std::string text = read_file(again + "/calibrated.urdf");
  size_t links = 0;
  for (size_t at = text.find("<link name=\"hapticcal_"); at != std::string::npos;
       at = text.find("<link name=\"hapticcal_", at + 1)) {
    ++links;
  }
  EXPECT_EQ(links, 1u) << text;  // hapticcal_measurement alone
  const DeviceModel yaml = load_device(again + "/calibrated.yaml");
  EXPECT_GT(std::hypot(yaml.base[0] - load_device(out_ + "/calibrated.yaml").base[0],
                       yaml.base[1] - load_device(out_ + "/calibrated.yaml").base[1]),
            0.045);  // the frame moved
  const double rms_yaml = rms_position({"--model", again + "/calibrated.yaml"}, held_out);
  const double rms_urdf = rms_position(
      {"--model", again + "/calibrated.urdf", "--root", "hapticcal_measurement", "--tip", "tcp"},
      held_out);
  EXPECT_NEAR(rms_urdf, rms_yaml, 1e-9);
  EXPECT_LT(rms_yaml, 5 * kNoise);
}

TEST_F(MeasurementFrame, TheReportTitleNamesTheLogWithoutPathArtefacts) {
  ASSERT_EQ(calibrate_.exit_code, 0) << calibrate_.out << calibrate_.err;
  const std::string html = testing::slurp(out_ + "/report.html");
  const size_t h1 = html.find("<h1>");
  ASSERT_NE(h1, std::string::npos);
  const std::string title = html.substr(h1, html.find("</h1>", h1) - h1);
  EXPECT_NE(title.find(" on " + train_), std::string::npos) << title;
  EXPECT_EQ(title.find("//"), std::string::npos) << title;
  EXPECT_EQ(title.find("/./"), std::string::npos) << title;
}

TEST(MeasurementFrameReader, ARootBesideTheChainNeedsFixedJoints) {
  // A root that is not above the tip and is joined to it through a movable
  // joint is refused, naming both links.
  const testing::CliResult r = testing::run_cli(
      std::vector<std::string>{"evaluate", "--model", arm_path(), "--root", "finger_left", "--tip",
                               "tcp", "--log", source_path("tests/malformed/good-2dof.csv")});
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.err.find("link 'tcp' is not below the root link 'finger_left' (a root beside the "
                       "chain must be joined to it by fixed joints only)"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace hapticcal

namespace hapticcal {
namespace {

// convert, then calibrate, then evaluate --model calibrated.urdf: the URDF's
// measurement frame (added below the root convert wrote, whose own fixed joint
// holds the nominal base) is the one evaluate reads by default. With the
// geometry alone it reproduces calibrated.yaml's RMS on held-out data; where
// the default's search keeps joint compliance (which URDF cannot hold), it is
// the geometry alone fitted as such: the same held-out RMS as the geometry-only
// calibration's, with no warning of anything left out.
TEST(MeasurementFrameUrdf, ConvertCalibrateEvaluateReproducesTheYamlOrTheGeometry) {
  const std::string dir = testing::fresh_folder("measurement_frame_urdf");
  const std::string data = std::string(HAPTICCAL_SOURCE_DIR) + "/examples/meca500/";
  // The nominal placed in the tracker's frame (the data set's T_base.txt): from
  // there the default search keeps joint compliance on this set (from the
  // example's own frame, which calibrate registers, it keeps the geometry).
  ASSERT_EQ(testing::run_cli({"convert",
                              testing::write_meca500_on_tracker(dir + "/meca500-on-tracker.yaml"),
                              dir + "/meca500.urdf"})
                .exit_code,
            0);
  const std::string validation = data + "val-norm_dist_data_0deg_160cube.csv";
  const auto rms = [&](const std::string& out) {
    const nlohmann::json j = nlohmann::json::parse(out);
    return j["rms_position"].get<double>();
  };
  double geometry_yaml = 0;
  for (const char* joint_errors : {"none", ""}) {
    SCOPED_TRACE(joint_errors);
    const std::string out = dir + "/cal-" + (*joint_errors ? joint_errors : "default");
    std::vector<std::string> args = {"calibrate",
                                     "--model",
                                     dir + "/meca500.urdf",
                                     "--tip",
                                     "tool",
                                     "--log",
                                     data + "cal-norm_dist_data_0deg_160cube.csv",
                                     "--out",
                                     out};
    if (*joint_errors) args.insert(args.end(), {"--joint-errors", joint_errors});
    const testing::CliResult c = testing::run_cli(args);
    ASSERT_EQ(c.exit_code, 0) << c.err;
    const testing::CliResult yaml = testing::run_cli(
        {"evaluate", "--model", out + "/calibrated.yaml", "--log", validation, "--json"});
    const testing::CliResult urdf = testing::run_cli(
        {"evaluate", "--model", out + "/calibrated.urdf", "--tip", "tool", "--log", validation});
    const testing::CliResult urdf_json =
        testing::run_cli({"evaluate", "--model", out + "/calibrated.urdf", "--tip", "tool", "--log",
                          validation, "--json"});
    ASSERT_EQ(urdf.exit_code, 0) << urdf.err;
    // One measurement-frame link: the converted URDF's root takes the new frame.
    const std::string calibrated_text = testing::slurp(out + "/calibrated.urdf");
    EXPECT_EQ(calibrated_text.find("hapticcal_hapticcal_measurement"), std::string::npos);
    EXPECT_NE(urdf.out.find("read from its root, link 'hapticcal_measurement', the measurement "
                            "frame its calibration was fitted in"),
              std::string::npos)
        << urdf.out;
    // The robot alone (--root base_link) leaves the frame out, and is told.
    const testing::CliResult robot =
        testing::run_cli({"evaluate", "--model", out + "/calibrated.urdf", "--tip", "tool",
                          "--root", "base_link", "--log", validation});
    EXPECT_NE(robot.out.find("the robot alone"), std::string::npos) << robot.out;
    EXPECT_EQ(urdf.out.find("left out of this URDF"), std::string::npos) << urdf.out;
    const nlohmann::json results = nlohmann::json::parse(testing::slurp(out + "/results.json"));
    if (*joint_errors) {
      EXPECT_FALSE(results.contains("geometry_model"));
      EXPECT_NEAR(rms(urdf_json.out), rms(yaml.out), 1e-9);
      geometry_yaml = rms(yaml.out);
    } else {
      // The default model search on this set keeps joint compliance.
      EXPECT_TRUE(results.contains("geometry_model")) << c.out;
      EXPECT_EQ(results["joint_errors"]["families"], nlohmann::json::array({"compliance"}));
      EXPECT_NEAR(rms(urdf_json.out), geometry_yaml, 1e-9);
      std::printf("Meca500 held out: calibrated.yaml %.4f mm, calibrated.urdf %.4f mm\n",
                  1e3 * rms(yaml.out), 1e3 * rms(urdf_json.out));
    }
  }
}

}  // namespace
}  // namespace hapticcal
