// Experiment design (issue 12): planned poses against random ones of the same
// count and of twice the count, by the exact two-step Cramer-Rao covariance on
// an independent validation sample; the path; plan.csv.
#include "hapticcal/design/plan.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/paper.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t m = v.size();
  return m % 2 ? v[m / 2] : 0.5 * (v[m / 2 - 1] + v[m / 2]);
}

struct Builtin {
  DeviceModel model = load_device(builtin_device_path());
  Eigen::MatrixXd analysis = random_readings(model, 300, 11);
  PlanProblem problem{model, MeasurementType::kDistance, kPaperSigmaMPaper, kPaperSigmaE, analysis};
  // 2000 validation poses, independent of the plan's own samples.
  Eigen::MatrixXd validation = random_readings(model, 2000, 777);
  Eigen::MatrixXd G = problem.prediction_rows(validation);

  double sd(const Eigen::MatrixXd& design) const {
    return problem.rms_sd_of(problem.covariance(design), G);
  }
  double median_random(int poses, int draws = 20) const {
    std::vector<double> v;
    for (int k = 0; k < draws; ++k) v.push_back(sd(random_readings(model, poses, 1000 + k)));
    return median(v);
  }
};

TEST(Plan, BuiltinDistanceParametersAreTheIdentifiableSetPlusStepOne) {
  const Builtin b;
  EXPECT_EQ(b.problem.kinematic_slots().size(), 28u);  // 28 of 32
  EXPECT_EQ(b.problem.held().size(), 10u);             // 4 of the links and base, 6 of the tool
  // Capstans 1-3: 5 parameters and c each; joint 4: polynomial order 10 and c.
  EXPECT_EQ(b.problem.parameters(), 28 + 3 * 6 + 11);
  EXPECT_EQ(b.problem.rows_per_pose(), 1 + 4);
}

// Acceptance A: 30 planned poses predict <= 1/4 of the RMS distance sd of 30
// random ones (median of 20 draws); 100 planned <= 200 random.
TEST(Plan, ThirtyPlannedPosesPredictAQuarterOfRandomSd) {
  const Builtin b;
  PlanOptions o;
  o.poses = 30;
  o.seed = 1;
  const Plan plan = plan_poses(b.problem, o);
  const double planned = b.sd(plan.readings), random = b.median_random(30);
  std::printf("30 poses: planned %.3f um, random %.3f um (median of 20), ratio %.3f; %.2f s\n",
              planned * 1e6, random * 1e6, planned / random, plan.seconds);
  EXPECT_LE(planned, random / 4);
  EXPECT_EQ(plan.readings.rows(), 30);
}

// Every measurement of the family: 3 position rows or 6 pose rows a pose (the
// rotation rows scaled by the length scale); more parameters identifiable than
// from distances; the plan predicts less than random poses by its own measure.
TEST(Plan, PositionAndPosePlansBeatRandomPoses) {
  const DeviceModel model = load_device(builtin_device_path());
  const Eigen::MatrixXd analysis = random_readings(model, 300, 11);
  size_t distance_slots = 0;
  for (MeasurementType type :
       {MeasurementType::kDistance, MeasurementType::kPosition, MeasurementType::kPose}) {
    SCOPED_TRACE(traits(type).name);
    const PlanProblem problem(model, type, 1e-5, kPaperSigmaE, analysis);
    EXPECT_EQ(problem.dimension(), traits(type).dimension);
    if (type == MeasurementType::kDistance) distance_slots = problem.kinematic_slots().size();
    if (type != MeasurementType::kDistance) {
      EXPECT_GT(problem.kinematic_slots().size(), distance_slots);
    }
    PlanOptions o;
    o.poses = 40;
    o.pool = 2000;
    o.refine_passes = 2;
    o.random_draws = 5;
    const Plan plan = plan_poses(problem, o);
    std::printf("%s: %zu kinematic parameters, planned %.3f um, random %.3f um\n",
                traits(type).name, problem.kinematic_slots().size(), plan.planned.rms_sd * 1e6,
                plan.random_median_rms_sd * 1e6);
    EXPECT_TRUE(std::isfinite(plan.planned.rms_sd));
    EXPECT_LT(plan.planned.rms_sd, plan.random_median_rms_sd);
  }
}

