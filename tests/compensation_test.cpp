// Targets compensated for a controller that runs the nominal model: on a
// simulated 6R (the Meca500) and 7R (a Panda-like arm) whose truth is off the
// drawing and compliant under its links' weights, a program of 100 targets,
// compensated through a calibration from a tracker's poses, is reached by the
// truth within twice the calibration's predicted (held-out) accuracy, the
// nominal program's error shown beside; the controller's own inverse
// kinematics of each compensated pose gives back the compensated readings; the
// inverse kinematics converges to its tolerance on every target; a payload
// given to the compensation is what the truth carries; an unreachable target
// is named and has no command; the command line writes what the library finds.
#include "hapticcal/study/compensation.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/simulation.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// Masses of an arm's links (1-3 kg, their centres a few cm out) and, for the
// truth, joint compliance on the loaded joints.
DeviceModel with_masses(DeviceModel m) {
  for (size_t i = 0; i < m.links.size(); ++i) {
    m.links[i].mass = 3.0 - 0.3 * static_cast<double>(i);
    m.links[i].com = Eigen::Vector3d(0.04, 0.01, 0.02);
  }
  return m;
}

DeviceModel compliant_truth(const DeviceModel& nominal, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  DeviceModel truth = testing::perturbed(nominal, rng, 1e-3);
  truth.base = nominal.base;  // the robot's frame is the measurement frame
  truth.links[1].compliance = 6e-4;
  truth.links[2].compliance = 8e-4;
  truth.links[4].compliance = 1e-3;
  return truth;
}

// The smallest singular value of the nominal model's Jacobian with respect to
// the readings at q (rotation rows times 0.1 m), by Eigen's SVD.
double conditioning(const DeviceModel& nominal, const Eigen::VectorXd& q) {
  const PreparedModel prepared(nominal);
  Jacobian6<double> J(6, nominal.dof());
  prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J);
  Eigen::MatrixXd reading(nominal.dof(), nominal.dof());
  prepared.reading_jacobian(q.data(), reading.data());
  Eigen::MatrixXd A = J * reading;
  A.bottomRows(3) *= 0.1;
  return Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues().minCoeff();
}

// The program: joint targets drawn within the limits, taught on the nominal
// model, as a program is planned: away from singularities.
Log joint_program(const DeviceModel& nominal, int rows, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Log log = testing::blank_marker_log("program.csv", rows, nominal.dof(), 0);
  for (int r = 0; r < rows; ++r) {
    Eigen::VectorXd q = testing::random_readings(nominal, rng);
    // Away from the limits' edges: a compensation moves a reading a little.
    for (int i = 0; i < nominal.dof(); ++i) {
      const Link& l = nominal.links[static_cast<size_t>(i)];
      q[i] = 0.5 * (l.lower + l.upper) + 0.8 * (q[i] - 0.5 * (l.lower + l.upper));
    }
    if (conditioning(nominal, q) < 0.02) {
      --r;  // drawn again
      continue;
    }
    log.q.row(r) = q.transpose();
  }
  return log;
}

struct Arm {
  const char* name;
  DeviceModel nominal;
};

