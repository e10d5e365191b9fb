// SPEC section 7: compensation + forward kinematics + 6x7 geometric Jacobian of the
// calibrated 7-DOF model (transmissions included) against orocos KDL's
// ChainFkSolverPos_recursive + ChainJntToJacSolver on the same chain. KDL has no
// transmissions, so it is handed the compensated joint angles: it does less work.
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <numbers>
#include <random>

#include "hapticcal/kinematics.hpp"
#include "kdl_chain.hpp"
#include "ratio_main.hpp"
#include "test_models.hpp"

namespace {

using namespace hapticcal;

// The built-in device with the paper's assigned values: Table 3 deviations and
// Table 2 capstans (radii in m), a 10th-order polynomial on joint 4.
DeviceModel calibrated_7dof() {
  DeviceModel m = testing::builtin("baser-7dof");
  constexpr double mrad = 1e-3, mm = 1e-3, deg = std::numbers::pi / 180;
  const double d_alpha[] = {-1.5, 1.3, -1.4, 1.2, -1.1, -1.6, 1.7};
  const double d_a[] = {-1.1, 1.6, -1.2, 1.4, -1.5, 1.4, -1.3};
  const double d_d[] = {1.2, -1.5, 1.3, -1.3, 1.4, -1.2, 1.0};
  const double d_theta[] = {1.0, 1.7, -1.3, 1.0, -1.2, -1.0, 1.1};
  m.base[0] += 1.9 * mm;
  m.base[1] += 1.5 * mrad;
  for (int i = 0; i < 7; ++i) {
    m.links[i].alpha += d_alpha[i] * mrad;
    m.links[i].a += d_a[i] * mm;
    m.links[i].d += d_d[i] * mm;
    m.links[i].theta += d_theta[i] * mrad;
  }
  const double Re[] = {-0.025, -0.020, 0.015}, ro[] = {0.2, 0.25, 0.2},
               ri[] = {0.005, 0.0025, 0.004};
  const double bo[] = {-105, -10, 150}, bi[] = {-15, 140, -100};
  for (int i = 0; i < 3; ++i) {
    Capstan& c = std::get<Capstan>(m.links[i].transmission.model());
    c.ratio_error = Re[i];
    c.r_out = ro[i] * mm;
    c.r_in = ri[i] * mm;
    c.beta_out = bo[i] * deg;
    c.beta_in = bi[i] * deg;
  }
  Polynomial& p = std::get<Polynomial>(m.links[3].transmission.model());
  for (int k = 1; k <= 10; ++k) p.coefficients[k] = 1e-3 / (k * k);
  return m;
}

std::vector<Eigen::VectorXd> configurations(const DeviceModel& m) {
  std::mt19937_64 rng(1);
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < 1024; ++k) qs.push_back(testing::random_readings(m, rng));
  return qs;
}

void BM_FkJacobian_Hapticcal(benchmark::State& state) {
  const DeviceModel model = calibrated_7dof();
  const PreparedModel prepared(model);
  const auto qs = configurations(model);
  Jacobian6<double> J(6, model.dof());
  size_t k = 0;
  for (auto _ : state) {
    const Frame<double> T =
        prepared.forward_jacobian(qs[k++ & 1023].data(), JacobianFrame::kMeasurement, J);
    benchmark::DoNotOptimize(T.p.data());
    benchmark::DoNotOptimize(J.data());
    benchmark::ClobberMemory();
  }
}

void BM_FkJacobian_KDL(benchmark::State& state) {
  const DeviceModel model = calibrated_7dof();
  const KDL::Chain chain = testing::kdl_chain(model);
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::ChainJntToJacSolver jac(chain);
  std::vector<KDL::JntArray> qs;
  for (const Eigen::VectorXd& q : configurations(model)) {
    const Eigen::VectorXd joint = model.compensate(q);
    KDL::JntArray a(model.dof());
    for (int i = 0; i < model.dof(); ++i) a(i) = joint[i];
    qs.push_back(a);
  }
  KDL::Frame T;
  KDL::Jacobian J(model.dof());
  size_t k = 0;
  for (auto _ : state) {
    const KDL::JntArray& q = qs[k++ & 1023];
    fk.JntToCart(q, T);
    jac.JntToJac(q, J);
    benchmark::DoNotOptimize(T.p.data);
    benchmark::DoNotOptimize(J.data.data());
    benchmark::ClobberMemory();
  }
}

BENCHMARK(BM_FkJacobian_Hapticcal);
BENCHMARK(BM_FkJacobian_KDL);

}  // namespace

int main(int argc, char** argv) { return hapticcal::bench::ratio_main(argc, argv, {"KDL"}); }
