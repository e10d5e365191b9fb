// Forward kinematics, geometric Jacobian and parameter derivatives against
// orocos KDL, central differences and ceres::Jet.
#include "hapticcal/kinematics/kinematics.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <random>

#include "hapticcal/identification/derivative_check.hpp"
#include "kdl_chain.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using testing::builtin;
using testing::kdl_chain;
using testing::meca500;
using testing::mixed_chain;
using testing::panda_like;
using testing::perturbed;
using testing::random_readings;
using testing::with_random_axes;

// Every device below goes through every test: the DH and MDH ones take the
// prepared register paths, the origin-geometry and mixed ones the generic path.
//
// The simulated "actual" 7-DOF: joint 4 a capstan followed by a parallelogram
// (the paper's study), and a large offset on a capstan joint (the prepared path's
// fallback from turning sin/cos of q by a small angle).
DeviceModel actual_7dof() {
  DeviceModel m = builtin("baser-7dof");
  Capstan c{10, 0.005, 0, 0.02, 0.1e-3, -0.7, 0.002e-3, -2.1};
  m.links[3].transmission = Transmission(
      Chain{{Transmission(c), Transmission(Parallelogram{0.0495, 0.2093, 0.05, 0.21})}});
  m.links[1].theta += 1.0;
  return m;
}

std::vector<std::pair<std::string, DeviceModel>> devices() {
  std::mt19937_64 rng(7);
  return {{"baser-7dof", builtin("baser-7dof")},
          {"baser-7dof actual (chain, offset)", actual_7dof()},
          {"phantom-premium-1.5", builtin("phantom-premium-1.5")},
          {"meca500 (mdh)", meca500()},
          {"baser-7dof perturbed", perturbed(builtin("baser-7dof"), rng)},
          {"phantom perturbed", perturbed(builtin("phantom-premium-1.5"), rng)},
          {"meca500 perturbed", perturbed(meca500(), rng)},
          {"panda-like (origin)", panda_like()},
          {"panda-like perturbed, random axes",
           with_random_axes(perturbed(panda_like(), rng, 0.02), rng)},
          {"mixed (DH base)", mixed_chain(BaseKind::kDh)},
          {"mixed (pose base)", mixed_chain(BaseKind::kPose)},
          {"mixed perturbed", perturbed(mixed_chain(BaseKind::kDh), rng)}};
}

// Gives the built-in devices non-trivial transmissions so that compensation is
// part of every comparison.
DeviceModel with_transmission_errors(DeviceModel m) {
  for (Link& l : m.links) {
    if (auto* c = std::get_if<Capstan>(&l.transmission.model())) {
      c->ratio_error = 0.02;
      c->r_out = 0.2 * c->drum_distance / 5;
      c->beta_out = -1.2;
      c->r_in = 0.01 * c->drum_distance;
      c->beta_in = 2.0;
    }
    if (auto* p = std::get_if<Polynomial>(&l.transmission.model())) {
      for (int k = 1; k <= p->order(); ++k) p->coefficients[k] = 1e-3 / k;
    }
  }
  return m;
}

TEST(Kinematics, ForwardKinematicsAndJacobianMatchKdlOn1000Configurations) {
  for (const auto& [label, nominal] : devices()) {
    SCOPED_TRACE(label);
    const DeviceModel model = with_transmission_errors(nominal);
    const ChainStructure s = model.structure();
    const Eigen::VectorXd params = model.kinematic_parameters();
    const PreparedModel prepared(model);
    const KDL::Chain chain = kdl_chain(model);
    KDL::ChainFkSolverPos_recursive fk(chain);
    KDL::ChainJntToJacSolver jac_solver(chain);
    ASSERT_EQ(static_cast<int>(chain.getNrOfJoints()), model.dof());
    std::mt19937_64 rng(42);
    double worst_p = 0, worst_R = 0, worst_J = 0, worst_Jt = 0;
    for (int trial = 0; trial < 1000; ++trial) {
      const Eigen::VectorXd q = random_readings(model, rng);
      const Eigen::VectorXd joint = model.compensate(q);
      const testing::KdlSolution kdl = testing::kdl_solve(fk, jac_solver, joint);
      const Frame<double>& ref = kdl.T;

      std::array<Frame<double>, kMaxDof + 1> frames;
      const Frame<double> generic =
          forward_kinematics(s, params.data(), joint.data(), frames.data());
      Jacobian6<double> J, Jt;
      const Frame<double> fast =
          prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J);
      const Frame<double> fast_t = prepared.forward_jacobian(q.data(), JacobianFrame::kTool, Jt);
      const Frame<double> fast_fk = prepared.forward(q.data());
      Jacobian6<double> Jg, Jgt;
      geometric_jacobian(s, frames.data(), generic, JacobianFrame::kMeasurement, Jg);
      geometric_jacobian(s, frames.data(), generic, JacobianFrame::kTool, Jgt);

      for (const Frame<double>* f : {&generic, &fast, &fast_t, &fast_fk}) {
        worst_p = std::max(worst_p, (f->p - ref.p).cwiseAbs().maxCoeff());
        worst_R = std::max(worst_R, (f->R - ref.R).cwiseAbs().maxCoeff());
      }
      const Jacobian6<double>&Jref = kdl.J, &Jtref = kdl.J_tool;
      worst_J =
          std::max({worst_J, (J - Jref).cwiseAbs().maxCoeff(), (Jg - Jref).cwiseAbs().maxCoeff()});
      worst_Jt = std::max(
          {worst_Jt, (Jt - Jtref).cwiseAbs().maxCoeff(), (Jgt - Jtref).cwiseAbs().maxCoeff()});
    }
    EXPECT_LT(worst_p, 1e-12);
    EXPECT_LT(worst_R, 1e-12);
    EXPECT_LT(worst_J, 1e-12);
    EXPECT_LT(worst_Jt, 1e-12);
  }
}

