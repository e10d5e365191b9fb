// Joint compliance (issue 25, item 2a): gravity torques from the links' masses
// (a URDF's <inertial> elements), the deflection theta += k tau they cause in
// every path from readings to joint values, and k fitted with the geometry in
// step 2 from tracker positions.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/runtime.h"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "support/held_out.hpp"
#include "support/kdl_chain.hpp"
#include "support/run_cli.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

DeviceModel arm() {
  return load_urdf(testing::source_path("tests/data/urdf/compliant-arm.urdf"), "tool");
}

// The arm with compliances of 3e-4, 5e-4 and 1e-3 rad/N m on its loaded
// joints 2, 3 and 5 (the others carry no gravity torque or k = 0).
DeviceModel compliant_arm() {
  DeviceModel m = arm();
  m.links[1].compliance = 3e-4;
  m.links[2].compliance = 5e-4;
  m.links[4].compliance = 1e-3;
  return m;
}

// The gravity torque on each joint by central differences of the potential
// energy's gradient, Q_i = d/dtheta_i sum_j m_j g . c_j(theta), with the
// centres c_j placed by KDL's own forward kinematics: independent of
// gravity_torques' recursion.
Eigen::VectorXd torques_by_energy(const DeviceModel& m, const Eigen::VectorXd& theta) {
  KDL::Chain chain = testing::kdl_chain(m);
  const int n = m.dof();
  auto work = [&](const Eigen::VectorXd& joint) {  // sum_j m_j g . c_j
    KDL::ChainFkSolverPos_recursive fk(chain);
    KDL::JntArray q(n);
    for (int i = 0; i < n; ++i) q(i) = joint[i];
    const KDL::Vector g =
        testing::kdl_pose(m.base).M * KDL::Vector(m.gravity[0], m.gravity[1], m.gravity[2]);
    double sum = 0;
    // Segment index of link j's frame: base, then each URDF joint as an
    // origin segment and a joint segment (kdl_chain.hpp).
    for (int j = 0; j < n; ++j) {
      KDL::Frame f;
      fk.JntToCart(q, f, 1 + 2 * (j + 1));
      const KDL::Vector c =
          f * KDL::Vector(m.links[j].com[0], m.links[j].com[1], m.links[j].com[2]);
      sum += m.links[j].mass * (g[0] * c[0] + g[1] * c[1] + g[2] * c[2]);
    }
    return sum;
  };
  Eigen::VectorXd tau(n);
  const double h = 1e-6;
  for (int i = 0; i < n; ++i) {
    Eigen::VectorXd plus = theta, minus = theta;
    plus[i] += h;
    minus[i] -= h;
    tau[i] = (work(plus) - work(minus)) / (2 * h);
  }
  return tau;
}

TEST(Compliance, UrdfInertialsAreLumpedIntoTheLinksThatCarryThem) {
  const DeviceModel m = arm();
  ASSERT_EQ(m.dof(), 6);
  EXPECT_DOUBLE_EQ(m.links[1].mass, 6.0);
  EXPECT_LT((m.links[1].com - Eigen::Vector3d(0.2, 0, 0.01)).norm(), 1e-15);
  // link6 (0.5 kg at 0.02 m) and the tool (0.8 kg at 0.05 + 0.03 m, 0.02 m up).
  EXPECT_DOUBLE_EQ(m.links[5].mass, 1.3);
  const Eigen::Vector3d expected =
      (0.5 * Eigen::Vector3d(0.02, 0, 0) + 0.8 * Eigen::Vector3d(0.08, 0, 0.02)) / 1.3;
  EXPECT_LT((m.links[5].com - expected).norm(), 1e-15);
  const DeviceModel back = parse_device(device_to_yaml(compliant_arm()), "written.yaml");
  EXPECT_EQ(back.links[5].mass, m.links[5].mass);
  EXPECT_EQ(back.links[5].com, m.links[5].com);
  EXPECT_EQ(back.links[2].compliance, 5e-4);
  EXPECT_EQ(back.gravity, m.gravity);
}

// Gravity torques against the energy gradient; the prepared kinematics of a
// compliant model against KDL at the deflected joint values; d theta / d q and
// the runtime's torques against central differences.
TEST(Compliance, DeflectionMatchesTheEnergyGradientAndKdl) {
  const DeviceModel m = compliant_arm();
  const int n = m.dof();
  const GravityModel gravity(m);
  const PreparedModel prepared(m);
  KDL::Chain chain = testing::kdl_chain(m);
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::ChainJntToJacSolver jac(chain);
  const std::string path = testing::fresh_folder("compliance_runtime") + "/arm.yaml";
  save_device(m, path);
  hapticcal_model* runtime = nullptr;
  ASSERT_EQ(hapticcal_load(path.c_str(), nullptr, nullptr, &runtime, nullptr, 0), HAPTICCAL_OK);
  std::mt19937_64 rng(4);
  double largest = 0;
  for (int k = 0; k < 100; ++k) {
    const Eigen::VectorXd q = testing::random_readings(m, rng);
    Eigen::VectorXd tau(n);
    gravity.torques(q.data(), tau.data());
    const Eigen::VectorXd reference = torques_by_energy(m, q);
    ASSERT_LT((tau - reference).cwiseAbs().maxCoeff(), 1e-6) << tau.transpose();
    largest = std::max(largest, tau.cwiseAbs().maxCoeff());
    Eigen::VectorXd theta = q;
    for (int i = 0; i < n; ++i) theta[i] += m.links[i].compliance * reference[i];
    EXPECT_LT((m.compensate(q) - theta).cwiseAbs().maxCoeff(), 1e-9);
    const testing::KdlSolution ref = testing::kdl_solve(fk, jac, m.compensate(q));
    Jacobian6<double> J;
    const Frame<double> T = prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J);
    ASSERT_LT((T.p - ref.T.p).norm(), 1e-12);
    ASSERT_LT((J - ref.J).cwiseAbs().maxCoeff(), 1e-12);
    Eigen::MatrixXd D(n, n);
    prepared.reading_jacobian(q.data(), D.data());
    const double h = 1e-5;
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      const Eigen::VectorXd numeric = (m.compensate(qp) - m.compensate(qm)) / (2 * h);
      EXPECT_LT((numeric - D.col(j)).cwiseAbs().maxCoeff(), 1e-7) << j;
    }
    Eigen::Matrix<double, 6, 1> F;
    F << 2.0, -1.0, 3.0, 0.2, 0.1, -0.1;
    Eigen::VectorXd torques(n);
    ASSERT_EQ(hapticcal_joint_torques(runtime, q.data(), F.data(), HAPTICCAL_FRAME_MEASUREMENT,
                                      torques.data()),
              HAPTICCAL_OK);
    EXPECT_LT((torques - (ref.J * D).transpose() * F).cwiseAbs().maxCoeff(), 1e-9);
  }
  EXPECT_GT(largest, 20.0);  // N m: the shoulder carries the arm
  hapticcal_free(runtime);
}

