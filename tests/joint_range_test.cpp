// A coupled joint's range (Link::range_lower, range_upper): the stop of a
// joint whose value is a coupling of readings (a parallelogram's elbow turns by
// q3 - q2), on that value. Read and written by the device file and the URDF,
// refused where it cannot be, kept by the draws, the inverse kinematics and the
// default posture, and warned of by calibrate beyond the joint's play.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/simulation.hpp"
#include "support/run_cli.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

// A planar two-link arm whose elbow reads its forearm's angle (q2), turning by
// q2 - q1, with the elbow's stop at [-0.5, 1.0] rad.
constexpr const char* kParallelogram = R"(format: hapticcal-device/2
name: parallelogram
convention: urdf
base: {pose: {xyz: [0, 0, 0], rpy: [0, 0, 0]}}
links:
  - {name: shoulder, origin: {xyz: [0, 0, 0], rpy: [0, 0, 0]}, axis: [0, 0, 1], offset: 0,
     limits: [0, 1.5]}
  - {name: elbow, origin: {xyz: [0.3, 0, 0], rpy: [0, 0, 0]}, axis: [0, 0, 1], offset: 0,
     limits: [-0.5, 2.5], range: [-0.5, 1.0], coupling: {shoulder: -1, elbow: 1}}
  - {name: wrist, origin: {xyz: [0.25, 0, 0], rpy: [0, 0, 0]}, axis: [0, 0, 1], offset: 0,
     limits: [-1, 1]}
