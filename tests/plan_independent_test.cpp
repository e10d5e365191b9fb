// Planned poses judged by a measure the plan never saw (issue 24).
// plan_meca500_test shows the planned pose set beating random subsets only by
// the plan's own measure (rms_sd: the linearised Cramer-Rao prediction of the
// criterion it optimised). Here a plan is judged by what calibrating on it gives:
// a simulated Meca500 (examples/meca500/meca500.yaml) of known true geometry,
// measured by a laser tracker (positions, sd kPlanSigmaPosition = 10 um per
// coordinate) at every candidate pose; the model calibrated by `calibrate`
// with its defaults (nonlinear LM, model selection) on the planned poses and on
// random subsets of the same candidates of the same size, each scored by the RMS
// position error of the calibrated model against the truth at 1000 held-out
// poses that neither the plan nor any calibration used.
//
// One trial (seed s = 1000, 2000, ... 15000): true device = nominal with every
// kinematic parameter moved uniformly within +-1 mm / +-1 mrad (seed s); the
// candidates random_readings(seed s + 1); the held-out poses random_readings(s + 2);
// the plan (criterion I, its default) with seed s + 3; the 9 random subsets
// drawn by std::mt19937_64(s + 5); 3 noise realisations of the tracker
// (simulate_measurement_log seeds s + 10 .. s + 12), each design calibrated on
// each and scored by the RMS over all three (the design's expected error, less
// the luck of one noise draw). A trial's ratio: planned / median of the random
// subsets. 15 trials; the medians over them are asserted.
//
// A placebo run of the same statistic, one random subset in the planned one's
// place (against the median of the other 8), shows what the assertions reject.
// Measured (Release and -O1 alike; seeds fixed, so deterministic):
//   20 of 500 candidates: median ratio 0.776 (worst trial 0.884), planned better
//     in 15 of 15 trials; placebo median 1.028, better in 6 of 15. The plan's own
//     measure predicted 0.766. Asserted: median <= 0.85 (margin 9 %), >= 13 wins.
//   20 of 70 candidates (plan_meca500_test's numbers): median 0.837 (worst 1.022),
//     14 of 15; placebo median 1.010, 7 of 15; predicted 0.805. Asserted:
//     median <= 0.92 (margin 9 %), >= 12 wins.
// Both fail for the placebo. About 5 s each (10.4 s in all) on a loaded 2-core machine.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/simulation.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t m = v.size();
  return m % 2 ? v[m / 2] : 0.5 * (v[m / 2 - 1] + v[m / 2]);
}

// The rows `chosen` of a log (one row a pose), in the order given.
Log rows_of(const Log& log, const std::vector<int>& chosen) {
  Log out = log;
  const auto n = static_cast<Eigen::Index>(chosen.size());
  out.rows = static_cast<int>(n);
  auto take = [&](const Eigen::MatrixXd& from, Eigen::MatrixXd& to) {
    if (from.rows() != log.rows) return;
    to.resize(n, from.cols());
    for (Eigen::Index i = 0; i < n; ++i) to.row(i) = from.row(chosen[i]);
  };
  take(log.q, out.q);
  take(log.ext, out.ext);
  take(log.position, out.position);
  take(log.orientation, out.orientation);
  if (log.distance.size() == log.rows) {
    out.distance.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) out.distance[i] = log.distance[chosen[i]];
  }
  out.line.clear();
  for (int i : chosen) out.line.push_back(log.line.empty() ? i + 2 : log.line[i]);
  return out;
}

// The true device: every kinematic parameter of the nominal one moved
// uniformly within +-1 mm or +-1 mrad.
DeviceModel true_device(const DeviceModel& nominal, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  DeviceModel actual = nominal;
  Eigen::VectorXd p = actual.kinematic_parameters();
  for (const ParameterInfo& info : actual.parameter_info()) p[info.slot] += u(rng);
  actual.set_kinematic_parameters(p);
  return actual;
}

struct Trial {
  double planned = 0;          // held-out RMS position error of the planned poses' calibration [m]
  std::vector<double> random;  // of each random subset's
  double predicted_ratio = 0;  // the plan's own measure: planned / median random rms_sd
};

constexpr int kRandomSubsets = 9, kNoiseDraws = 3, kHeldOut = 1000;

