// Coupled joints (issue 25, item 3): a joint's angle a linear combination of
// readings, theta = C (q + dtheta(q)): a passive joint driven by two others, a
// parallelogram's relative reading. The kinematics, the runtime and the force
// study against KDL and central differences; the device file and URDF <mimic>;
// a passive joint that calibrates on the first run.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <numbers>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/runtime.h"
#include "hapticcal/study/control.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "support/held_out.hpp"
#include "support/kdl_chain.hpp"
#include "support/run_cli.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

// A 7-joint arm whose fourth joint is passive and keeps the wrist level
// (examples/coupled/level-arm.yaml): joints 2, 3 and 4 are parallel and
// theta4 = -(u2 + u3) (u_k: reading k through its transmission). Joint 2 has
// a capstan, so the coupling acts on a compensated reading.

DeviceModel level_arm() {
  return load_device(testing::source_path("examples/coupled/level-arm.yaml"));
}

// theta by hand from the file's words: each reading through its own
// transmission, joint 4 = -(u2 + u3), the others their own reading.
Eigen::VectorXd joint_values_by_hand(const DeviceModel& m, const Eigen::VectorXd& q) {
  Eigen::VectorXd u(q.size());
  for (int k = 0; k < q.size(); ++k) u[k] = q[k] + m.links[k].transmission.error(q[k]);
  Eigen::VectorXd theta = u;
  theta[3] = -(u[1] + u[2]);
  return theta;
}

TEST(Coupling, DeviceFileCouplingIsReadWrittenAndApplied) {
  const DeviceModel m = level_arm();
  ASSERT_TRUE(m.coupled());
  EXPECT_FALSE(m.reading_used(3));  // joint 4 is passive
  EXPECT_TRUE(m.reading_used(1));
  EXPECT_EQ(m.coupling(3, 1), -1);
  EXPECT_EQ(m.coupling(3, 2), -1);
  EXPECT_EQ(m.coupling(3, 3), 0);
  const DeviceModel back = parse_device(device_to_yaml(m), "written.yaml");
  EXPECT_EQ(back.coupling, m.coupling);
  std::mt19937_64 rng(3);
  const PreparedModel prepared(m);
  for (int k = 0; k < 50; ++k) {
    const Eigen::VectorXd q = testing::random_readings(m, rng);
    const Eigen::VectorXd theta = joint_values_by_hand(m, q);
    EXPECT_LT((m.compensate(q) - theta).cwiseAbs().maxCoeff(), 1e-15);
    Eigen::VectorXd joint(q.size());
    prepared.compensate(q.data(), joint.data());
    EXPECT_LT((joint - theta).cwiseAbs().maxCoeff(), 1e-15);
  }
}

// The prepared (runtime) kinematics of a coupled model from the readings
// against KDL's from joint values formed by hand; d theta / d q against central
// differences; the runtime's torques against virtual work, tau_q = (J dtheta/dq)^T F.
TEST(Coupling, PreparedKinematicsAndTorquesMatchKdlThroughTheCoupling) {
  const DeviceModel m = level_arm();
  const int n = m.dof();
  const PreparedModel prepared(m);
  KDL::Chain chain = testing::kdl_chain(m);
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::ChainJntToJacSolver jac(chain);
  const std::string path = testing::fresh_folder("coupling_runtime") + "/level-arm.yaml";
  save_device(m, path);
  hapticcal_model* runtime = nullptr;
  ASSERT_EQ(hapticcal_load(path.c_str(), nullptr, nullptr, &runtime, nullptr, 0), HAPTICCAL_OK);
  std::mt19937_64 rng(5);
  const double h = 1e-6;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::VectorXd q = testing::random_readings(m, rng);
    const testing::KdlSolution ref = testing::kdl_solve(fk, jac, joint_values_by_hand(m, q));
    Jacobian6<double> J;
    const Frame<double> T = prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J);
    ASSERT_LT((T.p - ref.T.p).norm(), 1e-12);
    ASSERT_LT((T.R - ref.T.R).norm(), 1e-12);
    ASSERT_LT((J - ref.J).cwiseAbs().maxCoeff(), 1e-12);
    if (k % 20 != 0) continue;
    Eigen::MatrixXd D(n, n);
    prepared.reading_jacobian(q.data(), D.data());
    EXPECT_LT((D - m.reading_jacobian(q)).cwiseAbs().maxCoeff(), 1e-15);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      const Eigen::VectorXd numeric = (m.compensate(qp) - m.compensate(qm)) / (2 * h);
      EXPECT_LT((numeric - D.col(j)).cwiseAbs().maxCoeff(), 1e-8) << j;
    }
    EXPECT_EQ(D.col(3).norm(), 0.0);  // the passive joint's own reading moves nothing
    Eigen::Matrix<double, 6, 1> F;
    F << 1.0, -2.0, 0.5, 0.1, 0.2, -0.3;
    Eigen::VectorXd tau(n);
    ASSERT_EQ(hapticcal_joint_torques(runtime, q.data(), F.data(), HAPTICCAL_FRAME_MEASUREMENT,
                                      tau.data()),
              HAPTICCAL_OK);
    const Eigen::VectorXd expected = (ref.J * D).transpose() * F;
    EXPECT_LT((tau - expected).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(tau[3], 0.0);
  }
  hapticcal_free(runtime);
}

