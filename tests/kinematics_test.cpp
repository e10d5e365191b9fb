// Forward kinematics, geometric Jacobian and parameter derivatives against
// orocos KDL, central differences and ceres::Jet.
#include "hapticcal/kinematics.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <random>

#include "hapticcal/derivative_check.hpp"
#include "kdl_chain.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using testing::builtin;
using testing::kdl_chain;
using testing::meca500;
using testing::perturbed;
using testing::random_readings;

// The simulated "actual" 7-DOF: joint 4 a capstan followed by a parallelogram
// (SPEC section 3), and a large offset on a capstan joint (the prepared path's
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
          {"meca500 perturbed", perturbed(meca500(), rng)}};
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
      KDL::JntArray kq(model.dof());
      for (int i = 0; i < model.dof(); ++i) kq(i) = joint[i];
      KDL::Frame kf;
      ASSERT_GE(fk.JntToCart(kq, kf), 0);
      KDL::Jacobian kj(model.dof());
      ASSERT_GE(jac_solver.JntToJac(kq, kj), 0);
      const Frame<double> ref = testing::from_kdl(kf);

      std::array<Frame<double>, kMaxDof + 1> frames;
      const Frame<double> generic =
          forward_kinematics(s, params.data(), joint.data(), frames.data());
      Jacobian6<double> J, Jt;
      const Frame<double> fast =
          prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J);
      prepared.forward_jacobian(q.data(), JacobianFrame::kTool, Jt);
      Jacobian6<double> Jg;
      geometric_jacobian(s, frames.data(), generic, JacobianFrame::kMeasurement, Jg);

      worst_p = std::max({worst_p, (generic.p - ref.p).cwiseAbs().maxCoeff(),
                          (fast.p - ref.p).cwiseAbs().maxCoeff()});
      worst_R = std::max({worst_R, (generic.R - ref.R).cwiseAbs().maxCoeff(),
                          (fast.R - ref.R).cwiseAbs().maxCoeff()});
      // KDL: reference point at the end effector, expressed in the base (here
      // measurement) frame; changeBase(R^T) expresses it in the tool frame.
      Jacobian6<double> Jref(6, model.dof()), Jtref(6, model.dof());
      KDL::Jacobian kjt(model.dof());
      KDL::changeBase(kj, kf.M.Inverse(), kjt);
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < model.dof(); ++c) {
          Jref(r, c) = kj(r, c);
          Jtref(r, c) = kjt(r, c);
        }
      }
      worst_J =
          std::max({worst_J, (J - Jref).cwiseAbs().maxCoeff(), (Jg - Jref).cwiseAbs().maxCoeff()});
      worst_Jt = std::max(worst_Jt, (Jt - Jtref).cwiseAbs().maxCoeff());
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

// Analytic d p / d params and d |p| / d params against central differences
// (hapticcal::check_kinematic_derivatives: step 1e-6, tolerance 1e-8 in m per m or
// per rad); slots without meaning must have zero columns.
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
  // SPEC section 3 lengths: at home the tool point sits at
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

}  // namespace
}  // namespace hapticcal