tool: {pose: {xyz: [0.05, 0, 0], rpy: [0, 0, 0]}}
)";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The message of the InputError `read` throws (empty: none thrown).
template <typename Read>
std::string refusal(Read read) {
  try {
    read();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(JointRange, DeviceFileAndUrdfKeepTheRange) {
  const DeviceModel m = parse_device(kParallelogram, "parallelogram.yaml");
  EXPECT_EQ(m.links[1].range_lower, -0.5);
  EXPECT_EQ(m.links[1].range_upper, 1.0);
  EXPECT_FALSE(m.links[0].has_range());
  const DeviceModel again = parse_device(device_to_yaml(m), "again.yaml");
  EXPECT_EQ(again.links[1].range_lower, -0.5);
  EXPECT_EQ(again.links[1].range_upper, 1.0);
  const std::string urdf = device_to_urdf(m);
  EXPECT_NE(urdf.find("<hapticcal_range lower=\"-0.5\" upper=\"1\"/>"), std::string::npos) << urdf;
  const DeviceModel from_urdf = parse_urdf(urdf, "parallelogram.urdf", "tool", "");
  EXPECT_EQ(from_urdf.links[1].range_lower, -0.5);
  EXPECT_EQ(from_urdf.links[1].range_upper, 1.0);
  // The built-in Touch through both.
  const DeviceModel touch = testing::builtin("geomagic-touch");
  const DeviceModel touch_urdf = parse_urdf(device_to_urdf(touch), "touch.urdf", "tool", "");
  EXPECT_EQ(touch_urdf.links[2].range_lower, -0.81);
  EXPECT_EQ(touch_urdf.links[2].range_upper, 1.25);
}

TEST(JointRange, RangesThatCannotBeAreRefused) {
  struct Case {
    std::string from, to, expected;
  };
  const std::string elbow = "range: [-0.5, 1.0]";
  for (const Case& c : {
           Case{elbow, "range: [1.0, -0.5]", "lower 1 must be below upper -0.5"},
           Case{elbow, "range: [-0.5, .inf]", "is not finite"},
           Case{elbow, "range: [5, 6]", "none of 1000 readings"},
           Case{"limits: [-1, 1]}", "limits: [-1, 1], range: [-0.5, 0.5]}",
                "a range belongs to a coupled joint"},
       }) {
    SCOPED_TRACE(c.to);
    const std::string why = refusal(
        [&] { parse_device(replaced(kParallelogram, c.from, c.to), "parallelogram.yaml"); });
    EXPECT_NE(why.find(c.expected), std::string::npos) << why;
    EXPECT_NE(why.find("parallelogram.yaml"), std::string::npos) << why;
    EXPECT_NE(why.find("range"), std::string::npos) << why;
  }
  const std::string urdf = device_to_urdf(parse_device(kParallelogram, "p.yaml"));
  const std::string element = "<hapticcal_range lower=\"-0.5\" upper=\"1\"/>";
  for (const Case& c : {
           Case{element, "<hapticcal_range lower=\"-0.5\" upper=\"1\" offset=\"0\"/>",
                "unknown attribute 'offset'"},
           Case{element, "<hapticcal_range lower=\"-0.5\"/>", "needs lower="},
           Case{element, "<hapticcal_range lower=\"a\" upper=\"1\"/>", "finite numbers"},
           Case{element, element + element, "given twice"},
           Case{element, "<hapticcal_range lower=\"1\" upper=\"-0.5\"/>", "must be below"},
           Case{"<link name=\"tool\"/>",
                "<link name=\"tool\"><hapticcal_range lower=\"0\" upper=\"1\"/></link>",
                "inside <link name=\"tool\">"},
       }) {
    SCOPED_TRACE(c.to);
    const std::string why =
        refusal([&] { parse_urdf(replaced(urdf, c.from, c.to), "p.urdf", "tool", ""); });
    EXPECT_NE(why.find(c.expected), std::string::npos) << why;
    EXPECT_NE(why.find("p.urdf"), std::string::npos) << why;
  }
}

// Draws, inverse kinematics and the default posture keep the range.
TEST(JointRange, PosesAreKeptWithinTheRange) {
  const DeviceModel m = parse_device(kParallelogram, "parallelogram.yaml");
  std::mt19937_64 rng(3);
  int box_only = 0;  // draws of the box alone that the range refuses: the range matters
  for (int k = 0; k < 2000; ++k) {
    const Eigen::VectorXd q = m.draw_readings(rng);
    EXPECT_TRUE(m.within_limits(q));
    EXPECT_GE(q[1] - q[0], -0.5);
    EXPECT_LE(q[1] - q[0], 1.0);
    Eigen::VectorXd box(3);
    for (int j = 0; j < 3; ++j)
      box[j] = std::uniform_real_distribution<double>(m.links[j].lower, m.links[j].upper)(rng);
    box_only += m.outside_range(box) >= 0;
  }
  EXPECT_GT(box_only, 400);
  // A solution within the readings' limits but beyond the elbow's stop.
  InverseResult r;
  r.status = InverseStatus::kConverged;
  const Eigen::Vector3d beyond(0.1, 1.5, 0);  // elbow 1.4 rad
  check_ranges(m, beyond.data(), r);
  EXPECT_EQ(r.status, InverseStatus::kOutsideLimits);
  EXPECT_EQ(r.outside_limit, 1);
  // Home (0, 0, 0) is within; a model whose home is not gets the middle.
  EXPECT_EQ(default_posture(m), Eigen::VectorXd::Zero(3));
  const DeviceModel shifted =
      parse_device(replaced(kParallelogram, "limits: [0, 1.5]", "limits: [0.2, 1.5]"), "s.yaml");
  const Eigen::VectorXd middle = default_posture(shifted);
  EXPECT_TRUE(shifted.within_limits(middle));
  EXPECT_NEAR(middle[1] - middle[0], 0.25, 1e-12);  // the elbow's range's middle
}

// calibrate warns of rows beyond a range by more than the joint's play, naming
// the first; rows within the play are the device at its stop.
TEST(JointRange, CalibrateWarnsOfRowsBeyondTheRange) {
  const std::string dir = testing::fresh_folder("joint_range_warning");
  const std::string model = dir + "/parallelogram.yaml";
  write_file_atomically(model, kParallelogram);
  const DeviceModel m = parse_device(kParallelogram, model);
  SimulationNoise noise;
  noise.sigma_position = 1e-5;
  for (const double elbow : {1.0 + 0.005, 1.0 + 0.05}) {
    Log log = simulate_log(m, 60, noise, 8, false, true);
    const int row = 7;
    log.q(row, 1) = log.q(row, 0) + elbow;  // the elbow at (or beyond) its stop
    log.position.row(row) = PreparedModel(m).forward(log.q.row(row).eval().data()).p.transpose();
    const std::string path = dir + "/log.csv";
    write_file_atomically(path, log_to_csv(log));
    const testing::CliResult r = testing::run_cli(
        {"calibrate", "--model", model, "--log", path, "--out", dir + "/cal", "--no-search"});
    const bool beyond = elbow > 1.0 + 0.01;
    const std::string warning =
        "1 of 60 rows put elbow (its coupling of the readings) outside "
        "its range [-0.5, 1] rad by more than its play (0.01 rad), the "
        "first at line 9";
    EXPECT_EQ(r.out.find(warning) != std::string::npos, beyond) << r.out << r.err;
    EXPECT_EQ(r.out.find("outside its range") != std::string::npos, beyond) << r.out;
  }
}

}  // namespace
}  // namespace hapticcal
