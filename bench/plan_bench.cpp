// A plan of 200 poses from 10,000 random candidates for
// the built-in device (distances, the default I criterion, greedy start,
// exchange, continuous refinement and path; without the report's comparison
// with random designs) in <= 2 s. Reference in the same run: the full two-step
// calibration of the default 200-pose problem (BM_Calibrate_Default's work).
#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/simulation.hpp"
#include "ratio_main.hpp"
#include "test_models.hpp"

namespace {

using namespace hapticcal;

void BM_Plan_Default(benchmark::State& state) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  for (auto _ : state) {
    const PlanProblem problem(nominal, MeasurementType::kDistance, kPaperSigmaMPaper, kPaperSigmaE,
                              random_readings(nominal, 300, 1));
    PlanOptions o;
    o.poses = 200;
    o.pool = 10000;
    o.random_draws = 0;
    o.evaluation_poses = 200;
    const Plan plan = plan_poses(problem, o);
    benchmark::DoNotOptimize(plan.planned.rms_sd);
    state.counters["rms_sd_um"] = plan.planned.rms_sd * 1e6;
  }
}

void BM_Calibrate200_Reference(benchmark::State& state) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const Log log = simulate_log(paper_actual_device(nominal), 200, SimulationNoise{}, 1);
  for (auto _ : state) {
    CalibrationResult r = calibrate(nominal, log, CalibrationOptions{});
    benchmark::DoNotOptimize(r.kinematics.rms_after);
  }
}

BENCHMARK(BM_Plan_Default)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Calibrate200_Reference)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  return hapticcal::bench::ratio_main(
      argc, argv, hapticcal::bench::Pairs{{"BM_Plan_Default", "BM_Calibrate200_Reference"}});
}
