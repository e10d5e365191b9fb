// The full two-step calibration of the default problem (the
// paper's device, Tables 2-3, 200 poses with the study's noise), against a machine
// yardstick in the same process: one pass of orocos KDL FK + Jacobian over the
// same 200 poses.
#include <filesystem>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/simulation.hpp"
#include "hapticcal/study/study.hpp"
#include "kdl_chain.hpp"
#include "ratio_main.hpp"
#include "test_models.hpp"

namespace {

using namespace hapticcal;

void calibrate_with(benchmark::State& state, const CalibrationOptions& options) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const Log log = simulate_log(paper_actual_device(nominal), 200, SimulationNoise{}, 1);
  for (auto _ : state) {
    CalibrationResult r = calibrate(nominal, log, options);
    benchmark::DoNotOptimize(r.kinematics.rms_after);
  }
}

// The default: the model search over the estimators, the joint-error families
// that apply (compliance, harmonic) and the instrument's zero.
void BM_Calibrate_Default(benchmark::State& state) { calibrate_with(state, {}); }

// The search over the estimators alone (no joint-error family, the zero
// fitted): the work of the default before the model search (the prior, the cut
// and least squares each fitted and cross-validated).
void BM_Calibrate_Estimators(benchmark::State& state) {
  CalibrationOptions options;
  options.joint_errors = {"none"};
  options.free = {"instrument.zero"};
  calibrate_with(state, options);
}

// One model, no search (--no-search: the tolerance prior).
void BM_Calibrate_NoSearch(benchmark::State& state) {
  CalibrationOptions options;
  options.search = false;
  calibrate_with(state, options);
}

// A 700-pose tracker problem: the Meca500 with its tracker positions (10 um),
// the geometry and gear harmonics off, calibrated by the default's search.
void BM_Calibrate_Tracker700(benchmark::State& state) {
  const DeviceModel nominal = testing::meca500();
  std::mt19937_64 rng(7);
  const DeviceModel actual = testing::perturbed(nominal, rng, 5e-4);
  SimulationNoise noise;
  noise.sigma_position = 10e-6;
  const Log log = simulate_log(actual, 700, noise, 3, /*distance=*/false, /*position=*/true);
  for (auto _ : state) {
    CalibrationResult r = calibrate(nominal, log, CalibrationOptions{});
    benchmark::DoNotOptimize(r.kinematics.rms_after);
  }
}

// The significance cut alone (--select, the default before issue 25).
void BM_Calibrate_Select(benchmark::State& state) {
  CalibrationOptions options;
  options.select = true;
  calibrate_with(state, options);
}

void BM_KdlPass200_Reference(benchmark::State& state) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const DeviceModel actual = paper_actual_device(nominal);
  const Log log = simulate_log(actual, 200, SimulationNoise{}, 1);
  const KDL::Chain chain = testing::kdl_chain(nominal);
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::ChainJntToJacSolver jac(chain);
  std::vector<KDL::JntArray> qs;
  for (int r = 0; r < log.rows; ++r) {
    KDL::JntArray a(nominal.dof());
    for (int i = 0; i < nominal.dof(); ++i) a(i) = log.q(r, i);
    qs.push_back(a);
  }
  KDL::Frame T;
  KDL::Jacobian J(nominal.dof());
  for (auto _ : state) {
    for (const KDL::JntArray& q : qs) {
      fk.JntToCart(q, T);
      jac.JntToJac(q, J);
      benchmark::DoNotOptimize(T.p.data);
    }
  }
}

// Issue 4: one trial of the default study with its files (logs, trajectory of
// 100 s at 1 kHz, models, figure series), as `hapticcal simulate` runs it.
void BM_Simulate_DefaultTrial(benchmark::State& state) {
  const Scenario sc = default_scenario(testing::source_path("data/devices/baser-7dof.yaml"));
  const std::string out = "/tmp/hapticcal_bench_simulate";
  for (auto _ : state) {
    TrialResult t = run_trial(sc, trial_seed(sc.seed, 0), out);
    benchmark::DoNotOptimize(t.trajectory_rms_full);
  }
  std::filesystem::remove_all(out);
}

BENCHMARK(BM_Calibrate_Default)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Calibrate_Estimators)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Calibrate_NoSearch)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Calibrate_Tracker700)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Calibrate_Select)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate_DefaultTrial)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KdlPass200_Reference)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  return hapticcal::bench::ratio_main(
      argc, argv,
      hapticcal::bench::Pairs{{"BM_Calibrate_Default", "BM_KdlPass200_Reference"},
                              {"BM_Calibrate_Default", "BM_Calibrate_Estimators"},
                              {"BM_Calibrate_Tracker700", "BM_Calibrate_Estimators"},
                              {"BM_Calibrate_Estimators", "BM_KdlPass200_Reference"},
                              {"BM_Calibrate_NoSearch", "BM_KdlPass200_Reference"},
                              {"BM_Calibrate_Tracker700", "BM_KdlPass200_Reference"}});
}