// The path visits every pose once and is no longer than the unordered one.
TEST(Plan, ShortPathIsAPermutationAndNotLonger) {
  const DeviceModel model = load_device(builtin_device_path());
  const Eigen::MatrixXd q = random_readings(model, 60, 5);
  std::vector<int> order = short_path(q);
  Eigen::MatrixXd ordered(q.rows(), q.cols());
  for (size_t i = 0; i < order.size(); ++i) ordered.row(i) = q.row(order[i]);
  std::sort(order.begin(), order.end());
  for (int i = 0; i < 60; ++i) EXPECT_EQ(order[i], i);
  EXPECT_LT(path_length(ordered), 0.6 * path_length(q));
}

// plan.csv reads back as a log of the same readings (radians, 17 digits).
TEST(Plan, PlanCsvReadsBackExactly) {
  const DeviceModel model = load_device(builtin_device_path());
  const Eigen::MatrixXd q = random_readings(model, 7, 9);
  const Log log = parse_log(plan_to_csv(q), "plan.csv");
  ASSERT_EQ(log.rows, 7);
  EXPECT_EQ((log.q - q).cwiseAbs().maxCoeff(), 0.0);
}

// Constraints: every planned and refined pose puts the tool point in the
// distance range and the box.
TEST(Plan, ConstrainedPlansStayInsideTheDistanceRangeAndTheBox) {
  const DeviceModel model = load_device(builtin_device_path());
  PlanOptions o;
  o.poses = 40;
  o.pool = 2000;
  o.refine_passes = 3;
  o.random_draws = 3;
  o.constraints.min_distance = 0.35;
  o.constraints.max_distance = 0.6;
  o.constraints.box = std::array<double, 6>{-1, 1, -1, 1, -0.2, 1};
  const PlanProblem problem(model, MeasurementType::kDistance, kPaperSigmaMPaper, kPaperSigmaE,
                            random_readings(model, 300, 11, o.constraints));
  const Plan plan = plan_poses(problem, o);
  EXPECT_GT(plan.refined_moves, 0);
  const PreparedModel prepared(model);
  for (Eigen::Index i = 0; i < plan.readings.rows(); ++i) {
    const Eigen::VectorXd q = plan.readings.row(i).transpose();
    const Eigen::Vector3d p = prepared.forward(q.data()).p;
    EXPECT_TRUE(o.constraints.admits(p)) << i << ": " << p.transpose() << " |p| " << p.norm();
  }
}

// The kinematic fit's share alone, sigma_m^2 (J_k^T J_k)^-1 without step 1's
// error (the filer's figures: 100 random 6.3 um, 200 random 4.06 um).
double measurement_only(const Builtin& b, const Eigen::MatrixXd& design) {
  const int p = b.problem.parameters(), r = b.problem.rows_per_pose();
  const int k = static_cast<int>(b.problem.kinematic_slots().size());
  const Eigen::MatrixXd F = b.problem.fisher_rows(design);
  Eigen::MatrixXd Jk(design.rows(), k);
  for (Eigen::Index i = 0; i < design.rows(); ++i)
    Jk.row(i) = F.block(p - k, i * r, k, 1).transpose();
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(p, p);
  C.bottomRightCorner(k, k) = (Jk.transpose() * Jk).inverse();
  return b.problem.rms_sd_of(C, b.G);
}

double median_measurement_only(const Builtin& b, int poses) {
  std::vector<double> v;
  for (int k = 0; k < 20; ++k)
    v.push_back(measurement_only(b, random_readings(b.model, poses, 1000 + k)));
  return median(v);
}

// What is met of acceptance A's second half: 100 planned poses predict at
// least 20 % less than 100 random ones and at most 25 % more than 200 random.
TEST(Plan, HundredPlannedPosesPredictMuchLessThanHundredRandom) {
  const Builtin b;
  PlanOptions o;
  o.poses = 100;
  o.seed = 1;
  const Plan plan = plan_poses(b.problem, o);
  const double planned = b.sd(plan.readings);
  const double random100 = b.median_random(100), random200 = b.median_random(200);
  std::printf(
      "100 poses: planned %.3f um (two-step criterion %.6g after the exchange, %.6g refined), "
      "100 random %.3f um, 200 random %.3f um (medians of 20); %.2f s\n"
      "  measurement noise alone: planned %.3f um, 100 random %.3f um, 200 random %.3f um\n",
      planned * 1e6, plan.two_step_exchange, plan.two_step_refined, random100 * 1e6,
      random200 * 1e6, plan.seconds, measurement_only(b, plan.readings) * 1e6,
      median_measurement_only(b, 100) * 1e6, median_measurement_only(b, 200) * 1e6);
  EXPECT_LE(planned, 0.8 * random100);
  EXPECT_LE(planned, 1.25 * random200);
}

