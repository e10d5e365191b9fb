// Compensation + forward kinematics + 6x7 geometric Jacobian of the
// calibrated 7-DOF model (transmissions included) against orocos KDL's
// ChainFkSolverPos_recursive + ChainJntToJacSolver on the same chain. KDL has no
// transmissions, so it is handed the compensated joint angles: it does less work.
// The same for a Panda-like 7-DOF in URDF origin + axis geometry and for the
// 7-DOF with coupled joints and with joint compliance (KDL handed the deflected
// angles). And the 7-DOF through the C runtime
// (hapticcal/runtime.h), against the library's call.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <filesystem>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <numbers>
#include <random>

#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/runtime.h"
#include "hapticcal/study/simulation.hpp"
#include "kdl_chain.hpp"
#include "ratio_main.hpp"
#include "test_models.hpp"

namespace {

using namespace hapticcal;

// The built-in device with the paper's assigned values (Table 3 deviations,
// Table 2 capstans) as a calibrated model: joint 4 stays a 10th-order polynomial.
DeviceModel calibrated_7dof() {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  DeviceModel m = paper_actual_device(nominal);
  m.links[3].transmission = nominal.links[3].transmission;
  Polynomial& p = std::get<Polynomial>(m.links[3].transmission.model());
  for (int k = 1; k <= 10; ++k) p.coefficients[k] = 1e-3 / (k * k);
  return m;
}

// The Panda-like chain in URDF origin + axis geometry (PreparedModel's generic
// path) with the same transmissions: the capstans, and joint 4's polynomial on
// the Panda's joint-4 range.
DeviceModel calibrated_panda_like() {
  DeviceModel m = testing::panda_like();
  const DeviceModel calibrated = calibrated_7dof();
  for (int i = 0; i < m.dof(); ++i) m.links[i].transmission = calibrated.links[i].transmission;
  Polynomial& p = std::get<Polynomial>(m.links[3].transmission.model());
  p.lower = m.links[3].lower;
  p.upper = m.links[3].upper;
  return m;
}

// The calibrated 7-DOF with its joints coupled as haptic devices couple them
// (issue 25): joint 3 read relative to joint 2, as a PHANToM's parallelogram
// (theta3 = u3 - u2), and joint 4 moved by both, as the dVRK MTM's
// actuator-to-joint map (theta4 = u4 + 0.6697 (u2 - u3)).
DeviceModel coupled_7dof() {
  DeviceModel m = calibrated_7dof();
  m.coupling = Eigen::MatrixXd::Identity(m.dof(), m.dof());
  m.coupling(2, 1) = -1;
  m.coupling(3, 1) = 0.6697;
  m.coupling(3, 2) = -0.6697;
  return m;
}

// The calibrated 7-DOF with joint compliance (issue 25): each link a lumped
// 1 kg at its frame's origin and k = 5e-4 rad/N m on every joint, so that the
// prepared path forms the gravity torques and deflects the joints.
DeviceModel compliant_7dof() {
  DeviceModel m = calibrated_7dof();
  for (Link& l : m.links) {
    l.mass = 1.0;
    l.compliance = 5e-4;
  }
  return m;
}

std::vector<Eigen::VectorXd> configurations(const DeviceModel& m) {
  std::mt19937_64 rng(1);
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < 1024; ++k) qs.push_back(testing::random_readings(m, rng));
  return qs;
}

void fk_jacobian_hapticcal(benchmark::State& state, const DeviceModel& model) {
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

// FK alone (compensation, the batched sines and cosines, the composition):
// the pass a compliant model makes first, undeflected, for its gravity torques.
void BM_Fk_Hapticcal(benchmark::State& state) {
  const DeviceModel model = calibrated_7dof();
  const PreparedModel prepared(model);
  const auto qs = configurations(model);
  size_t k = 0;
  for (auto _ : state) {
    const Frame<double> T = prepared.forward(qs[k++ & 1023].data());
    benchmark::DoNotOptimize(T.p.data());
    benchmark::ClobberMemory();
  }
}

void fk_jacobian_kdl(benchmark::State& state, const DeviceModel& model) {
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

// The model saved as a device file and loaded by hapticcal_load, as a
// controller would; null (the benchmark skipped with the message) if it fails.
hapticcal_model* load_runtime(const DeviceModel& model, benchmark::State& state) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("fk_jacobian_bench_" + std::to_string(::getpid()) + ".yaml"))
                               .string();
  save_device(model, path);
  hapticcal_model* runtime = nullptr;
  char message[256];
  const hapticcal_status status =
      hapticcal_load(path.c_str(), nullptr, nullptr, &runtime, message, sizeof message);
  std::filesystem::remove(path);
  if (status != HAPTICCAL_OK) state.SkipWithError(message);
  return runtime;
}

// Compensation + FK + Jacobian through the C ABI.
void BM_Runtime_FkJacobian(benchmark::State& state) {
  const DeviceModel model = calibrated_7dof();
  hapticcal_model* runtime = load_runtime(model, state);
  if (!runtime) return;
  const auto qs = configurations(model);
  std::vector<double> J(6 * model.dof());
  double T[16];
  size_t k = 0;
  for (auto _ : state) {
    hapticcal_jacobian(runtime, qs[k++ & 1023].data(), HAPTICCAL_FRAME_MEASUREMENT, J.data(), T);
    benchmark::DoNotOptimize(T);
    benchmark::DoNotOptimize(J.data());
    benchmark::ClobberMemory();
  }
  hapticcal_free(runtime);
}