TEST(Compensation, TheTruthReachesTheCompensatedProgram) {
  for (const Arm& arm : {Arm{"6R", with_masses(testing::meca500())},
                         Arm{"7R", with_masses(testing::panda_like())}}) {
    SCOPED_TRACE(arm.name);
    const DeviceModel& nominal = arm.nominal;
    const DeviceModel truth = compliant_truth(nominal, 57);
    SimulationNoise noise;
    noise.sigma_position = 2e-5;
    noise.sigma_orientation = 2e-5;
    const Log poses =
        simulate_measurement_log(truth, MeasurementType::kPose, 300, Eigen::MatrixXd(), noise, 7);
    const CalibrationResult cal = calibrate(nominal, poses, CalibrationOptions{});
    ASSERT_EQ(cal.status, CalibrationStatus::kConverged) << cal.status_reason;
    const double predicted = cal.kinematics.cv_rms;  // held-out position RMS [m]
    ASSERT_TRUE(std::isfinite(predicted));

    const Log program = joint_program(nominal, 100, 11);
    const std::vector<CompensatedTarget> targets =
        compensate_targets(cal.calibrated, nominal, program);
    const PreparedModel actual(truth), controller(nominal);
    double before = 0, after = 0;
    int usable = 0;
    for (size_t k = 0; k < targets.size(); ++k) {
      const CompensatedTarget& t = targets[k];
      // Within the limits (the program keeps off their edges and away from
      // singularities), reached to the tolerance.
      EXPECT_LE(t.calibrated.position_error, 1e-9) << "line " << t.line;
      EXPECT_LE(t.calibrated.rotation_error, 1e-9) << "line " << t.line;
      EXPECT_FALSE(t.near_singularity()) << "line " << t.line;
      EXPECT_TRUE(t.usable()) << "line " << t.line << ": " << to_string(t.calibrated.status);
      if (!t.usable()) continue;
      ++usable;
      // The controller, given the compensated pose, solves its nominal
      // inverse kinematics from the program's readings: the compensated ones.
      Eigen::VectorXd commanded(nominal.dof());
      const Eigen::VectorXd from = program.q.row(static_cast<Eigen::Index>(k)).transpose();
      const InverseResult solved =
          inverse_kinematics(controller, t.command, from.data(), commanded.data());
      ASSERT_EQ(solved.status, InverseStatus::kConverged);
      // The same readings (a redundant arm's: further along its self-motion
      // by 1e-4 rad at most, the calibrated model's tool microns away).
      const Frame<double> reached = PreparedModel(cal.calibrated).forward(commanded.data());
      EXPECT_LT((reached.p - t.target.p).norm(), 1e-5);
      if (nominal.dof() == 6) EXPECT_LT((commanded - t.readings).cwiseAbs().maxCoeff(), 1e-6);
      before += (actual.forward(from.data()).p - t.target.p).squaredNorm();
      after += (actual.forward(commanded.data()).p - t.target.p).squaredNorm();
    }
    ASSERT_EQ(usable, 100);
    before = std::sqrt(before / usable);
    after = std::sqrt(after / usable);
    std::printf(
        "[ figures  ] %s: the truth's RMS position error on a program of 100 targets: nominal "
        "program %.4f mm, compensated %.4f mm; the calibration's held-out RMS %.4f mm\n",
        arm.name, before * 1e3, after * 1e3, predicted * 1e3);
    // A target at a singularity (the 6R's wrist: joint 5 at 0 puts the axes
    // of joints 4 and 6 in line) is named.
    if (nominal.dof() == 6) {
      Log singular = joint_program(nominal, 1, 11);
      singular.q(0, 4) = 0;
      const CompensatedTarget at = compensate_targets(cal.calibrated, nominal, singular).front();
      EXPECT_TRUE(at.near_singularity() || !at.usable()) << to_string(at.calibrated.status);
    }
    EXPECT_LT(after, 2 * predicted);
    EXPECT_LT(after, 0.1 * before);
  }
}

// A payload the truth carries: the compensation told of it reaches the
// targets as well as without one; told nothing, it is off by the deflection.
TEST(Compensation, APayloadGivenIsThePayloadCarried) {
  const DeviceModel nominal = with_masses(testing::meca500());
  const DeviceModel truth = compliant_truth(nominal, 58);
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  noise.sigma_orientation = 2e-5;
  CalibrationOptions options;
  options.joint_errors = {"compliance"};
  const CalibrationResult cal = calibrate(
      nominal,
      simulate_measurement_log(truth, MeasurementType::kPose, 300, Eigen::MatrixXd(), noise, 8),
      options);
  ASSERT_EQ(cal.status, CalibrationStatus::kConverged) << cal.status_reason;
  const Log program = joint_program(nominal, 50, 12);
  const PreparedModel loaded(with_load(truth, 4.0));
  const auto error = [&](double load) {
    CompensationOptions o;
    o.load = load;
    double sum = 0;
    for (const CompensatedTarget& t : compensate_targets(cal.calibrated, nominal, program, o)) {
      EXPECT_TRUE(t.usable());
      sum += (loaded.forward(t.readings.data()).p - t.target.p).squaredNorm();
    }
    return std::sqrt(sum / program.rows);
  };
  const double told = error(4.0), untold = error(0.0);
  std::printf("[ figures  ] 4 kg carried: compensated for it %.4f mm, not %.4f mm\n", told * 1e3,
              untold * 1e3);
  EXPECT_LT(told, 0.5 * untold);
  EXPECT_LT(told, 2 * cal.kinematics.cv_rms);
  EXPECT_THROW(with_load(nominal, -1), InputError);
}

