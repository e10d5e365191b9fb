// The model search (issue 39, docs/calibrate.md, "The model search"): the candidates'
// honest held-out errors against calibrating fold by fold by hand, the rule
// that keeps the simplest model within a standard error of the best, what the
// options restrict, and what makes a result unusable.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/simulation.hpp"
#include "identification/problem/stack.hpp"
#include "identification/search/held_out.hpp"
#include "identification/search/prior.hpp"
#include "support/held_out.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

// A Meca500 whose geometry deviates by up to 1 mm / 1 mrad, seen by a tracker
// (20 um) at `poses` random poses.
Log meca500_tracker_log(int poses, std::uint64_t seed, DeviceModel* truth_out = nullptr) {
  const DeviceModel nominal = testing::meca500();
  std::mt19937_64 rng(seed);
  const DeviceModel truth = testing::perturbed(nominal, rng, 1e-3);
  if (truth_out) *truth_out = truth;
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  return simulate_log(truth, poses, noise, seed + 100, false, true);
}

CalibrationOptions one_model(Estimator e) {
  CalibrationOptions o;
  o.search = false;
  o.keep_all = e == Estimator::kLeastSquares;
  o.select = e == Estimator::kCut;
  o.prior = e == Estimator::kPrior;
  o.folds = 0;
  return o;
}

// Each estimator's held-out error, re-run on each fold's training poses on the
// problem linearised at the whole fit, against calibrating those poses by hand
// (Levenberg-Marquardt, the cut's elimination and the prior's evidence on the
// nonlinear problem) and evaluating the fold's own.
TEST(ModelSearch, HeldOutErrorsAreThoseOfCalibratingEachFoldByHand) {
  const DeviceModel nominal = testing::meca500();
  const Log log = meca500_tracker_log(60, 4);
  CalibrationOptions options;
  const KinematicProblem problem = kinematic_problem(nominal, log, {}, options);
  const std::vector<int> candidates = candidate_slots(nominal, {}, {});
  const IdentifiabilityAnalysis analysis = analyze_identifiability(problem, candidates);
  const KinematicSolution solution = solve_kinematics(problem, analysis.identified);
  ASSERT_EQ(solution.termination, SolveTermination::kConverged);
  const detail::Stack at =
      detail::stack(nominal.structure(), solution.parameters, problem.joints,
                    detail::rows_of(problem), problem.measured, problem.weights);
  const Eigen::VectorXd tolerance = detail::slot_tolerances(nominal, options.tolerances);
  const detail::HeldOutSystem system =
      detail::held_out_system(problem, at, analysis.identified, analysis.scale,
                              nominal.kinematic_parameters(), solution.parameters, tolerance);
  std::vector<int> all(analysis.identified.size());
  std::iota(all.begin(), all.end(), 0);
  const Estimator estimators[] = {Estimator::kLeastSquares, Estimator::kCut, Estimator::kPrior};
  std::vector<detail::LinearCandidate> linear;
  for (Estimator e : estimators) linear.push_back({all, e});
  detail::FoldPlan plan;
  plan.folds = 5;
  plan.repeats = 1;
  plan.seed = 7;
  const std::vector<Eigen::VectorXd> errors =
      detail::held_out_errors(system, linear, plan, options.selection_alpha, std::nullopt);
  const std::vector<int> fold = pose_folds(log.rows, 5, 7);
  for (size_t k = 0; k < 3; ++k) {
    ASSERT_EQ(errors[k].size(), log.rows);
    double by_hand = 0;
    for (int f = 0; f < 5; ++f) {
      std::vector<std::vector<int>> train, test;
      for (int i = 0; i < log.rows; ++i) (fold[i] == f ? test : train).push_back({i});
      const CalibrationResult c =
          calibrate(nominal, average_repeats(log, train), one_model(estimators[k]));
      ASSERT_EQ(c.status, CalibrationStatus::kConverged) << c.status_reason;
      const Evaluation e = evaluate(c.calibrated, average_repeats(log, test));
      by_hand += e.figure("position")->error.squaredNorm();
    }
    const double linearised = errors[k].sum();
    std::printf("%s: held-out RMS %.6f mm linearised, %.6f mm by hand\n", to_string(estimators[k]),
                std::sqrt(linearised / log.rows) * 1e3, std::sqrt(by_hand / log.rows) * 1e3);
    // Least squares: the refits to second order; the cut and the prior decide
    // (what to hold, the evidence's scale) on the linearised problem.
    EXPECT_NEAR(std::sqrt(linearised / by_hand), 1.0,
                estimators[k] == Estimator::kLeastSquares ? 1e-4 : 1e-2)
        << to_string(estimators[k]);
  }
}