// Inverse kinematics through the C ABI on the compliant 7-DOF (every effect in
// the model: capstans, joint 4's polynomial, compliance): a pose of the tool
// from readings `away` rad off on every joint (0.01: a 1 kHz loop tracking a
// moving target; 0.3: a new target; `out_of_reach`: each target moved 1 m away,
// the bound's case). The worst call is a counter (worst_us): the work is
// bounded (100 Jacobians, 300 evaluations of the model).
void runtime_inverse(benchmark::State& state, double away, bool out_of_reach = false) {
  const DeviceModel model = compliant_7dof();
  hapticcal_model* runtime = load_runtime(model, state);
  if (!runtime) return;
  const auto qs = configurations(model);
  std::vector<std::array<double, 16>> targets(qs.size());
  for (size_t k = 0; k < qs.size(); ++k) {
    hapticcal_forward(runtime, qs[k].data(), targets[k].data());
    if (out_of_reach) targets[k][3] += 1.0;
  }
  std::vector<double> start(model.dof()), q(model.dof());
  hapticcal_inverse_result result{};
  double worst = 0;
  long reached = 0, calls = 0, iterations = 0;
  size_t k = 0;
  for (auto _ : state) {
    const size_t at = k++ & 1023;
    for (int i = 0; i < model.dof(); ++i) start[i] = qs[at][i] + (i % 2 ? away : -away);
    const auto begin = std::chrono::steady_clock::now();
    hapticcal_inverse(runtime, targets[at].data(), 1, start.data(), 0, q.data(), &result);
    worst = std::max(
        worst, std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count());
    reached += result.status != HAPTICCAL_INVERSE_NOT_CONVERGED;
    iterations += result.iterations;
    ++calls;
    benchmark::DoNotOptimize(q.data());
    benchmark::ClobberMemory();
  }
  state.counters["worst_us"] = worst * 1e6;
  state.counters["reached"] = calls ? static_cast<double>(reached) / calls : 0;
  state.counters["iterations"] = calls ? static_cast<double>(iterations) / calls : 0;
  hapticcal_free(runtime);
}

void BM_Runtime_Inverse_Tracking(benchmark::State& state) { runtime_inverse(state, 0.01); }
void BM_Runtime_Inverse_NewTarget(benchmark::State& state) { runtime_inverse(state, 0.3); }
void BM_Runtime_Inverse_OutOfReach(benchmark::State& state) { runtime_inverse(state, 0.01, true); }

void BM_FkJacobian_Hapticcal(benchmark::State& state) {
  fk_jacobian_hapticcal(state, calibrated_7dof());
}
void BM_FkJacobian_KDL(benchmark::State& state) { fk_jacobian_kdl(state, calibrated_7dof()); }
void BM_FkJacobian_PandaLike_Hapticcal(benchmark::State& state) {
  fk_jacobian_hapticcal(state, calibrated_panda_like());
}
void BM_FkJacobian_PandaLike_KDL(benchmark::State& state) {
  fk_jacobian_kdl(state, calibrated_panda_like());
}

void BM_FkJacobian_Coupled_Hapticcal(benchmark::State& state) {
  fk_jacobian_hapticcal(state, coupled_7dof());
}
void BM_FkJacobian_Coupled_KDL(benchmark::State& state) { fk_jacobian_kdl(state, coupled_7dof()); }

void BM_FkJacobian_Compliant_Hapticcal(benchmark::State& state) {
  fk_jacobian_hapticcal(state, compliant_7dof());
}
void BM_FkJacobian_Compliant_KDL(benchmark::State& state) {
  fk_jacobian_kdl(state, compliant_7dof());
}

BENCHMARK(BM_FkJacobian_Hapticcal);
BENCHMARK(BM_Runtime_FkJacobian);
BENCHMARK(BM_FkJacobian_KDL);
BENCHMARK(BM_FkJacobian_PandaLike_Hapticcal);
BENCHMARK(BM_FkJacobian_PandaLike_KDL);
BENCHMARK(BM_FkJacobian_Coupled_Hapticcal);
BENCHMARK(BM_FkJacobian_Coupled_KDL);
BENCHMARK(BM_FkJacobian_Compliant_Hapticcal);
BENCHMARK(BM_FkJacobian_Compliant_KDL);
BENCHMARK(BM_Fk_Hapticcal);
BENCHMARK(BM_Runtime_Inverse_Tracking);
BENCHMARK(BM_Runtime_Inverse_NewTarget);
BENCHMARK(BM_Runtime_Inverse_OutOfReach);

}  // namespace

int main(int argc, char** argv) {
  return hapticcal::bench::ratio_main(
      argc, argv,
      hapticcal::bench::Pairs{{"BM_FkJacobian_Hapticcal", "BM_FkJacobian_KDL"},
                              {"BM_Runtime_FkJacobian", "BM_FkJacobian_Hapticcal"},
                              {"BM_FkJacobian_PandaLike_Hapticcal", "BM_FkJacobian_PandaLike_KDL"},
                              {"BM_FkJacobian_Coupled_Hapticcal", "BM_FkJacobian_Coupled_KDL"},
                              {"BM_FkJacobian_Coupled_Hapticcal", "BM_FkJacobian_Hapticcal"},
                              {"BM_FkJacobian_Compliant_Hapticcal", "BM_FkJacobian_Compliant_KDL"},
                              {"BM_FkJacobian_Compliant_Hapticcal", "BM_FkJacobian_Hapticcal"},
                              {"BM_Fk_Hapticcal", "BM_FkJacobian_Hapticcal"},
                              {"BM_Runtime_Inverse_Tracking", "BM_FkJacobian_Hapticcal"},
                              {"BM_Runtime_Inverse_NewTarget", "BM_FkJacobian_Hapticcal"},
                              {"BM_Runtime_Inverse_OutOfReach", "BM_FkJacobian_Hapticcal"}});
}
