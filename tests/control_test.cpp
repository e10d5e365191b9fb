// Force study: closed forms, the truth as the controller's model, the default
// simulated device, and refused gains.
#include "hapticcal/study/control.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <filesystem>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/study/simulation.hpp"
#include "hapticcal/study/study.hpp"
#include "kdl_chain.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

DeviceModel actual() { return paper_actual_device(testing::builtin("baser-7dof")); }

// KDL's Jacobian in the handle frame with joint 3 removed (transmission errors
// compensated first), independent of hapticcal's kinematics.
Eigen::Matrix<double, 6, 6> kdl_jacobian(const DeviceModel& m, const Eigen::VectorXd& q) {
  const KDL::Chain chain = testing::kdl_chain(m);
  const Eigen::VectorXd joint = m.compensate(q);
  KDL::JntArray a(m.dof());
  for (int i = 0; i < m.dof(); ++i) a(i) = joint[i];
  KDL::Frame f;
  KDL::ChainFkSolverPos_recursive(chain).JntToCart(a, f);
  KDL::Jacobian J(m.dof()), Jt(m.dof());
  KDL::ChainJntToJacSolver(chain).JntToJac(a, J);
  KDL::changeBase(J, f.M.Inverse(), Jt);
  Eigen::Matrix<double, 6, 6> out;
  for (int r = 0; r < 6; ++r) {
    for (int i = 0, c = 0; i < m.dof(); ++i) {
      if (i != 2) out(r, c++) = Jt(r, i);
    }
  }
  return out;
}

TEST(Control, TruthAsTheModelRendersNoTransverseForce) {
  ForceScenario sc;
  const ForceRun run = run_force(actual(), actual(), sc);
  double worst = 0;
  for (const Vector6d& w : run.measured) worst = std::max({worst, std::abs(w[0]), std::abs(w[1])});
  EXPECT_LT(worst, 1e-9);
  EXPECT_NEAR(run.measured.back()[2], 2.0, 1e-3);  // K * 20 mm, reached
}

// G = 0 and a constant desired force: W = J_a^-T J_m^T F_d (the models share
// their transmissions here, so the transmission terms cancel).
TEST(Control, WithoutFeedbackTheWrenchIsTheClosedForm) {
  const DeviceModel a = actual();
  std::mt19937_64 rng(3);
  DeviceModel m = testing::perturbed(a, rng, 0.01);
  ForceScenario sc;
  sc.gain = 0;
  sc.move_seconds = 0;
  sc.hold_seconds = 0.01;
  sc.posture = default_posture(a);
  const ForceRun run = run_force(a, m, sc);
  Vector6d Fd = Vector6d::Zero();
  Fd[2] = sc.stiffness * sc.travel;
  const Vector6d expected = kdl_jacobian(a, sc.posture)
                                .transpose()
                                .fullPivLu()
                                .solve(kdl_jacobian(m, sc.posture).transpose() * Fd);
  const Vector6d measured = run.measured.back();  // the sensor, one sample late: constant by now
  EXPECT_LT((measured - expected).norm(), 1e-12 * expected.norm());
  EXPECT_EQ(run.measured.front().norm(), 0.0);  // the first sample sees nothing yet
}

TEST(Control, CalibratedModelCutsTransverseForceByAtLeast90Percent) {
  const Scenario study = default_scenario(testing::source_path("data/devices/baser-7dof.yaml"));
  const TrialResult t = run_trial(study, trial_seed(study.seed, 0), "");
  ForceScenario sc;
  const ForceRun before = run_force(study.actual, study.nominal, sc);
  const ForceRun after = run_force(study.actual, t.full.calibrated, sc);
  std::printf("transverse RMS: nominal %.5f N, calibrated %.5f N\n", before.transverse_rms,
              after.transverse_rms);
  EXPECT_GT(before.transverse_rms, 1e-3);
  EXPECT_LT(after.transverse_rms, 0.1 * before.transverse_rms);
}

TEST(Control, GainOutsideTheStableRangeIsRefusedWithTheRange) {
  const std::string dir = ::testing::TempDir() + "/force_models";
  std::filesystem::create_directories(dir);
  save_device(actual(), dir + "/actual.yaml");
  const std::string nominal = testing::source_path("data/devices/baser-7dof.yaml");
  const std::string args = "force --actual " + dir + "/actual.yaml --nominal " + nominal +
                           " --calibrated " + dir + "/actual.yaml --out " + dir + "/out";
  const testing::CliResult bad = testing::run_cli(args + " --gain 1.2");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("outside the stable range: |G| < 0.99"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  const double limit = stable_gain_limit(actual(), testing::builtin("baser-7dof"), ForceScenario{});
  EXPECT_GT(limit, 0.9);
  EXPECT_LT(limit, 1.1);
  // A gain inside the range runs, and the loop settles on the desired force.
  const testing::CliResult good = testing::run_cli(args + " --gain 0.9");
  EXPECT_EQ(good.exit_code, 0) << good.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/out/force_calibrated.csv"));
  std::filesystem::remove_all(dir);
}

TEST(Control, SingularPostureIsRefused) {
  ForceScenario sc;
  sc.posture = Eigen::VectorXd::Zero(7);  // home: wrist axes 5 and 7 (nearly) aligned
  EXPECT_THROW(run_force(actual(), actual(), sc), InputError);
  EXPECT_THROW(run_force(testing::builtin("baser-7dof"), testing::builtin("baser-7dof"), sc),
               InputError);
  sc.posture = default_posture(actual());
  EXPECT_NO_THROW(run_force(actual(), actual(), sc));
}

// With the truth as the model the rendering map is the identity, so the sensed
// transverse force is noise fed back: s_k = -G s_(k-1) + sigma n_k per axis,
// whose stationary variance is sigma^2 / (1 - G^2). The RMS of sqrt(Fx^2 + Fy^2)
// is then sqrt(2) sigma without feedback (G = 0) and sqrt(2 / (1 - G^2)) sigma
// with it. 22 s at 1 kHz, two axes: the RMS is known to about 0.4 %; tolerance 2 %. The
// same seed gives the same run, another seed another one.
TEST(Control, SensorNoiseGivesTheClosedFormTransverseRmsAndIsSeeded) {
  const DeviceModel a = actual();
  for (const double gain : {0.0, 0.5}) {
    ForceScenario sc;
    sc.sensor_noise = 0.01;
    sc.gain = gain;
    sc.hold_seconds = 20;
    const ForceRun run = run_force(a, a, sc);
    const double expected = std::sqrt(2 / (1 - gain * gain)) * sc.sensor_noise;
    EXPECT_NEAR(run.transverse_rms / expected, 1.0, 0.02) << "G = " << gain;
    // The RMS over the recorded samples is the reported one.
    double sum = 0;
    for (const Vector6d& w : run.measured) sum += w[0] * w[0] + w[1] * w[1];
    EXPECT_NEAR(std::sqrt(sum / run.measured.size()), run.transverse_rms, 1e-15);
  }
  ForceScenario sc;
  sc.sensor_noise = 0.01;
  const ForceRun first = run_force(a, a, sc), again = run_force(a, a, sc);
  sc.seed = 2;
  const ForceRun other = run_force(a, a, sc);
  EXPECT_EQ(first.measured[500], again.measured[500]);
  EXPECT_NE(first.measured[500], other.measured[500]);
}

}  // namespace
}  // namespace hapticcal