// Central differences of the tool pose over the joint angles give the Jacobian.
TEST(Kinematics, GeometricJacobianMatchesCentralDifferences) {
  constexpr double kStep = 1e-6, kTolerance = 1e-8;
  for (const auto& [label, model] : devices()) {
    SCOPED_TRACE(label);
    const ChainStructure s = model.structure();
    const Eigen::VectorXd params = model.kinematic_parameters();
    std::mt19937_64 rng(3);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd joint = random_readings(model, rng);
      std::array<Frame<double>, kMaxDof + 1> frames;
      const Frame<double> T = forward_kinematics(s, params.data(), joint.data(), frames.data());
      Jacobian6<double> J;
      geometric_jacobian(s, frames.data(), T, JacobianFrame::kMeasurement, J);
      for (int i = 0; i < model.dof(); ++i) {
        Eigen::VectorXd plus = joint, minus = joint;
        plus[i] += kStep;
        minus[i] -= kStep;
        const Frame<double> Tp = forward_kinematics(s, params.data(), plus.data());
        const Frame<double> Tm = forward_kinematics(s, params.data(), minus.data());
        const Eigen::Vector3d v = (Tp.p - Tm.p) / (2 * kStep);
        // Angular velocity from dR R^T (skew-symmetric).
        const Eigen::Matrix3d W = (Tp.R - Tm.R) / (2 * kStep) * T.R.transpose();
        const Eigen::Vector3d w(W(2, 1), W(0, 2), W(1, 0));
        EXPECT_LT((J.block<3, 1>(0, i) - v).cwiseAbs().maxCoeff(), kTolerance);
        EXPECT_LT((J.block<3, 1>(3, i) - w).cwiseAbs().maxCoeff(), kTolerance);
      }
    }
  }
}

// Analytic d (p, w) / d params (pose_parameter_jacobian<6>: position and tool
// rotation rows), d p / d params (<3>) and d |p| / d params against central
// differences of forward_kinematics, the rotation rows through the rotation log
// of R(p + h) R(p)^T (hapticcal::check_kinematic_derivatives: step 1e-6,
// tolerance 1e-8 absolute in m or rad per m or per rad, for entries of order 1);
// slots without meaning must have zero columns.
TEST(Kinematics, ParameterDerivativesMatchCentralDifferences) {
  for (const auto& [label, model] : devices()) {
    SCOPED_TRACE(label);
    std::mt19937_64 rng(5);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd joint = random_readings(model, rng);
      const DerivativeCheck check = check_kinematic_derivatives(model, joint, 1e-6);
      EXPECT_LT(check.max_error, 1e-8) << check.worst;
    }
  }
}

// |p| by orocos KDL, independent of hapticcal's kinematics, at random readings
// of every device.
double kdl_distance(const DeviceModel& model, const Eigen::VectorXd& joint) {
  const KDL::Chain chain = kdl_chain(model);
  KDL::JntArray a(model.dof());
  for (int i = 0; i < model.dof(); ++i) a(i) = joint[i];
  KDL::Frame f;
  KDL::ChainFkSolverPos_recursive(chain).JntToCart(a, f);
  return f.p.Norm();
}

