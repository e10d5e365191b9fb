// `hapticcal evaluate --register`: a log taken after the tracker moved is scored
// in its own frame. Checked against the rigid motion applied to simulated logs:
// the fitted frame must be that motion, and the errors those of the unmoved log.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using nlohmann::json;

// A rigid motion of `metres` along a random direction and `angle` about a random axis.
Frame<double> random_motion(std::mt19937_64& rng, double metres, double angle) {
  const Eigen::Vector3d axis = testing::random_axis(rng);
  const Eigen::Vector3d direction = testing::random_axis(rng);
  return {Eigen::AngleAxisd(angle, axis).toRotationMatrix(), metres * direction};
}

// A position log of `truth` at random readings, each coordinate with N(0, sd) noise.
Log position_log(const DeviceModel& truth, int rows, double sd, std::mt19937_64& rng) {
  Log log = testing::pose_log(truth, rows, rng);
  log.has_orientation = false;
  log.orientation.resize(0, 4);
  std::normal_distribution<double> noise(0, sd);
  for (int r = 0; r < rows; ++r) {
    for (int k = 0; k < 3; ++k) log.position(r, k) += sd > 0 ? noise(rng) : 0;
  }
  return log;
}

// The log as the tracker would have measured it from a frame moved by T: p' = T p.
Log moved(Log log, const Frame<double>& T) {
  for (int r = 0; r < log.rows; ++r) {
    log.position.row(r) = (T * Eigen::Vector3d(log.position.row(r).transpose())).transpose();
    if (!log.has_orientation) continue;
    const Eigen::Quaterniond q(log.orientation(r, 0), log.orientation(r, 1), log.orientation(r, 2),
                               log.orientation(r, 3));
    const Eigen::Quaterniond turned(T.R * q.toRotationMatrix());
    log.orientation.row(r) << turned.w(), turned.x(), turned.y(), turned.z();
  }
  return log;
}

std::string write_log(const Log& log, const std::string& name) {
  const std::string path = ::testing::TempDir() + "/register_" + name + ".csv";
  std::ofstream(path) << log_to_csv(log);
  return path;
}

const std::string kMeca = testing::source_path("examples/meca500/meca500.yaml");

json evaluate_json(const std::string& log_path, const std::string& extra) {
  const testing::CliResult r =
      testing::run_cli("evaluate --json --model " + kMeca + " --log " + log_path + " " + extra);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.exit_code == 0 ? json::parse(r.out) : json();
}

Frame<double> frame_of(const json& pose) {
  const std::array<double, 6> p = pose.get<std::array<double, 6>>();
  return pose_frame(p[0], p[1], p[2], p[3], p[4], p[5]);
}

Frame<double> base_of(const DeviceModel& m) {
  return base_frame(m.structure(), m.kinematic_parameters().data());
}

void expect_same_frame(const Frame<double>& a, const Frame<double>& b, double metres,
                       double radians) {
  EXPECT_LT((a.p - b.p).norm(), metres) << a.p.transpose() << " vs " << b.p.transpose();
  EXPECT_LT(Eigen::AngleAxisd(Eigen::Matrix3d(a.R * b.R.transpose())).angle(), radians);
}

// Noise-free data from the model itself: the fit recovers the applied motion
// exactly, the base becomes T * B_model, and the error vanishes.
TEST(EvaluateRegister, RecoversA500MillimetreThirtyDegreeMoveExactly) {
  std::mt19937_64 rng(22);
  const DeviceModel model = testing::meca500();
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const std::string path = write_log(moved(position_log(model, 40, 0, rng), T), "exact");
  const json raw = evaluate_json(path, "");
  const json j = evaluate_json(path, "--register frame");
  ASSERT_TRUE(j.contains("registered"));
  EXPECT_GT(raw["rms_position"].get<double>(), 0.1);  // unregistered: the move shows
  EXPECT_DOUBLE_EQ(j["registered"]["rms_position_before_registration"].get<double>(),
                   raw["rms_position"].get<double>());
  EXPECT_LT(j["rms_position"].get<double>(), 1e-9);
  expect_same_frame(frame_of(j["registered"]["change"]), T, 1e-9, 1e-9);
  expect_same_frame(frame_of(j["registered"]["base"]), T * base_of(model), 1e-9, 1e-9);
  EXPECT_NEAR(j["registered"]["turned"].get<double>(), 30 * M_PI / 180, 1e-9);
  EXPECT_EQ(j["registered"]["what"], "frame");
  EXPECT_FALSE(j["registered"].contains("tool"));
}

