// The device's own model out of a calibration in a tracker's frame
// (kinematics/device_frame.hpp): the split against the calibrated model's own
// forward kinematics, and a simulated Touch whose driver positions the
// device-frame model reproduces to the calibration's own sd.
#include "hapticcal/kinematics/device_frame.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/simulation.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using testing::builtin;
using testing::mixed_chain;
using testing::random_readings;

// Every parameter moved: lengths by up to `length`, angles by up to `angle`.
DeviceModel deviated(DeviceModel m, std::mt19937_64& rng, double length, double angle) {
  Eigen::VectorXd p = m.kinematic_parameters();
  std::uniform_real_distribution<double> u(-1, 1);
  for (const ParameterInfo& info : m.parameter_info())
    p[info.slot] += u(rng) * (info.unit == ParameterUnit::kLength ? length : angle);
  m.set_kinematic_parameters(p);
  return m;
}

void expect_same_frame(const Frame<double>& a, const Frame<double>& b, double tolerance) {
  EXPECT_LT((a.p - b.p).norm(), tolerance);
  EXPECT_LT((a.R - b.R).norm(), tolerance);
}

// FK of the device model = D^-1 FK of the calibrated one (with the same tool)
// at random readings, and the device's joint 1 where the nominal model has it.
void check_split(const DeviceModel& nominal, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  DeviceModel calibrated = deviated(nominal, rng, 0.02, 0.05);
  const std::array<double, 6> tool{0.01, -0.03, 0.05, 0.2, -0.1, 0.4};
  const DeviceFrameSplit split = split_device_frame(calibrated, nominal, tool);
  EXPECT_EQ(split.measured_tool, calibrated.tool);
  calibrated.tool = tool;
  const PreparedModel device(split.device), measured(calibrated);
  const Frame<double> to_device = split.device_in_measurement.inverse();
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd q = random_readings(nominal, rng);
    expect_same_frame(device.forward(q.data()), to_device * measured.forward(q.data()), 1e-12);
  }
  expect_same_frame(first_joint_frame(split.device), first_joint_frame(nominal), 1e-15);
}

TEST(DeviceFrame, SplitIsTheCalibratedModelInTheFrameOfItsFirstJoint) {
  check_split(mixed_chain(BaseKind::kPose), 1);  // a DH joint 1
  check_split(mixed_chain(BaseKind::kDh), 2);
  check_split(builtin("geomagic-touch"), 3);  // URDF joints, coupled
  check_split(builtin("baser-7dof"), 4);      // DH base, capstans
  check_split(testing::meca500(), 5);         // MDH
  DeviceModel prismatic = mixed_chain(BaseKind::kPose);
  prismatic.links.erase(prismatic.links.begin());  // an MDH prismatic joint 1
  check_split(prismatic, 6);
  prismatic.links.erase(prismatic.links.begin());  // an origin joint 1 on a non-z axis
  check_split(prismatic, 7);
}

// A compliant chain: the gravity torques, and so the joints' deflections, are
// the same in the device's frame (gravity turned with the base).
TEST(DeviceFrame, GravityIsTurnedIntoTheDevicesBase) {
  DeviceModel nominal = mixed_chain(BaseKind::kPose);
  for (Link& l : nominal.links) {
    l.mass = 0.5;
    l.com = Eigen::Vector3d(0.02, 0.01, 0.03);
    l.compliance = l.prismatic() ? 0 : 2e-3;
  }
  nominal.gravity = Eigen::Vector3d(1.0, -2.0, -9.5);
  ASSERT_TRUE(nominal.compliant());
  check_split(nominal, 8);
}