// The distance (paper eq. 5) and its parameter Jacobian against orocos KDL: the
// value against KDL's |p|, each meaningful parameter's derivative against
// central differences of KDL's |p| over that parameter (step 1e-6 m or rad,
// tolerance 1e-8).
TEST(Kinematics, DistanceAndItsParameterJacobianMatchKdl) {
  constexpr double kStep = 1e-6;
  for (const auto& [label, model] : devices()) {
    SCOPED_TRACE(label);
    const ChainStructure s = model.structure();
    const Eigen::VectorXd params = model.kinematic_parameters();
    std::mt19937_64 rng(6);
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::VectorXd joint = random_readings(model, rng);
      Eigen::Matrix<double, 1, Eigen::Dynamic> J_delta_params;
      const double delta =
          distance_parameter_jacobian(s, params.data(), joint.data(), J_delta_params);
      EXPECT_NEAR(delta, kdl_distance(model, joint), 1e-12);
      for (const ParameterInfo& info : model.parameter_info()) {
        DeviceModel plus = model, minus = model;
        Eigen::VectorXd p = params;
        p[info.slot] += kStep;
        plus.set_kinematic_parameters(p);
        p[info.slot] -= 2 * kStep;
        minus.set_kinematic_parameters(p);
        const double numeric =
            (kdl_distance(plus, joint) - kdl_distance(minus, joint)) / (2 * kStep);
        EXPECT_NEAR(J_delta_params[info.slot], numeric, 1e-8) << info.name;
      }
    }
  }
}

// The generic code instantiated with ceres::Jet gives the same values, and its
// automatic derivatives equal the analytic ones.
TEST(Kinematics, RunsWithCeresJetAndAgreesWithAnalyticDerivatives) {
  using Jet = ceres::Jet<double, 4>;
  for (const auto& [label, model] : devices()) {
    SCOPED_TRACE(label);
    const ChainStructure s = model.structure();
    const Eigen::VectorXd params = model.kinematic_parameters();
    const std::vector<ParameterInfo> info = model.parameter_info();
    std::mt19937_64 rng(11);
    const Eigen::VectorXd joint = random_readings(model, rng);
    Eigen::Matrix<double, 3, Eigen::Dynamic> J_p_params;
    position_parameter_jacobian(s, params.data(), joint.data(), J_p_params);
    // Differentiate with respect to four parameters at a time.
    for (size_t first = 0; first < info.size(); first += 4) {
      std::vector<Jet> p(params.size()), j(joint.size());
      for (int k = 0; k < params.size(); ++k) p[k] = Jet(params[k]);
      for (int k = 0; k < joint.size(); ++k) j[k] = Jet(joint[k]);
      for (size_t m = first; m < std::min(first + 4, info.size()); ++m) {
        p[info[m].slot].v[m - first] = 1.0;
      }
      std::array<Frame<Jet>, kMaxDof + 1> frames;
      const Frame<Jet> T = forward_kinematics(s, p.data(), j.data(), frames.data());
      Jacobian6<Jet> J;
      geometric_jacobian(s, frames.data(), T, JacobianFrame::kTool, J);
      Eigen::Matrix<Jet, 3, Eigen::Dynamic> Jj;
      position_parameter_jacobian(s, p.data(), j.data(), Jj);
      const Eigen::Vector3d p_double = forward_kinematics(s, params.data(), joint.data()).p;
      for (int r = 0; r < 3; ++r) {
        EXPECT_NEAR(T.p[r].a, p_double[r], 1e-15);
        for (size_t m = first; m < std::min(first + 4, info.size()); ++m) {
          EXPECT_NEAR(T.p[r].v[m - first], J_p_params(r, info[m].slot), 1e-12) << info[m].name;
        }
      }
    }
  }
}