// The command line: compensated.csv holds the library's readings and poses; a
// Cartesian target 10 m away is named, its row has no command.
TEST(Compensation, CommandLineWritesTheCompensatedProgram) {
  const std::string dir = testing::fresh_folder("compensation_cli");
  const DeviceModel nominal = with_masses(testing::meca500());
  const DeviceModel calibrated = compliant_truth(nominal, 59);  // a calibrated model
  save_device(nominal, dir + "/nominal.yaml");
  save_device(calibrated, dir + "/calibrated.yaml");
  const Log program = joint_program(nominal, 5, 13);
  const std::vector<CompensatedTarget> expected = compensate_targets(
      load_device(dir + "/calibrated.yaml"), load_device(dir + "/nominal.yaml"), program);
  // Cartesian targets: the joint targets' poses, the readings their configuration.
  std::string csv = "q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n";
  for (int r = 0; r <= program.rows; ++r) {
    const int k = std::min(r, program.rows - 1);
    for (int i = 0; i < 6; ++i) csv += fmt::format("{},", program.q(k, i));
    const Frame<double>& T = expected[static_cast<size_t>(k)].target;
    const Eigen::Quaterniond turn(T.R);
    const double far = r == program.rows ? 10 : 0;  // the last: out of reach
    csv += fmt::format("{},{},{},{},{},{},{}\n", T.p.x() + far, T.p.y(), T.p.z(), turn.w(),
                       turn.x(), turn.y(), turn.z());
  }
  write_file_atomically(dir + "/program.csv", csv);
  const testing::CliResult r = testing::run_cli({"compensate", "--model", dir + "/calibrated.yaml",
                                                 "--nominal", dir + "/nominal.yaml", "--targets",
                                                 dir + "/program.csv", "--out", dir + "/out"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("5 of 6 targets compensated (Cartesian targets"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("program.csv:7: no command"), std::string::npos) << r.out;
  std::istringstream rows(testing::slurp(dir + "/out/compensated.csv"));
  std::string line;
  std::getline(rows, line);
  EXPECT_EQ(line.rfind("line,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,status", 0), 0u) << line;
  for (int k = 0; k <= program.rows && std::getline(rows, line); ++k) {
    std::vector<std::string> fields;
    std::stringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) fields.push_back(cell);
    ASSERT_GE(fields.size(), 16u) << line;
    if (k == program.rows) {
      EXPECT_EQ(fields[1], "") << line;
      EXPECT_EQ(fields[14], "not converged") << line;
      continue;
    }
    EXPECT_EQ(fields[14], "converged") << line;
    for (int i = 0; i < 6; ++i)
      EXPECT_NEAR(std::stod(fields[static_cast<size_t>(1 + i)]),
                  expected[static_cast<size_t>(k)].readings[i], 1e-8)
          << line;
    EXPECT_NEAR(std::stod(fields[7]), expected[static_cast<size_t>(k)].command.p.x(), 1e-9);
  }
  // A calibrated model ending at another tool (a tracker's target 40 mm out)
  // than the controller's is refused, not compensated to the wrong point.
  DeviceModel other_tool = load_device(dir + "/calibrated.yaml");
  other_tool.tool[2] += 0.04;
  save_device(other_tool, dir + "/target.yaml");
  const testing::CliResult tool = testing::run_cli({"compensate", "--model", dir + "/target.yaml",
                                                    "--nominal", dir + "/nominal.yaml", "--targets",
                                                    dir + "/program.csv", "--out", dir + "/tool"});
  EXPECT_EQ(tool.exit_code, 2);
  EXPECT_NE(tool.err.find("--tool-point nominal"), std::string::npos) << tool.err;
  // A continuous joint's reading has no limits to leave.
  DeviceModel endless = nominal;
  endless.links[5].type = JointType::kContinuous;
  std::vector<double> lower(6), upper(6);
  reading_limits(endless, lower.data(), upper.data());
  EXPECT_TRUE(std::isinf(lower[5]) && std::isinf(upper[5]) && upper[5] > 0);
  EXPECT_EQ(lower[4], nominal.links[4].lower);
  // Models of two devices are refused with one line.
  const testing::CliResult other = testing::run_cli(
      {"compensate", "--model", dir + "/calibrated.yaml", "--nominal", "geomagic-touch",
       "--targets", dir + "/program.csv", "--out", dir + "/other"});
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_NE(other.err.find("not of one device"), std::string::npos) << other.err;
}

}  // namespace
}  // namespace hapticcal