// The Touch with its geometry off the drawing, seen by a tracker 0.40 m away
// through a marker 5 cm up the stylus. The truth's device frame is the
// driver's (its base and joint 1 as the device file has them): its driver
// positions at the marker are what the device-frame model must reproduce,
// within the calibration's own sd (the covariance of the identified
// parameters carried to the position by a numerical Jacobian): over noise
// draws, the mean of e^T C^-1 e is 3, a chi-square's with 3 degrees of freedom.
TEST(DeviceFrame, ReproducesTheTruthsDriverPositionsToItsOwnSd) {
  const DeviceModel nominal = builtin("geomagic-touch");
  std::mt19937_64 rng(42);
  DeviceModel truth = deviated(nominal, rng, 5e-4, 5e-3);
  truth.tool = {0.004, -0.003, 0.05, 0, 0, 0};
  const std::array<double, 6> placement_pose{0.33, -0.12, 0.18, 0.3, -0.2, 2.1};
  SimulationNoise noise;
  noise.sigma_position = 1e-4;
  CalibrationOptions options;
  options.search = false;
  options.keep_all = true;
  // The device's (the driver's) frame at the placement: its base the
  // placement composed with the driver's base.
  const Frame<double> placed = pose_frame(placement_pose) * pose_frame(nominal.base);
  const Eigen::Vector3d placed_rpy = matrix_rpy(placed.R);
  const auto seen_by_tracker = [&](std::uint64_t seed) {
    DeviceModel seen = truth;  // the tracker's frame
    seen.base = {placed.p.x(),  placed.p.y(),  placed.p.z(),
                 placed_rpy[0], placed_rpy[1], placed_rpy[2]};
    return simulate_log(seen, 400, noise, seed, /*distance=*/false, /*position=*/true);
  };
  // The truth as the data can tell it: what no tool measurement can see (the
  // parameters the identifiability analysis holds, e.g. a turn of joint 2's
  // origin about joint 1's axis, which the zero of joint 1 takes up) at
  // nominal; then the driver's frame: the base and joint 1 as in the file.
  const CalibrationResult first = calibrate(nominal, seen_by_tracker(1), options);
  Eigen::VectorXd truth_values = truth.kinematic_parameters();
  const Eigen::VectorXd nominal_values = nominal.kinematic_parameters();
  for (const ParameterEstimate& e : first.kinematics.parameters) {
    if (!e.identifiable) truth_values[e.slot] = nominal_values[e.slot];
  }
  truth.set_kinematic_parameters(truth_values);
  truth.base = nominal.base;
  truth.links[0].origin = nominal.links[0].origin;
  truth.links[0].offset = nominal.links[0].offset;
  const PreparedModel actual(truth);
  const Frame<double> placement = pose_frame(placement_pose);

  constexpr int kTrials = 12, kPoses = 30;
  double chi2 = 0, largest = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const CalibrationResult result = calibrate(nominal, seen_by_tracker(100 + trial), options);
    ASSERT_EQ(result.status, CalibrationStatus::kConverged) << result.status_reason;
    const DeviceFrameSplit split = split_device_frame(result.calibrated, nominal);
    // The device's frame in the tracker's is the tracker's placement.
    EXPECT_LT((split.device_in_measurement.p - placement.p).norm(), 1e-3);
    EXPECT_LT((split.device_in_measurement.R - placement.R).norm(), 5e-3);

    // The identified parameters' covariance.
    const KinematicFit& fit = result.kinematics;
    std::vector<int> slots;
    std::vector<double> sd;
    for (const std::string& name : fit.identified_names) {
      for (const ParameterEstimate& e : fit.parameters) {
        if (e.name != name) continue;
        slots.push_back(e.slot);
        sd.push_back(e.sd);
      }
    }
    const int n = static_cast<int>(slots.size());
    ASSERT_EQ(n, fit.correlation.rows());
    Eigen::MatrixXd covariance(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) covariance(i, j) = sd[i] * sd[j] * fit.correlation(i, j);

    const PreparedModel device(split.device);
    const Eigen::VectorXd values = result.calibrated.kinematic_parameters();
    std::vector<PreparedModel> shifted;  // each identified parameter moved by h
    constexpr double h = 1e-7;
    for (int i = 0; i < n; ++i) {
      DeviceModel moved = result.calibrated;
      Eigen::VectorXd p = values;
      p[slots[i]] += h;
      moved.set_kinematic_parameters(p);
      shifted.emplace_back(split_device_frame(moved, nominal).device);
    }
    for (int k = 0; k < kPoses; ++k) {
      const Eigen::VectorXd q = random_readings(nominal, rng);
      const Eigen::Vector3d at = device.forward(q.data()).p;
      const Eigen::Vector3d error = at - actual.forward(q.data()).p;
      Eigen::MatrixXd jacobian(3, n);
      for (int i = 0; i < n; ++i) jacobian.col(i) = (shifted[i].forward(q.data()).p - at) / h;
      const Eigen::Matrix3d position_covariance = jacobian * covariance * jacobian.transpose();
      chi2 += error.dot(position_covariance.ldlt().solve(error));
      largest = std::max(largest, error.norm());
    }
  }
  const double mean = chi2 / (kTrials * kPoses);
  std::printf(
      "device frame: mean e^T C^-1 e %.3f over %d noise draws (3 if the sd are right); "
      "largest error %.4f mm\n",
      mean, kTrials, largest * 1e3);
  EXPECT_GT(mean, 3 / 2.0);
  EXPECT_LT(mean, 3 * 2.0);
  EXPECT_LT(largest, 0.5e-3);  // against a truth 0.5 mm / 5 mrad off the drawing
}