TEST(Kinematics, PaperDeviceHomePostureIsTheDrawnOne) {
  // the study's lengths: at home the tool point sits at
  // base (a0 = 0.3 along x, alpha0 = -pi/2) + d1, d3, d5 (elbow bent), d7, a7.
  const DeviceModel model = builtin("baser-7dof");
  const PreparedModel prepared(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  const Eigen::Vector3d p = prepared.forward(q.data()).p;
  // Independent hand computation of the chain at q = 0 (see DH table 1).
  Frame<double> T{rot_x(0.0, -1.0), {0.3, 0, 0}};  // base: Tx(0.3) Rx(-pi/2)
  const double d[] = {0.1, 0, 0.21, 0, 0.21, 0, 0.05};
  const double alpha_sign[] = {-1, 1, -1, 1, -1, 1, 0};
  for (int i = 0; i < 7; ++i) {
    const double th = i == 3 ? std::numbers::pi / 2 : 0.0;
    const double a = i == 6 ? 0.02 : 0.0;
    Frame<double> A{
        rot_z(std::cos(th), std::sin(th)) * rot_x(alpha_sign[i] == 0 ? 1.0 : 0.0, alpha_sign[i]),
        rot_z(std::cos(th), std::sin(th)) * Eigen::Vector3d(a, 0, d[i])};
    T = T * A;
  }
  EXPECT_LT((p - T.p).norm(), 1e-15);
}

// The checker behind ParameterDerivativesMatchCentralDifferences finds a wrong
// entry in a rotation row and in a position row, and names its slot.
TEST(Kinematics, PoseParameterJacobianCheckFindsAWrongEntry) {
  const DeviceModel model = mixed_chain(BaseKind::kDh);
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  std::mt19937_64 rng(8);
  const Eigen::VectorXd joint = random_readings(model, rng);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J;
  pose_parameter_jacobian<6>(s, chain_constants(s, params.data()), params.data(), joint.data(), J);
  EXPECT_LT(check_pose_parameter_jacobian(model, joint, J).max_error, 1e-8);
  const int roll = s.link_slot(2) + kOriginRoll;  // j3.roll
  Eigen::Matrix<double, 6, Eigen::Dynamic> wrong = J;
  wrong(4, roll) += 1e-6;
  DerivativeCheck check = check_pose_parameter_jacobian(model, joint, wrong);
  EXPECT_NEAR(check.max_error, 1e-6, 1e-8);
  EXPECT_EQ(check.worst, "j3.roll (rotation)");
  wrong = J;
  wrong(1, s.link_slot(3) + kLinkBeta) -= 1e-6;
  check = check_pose_parameter_jacobian(model, joint, wrong);
  EXPECT_NEAR(check.max_error, 1e-6, 1e-8);
  EXPECT_EQ(check.worst, "j4.beta");
}

// The Panda's published zero posture (franka_description): the flange 0.088 m
// ahead of the base axis and 0.333 + 0.316 + 0.384 - 0.107 m up, its z axis
// pointing down; the tool 0.1034 m further down.
TEST(Kinematics, PandaLikeZeroPostureIsThePublishedOne) {
  const DeviceModel model = panda_like();
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  const Eigen::Vector3d p_meas(0.088, 0, 0.333 + 0.316 + 0.384 - 0.107 - 0.1034);
  const Eigen::Matrix3d R_meas = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Frame<double> generic =
      forward_kinematics(model.structure(), model.kinematic_parameters().data(), q.data());
  const Frame<double> prepared = PreparedModel(model).forward(q.data());
  for (const Frame<double>& T : {generic, prepared}) {
    EXPECT_LT((T.p - p_meas).norm(), 1e-15);
    EXPECT_LT((T.R - R_meas).cwiseAbs().maxCoeff(), 1e-15);
  }
}

// A prismatic joint's Jacobian column: its unit axis in the linear rows, zero
// in the angular rows; moving the joint by t moves the tool by t along that
// axis without turning it (generic and prepared paths, both frames).
TEST(Kinematics, PrismaticJointColumnIsTheAxisAndDoesNotTurn) {
  for (BaseKind base : {BaseKind::kDh, BaseKind::kPose}) {
    std::mt19937_64 rng(9);
    const DeviceModel model = perturbed(mixed_chain(base), rng);
    const ChainStructure s = model.structure();
    const Eigen::VectorXd params = model.kinematic_parameters();
    const PreparedModel prepared(model);
    int prismatic = 0;
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd q = random_readings(model, rng);
      const Eigen::VectorXd joint = model.compensate(q);
      std::array<Frame<double>, kMaxDof + 1> frames;
      const Frame<double> T = forward_kinematics(s, params.data(), joint.data(), frames.data());
      Jacobian6<double> Jg, Jgt, Jp, Jpt;
      geometric_jacobian(s, frames.data(), T, JacobianFrame::kMeasurement, Jg);
      geometric_jacobian(s, frames.data(), T, JacobianFrame::kTool, Jgt);
      prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, Jp);
      prepared.forward_jacobian(q.data(), JacobianFrame::kTool, Jpt);
      for (int i = 0; i < model.dof(); ++i) {
        if (!model.links[i].prismatic()) continue;
        ++prismatic;
        constexpr double t = 0.1;
        Eigen::VectorXd moved = joint;
        moved[i] += t;
        const Frame<double> Tm = forward_kinematics(s, params.data(), moved.data());
        const Eigen::Vector3d axis = (Tm.p - T.p) / t;
        EXPECT_NEAR(axis.norm(), 1.0, 1e-13);
        EXPECT_LT((Tm.R - T.R).cwiseAbs().maxCoeff(), 1e-15);
        for (const Jacobian6<double>* J : {&Jg, &Jp}) {
          EXPECT_LT((J->col(i).head<3>() - axis).cwiseAbs().maxCoeff(), 1e-13);
          EXPECT_EQ(J->col(i).tail<3>().cwiseAbs().maxCoeff(), 0.0);
        }
        for (const Jacobian6<double>* J : {&Jgt, &Jpt}) {
          EXPECT_LT((J->col(i).head<3>() - T.R.transpose() * axis).cwiseAbs().maxCoeff(), 1e-13);
          EXPECT_EQ(J->col(i).tail<3>().cwiseAbs().maxCoeff(), 0.0);
        }
      }
    }
    EXPECT_EQ(prismatic, 20 * 3);  // the MDH, DH and origin prismatic joints
  }
}