// A perturbed device with 20 um noise: the model does not fit exactly, yet the
// registered error does not depend on where the tracker stood (to 1e-9 m), and
// the two fitted bases differ by the applied motion.
TEST(EvaluateRegister, ErrorOfAMovedNoisyLogIsThatOfTheUnmovedOne) {
  std::mt19937_64 rng(7);
  const DeviceModel model = testing::meca500();
  const DeviceModel truth = testing::perturbed(model, rng, 0.002);
  const Log log = position_log(truth, 60, 20e-6, rng);
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const json here = evaluate_json(write_log(log, "noisy_here"), "--register frame");
  const json there = evaluate_json(write_log(moved(log, T), "noisy_there"), "--register frame");
  ASSERT_TRUE(here.contains("registered") && there.contains("registered"));
  EXPECT_NEAR(here["rms_position"].get<double>(), there["rms_position"].get<double>(), 1e-9);
  EXPECT_NEAR(here["max_position"].get<double>(), there["max_position"].get<double>(), 1e-9);
  // The fit helps even unmoved: the perturbed device's base error is absorbed.
  EXPECT_LT(here["rms_position"].get<double>(),
            here["registered"]["rms_position_before_registration"].get<double>());
  expect_same_frame(frame_of(there["registered"]["base"]), T * frame_of(here["registered"]["base"]),
                    1e-8, 1e-8);
}

// The tool point moved 50 mm (x +30, y -40 mm in the flange frame) and the
// tracker moved: --register frame,tool recovers both from noise-free positions.
TEST(EvaluateRegister, FrameAndToolRecoversA50MillimetreToolOffset) {
  std::mt19937_64 rng(50);
  const DeviceModel model = testing::meca500();
  DeviceModel truth = model;
  truth.tool[0] += 0.030;
  truth.tool[1] -= 0.040;
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const std::string path = write_log(moved(position_log(truth, 40, 0, rng), T), "tool");
  const json frame_only = evaluate_json(path, "--register frame");
  const json j = evaluate_json(path, "--register frame,tool");
  ASSERT_TRUE(j.contains("registered"));
  EXPECT_EQ(j["registered"]["what"], "frame,tool");
  const auto offset = j["registered"]["tool_offset"].get<std::array<double, 3>>();
  EXPECT_NEAR(offset[0], 0.030, 1e-6);
  EXPECT_NEAR(offset[1], -0.040, 1e-6);
  EXPECT_NEAR(offset[2], 0, 1e-6);
  EXPECT_NEAR(j["registered"]["tool"][0].get<double>(), truth.tool[0], 1e-6);
  expect_same_frame(frame_of(j["registered"]["base"]), T * base_of(model), 1e-6, 1e-6);
  EXPECT_LT(j["rms_position"].get<double>(), 1e-6);
  EXPECT_GT(frame_only["rms_position"].get<double>(), 1e-3);  // the frame alone cannot
}

// Pose logs: the frame turns the measured orientations too, and with the tool
// its rotation (which positions cannot see) is fitted.
TEST(EvaluateRegister, PoseLogRecoversFrameAndToolRotation) {
  std::mt19937_64 rng(6);
  const DeviceModel model = testing::meca500();
  DeviceModel truth = model;
  truth.tool[2] += 0.02;
  truth.tool[5] += 0.05;
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const Log log = moved(testing::pose_log(truth, 30, rng), T);
  const Evaluation e = evaluate_registered(model, log, RegisterWhat::kFrameAndTool);
  ASSERT_TRUE(e.registered && e.registered->tool && e.figure("orientation") &&
              e.figure("position"));
  EXPECT_LT(e.figure("position")->stats.rms, 1e-9);
  EXPECT_LT(e.figure("orientation")->stats.rms, 1e-9);
  EXPECT_NEAR(e.registered->tool_offset.z(), 0.02, 1e-9);
  EXPECT_NEAR(e.registered->tool_turned, 0.05, 1e-9);
  const std::array<double, 6>& b = e.registered->base;
  expect_same_frame(pose_frame(b[0], b[1], b[2], b[3], b[4], b[5]), T * base_of(model), 1e-9, 1e-9);
  // The frame alone on the same log: the tool's turn is left as orientation error.
  const Evaluation frame_only = evaluate_registered(model, log, RegisterWhat::kFrame);
  EXPECT_GT(frame_only.figure("orientation")->stats.rms, 0.01);
}

// A DH base (the Phantom's) is registered as a pose; the device file's base kind
// does not limit the fit.
TEST(EvaluateRegister, DhBaseIsRegisteredAsAPose) {
  std::mt19937_64 rng(3);
  DeviceModel model = testing::mixed_chain(BaseKind::kDh);
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const Log log = moved(position_log(model, 40, 0, rng), T);
  const Evaluation e = evaluate_registered(model, log, RegisterWhat::kFrame);
  ASSERT_TRUE(e.registered && e.figure("position"));
  EXPECT_LT(e.figure("position")->stats.rms, 1e-9);
  const std::array<double, 6>& b = e.registered->base;
  expect_same_frame(pose_frame(b[0], b[1], b[2], b[3], b[4], b[5]), T * base_of(model), 1e-9, 1e-9);
}