// Acceptance: geometric-only leaves more than 3 times the noise on held-out
// poses; with the compliance family the held-out error is within 10 % of the
// noise floor and each k within 3 sd of the truth.
TEST(Compliance, JointComplianceIsRecoveredFromTrackerPositions) {
  const DeviceModel nominal = arm();
  std::mt19937_64 rng(7);
  DeviceModel actual = testing::perturbed(nominal, rng, 5e-4);
  const DeviceModel loaded = compliant_arm();
  for (int i = 0; i < actual.dof(); ++i) actual.links[i].compliance = loaded.links[i].compliance;
  const auto [cal, val, floor] = testing::held_out_study(actual, 300, 10e-6, 1);

  CalibrationOptions geometry_alone;
  geometry_alone.joint_errors = {"none"};
  const CalibrationResult geometric = calibrate(nominal, cal, geometry_alone);
  ASSERT_EQ(geometric.status, CalibrationStatus::kConverged) << geometric.status_reason;
  const double geometric_rms = evaluate(geometric.calibrated, val).figure("position")->stats.rms;
  EXPECT_GT(geometric_rms, 3 * floor) << geometric_rms;
  // The default's search finds the family by itself.
  const CalibrationResult found = calibrate(nominal, cal, {});
  ASSERT_EQ(found.status, CalibrationStatus::kConverged) << found.status_reason;
  const std::vector<std::string>& families = found.kinematics.joint_error_families;
  EXPECT_NE(std::find(families.begin(), families.end(), "compliance"), families.end());
  EXPECT_LT(evaluate(found.calibrated, val).figure("position")->stats.rms, 1.1 * floor);

  CalibrationOptions options;
  options.joint_errors = {"compliance"};
  const CalibrationResult r = calibrate(nominal, cal, options);
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  const double rms = evaluate(r.calibrated, val).figure("position")->stats.rms;
  EXPECT_LT(rms, 1.1 * floor) << rms << " vs " << floor;
  std::printf("compliance: held-out %.4f mm geometric, %.4f mm with k (floor %.4f mm)\n",
              geometric_rms * 1e3, rms * 1e3, floor * 1e3);
  int identified = 0;
  for (int i = 0; i < actual.dof(); ++i) {
    const ParameterEstimate* e = testing::find_parameter(r.kinematics, actual.links[i].name + ".k");
    ASSERT_NE(e, nullptr) << i;
    std::printf("  %s: %.3e (truth %.1e) sd %.1e %s\n", e->name.c_str(), e->value,
                actual.links[i].compliance, e->sd, e->reason.c_str());
    if (!e->reason.empty()) {
      EXPECT_EQ(actual.links[i].compliance, 0.0) << e->name << " held: " << e->reason;
      continue;
    }
    ++identified;
    EXPECT_LT(std::abs(e->value - actual.links[i].compliance), 3 * e->sd) << e->name;
    EXPECT_EQ(r.calibrated.links[i].compliance, e->value);
  }
  EXPECT_GE(identified, 3);
  EXPECT_TRUE(r.calibrated.fitted.empty());
}

// A device file that states its compliance and masses is its own truth here:
// fitting k from it starts at the stated deflection (counted once: the
// nominal residual is the noise), and the simulated external encoders read the
// drive's angle, so step 1 fits no deflection into the transmissions.
TEST(Compliance, StatedComplianceIsCountedOnceAndStepOneSeesNoDeflection) {
  DeviceModel truth = compliant_arm();
  Capstan c;
  c.ratio = 10;
  c.drum_distance = 0.01;
  truth.links[1].transmission = Transmission(c);  // step 1 on the loaded shoulder
  SimulationNoise noise;
  noise.sigma_position = 10e-6;
  noise.sigma_ext = 1e-6;
  const Log cal = simulate_log(truth, 200, noise, 5, false, true);
  ASSERT_TRUE(cal.has_ext[1]);
  CalibrationOptions options;
  options.joint_errors = {"compliance"};
  const CalibrationResult r = calibrate(truth, cal, options);
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  EXPECT_LT(r.kinematics.rms_before, 2 * std::sqrt(3.0) * 10e-6) << r.kinematics.rms_before;
  std::mt19937_64 rng(6);
  for (int k = 0; k < 100; ++k) {
    const double q = testing::random_readings(truth, rng)[1];
    EXPECT_LT(std::abs(r.calibrated.links[1].transmission.error(q)), 2e-5) << q;
  }
}

}  // namespace
}  // namespace hapticcal