// The origin + axis description of a DH or MDH prismatic link (KDL's roll,
// pitch, yaw of its constant rotation; the joint offset carrying d):
//   DH:  Rz(theta) T(a, 0, d + q) Rx(alpha) Ry(beta)
//        = T(a cos theta, a sin theta, 0) R * T(R^T z (d + q)),  R = Rz Rx Ry
//   MDH: Rx(alpha) Tx(a) Ry(beta) Rz(theta) Tz(d + q)
//        = Tx(a) R * Tz(d + q),  R = Rx Ry Rz
Link as_origin_link(const Link& l) {
  const KDL::Rotation Rz = KDL::Rotation::RotZ(l.theta), Rx = KDL::Rotation::RotX(l.alpha),
                      Ry = KDL::Rotation::RotY(l.beta);
  const KDL::Rotation R = l.geometry == Geometry::kDh ? Rz * Rx * Ry : Rx * Ry * Rz;
  Link o = l;
  o.geometry = Geometry::kOrigin;
  o.origin = l.geometry == Geometry::kDh
                 ? std::array<double, 6>{l.a * std::cos(l.theta), l.a * std::sin(l.theta), 0}
                 : std::array<double, 6>{l.a, 0, 0};
  R.GetRPY(o.origin[3], o.origin[4], o.origin[5]);
  const KDL::Vector z(0, 0, 1);
  const KDL::Vector u = l.geometry == Geometry::kDh ? R.Inverse(z) : z;
  o.axis = Eigen::Vector3d(u.x(), u.y(), u.z());
  o.offset = l.d;
  o.a = o.alpha = o.d = o.theta = o.beta = 0;
  return o;
}

TEST(Kinematics, DhMdhAndOriginDescriptionsOfAPrismaticJointAgree) {
  std::mt19937_64 rng(10);
  const DeviceModel model = perturbed(mixed_chain(BaseKind::kPose), rng);
  DeviceModel converted = model;
  int count = 0;
  for (Link& l : converted.links) {
    if (l.prismatic() && l.geometry != Geometry::kOrigin) {
      l = as_origin_link(l);
      ++count;
    }
  }
  ASSERT_EQ(count, 2);
  const ChainStructure s = model.structure(), sc = converted.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const Eigen::VectorXd params_c = converted.kinematic_parameters();
  const PreparedModel prepared(model), prepared_c(converted);
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::VectorXd q = random_readings(model, rng);
    const Eigen::VectorXd joint = model.compensate(q);
    std::array<Frame<double>, kMaxDof + 1> frames, frames_c;
    const Frame<double> T = forward_kinematics(s, params.data(), joint.data(), frames.data());
    const Frame<double> Tc = forward_kinematics(sc, params_c.data(), joint.data(), frames_c.data());
    EXPECT_LT((T.p - Tc.p).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((T.R - Tc.R).cwiseAbs().maxCoeff(), 1e-14);
    Jacobian6<double> J, Jc;
    geometric_jacobian(s, frames.data(), T, JacobianFrame::kMeasurement, J);
    geometric_jacobian(sc, frames_c.data(), Tc, JacobianFrame::kMeasurement, Jc);
    EXPECT_LT((J - Jc).cwiseAbs().maxCoeff(), 1e-14);
    const Frame<double> Tp = prepared_c.forward_jacobian(q.data(), JacobianFrame::kMeasurement, Jc);
    prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J);
    EXPECT_LT((T.p - Tp.p).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((J - Jc).cwiseAbs().maxCoeff(), 1e-14);
  }
}

}  // namespace
}  // namespace hapticcal