// The prior's evidence in its eigenbasis (free columns eliminated once) is the
// same as solving the whole system at each lambda: the MAP step against a
// direct solve of (J^T J + lambda P) dx = ... on random normal equations.
TEST(ModelSearch, PriorStepIsTheDirectSolveOfTheMapSystem) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n;
  const int rows = 40, k = 6;
  Eigen::MatrixXd J(rows, k);
  Eigen::VectorXd r(rows);
  for (int i = 0; i < rows; ++i) {
    r[i] = n(rng);
    for (int j = 0; j < k; ++j) J(i, j) = n(rng);
  }
  detail::NormalEquations ne{J.transpose() * J, J.transpose() * r, r.squaredNorm()};
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::VectorXd tolerance(k), deviation(k);
  tolerance << 0.5, 2.0, inf, 1.0, inf, 0.3;
  deviation << 0.1, -0.4, 0, 0.2, 0, -0.05;
  const std::optional<detail::PriorChoice> c =
      detail::choose_prior(ne, tolerance, deviation, rows, std::nullopt);
  ASSERT_TRUE(c.has_value());
  // Direct: minimise |r + J dx|^2 + lambda sum over prior columns of
  // ((dev_j + dx_j) / t_j)^2.
  Eigen::MatrixXd A = ne.G;
  Eigen::VectorXd b = -ne.g;
  for (int j = 0; j < k; ++j) {
    if (!std::isfinite(tolerance[j])) continue;
    const double w = c->lambda / (tolerance[j] * tolerance[j]);
    A(j, j) += w;
    b[j] -= w * deviation[j];
  }
  const Eigen::VectorXd direct = A.ldlt().solve(b);
  EXPECT_LT((c->step - direct).norm(), 1e-10 * direct.norm());
  // Each data share is 1 - lambda [(H + lambda P)^-1]_jj in tolerance units.
  for (int j = 0; j < k; ++j) {
    if (!std::isfinite(tolerance[j])) {
      EXPECT_DOUBLE_EQ(c->data_share[j], 1.0);
      continue;
    }
    const double inverse = A.inverse()(j, j) / (tolerance[j] * tolerance[j]);
    EXPECT_NEAR(c->data_share[j], 1 - c->lambda * inverse, 1e-10);
  }
}

// A geometric truth: the search keeps no joint-error family (the families it
// compared fit noise), and the model kept is the simplest within a standard
// error of the best.
TEST(ModelSearch, GeometricTruthKeepsNoJointErrorFamily) {
  DeviceModel truth;
  const Log log = meca500_tracker_log(200, 11, &truth);
  const CalibrationResult r = calibrate(testing::meca500(), log, {});
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  const ModelSearch& s = r.kinematics.search;
  ASSERT_TRUE(s.ran) << s.note;
  EXPECT_TRUE(r.kinematics.joint_error_families.empty());
  bool families_compared = false;
  for (const SearchCandidate& c : s.candidates) families_compared |= !c.families.empty();
  EXPECT_TRUE(families_compared);
  // The rule: the kept one is within one standard error of the best, and no
  // candidate with fewer families is.
  const SearchCandidate& kept = s.candidates[s.kept];
  const SearchCandidate& best = s.candidates[s.best];
  EXPECT_LE(kept.cv_rms - best.cv_rms, kept.difference_se + 1e-15);
  for (const SearchCandidate& c : s.candidates) {
    if (c.families.size() < kept.families.size() && c.usable && std::isfinite(c.cv_rms)) {
      EXPECT_GT(c.cv_rms - best.cv_rms, c.difference_se);
    }
  }
  EXPECT_EQ(r.kinematics.cv_rms, kept.cv_rms);
  EXPECT_LT(kept.cv_rms, 0.1 * s.nominal_rms);
}

// What the options name restricts the search to it.
TEST(ModelSearch, OptionsRestrictTheSearchToWhatTheyName) {
  const DeviceModel nominal = testing::meca500();
  const Log log = meca500_tracker_log(80, 5);
  CalibrationOptions keep_all;
  keep_all.keep_all = true;
  const CalibrationResult a = calibrate(nominal, log, keep_all);
  ASSERT_TRUE(a.kinematics.search.ran);
  for (const SearchCandidate& c : a.kinematics.search.candidates) {
    EXPECT_EQ(c.estimator, Estimator::kLeastSquares);
  }
  CalibrationOptions compliance;
  compliance.joint_errors = {"compliance"};
  const CalibrationResult b = calibrate(nominal, log, compliance);
  ASSERT_TRUE(b.kinematics.search.ran);
  int references = 0;
  for (const SearchCandidate& c : b.kinematics.search.candidates) {
    EXPECT_EQ(c.allowed, c.families == std::vector<std::string>{"compliance"});
    references += !c.allowed;
  }
  EXPECT_GT(references, 0);  // the geometry alone, for what the family bought
  EXPECT_EQ(b.kinematics.joint_error_families, std::vector<std::string>{"compliance"});
  EXPECT_TRUE(std::isfinite(b.kinematics.cv_rms_without_joint_errors));
  CalibrationOptions none;
  none.joint_errors = {"none"};
  for (const SearchCandidate& c : calibrate(nominal, log, none).kinematics.search.candidates) {
    EXPECT_TRUE(c.families.empty());
  }
  CalibrationOptions off;
  off.search = false;
  const CalibrationResult d = calibrate(nominal, log, off);
  EXPECT_FALSE(d.kinematics.search.ran);
  EXPECT_TRUE(d.kinematics.search.candidates.empty());
  EXPECT_EQ(d.kinematics.estimator, Estimator::kPrior);
  CalibrationOptions two;
  two.keep_all = two.prior = true;
  EXPECT_THROW(calibrate(nominal, log, two), InputError);
  CalibrationOptions mixed;
  mixed.joint_errors = {"none", "harmonic"};
  EXPECT_THROW(calibrate(nominal, log, mixed), InputError);
}