// Acceptance A's second half (100 planned poses predict no worse than 200
// random ones) is not met; a DISABLED test of it, which never ran, is deleted
// (issue 24): the test above prints the figures and this one shows why. With
// step 1's error included (as the Monte Carlo of plan_monte_carlo_test confirms
// it must be), 100 planned poses predict 7.4 um (about 7.0 um with 40 exchange
// sweeps and 60 refinement passes) against 6.15 um for 200 random ones. The
// encoder fits (capstans, the 10th-order polynomial of joint 4) then have half
// the samples: the plan cuts step 1's share of the variance by about 1.8
// against random poses of the same count, not by the 2 or more needed. The
// issue's filer's figures (100 random 6.3 um, 200 random 4.06 um) are the
// kinematic fit's measurement noise alone.
//
// Why acceptance A's second half is blocked, by a check independent of the
// planner: the issue's own measure (the kinematic fit's measurement noise
// alone, the filer's 4.06 um for 200 random poses) on the best approximate
// design of 100 poses over 6000 candidates rich in joint limits (each joint at
// its lower or upper limit or uniform, 1/3 each), found by the multiplicative
// algorithm for I-optimality and certified by the equivalence theorem (max d /
// value -> 1), stays above 200 random poses; so does a plan optimised for that
// measure alone (step 1 made exact).
TEST(Plan, HundredPosesCannotMatchTwoHundredRandomEvenOnTheKinematicFitAlone) {
  const Builtin b;
  const int p = b.problem.parameters(), r = b.problem.rows_per_pose();
  const int k = static_cast<int>(b.problem.kinematic_slots().size());
  const int n = 6000;
  Eigen::MatrixXd pool = random_readings(b.model, n, 4242);
  std::mt19937_64 rng(99);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < b.model.dof(); ++j) {
      const auto c = rng() % 3;
      if (c == 0) pool(i, j) = b.model.links[j].lower;
      if (c == 1) pool(i, j) = b.model.links[j].upper;
    }
  }
  const Eigen::MatrixXd F = b.problem.fisher_rows(pool);
  Eigen::MatrixXd f(k, n);
  for (int i = 0; i < n; ++i) f.col(i) = F.block(p - k, i * r, k, 1);
  const Eigen::MatrixXd Gk = b.G.bottomRows(k);
  const Eigen::MatrixXd W = Gk * Gk.transpose() / static_cast<double>(Gk.cols());
  Eigen::VectorXd w = Eigen::VectorXd::Constant(n, 1.0 / n), d(n);
  double value = 0;
  for (int it = 0; it < 800; ++it) {
    const Eigen::MatrixXd M = f * w.asDiagonal() * f.transpose();
    const Eigen::MatrixXd Minv = M.ldlt().solve(Eigen::MatrixXd::Identity(k, k));
    const Eigen::MatrixXd B = Minv * W * Minv;
    value = (W * Minv).trace();  // per pose: N poses give value / N
    for (int i = 0; i < n; ++i) d[i] = f.col(i).dot(B * f.col(i));
    w = w.cwiseProduct(d.cwiseSqrt());
    w /= w.sum();
  }
  const double bound = std::sqrt(value / 100), random200 = median_measurement_only(b, 200);
  const PlanProblem exact_step_one(b.model, MeasurementType::kDistance, kPaperSigmaMPaper, 1e-9,
                                   b.analysis);
  PlanOptions o;
  o.poses = 100;
  o.random_draws = 1;
  const double planned = measurement_only(b, plan_poses(exact_step_one, o).readings);
  std::printf(
      "kinematic fit alone: optimal approximate design of 100 poses %.3f um (max d / value %.4f), "
      "a plan for it %.3f um, 200 random %.3f um\n",
      bound * 1e6, d.maxCoeff() / value, planned * 1e6, random200 * 1e6);
  EXPECT_LT(d.maxCoeff() / value, 1.01);  // at the optimum: max d = value
  EXPECT_GT(bound, random200);
  EXPECT_GT(planned, random200);
  EXPECT_LT(planned, 1.05 * random200);  // yet within a few per cent of it
}

}  // namespace
}  // namespace hapticcal
