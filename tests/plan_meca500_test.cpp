// Issue 12, C: plan on real laser-tracker data. For each Meca500 set, `plan`
// chooses 20 of cal-<set>'s 70 recorded poses (position measurements); the
// model is calibrated on those poses' rows (all 3 repeats) and validated on
// val-<set>, against the median of 15 random 20-pose subsets. No target (the
// real errors are not the model's alone): the table of docs/plan.md, and sane
// results (converged, finite).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/paper.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using testing::kMeca500Sets;
using testing::meca500_log;

// The rows of the chosen poses (every repeat), in log order.
Log rows_of(const Log& log, const std::vector<std::vector<int>>& groups,
            const std::vector<int>& chosen) {
  std::vector<int> rows;
  for (int g : chosen) rows.insert(rows.end(), groups[g].begin(), groups[g].end());
  std::sort(rows.begin(), rows.end());
  Log out = log;
  out.rows = static_cast<int>(rows.size());
  out.q.resize(out.rows, log.q.cols());
  out.ext.resize(out.rows, log.ext.cols());
  out.position.resize(out.rows, 3);
  out.line.clear();
  for (int i = 0; i < out.rows; ++i) {
    out.q.row(i) = log.q.row(rows[i]);
    out.ext.row(i) = log.ext.row(rows[i]);
    out.position.row(i) = log.position.row(rows[i]);
    out.line.push_back(log.line[rows[i]]);
  }
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t m = v.size();
  return m % 2 ? v[m / 2] : 0.5 * (v[m / 2 - 1] + v[m / 2]);
}

TEST(PlanMeca500, TwentyPlannedOfSeventyRecordedPosesAgainstRandomSubsets) {
  const DeviceModel nominal = testing::meca500();
  constexpr int kPoses = 20, kRandom = 15;
  std::printf("%-32s %10s %12s %7s %10s %12s %7s\n", "set", "planned", "random(med)", "ratio",
              "pred.plan", "pred.random", "ratio");
  std::vector<double> ratios;
  for (const char* set : kMeca500Sets) {
    const Log cal = meca500_log("cal", set), val = meca500_log("val", set);
    const std::vector<std::vector<int>> groups = repeated_poses(cal);
    ASSERT_EQ(groups.size(), 70u) << set;
    PlanOptions o;
    o.poses = kPoses;
    o.candidates.resize(static_cast<Eigen::Index>(groups.size()), nominal.dof());
    for (size_t g = 0; g < groups.size(); ++g) o.candidates.row(g) = cal.q.row(groups[g].front());
    const PlanProblem problem(nominal, MeasurementType::kPosition, kPlanSigmaPosition, kPaperSigmaE,
                              o.candidates);
    const Plan plan = plan_poses(problem, o);
    std::vector<int> chosen = plan.candidate;
    ASSERT_EQ(chosen.size(), static_cast<size_t>(kPoses));
    std::sort(chosen.begin(), chosen.end());
    EXPECT_EQ(std::unique(chosen.begin(), chosen.end()), chosen.end()) << set;
    auto validated = [&](const std::vector<int>& poses) {
      const CalibrationResult r = calibrate(nominal, rows_of(cal, groups, poses), {});
      EXPECT_EQ(r.status, CalibrationStatus::kConverged) << set << ": " << r.status_reason;
      const double rms = evaluate(r.calibrated, val).figure("position")->stats.rms;
      EXPECT_TRUE(std::isfinite(rms)) << set;
      return rms;
    };
    const double planned = validated(chosen);
    std::vector<double> random;
    std::mt19937_64 rng(12);
    for (int k = 0; k < kRandom; ++k) {
      std::vector<int> idx(groups.size());
      std::iota(idx.begin(), idx.end(), 0);
      std::shuffle(idx.begin(), idx.end(), rng);
      idx.resize(kPoses);
      random.push_back(validated(idx));
    }
    const double random_median = median(random);
    ratios.push_back(planned / random_median);
    std::printf("%-32s %7.1f um %9.1f um %7.3f %7.1f um %9.1f um %7.3f\n", set, planned * 1e6,
                random_median * 1e6, planned / random_median, plan.planned.rms_sd * 1e6,
                plan.random_median_rms_sd * 1e6, plan.planned.rms_sd / plan.random_median_rms_sd);
    EXPECT_GT(planned, 0) << set;
    EXPECT_LT(plan.planned.rms_sd, plan.random_median_rms_sd) << set;  // by the plan's own measure
  }
  std::printf("median ratio planned / random over the 7 sets: %.3f\n", median(ratios));
}

}  // namespace
}  // namespace hapticcal