// Distances with no instrument zero in the truth: the zero is not supported
// and is held in every candidate (fitted and left out of the model, it would
// carry the noise into the device); with a 5 mm zero it is fitted.
TEST(ModelSearch, InstrumentZeroIsFittedOnlyWhereTheDataSupportIt) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const DeviceModel actual = paper_actual_device(nominal);
  const Log clean = simulate_log(actual, 200, SimulationNoise{}, 21);
  const CalibrationResult r = calibrate(nominal, clean, {});
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  for (const SearchCandidate& c : r.kinematics.search.candidates) EXPECT_FALSE(c.zero);
  // Held, the device's distances are better predicted than with the zero fitted
  // (it would carry the noise into the device): over 10 draws.
  SimulationNoise none;
  none.sigma_ext = none.sigma_distance = 0;
  const Log check = simulate_log(actual, 300, none, 999);
  double held = 0, fitted = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Log log = simulate_log(actual, 200, SimulationNoise{}, seed);
    CalibrationOptions free_zero;
    free_zero.free = {"instrument.zero"};
    held += std::pow(
        evaluate(calibrate(nominal, log, {}).calibrated, check).figure("distance")->stats.rms, 2);
    fitted += std::pow(evaluate(calibrate(nominal, log, free_zero).calibrated, check)
                           .figure("distance")
                           ->stats.rms,
                       2);
  }
  std::printf("distance RMS on new poses over 10 draws: zero held %.2f um, fitted %.2f um\n",
              std::sqrt(held / 10) * 1e6, std::sqrt(fitted / 10) * 1e6);
  EXPECT_LT(held, fitted);
  Log shifted = clean;
  shifted.distance.array() += 0.005;
  const CalibrationResult z = calibrate(nominal, shifted, {});
  ASSERT_EQ(z.status, CalibrationStatus::kConverged) << z.status_reason;
  EXPECT_NEAR(identified_instrument_zero(z.kinematics), 0.005, 1e-4);
  EXPECT_TRUE(z.kinematics.search.candidates[z.kinematics.search.kept].zero);
}

// A result no model of which predicts held-out poses better than the nominal
// with the measurement frame registered is unusable: 14 poses of a Meca500
// that is its nominal, by least squares alone (27 parameters on 42 rows).
TEST(ModelSearch, WorseThanTheNominalOnHeldOutPosesIsUnusable) {
  const DeviceModel nominal = testing::meca500();
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  const Log log = simulate_log(nominal, 14, noise, 3, false, true);
  CalibrationOptions keep_all;
  keep_all.keep_all = true;
  const CalibrationResult r = calibrate(nominal, log, keep_all);
  EXPECT_EQ(r.status, CalibrationStatus::kImplausible) << r.status_reason;
  EXPECT_NE(r.status_reason.find("better than the nominal model"), std::string::npos)
      << r.status_reason;
  for (const SearchCandidate& c : r.kinematics.search.candidates) EXPECT_FALSE(c.usable);
  // The default may keep the cut or the prior, which can hold the geometry.
  const CalibrationResult d = calibrate(nominal, log, {});
  EXPECT_EQ(d.status, CalibrationStatus::kConverged) << d.status_reason;
}

// The search's result does not depend on the threads it runs on.
TEST(ModelSearch, ThreadsDoNotChangeTheResult) {
  const DeviceModel nominal = testing::meca500();
  const Log log = meca500_tracker_log(100, 8);
  CalibrationOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const CalibrationResult a = calibrate(nominal, log, one), b = calibrate(nominal, log, two);
  ASSERT_EQ(a.kinematics.search.candidates.size(), b.kinematics.search.candidates.size());
  for (size_t i = 0; i < a.kinematics.search.candidates.size(); ++i) {
    EXPECT_EQ(a.kinematics.search.candidates[i].cv_rms, b.kinematics.search.candidates[i].cv_rms);
  }
  EXPECT_EQ(a.calibrated.kinematic_parameters(), b.calibrated.kinematic_parameters());
}

}  // namespace
}  // namespace hapticcal