// The twist about the axis of the last joint's zero, calibrated against
// nominal (offsets included).
double last_twist(const DeviceModel& calibrated, const DeviceModel& nominal) {
  const Link& c = calibrated.links.back();
  const Link& n = nominal.links.back();
  if (c.geometry != Geometry::kOrigin) return c.theta - n.theta;
  const auto rotation = [](const Link& l) {
    return Eigen::Matrix3d(rpy_matrix(l.origin[3], l.origin[4], l.origin[5]) *
                           Eigen::AngleAxisd(l.offset, l.axis.normalized()).toRotationMatrix());
  };
  const Eigen::Quaterniond q(rotation(n).transpose() * rotation(c));
  return 2 * std::atan2(q.vec().dot(n.axis.normalized()), q.w());
}

// The last joint's turn moved into the tool: the same forward kinematics, the
// joint's zero nominal; DH, MDH and URDF last joints.
TEST(DeviceFrame, LastJointsTurnMovesIntoTheTool) {
  for (int dof : {9, 8, 7}) {  // the mixed chain's j9 MDH, j8 DH, j7 origin
    SCOPED_TRACE(dof);
    DeviceModel nominal = mixed_chain(BaseKind::kPose);
    nominal.links.resize(dof);
    std::mt19937_64 rng(dof);
    const DeviceModel calibrated = deviated(nominal, rng, 0.01, 0.3);
    DeviceModel moved = calibrated;
    const double turn = move_last_turn_into_tool(moved, nominal);
    EXPECT_NEAR(turn, last_twist(calibrated, nominal), 1e-12);
    EXPECT_GT(std::abs(turn), 1e-3);
    EXPECT_NEAR(last_twist(moved, nominal), 0, 1e-12);
    const PreparedModel a(calibrated), b(moved);
    for (int k = 0; k < 20; ++k) {
      const Eigen::VectorXd q = random_readings(nominal, rng);
      expect_same_frame(a.forward(q.data()), b.forward(q.data()), 1e-12);
    }
  }
}