// The terminal lines say what was fitted and how far it moved.
TEST(EvaluateRegister, TerminalLinesSayTheFrameWasFitted) {
  std::mt19937_64 rng(22);
  const DeviceModel model = testing::meca500();
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const std::string path = write_log(moved(position_log(model, 40, 0, rng), T), "lines");
  const testing::CliResult r =
      testing::run_cli({"evaluate", "--model", kMeca, "--log", path, "--register", "frame,tool",
                        "--out", testing::fresh_folder("register_lines")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("registered: measurement frame fitted on this log (moved "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("30.00 deg from the model's base; RMS before registration"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("registered: tool fitted on this log (tool point moved 0.000 mm"),
            std::string::npos)
      << r.out;
}

// With --reference, each model is registered on its own and the JSON says so.
TEST(EvaluateRegister, ReferenceIsRegisteredOnItsOwn) {
  std::mt19937_64 rng(9);
  const DeviceModel model = testing::meca500();
  const Frame<double> T = random_motion(rng, 0.5, 30 * M_PI / 180);
  const std::string path = write_log(moved(position_log(model, 40, 0, rng), T), "reference");
  const json j = evaluate_json(path, "--register frame --reference " + kMeca);
  ASSERT_TRUE(j.contains("registered") && j.contains("reference_registered"));
  EXPECT_LT(j["reference_rms_position"].get<double>(), 1e-9);
  const testing::CliResult text = testing::run_cli(
      {"evaluate", "--model", kMeca, "--log", path, "--register", "frame", "--reference", kMeca,
       "--out", testing::fresh_folder("register_reference")});
  EXPECT_NE(text.out.find("registered for " + kMeca + " (on its own): measurement frame"),
            std::string::npos)
      << text.out;
}

TEST(EvaluateRegister, DistanceLogIsRefusedInOneLine) {
  const DeviceModel model = testing::meca500();
  std::mt19937_64 rng(1);
  Log log = position_log(model, 10, 0, rng);
  log.has_position = false;
  log.has_distance = true;
  log.distance = log.position.rowwise().norm();
  const std::string path = write_log(log, "distance");
  testing::expect_input_error(
      testing::run_cli("evaluate --model " + kMeca + " --log " + path + " --register frame"),
      "registration needs measured positions (x, y, z columns); this log has distances");
}

// Known distances are between fixture points: refused with --register as without.
TEST(EvaluateRegister, PointDistancesOnAPositionLogAreRefusedAsWithout) {
  const std::string val =
      testing::source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv");
  for (const char* registration : {"", " --register frame"}) {
    testing::expect_input_error(
        testing::run_cli("evaluate --model " + kMeca + " --log " + val +
                         " --point-distance A:B=0.1" + registration),
        "known distances are between fixture points: the log has no point column");
  }
}

TEST(EvaluateRegister, UnknownWordIsRefusedListingTheChoices) {
  testing::expect_input_error(
      testing::run_cli(
          "evaluate --model " + kMeca + " --log " +
          testing::source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv") +
          " --register base"),
      "--register 'base': expected frame (the measurement frame) or frame,tool");
  testing::expect_input_error(
      testing::run_cli(std::vector<std::string>{
          "evaluate", "--model", kMeca, "--log",
          testing::source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv"),
          "--register", ""}),
      "--register '': expected frame");
}

TEST(EvaluateRegister, FewerThanThreePointsOrOnePlaceAreRefused) {
  const DeviceModel model = testing::meca500();
  std::mt19937_64 rng(2);
  Log two = position_log(model, 2, 0, rng);
  testing::expect_input_error(
      testing::run_cli("evaluate --model " + kMeca + " --log " + write_log(two, "two") +
                       " --register frame"),
      "the log has 2 rows; fitting the measurement frame needs at least 3 positions");
  Log still = position_log(model, 5, 0, rng);  // every row the same pose
  for (int r = 1; r < still.rows; ++r) {
    still.q.row(r) = still.q.row(0);
    still.position.row(r) = still.position.row(0);
  }
  testing::expect_input_error(testing::run_cli("evaluate --model " + kMeca + " --log " +
                                               write_log(still, "still") + " --register frame"),
                              "the measurement frame is not determined");
}

// An improvement that is only the set-up's says so: the Meca500 in the
// tracker's frame against the same robot in its own base frame scores 99.9 %
// better on the tracker's poses, the device unchanged; a model whose link moved
// makes no such claim.
TEST(EvaluateRegister, AnImprovementOfTheFrameAloneSaysSo) {
  const std::string dir = testing::fresh_folder("evaluate_setup_only");
  const std::string placed = testing::write_meca500_on_tracker(dir + "/placed.yaml");
  DeviceModel shifted = testing::meca500_on_tracker();
  shifted.links[2].a += 1e-4;
  const std::string moved = dir + "/moved.yaml";
  save_device(shifted, moved);
  const std::string own = testing::source_path("examples/meca500/meca500.yaml");
  const std::string log =
      testing::source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv");
  const auto scored = [&](const std::string& model) {
    const testing::CliResult r =
        testing::run_cli({"evaluate", "--model", model, "--log", log, "--reference", own});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  };
  const std::string frame_only = scored(placed), device = scored(moved);
  EXPECT_NE(frame_only.find("improvement 99.9 % (eq. 9); the models differ only in their set-up"),
            std::string::npos)
      << frame_only;
  EXPECT_NE(device.find("improvement 99.9 % (eq. 9)\n"), std::string::npos) << device;
  EXPECT_EQ(device.find("differ only in their set-up"), std::string::npos) << device;
}

}  // namespace
}  // namespace hapticcal