// The actuated readings' handle Jacobian J_q = J (d theta / d q) from KDL's
// tool-frame Jacobian at joint values formed by hand and d theta / d q by
// central differences, the passive reading's column left out.
Eigen::Matrix<double, 6, 6> actuated_jacobian(const DeviceModel& m, const Eigen::VectorXd& q) {
  KDL::Chain chain = testing::kdl_chain(m);
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::ChainJntToJacSolver jac(chain);
  const testing::KdlSolution ref = testing::kdl_solve(fk, jac, joint_values_by_hand(m, q));
  Eigen::Matrix<double, 6, 6> Jq;
  const double h = 1e-7;
  for (int k = 0, c = 0; k < m.dof(); ++k) {
    if (k == 3) continue;
    Eigen::VectorXd qp = q, qm = q;
    qp[k] += h;
    qm[k] -= h;
    const Eigen::VectorXd D = (joint_values_by_hand(m, qp) - joint_values_by_hand(m, qm)) / (2 * h);
    Jq.col(c++) = ref.J_tool * D;
  }
  return Jq;
}

// The force study maps wrenches to the actuated readings through C^T: its
// rendering map for a controller model that differs from the device equals
// J_q,a^-T J_q,m^T formed independently; the passive joint is not actuated and
// cannot be locked.
TEST(Coupling, ForceStudyRendersThroughTheActuatedReadings) {
  const DeviceModel m = level_arm();
  std::mt19937_64 rng(21);
  const DeviceModel controller = testing::perturbed(m, rng, 0.01);
  ForceScenario sc;
  sc.posture = Eigen::VectorXd::Zero(m.dof());
  sc.posture << 0.3, 0.4, -0.6, 0.0, 0.5, 0.7, 0.2;
  sc.locked_joint = ForceScenario::kLockRedundant;  // 6 actuated joints: none locked
  EXPECT_EQ(resolved_locked_joint(sc, m), ForceScenario::kNoLock);
  const Eigen::Matrix<double, 6, 6> A = rendering_map(m, controller, sc);
  const Eigen::Matrix<double, 6, 6> expected =
      actuated_jacobian(m, sc.posture).transpose().inverse() *
      actuated_jacobian(controller, sc.posture).transpose();
  EXPECT_LT((A - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  EXPECT_GT((A - Eigen::Matrix<double, 6, 6>::Identity()).cwiseAbs().maxCoeff(), 1e-3);
  sc.locked_joint = 3;
  EXPECT_THROW(resolved_locked_joint(sc, m), InputError);
}

// Acceptance: a simulated arm with a passive joint coupled to two others
// calibrates on the first run, without --fix, says which parameters the
// coupling leaves to the prior, and predicts held-out poses to the noise.
TEST(Coupling, PassiveJointCoupledToTwoOthersCalibratesOnTheFirstRun) {
  const DeviceModel nominal = level_arm();
  std::mt19937_64 rng(11);
  DeviceModel actual = testing::perturbed(nominal, rng, 2e-3);
  const auto [cal, val, floor] = testing::held_out_study(actual, 200, 20e-6, 1);

  const CalibrationResult r = calibrate(nominal, cal, CalibrationOptions{});
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  const double held_out = evaluate(r.calibrated, val).figure("position")->stats.rms;
  EXPECT_LT(held_out, 1.2 * floor) << held_out << " vs " << floor;
  const double before = evaluate(nominal, val).figure("position")->stats.rms;
  EXPECT_GT(before, 10 * floor);
  EXPECT_EQ(r.calibrated.coupling, nominal.coupling);
  std::printf("passive joint: held-out %.4f mm (nominal %.3f mm, noise floor %.4f mm)\n",
              held_out * 1e3, before * 1e3, floor * 1e3);

  // The coupling keeps joint 4's frame level: j2, j3 and j4's rotations about
  // their parallel axes sum to a constant, so j4.a always points the way j1.a
  // does and j5's axis stays parallel to j1's (j5.d is j1.d). The rank test,
  // drawing its poses through the coupling, holds them and says why.
  const KinematicFit& k = r.kinematics;
  int left = 0;
  for (const ParameterEstimate& e : k.parameters) {
    if (e.set_by_prior || !e.reason.empty()) ++left;
  }
  EXPECT_GT(left, 0);
  for (const char* name : {"j4.a", "j5.d"}) {
    const ParameterEstimate* e = testing::find_parameter(k, name);
    ASSERT_NE(e, nullptr);
    EXPECT_NE(e->reason.find("dependent"), std::string::npos) << name << ": " << e->reason;
  }
  // The same data read as if the passive joint's angle were a reading of its
  // own (the model without its coupling, q4 = -(q2 + q3)).
  DeviceModel uncoupled = nominal;
  uncoupled.coupling.resize(0, 0);
  Log as_read = cal;
  as_read.q.col(3) = -(as_read.q.col(1) + as_read.q.col(2));
  const CalibrationResult u = calibrate(uncoupled, as_read, CalibrationOptions{});
  // Its rank test draws q4 independently and offers j4.a, which the data
  // cannot tell from j1.a: the fit moves it by centimetres, correlated with
  // j1.a; the held-out poses (read as the log reads them) judge the model,
  // and the move is reported beside what it trades with.
  const ParameterEstimate* j4a = testing::find_parameter(u.kinematics, "j4.a");
  ASSERT_NE(j4a, nullptr);
  std::printf("read as uncoupled: %s, j4.a moved %.1f mm (largest correlation %.2f with %s)\n",
              to_string(u.status), (j4a->value - j4a->nominal) * 1e3, j4a->max_correlation,
              j4a->max_correlation_with.c_str());
  if (j4a->identifiable && j4a->large_change) {
    EXPECT_FALSE(j4a->max_correlation_with.empty());
  }
  bool noted = false;
  for (const std::string& note : r.notes)
    noted = noted || note.find("passive") != std::string::npos;
  EXPECT_TRUE(noted);
}

// --joint-errors coupling: the passive joint's coefficients are off by 2 % and
// 1.5 % (its linkage's ratios). The geometry alone cannot express an angle error
// proportional to the readings; with the coupling family each coefficient is
// within 3 sd of the truth, the calibrated model carries them, and held-out
// poses are predicted to the noise. Joint 4's external encoder reads its angle
// through the coefficients, so step 1 leaves it out (mapped back through the
// nominal C it put the coefficients' error into a polynomial on joint 3 and the
// fit stopped at 1.2 mm).
TEST(Coupling, CouplingCoefficientsAreFittedWithJointErrorsCoupling) {
  const DeviceModel nominal = level_arm();
  std::mt19937_64 rng(12);
  DeviceModel actual = testing::perturbed(nominal, rng, 1e-3);
  actual.coupling(3, 1) = -1.02;
  actual.coupling(3, 2) = -0.985;
  const auto [cal, val, floor] = testing::held_out_study(actual, 200, 20e-6, 3);

  CalibrationOptions geometry_alone;
  geometry_alone.joint_errors = {"none"};
  const CalibrationResult geometric = calibrate(nominal, cal, geometry_alone);
  const double geometric_rms = evaluate(geometric.calibrated, val).figure("position")->stats.rms;
  EXPECT_GT(geometric_rms, 3 * floor);
  // The default's search finds the family by itself.
  const CalibrationResult found = calibrate(nominal, cal, {});
  ASSERT_EQ(found.status, CalibrationStatus::kConverged) << found.status_reason;
  EXPECT_EQ(found.kinematics.joint_error_families, std::vector<std::string>{"coupling"});
  EXPECT_LT(evaluate(found.calibrated, val).figure("position")->stats.rms, 1.2 * floor);

  CalibrationOptions options;
  options.joint_errors = {"coupling"};
  const CalibrationResult r = calibrate(nominal, cal, options);
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  const double held_out = evaluate(r.calibrated, val).figure("position")->stats.rms;
  EXPECT_LT(held_out, 1.2 * floor);
  EXPECT_TRUE(r.calibrated.fitted.empty());
  bool left_out = false;
  for (const std::string& note : r.notes)
    left_out = left_out || note.find("j4 are left out of step 1") != std::string::npos;
  EXPECT_TRUE(left_out);
  for (const auto& [name, reading] : {std::pair{"j4.c_j2", 1}, std::pair{"j4.c_j3", 2}}) {
    const ParameterEstimate* e = testing::find_parameter(r.kinematics, name);
    ASSERT_NE(e, nullptr) << name;
    EXPECT_TRUE(e->identifiable) << name << ": " << e->reason;
    EXPECT_LT(std::abs(e->value - actual.coupling(3, reading)), 3 * e->sd)
        << name << " " << e->value << " +- " << e->sd;
    EXPECT_EQ(r.calibrated.coupling(3, reading), e->value) << name;
  }
  std::printf(
      "coupling coefficients: held-out %.4f mm (geometry alone %.4f mm, noise floor %.4f mm)\n",
      held_out * 1e3, geometric_rms * 1e3, floor * 1e3);
  // Refused where there is nothing to fit.
  DeviceModel uncoupled = nominal;
  uncoupled.coupling.resize(0, 0);
  EXPECT_THROW(calibrate(uncoupled, cal, options), InputError);
}

// A URDF mimic joint is a passive joint that follows one reading: theta =
// multiplier q_k + offset. Read, exported as URDF and read back.
TEST(Coupling, UrdfMimicJointIsAPassiveCoupledJoint) {
  const std::string urdf = R"(<?xml version="1.0"?>
<robot name="mimic">
  <link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
  <joint name="j3" type="revolute"><parent link="c"/><child link="d"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/>
    <mimic joint="j2" multiplier="-0.5" offset="0.1"/></joint>
</robot>
)";
  const DeviceModel m = parse_urdf(urdf, "mimic.urdf", "d", "a");
  ASSERT_TRUE(m.coupled());
  EXPECT_EQ(m.coupling(2, 1), -0.5);
  EXPECT_EQ(m.coupling(2, 2), 0);
  EXPECT_FALSE(m.reading_used(2));
  EXPECT_DOUBLE_EQ(m.links[2].offset, 0.1);
  const DeviceModel back = parse_urdf(device_to_urdf(m), "exported.urdf", "tool", "");
  ASSERT_EQ(back.dof(), 3);
  EXPECT_EQ(back.coupling, m.coupling);
  const PreparedModel a(m), b(back);
  Eigen::Vector3d q(0.3, -0.4, 0.9);
  EXPECT_LT((a.forward(q.data()).p - b.forward(q.data()).p).norm(), 1e-12);
  // A mimic of a joint outside the chain is refused, naming the joint.
  const std::string outside =
      std::string(urdf).replace(urdf.find("joint=\"j2\""), 10, "joint=\"jx\"");
  try {
    parse_urdf(outside, "mimic.urdf", "d", "a");
    FAIL() << "a mimic of a joint outside the chain was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "mimic.urdf:10: joint 'j3': its <mimic> of 'jx': not a movable joint"),
              std::string::npos)
        << e.what();
  }
}