// A ball on the Panda's flange in a fixture's sockets sees no turn of the
// flange: calibrated.urdf keeps panda_joint7's zero at nominal, device.yaml
// too, and both give calibrated.yaml's ball positions.
TEST(DeviceFrame, MukcaFlangeTurnIsNotWrittenIntoTheUrdf) {
  const std::string dir = testing::fresh_folder("device_frame_mukca");
  std::ofstream(dir + "/train.csv") << testing::mukca_csv({"front", "right"});
  const std::string urdf = testing::real_data_path("mukca/panda.urdf");
  const auto r =
      testing::run_cli({"calibrate", "--model", urdf, "--tip", "ball_link", "--log",
                        dir + "/train.csv", "--out", dir + "/cal", "--point-distance",
                        "front_0:front_1=0.05", "--point-distance", "right_0:right_1=0.05"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const DeviceModel nominal = load_urdf(urdf, "ball_link");
  const DeviceModel yaml = load_device(dir + "/cal/calibrated.yaml");
  const DeviceModel written = load_urdf(dir + "/cal/calibrated.urdf", "ball_link");
  const DeviceModel device = load_device(dir + "/cal/device.yaml");
  const double fitted = last_twist(yaml, nominal);
  std::printf("panda_joint7's zero: %.2f deg in calibrated.yaml, %.2g deg in calibrated.urdf\n",
              fitted * 180 / std::numbers::pi,
              last_twist(written, nominal) * 180 / std::numbers::pi);
  EXPECT_GT(std::abs(fitted), 0.1);  // the fit turned it: the ball cannot see the turn
  EXPECT_NEAR(last_twist(written, nominal), 0, 1e-9);
  EXPECT_NEAR(last_twist(device, nominal), 0, 1e-9);
  EXPECT_NE(r.out.find("keep joint panda_joint7's zero at nominal"), std::string::npos) << r.out;
  const PreparedModel a(yaml), b(written), c(device);
  std::mt19937_64 rng(3);
  Eigen::Vector3d previous_a, previous_c;
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd q = random_readings(nominal, rng);
    const Eigen::Vector3d at_a = a.forward(q.data()).p, at_c = c.forward(q.data()).p;
    EXPECT_LT((at_a - b.forward(q.data()).p).norm(), 1e-9);
    // device.yaml: the same positions up to its frame (distances between them kept).
    if (k > 0) EXPECT_NEAR((at_a - previous_a).norm(), (at_c - previous_c).norm(), 1e-9);
    previous_a = at_a;
    previous_c = at_c;
  }
}

// calibrate writes device.yaml and setup.yaml; --tool-point moves the tool.
TEST(DeviceFrame, CalibrateWritesTheDeviceModelAndTheSetUp) {
  const std::string out = testing::fresh_folder("device_frame_cli");
  const std::string model = testing::source_path("examples/meca500/meca500.yaml");
  const std::string log =
      testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv");
  const auto r = testing::run_cli({"calibrate", "--model", model, "--log", log, "--out", out,
                                   "--tool-point", "0.001,-0.002,0.07"});
  ASSERT_EQ(r.exit_code, 0) << r.out + r.err;
  EXPECT_NE((r.out + r.err).find("device.yaml is the model in the device's own frame"),
            std::string::npos);
  const DeviceModel calibrated = load_device(out + "/calibrated.yaml");
  const DeviceModel device = load_device(out + "/device.yaml");
  EXPECT_NEAR(device.tool[0], 0.001, 1e-12);
  EXPECT_NEAR(device.tool[2], 0.07, 1e-12);
  const std::string setup = testing::slurp(out + "/setup.yaml");
  EXPECT_NE(setup.find("format: hapticcal-setup/1"), std::string::npos);
  EXPECT_NE(setup.find("device_frame: {xyz: ["), std::string::npos);
  const auto nominal_tool = testing::run_cli({"calibrate", "--model", model, "--log", log, "--out",
                                              out + "-nominal", "--tool-point", "nominal"});
  ASSERT_EQ(nominal_tool.exit_code, 0) << nominal_tool.out;
  EXPECT_EQ(load_device(out + "-nominal/device.yaml").tool, testing::meca500().tool);
  for (const char* bad : {"1,2", "0.1,0.2,x", "0.1,0.2,0.3,0.4", "20,0,0", "nominal,"}) {
    const auto refused = testing::run_cli(
        {"calibrate", "--model", model, "--log", log, "--out", out + "-bad", "--tool-point", bad});
    EXPECT_EQ(refused.exit_code, 2) << bad << ": " << refused.err;
    EXPECT_NE(refused.err.find("--tool-point"), std::string::npos) << refused.err;
    EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  }
}

}  // namespace
}  // namespace hapticcal