Trial run_trial(const DeviceModel& nominal, int poses, int candidate_count, std::uint64_t seed) {
  const DeviceModel actual = true_device(nominal, seed);
  const Eigen::MatrixXd candidates = random_readings(nominal, candidate_count, seed + 1);
  const Eigen::MatrixXd held_out = random_readings(nominal, kHeldOut, seed + 2);
  PlanOptions o;
  o.poses = poses;
  o.candidates = candidates;
  o.random_draws = kRandomSubsets;  // for the printed prediction only
  o.seed = seed + 3;
  const PlanProblem problem(nominal, MeasurementType::kPosition, kPlanSigmaPosition, kPaperSigmaE,
                            candidates);
  const Plan plan = plan_poses(problem, o);
  EXPECT_EQ(plan.candidate.size(), static_cast<size_t>(poses));

  const PreparedModel truth(actual);
  std::vector<Eigen::Vector3d> truth_p(held_out.rows());
  for (Eigen::Index v = 0; v < held_out.rows(); ++v) {
    const Eigen::VectorXd q = held_out.row(v).transpose();
    truth_p[v] = truth.forward(q.data()).p;
  }
  SimulationNoise noise;
  noise.sigma_position = kPlanSigmaPosition;
  std::vector<Log> logs;
  for (int k = 0; k < kNoiseDraws; ++k) {
    logs.push_back(simulate_measurement_log(actual, MeasurementType::kPosition, 0, candidates,
                                            noise, seed + 10 + k));
  }
  // RMS over the noise draws and held-out poses of |p_calibrated - p_true|.
  auto held_out_rms = [&](const std::vector<int>& chosen) {
    double sum = 0;
    for (const Log& log : logs) {
      const CalibrationResult r = calibrate(nominal, rows_of(log, chosen), {});
      EXPECT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
      const PreparedModel model(r.calibrated);
      for (Eigen::Index v = 0; v < held_out.rows(); ++v) {
        const Eigen::VectorXd q = held_out.row(v).transpose();
        sum += (model.forward(q.data()).p - truth_p[v]).squaredNorm();
      }
    }
    return std::sqrt(sum / static_cast<double>(held_out.rows() * logs.size()));
  };
  Trial trial;
  trial.planned = held_out_rms(plan.candidate);
  std::mt19937_64 rng(seed + 5);
  for (int k = 0; k < kRandomSubsets; ++k) {
    std::vector<int> idx(candidate_count);
    std::iota(idx.begin(), idx.end(), 0);
    std::shuffle(idx.begin(), idx.end(), rng);
    idx.resize(poses);
    trial.random.push_back(held_out_rms(idx));
  }
  trial.predicted_ratio = plan.planned.rms_sd / plan.random_median_rms_sd;
  return trial;
}

struct Summary {
  double median_ratio = 0, worst_ratio = 0;
  int wins = 0;
  double placebo_median_ratio = 0;
  int placebo_wins = 0;
};

Summary run(int poses, int candidate_count) {
  constexpr int kTrials = 15;
  const auto start = std::chrono::steady_clock::now();
  const DeviceModel nominal = testing::meca500();
  std::vector<double> ratio, placebo, predicted;
  Summary s;
  for (int t = 0; t < kTrials; ++t) {
    const Trial r = run_trial(nominal, poses, candidate_count, 1000 * (t + 1));
    const double random_median = median(r.random);
    const double others = median(std::vector<double>(r.random.begin() + 1, r.random.end()));
    ratio.push_back(r.planned / random_median);
    placebo.push_back(r.random[0] / others);
    predicted.push_back(r.predicted_ratio);
    s.wins += r.planned < random_median;
    s.placebo_wins += r.random[0] < others;
    std::printf(
        "trial %2d: planned %6.2f um, random median %6.2f um (%6.2f - %6.2f), ratio %.3f "
        "(predicted %.3f), placebo %.3f\n",
        t, r.planned * 1e6, random_median * 1e6,
        *std::min_element(r.random.begin(), r.random.end()) * 1e6,
        *std::max_element(r.random.begin(), r.random.end()) * 1e6, ratio.back(), predicted.back(),
        placebo.back());
  }
  s.median_ratio = median(ratio);
  s.worst_ratio = *std::max_element(ratio.begin(), ratio.end());
  s.placebo_median_ratio = median(placebo);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "%d of %d candidates: median ratio %.3f (worst %.3f), planned better in %d of %d; "
      "predicted median %.3f; placebo median %.3f, better in %d of %d; %.1f s\n",
      poses, candidate_count, s.median_ratio, s.worst_ratio, s.wins, kTrials, median(predicted),
      s.placebo_median_ratio, s.placebo_wins, kTrials, seconds);
  return s;
}

// A plan from many candidates: 20 of 500.
TEST(PlanIndependent, TwentyOfFiveHundredCalibrateBetterOnHeldOutPosesThanRandomSubsets) {
  const Summary s = run(20, 500);
  EXPECT_LE(s.median_ratio, 0.85);
  EXPECT_GE(s.wins, 13);
  // The same statistic for a random subset does not pass (the assertions can fail).
  EXPECT_GT(s.placebo_median_ratio, 0.85);
  EXPECT_LT(s.placebo_wins, 13);
}

// plan_meca500_test's numbers, in simulation: 20 of 70.
TEST(PlanIndependent, TwentyOfSeventyCalibrateBetterOnHeldOutPosesThanRandomSubsets) {
  const Summary s = run(20, 70);
  EXPECT_LE(s.median_ratio, 0.92);
  EXPECT_GE(s.wins, 12);
  EXPECT_GT(s.placebo_median_ratio, 0.92);
  EXPECT_LT(s.placebo_wins, 12);
}

}  // namespace
}  // namespace hapticcal