// A torso whose third joint is passive, theta3 = -(q1 + q2), then a wrist joint.
std::string torso_urdf() {
  return R"(<?xml version="1.0"?>
<robot name="torso">
  <link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/>
  <joint name="t1" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
  <joint name="t2" type="revolute"><parent link="b"/><child link="c"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
  <joint name="t3" type="revolute"><parent link="c"/><child link="d"/>
    <origin xyz="0 0 0.25" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="0" velocity="0"/>
    <hapticcal_coupling joint="t1" multiplier="-1"/>
    <hapticcal_coupling joint="t2" multiplier="-1"/></joint>
  <joint name="a1" type="revolute"><parent link="d"/><child link="e"/>
    <origin xyz="0.2 0 0.05" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
</robot>
)";
}

// A joint driven by several readings (a humanoid torso's passive joint,
// theta3 = -(q1 + q2)) on a URDF: one <hapticcal_coupling> a reading under the
// joint, which urdfdom and ROS tools ignore. Read, checked against the pose
// composed by hand, written back and read again.
TEST(Coupling, UrdfJointDrivenBySeveralReadings) {
  const std::string urdf = torso_urdf();
  const DeviceModel m = parse_urdf(urdf, "torso.urdf", "e", "a");
  ASSERT_TRUE(m.coupled());
  Eigen::MatrixXd expected = Eigen::MatrixXd::Identity(4, 4);
  expected.row(2) << -1, -1, 0, 0;
  EXPECT_EQ(m.coupling, expected);
  EXPECT_FALSE(m.reading_used(2));
  // By hand: rotations about y by q1, q2, -(q1 + q2), then about z by q4.
  auto by_hand = [](const Eigen::Vector4d& q) {
    using T = Eigen::Affine3d;
    const Eigen::Vector3d y = Eigen::Vector3d::UnitY(), z = Eigen::Vector3d::UnitZ();
    const T f = T(Eigen::Translation3d(0, 0, 0.1)) * Eigen::AngleAxisd(q[0], y) *
                Eigen::Translation3d(0, 0, 0.3) * Eigen::AngleAxisd(q[1], y) *
                Eigen::Translation3d(0, 0, 0.25) * Eigen::AngleAxisd(-(q[0] + q[1]), y) *
                Eigen::Translation3d(0.2, 0, 0.05) * Eigen::AngleAxisd(q[3], z);
    return Eigen::Vector3d(f.translation());
  };
  const DeviceModel back = parse_urdf(device_to_urdf(m), "exported.urdf", "tool", "");
  EXPECT_NE(device_to_urdf(m).find("<hapticcal_coupling joint=\"t2\" multiplier=\"-1\"/>"),
            std::string::npos);
  EXPECT_EQ(back.coupling, m.coupling);
  const PreparedModel a(m), b(back);
  for (const Eigen::Vector4d& q :
       {Eigen::Vector4d(0.3, -0.4, 0.9, 0.2), Eigen::Vector4d(-0.7, 0.5, -0.1, -0.8)}) {
    // The passive joint's own reading is unused: any value gives the same pose.
    const Eigen::Vector3d p = a.forward(q.data()).p;
    EXPECT_LT((p - by_hand(q)).norm(), 1e-12) << p.transpose();
    EXPECT_LT((b.forward(q.data()).p - p).norm(), 1e-12);
  }
  // Mistakes, each one line naming the file, the line and the joint.
  auto refused = [&](const std::string& from, const std::string& to, const std::string& why) {
    std::string bad = urdf;
    bad.replace(bad.find(from), from.size(), to);
    try {
      parse_urdf(bad, "torso.urdf", "e", "a");
      ADD_FAILURE() << "accepted: " << to;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused("joint=\"t2\" multiplier=\"-1\"", "joint=\"tx\" multiplier=\"-1\"",
          "torso.urdf:14: joint 't3': <hapticcal_coupling>: 'tx' is not a movable joint");
  refused("joint=\"t2\" multiplier=\"-1\"", "joint=\"t1\" multiplier=\"-1\"", "'t1' named twice");
  refused("joint=\"t2\" multiplier=\"-1\"", "joint=\"t2\" multiplier=\"1e400\"",
          "multiplier '1e400': a number of magnitude in [1e-06, 100]");
  refused("joint=\"t2\" multiplier=\"-1\"", "joint=\"t2\"", "needs joint=");
  refused(
      "<hapticcal_coupling joint=\"t1\" multiplier=\"-1\"/>",
      "<mimic joint=\"t1\" multiplier=\"-1\"/><hapticcal_coupling joint=\"t1\" multiplier=\"-1\"/>",
      "both <mimic> and <hapticcal_coupling>");
  // A fixed joint has no value; a mimic of a joint driven by readings would
  // read its reading, not its value.
  refused("<joint name=\"a1\" type=\"revolute\">",
          "<joint name=\"a1\" type=\"fixed\"><hapticcal_coupling joint=\"t1\" multiplier=\"1\"/>",
          "<hapticcal_coupling> on a fixed joint");
  refused("<joint name=\"a1\" type=\"revolute\">",
          "<joint name=\"a1\" type=\"revolute\"><mimic joint=\"t3\" multiplier=\"1\"/>",
          "its <mimic> of 't3', a joint driven by <hapticcal_coupling>");
  // Numbers as urdfdom reads them: blanks and a leading +.
  std::string plus = urdf;
  const std::string minus_one = "joint=\"t1\" multiplier=\"-1\"";
  plus.replace(plus.find(minus_one), minus_one.size(), "joint=\"t1\" multiplier=\" +1 \"");
  EXPECT_EQ(parse_urdf(plus, "torso.urdf", "e", "a").coupling(2, 0), 1.0);
}

// What another program would ignore is refused here too: the element out of
// its place (inside a <link>: the torso read as independent joints, its tool
// 165 mm off), an attribute it does not have, a multiplier of 1e-300 (read as
// a coupling that couples nothing); in a device file and a <mimic> alike.
TEST(Coupling, CouplingsOutOfPlaceOrOutOfRangeAreRefused) {
  const std::string urdf = torso_urdf();
  const auto refused = [](const std::string& text, const std::string& why) {
    try {
      parse_urdf(text, "torso.urdf", "e", "a");
      ADD_FAILURE() << "accepted: " << why;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  };
  const auto edited = [&](const std::string& from, const std::string& to) {
    std::string out = urdf;
    out.replace(out.find(from), from.size(), to);
    return out;
  };
  const std::string second = "\n    <hapticcal_coupling joint=\"t2\" multiplier=\"-1\"/>";
  std::string in_link = edited(second, "");
  in_link.replace(in_link.find("<link name=\"d\"/>"), 16,
                  "<link name=\"d\"><hapticcal_coupling joint=\"t2\" multiplier=\"-1\"/></link>");
  refused(in_link,
          "torso.urdf:3: <hapticcal_coupling>: inside <link name=\"d\">: it belongs under "
          "the <joint> whose value it gives");
  std::string at_top = edited(second, "");
  at_top.replace(at_top.find("</robot>"), 8,
                 "<hapticcal_coupling joint=\"t2\" multiplier=\"-1\"/></robot>");
  refused(at_top, "inside <robot name=\"torso\">");
  refused(edited("joint=\"t2\" multiplier=\"-1\"", "joint=\"t2\" multiplier=\"-1\" offset=\"0.1\""),
          "torso.urdf:14: <hapticcal_coupling>: unknown attribute 'offset' (joint= and "
          "multiplier= only");
  for (const char* tiny : {"1e-300", "-1e-7", "0"}) {
    refused(edited("joint=\"t2\" multiplier=\"-1\"",
                   std::string("joint=\"t2\" multiplier=\"") + tiny + "\""),
            std::string("multiplier '") + tiny + "': a number of magnitude in [1e-06, 100]");
  }
  // The bounds are coefficients: 1e-6 is one.
  EXPECT_EQ(parse_urdf(edited("joint=\"t2\" multiplier=\"-1\"", "joint=\"t2\" multiplier=\"1e-6\""),
                       "torso.urdf", "e", "a")
                .coupling(2, 1),
            1e-6);
  // A <mimic> and a device file's coupling: the same range.
  std::string mimic = edited(second, "");
  mimic = mimic.replace(mimic.find("<hapticcal_coupling joint=\"t1\" multiplier=\"-1\"/>"), 48,
                        "<mimic joint=\"t1\" multiplier=\"1e-300\"/>");
  refused(mimic,
          "its <mimic> of 't1': multiplier 1e-300 and offset 0: a multiplier of magnitude "
          "in [1e-06, 100]");
  std::string yaml = device_to_yaml(level_arm());
  const std::size_t at = yaml.find("coupling:");
  ASSERT_NE(at, std::string::npos) << yaml;
  const std::size_t minus = yaml.find("-1", at);
  yaml.replace(minus, 2, "1e-300");
  try {
    parse_device(yaml, "arm.yaml");
    ADD_FAILURE() << "accepted " << yaml;
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find("1e-300 is not 0 or a number of magnitude in [1e-06, 100]"),
        std::string::npos)
        << e.what();
  }
}

// calibrated.urdf keeps a coupling as the source wrote it: a mimic joint
// whose origin moved (its offset folded into the origin, not counted twice), a
// fitted coefficient of a joint driven by several readings, and a mimic joint
// that now follows two readings; each read back gives the calibrated pose.
TEST(Coupling, CalibratedUrdfWritesTheCouplingBack) {
  const std::string urdf = R"(<?xml version="1.0"?>
<robot name="torso">
  <link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/>
  <joint name="t1" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
  <joint name="t2" type="revolute"><parent link="b"/><child link="c"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/>
    <mimic joint="t1" multiplier="0.5" offset="0.1"/>
  </joint>
  <joint name="t3" type="revolute"><parent link="c"/><child link="d"/>
    <origin xyz="0 0 0.25" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="0" velocity="0"/>
    <hapticcal_coupling joint="t1" multiplier="-1"/>
    <hapticcal_coupling joint="a1" multiplier="-1"/></joint>
  <joint name="a1" type="revolute"><parent link="d"/><child link="e"/>
    <origin xyz="0.2 0 0.05" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="0" velocity="0"/></joint>
</robot>
)";
  const DeviceModel nominal = parse_urdf(urdf, "torso.urdf", "e", "a");
  ASSERT_EQ(nominal.coupling(1, 0), 0.5);
  ASSERT_EQ(nominal.coupling(2, 3), -1);
  auto round_trip = [&](const DeviceModel& calibrated, const char* what) {
    const std::string text = calibrated_urdf(urdf, "torso.urdf", "e", "a", calibrated, nullptr);
    const DeviceModel back = parse_urdf(text, "calibrated.urdf", "e", "a");
    EXPECT_EQ(back.coupling, calibrated.coupling) << what << "\n" << text;
    const PreparedModel a(calibrated), b(back);
    for (const Eigen::Vector4d& q :
         {Eigen::Vector4d(0.3, -0.4, 0.9, 0.2), Eigen::Vector4d(-0.7, 0.5, -0.1, -0.8)}) {
      EXPECT_LT((a.forward(q.data()).p - b.forward(q.data()).p).norm(), 1e-9) << what << "\n"
                                                                              << text;
    }
    return text;
  };
  DeviceModel moved = nominal;
  moved.links[1].origin[0] += 0.002;  // the mimic joint's origin
  round_trip(moved, "a mimic joint moved");
  DeviceModel fitted = nominal;
  fitted.coupling(2, 0) = -1.02;  // a fitted coefficient
  const std::string text = round_trip(fitted, "a coefficient fitted");
  EXPECT_NE(text.find("<hapticcal_coupling joint=\"t1\" multiplier=\"-1.02\"/>"), std::string::npos)
      << text;
  DeviceModel two = nominal;
  two.coupling(1, 3) = 0.25;  // the mimic joint now follows two readings
  round_trip(two, "a mimic joint with a second reading");
}

// Step 1 through the coupling: a parallelogram-style relative reading (joint
// 3 = u3 - u2, as on a PHANToM) with capstans on readings 2 and 3 and external
// encoders on the joint angles: each reading's capstan is recovered.
TEST(Coupling, StepOneFitsEachReadingsTransmissionThroughTheCoupling) {
  DeviceModel nominal = level_arm();
  nominal.coupling = Eigen::MatrixXd::Identity(7, 7);
  nominal.coupling(2, 1) = -1;  // theta3 = u3 - u2
  Capstan c;
  c.ratio = 8;
  c.drum_distance = 0.04;
  nominal.links[2].transmission = Transmission(c);
  nominal.links[1].transmission = Transmission(c);
  ASSERT_EQ(coupling_problem(nominal.coupling, nominal.links), "");
  DeviceModel actual = nominal;
  for (int j : {1, 2}) {
    Capstan t = c;
    t.ratio_error = j == 1 ? 0.02 : -0.015;
    t.r_out = j == 1 ? 3e-4 : -2e-4;
    t.beta_out = 0.4 * j;
    actual.links[j].transmission = Transmission(t);
  }
  SimulationNoise noise;
  noise.sigma_position = 10e-6;
  noise.sigma_ext = 1e-5;
  const Log log = simulate_log(actual, 150, noise, 4, false, true);
  ASSERT_TRUE(log.has_ext[1] && log.has_ext[2]);
  const CalibrationResult r = calibrate(nominal, log, CalibrationOptions{});
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  std::mt19937_64 rng(8);
  for (int k = 0; k < 200; ++k) {
    const Eigen::VectorXd q = testing::random_readings(actual, rng);
    for (int j : {1, 2}) {
      EXPECT_NEAR(r.calibrated.links[j].transmission.error(q[j]),
                  actual.links[j].transmission.error(q[j]), 5e-5)
          << j;
    }
  }
}

}  // namespace
}  // namespace hapticcal
