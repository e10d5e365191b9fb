// Model selection and cross-validation in `calibrate` (issue 12): on the real
// Meca500 data (held-out validation logs) and on simulated data whose truth is
// known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <numeric>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "hapticcal/study/study.hpp"
#include "nlohmann/json.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using testing::kMeca500Sets;
using testing::meca500_log;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

CalibrationOptions keep_all() {
  CalibrationOptions o;
  o.keep_all = true;
  o.search = false;  // one model
  return o;
}

// The significance cut (the default before the tolerance prior of issue 25).
CalibrationOptions select() {
  CalibrationOptions o;
  o.select = true;
  o.search = false;  // one model
  return o;
}

// Where nothing overfits (70 poses measured 3 times for 27 parameters) model
// selection must not cost accuracy: the 7-set mean validation RMS stays at or
// below the keep-all figure of issue 11 (0.0463 mm).
TEST(ModelSelection, Meca500SevenSetValidationMeanDoesNotGetWorse) {
  const DeviceModel nominal = testing::meca500();
  double sum_default = 0, sum_all = 0;
  for (const char* set : kMeca500Sets) {
    const Log cal = meca500_log("cal", set), val = meca500_log("val", set);
    const CalibrationResult d = calibrate(nominal, cal, select());
    const CalibrationResult a = calibrate(nominal, cal, keep_all());
    ASSERT_EQ(d.status, CalibrationStatus::kConverged) << set;
    ASSERT_EQ(a.status, CalibrationStatus::kConverged) << set;
    const double vd = evaluate(d.calibrated, val).figure("position")->stats.rms;
    const double va = evaluate(a.calibrated, val).figure("position")->stats.rms;
    std::printf(
        "%-32s default %2d params: train %.4f cv %.4f val %.4f mm | keep-all %2d: train %.4f cv "
        "%.4f val %.4f mm\n",
        set, d.kinematics.identified, d.kinematics.rms_after * 1e3, d.kinematics.cv_rms * 1e3,
        vd * 1e3, a.kinematics.identified, a.kinematics.rms_after * 1e3, a.kinematics.cv_rms * 1e3,
        va * 1e3);
    EXPECT_TRUE(d.kinematics.model_selection);
    EXPECT_FALSE(a.kinematics.model_selection);
    EXPECT_EQ(a.kinematics.identified, 27) << set;
    EXPECT_TRUE(std::isfinite(d.kinematics.cv_rms)) << set;
    // Held-out poses are predicted worse than the fitted ones, not absurdly so.
    EXPECT_GT(d.kinematics.cv_rms, d.kinematics.rms_after) << set;
    EXPECT_LT(d.kinematics.cv_rms, 3 * d.kinematics.rms_after) << set;
    sum_default += vd;
    sum_all += va;
  }
  const double mean_default = sum_default / 7, mean_all = sum_all / 7;
  std::printf("7-set mean validation RMS: default %.5f mm, --keep-all %.5f mm\n",
              mean_default * 1e3, mean_all * 1e3);
  EXPECT_LE(mean_default, 0.0463e-3);
}

// Where data are few (10 poses, 30 position readings averaged from 90 rows, for
// 27 parameters) selection must help: over 5 random draws, the default's
// median validation RMS is below --keep-all's.
TEST(ModelSelection, Meca500TenPosesValidateBetterThanKeepingEveryParameter) {
  const DeviceModel nominal = testing::meca500();
  const Log cal = meca500_log("cal", "norm_dist_data_0deg_160cube");
  const Log val = meca500_log("val", "norm_dist_data_0deg_160cube");
  std::vector<double> with_selection, with_all;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    CalibrationOptions d = select(), a = keep_all();
    d.samples = a.samples = 10;
    d.seed = a.seed = seed;
    const CalibrationResult rd = calibrate(nominal, cal, d);
    const CalibrationResult ra = calibrate(nominal, cal, a);
    ASSERT_EQ(rd.status, CalibrationStatus::kConverged) << seed;
    const double vd = evaluate(rd.calibrated, val).figure("position")->stats.rms;
    const double va = evaluate(ra.calibrated, val).figure("position")->stats.rms;
    std::printf(
        "seed %d: default %2d params val %.4f mm (cv %.4f) | keep-all %2d params val %.4f mm\n",
        static_cast<int>(seed), rd.kinematics.identified, vd * 1e3, rd.kinematics.cv_rms * 1e3,
        ra.kinematics.identified, va * 1e3);
    with_selection.push_back(vd);
    with_all.push_back(va);
  }
  std::printf("median validation RMS of 5 draws: default %.4f mm, --keep-all %.4f mm\n",
              median(with_selection) * 1e3, median(with_all) * 1e3);
  EXPECT_LT(median(with_selection), median(with_all));
}

// A Meca500 whose truth differs from nominal in six parameters only, measured
// at 30 poses with 20 um noise: the selection keeps all six (their changes are
// tens of standard deviations) and holds most of the other 21, and the model it
// keeps predicts 500 noise-free poses closer to the truth than --keep-all.
TEST(ModelSelection, HoldsWhatTheTruthLeavesAtNominalAndPredictsTheTruthBetter) {
  const DeviceModel nominal = testing::meca500_on_tracker();
  DeviceModel truth = nominal;
  const std::map<std::string, double> deviated = {{"j1.a", 5e-4},      {"j2.alpha", 1e-3},
                                                  {"j3.a", -4e-4},     {"j4.theta", 1e-3},
                                                  {"j5.alpha", -8e-4}, {"tool.x", 3e-4}};
  Eigen::VectorXd p = truth.kinematic_parameters();
  for (const ParameterInfo& pi : truth.parameter_info()) {
    if (deviated.count(pi.name)) p[pi.slot] += deviated.at(pi.name);
  }
  truth.set_kinematic_parameters(p);
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  std::vector<double> selected_error, all_error;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const Log log = simulate_log(truth, 30, noise, seed, false, true);
    SimulationNoise exact = noise;
    exact.sigma_position = 0;
    const Log check = simulate_log(truth, 500, exact, 100 + seed, false, true);
    const CalibrationResult d = calibrate(nominal, log, select());
    const CalibrationResult a = calibrate(nominal, log, keep_all());
    ASSERT_EQ(d.status, CalibrationStatus::kConverged);
    int held_unchanged = 0;
    for (const ParameterEstimate& e : d.kinematics.parameters) {
      if (deviated.count(e.name)) {
        EXPECT_TRUE(e.identifiable) << e.name << " seed " << seed;
      }
      if (!deviated.count(e.name) && e.held_by_selection) ++held_unchanged;
    }
    EXPECT_GE(held_unchanged, 11) << "seed " << seed;  // of the 21 left at nominal
    selected_error.push_back(evaluate(d.calibrated, check).figure("position")->stats.rms);
    all_error.push_back(evaluate(a.calibrated, check).figure("position")->stats.rms);
    std::printf(
        "seed %d: %d kept, %d unchanged held; error vs truth %.2f um (default), %.2f um "
        "(--keep-all)\n",
        static_cast<int>(seed), d.kinematics.identified, held_unchanged,
        selected_error.back() * 1e6, all_error.back() * 1e6);
  }
  EXPECT_LT(median(selected_error), median(all_error));
}

// The cross-validated RMS is what one gets by hand: for each fold, calibrate on
// the other folds' poses (Levenberg-Marquardt to convergence) and evaluate on
// its own (simulated log, no repeats, so that evaluate's per-row RMS is the
// fit's measure). The library's folds are linearised at the whole fit.
TEST(CrossValidation, EqualsCalibratingOnTheOtherFoldsAndEvaluatingOnEachFold) {
  const DeviceModel nominal = testing::meca500();
  std::mt19937_64 rng(4);
  const DeviceModel truth = testing::perturbed(nominal, rng, 1e-3);
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  const Log log = simulate_log(truth, 60, noise, 9, false, true);
  CalibrationOptions options = keep_all();
  options.folds = 5;
  options.seed = 3;
  const CalibrationResult r = calibrate(nominal, log, options);
  ASSERT_EQ(r.kinematics.cv_folds, 5);
  const std::vector<int> fold = pose_folds(log.rows, 5, 3);
  double sum = 0;
  for (int f = 0; f < 5; ++f) {
    std::vector<std::vector<int>> train, test;
    for (int i = 0; i < log.rows; ++i) (fold[i] == f ? test : train).push_back({i});
    EXPECT_EQ(test.size(), 12u);
    CalibrationOptions by_hand = keep_all();
    by_hand.folds = 0;
    const CalibrationResult c = calibrate(nominal, average_repeats(log, train), by_hand);
    ASSERT_EQ(c.kinematics.identified_names, r.kinematics.identified_names);
    const double rms =
        evaluate(c.calibrated, average_repeats(log, test)).figure("position")->stats.rms;
    sum += rms * rms * static_cast<double>(test.size());
  }
  const double by_hand = std::sqrt(sum / log.rows);
  std::printf("5-fold cross-validated RMS %.6f mm, by hand %.6f mm; training %.6f mm\n",
              r.kinematics.cv_rms * 1e3, by_hand * 1e3, r.kinematics.rms_after * 1e3);
  // Linearised at the fit: the refits to second order in their change.
  EXPECT_NEAR(r.kinematics.cv_rms / by_hand, 1.0, 1e-4);
  EXPECT_GT(r.kinematics.cv_rms, r.kinematics.rms_after);
}

TEST(CrossValidation, FoldsAreBalancedReproducibleAndDependOnTheSeed) {
  const std::vector<int> a = pose_folds(23, 5, 1), b = pose_folds(23, 5, 1),
                         c = pose_folds(23, 5, 2);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  std::vector<int> count(5);
  for (int f : a) ++count.at(f);
  EXPECT_EQ(
      *std::max_element(count.begin(), count.end()) - *std::min_element(count.begin(), count.end()),
      1);
}

// The paper study keeps the paper's procedure (Scenario::keep_all);
// with the selection on it still identifies the paper's parameters: on the
// default trial all of them, and over 60 trials every one but j6.theta always
// (assigned 1 mrad, 3.6 Cramer-Rao sd from 200 distances: below the 3.1 sd
// threshold in a few trials). The encoder's zero (instrument.zero, a candidate
// of calibrate's, not of the study's) is 0 in the simulation: held in most.
TEST(ModelSelection, PaperStudyStillIdentifiesWhatThePaperIdentifies) {
  Scenario sc = default_scenario(testing::source_path("data/devices/baser-7dof.yaml"));
  const TrialResult paper = run_trial(sc, trial_seed(sc.seed, 0), "");
  EXPECT_FALSE(paper.full.kinematics.model_selection);
  std::map<std::string, int> held;
  const int trials = 60;
  for (int t = 0; t < trials; ++t) {
    const Log log = simulate_log(sc.actual, 200, sc.noise, trial_seed(7, t));
    CalibrationOptions o = select();
    o.folds = 0;
    for (const ParameterEstimate& e : calibrate(sc.nominal, log, o).kinematics.parameters) {
      if (e.held_by_selection) ++held[e.name];
    }
  }
  for (const auto& [name, n] : held) {
    std::printf("held by the selection in %d of %d trials: %s\n", n, trials, name.c_str());
    if (name == "instrument.zero") {
      EXPECT_GE(n, trials * 85 / 100);
      continue;
    }
    EXPECT_EQ(name, "j6.theta");
    EXPECT_LE(n, trials * 15 / 100);
  }
  EXPECT_EQ(held.count("instrument.zero"), 1u);
}

TEST(ModelSelection, CommandLineKeepAllFoldsAndTheirErrors) {
  const std::string out = ::testing::TempDir() + "/hapticcal_selection_cli";
  std::filesystem::remove_all(out);
  const std::string model = testing::write_meca500_on_tracker(::testing::TempDir() +
                                                              "/selection-meca500-on-tracker.yaml");
  const std::string log =
      testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv");
  const testing::CliResult bad = testing::run_cli(
      {"calibrate", "--model", model, "--log", log, "--folds", "1", "--out", out + "/bad"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--folds 1: K-fold cross-validation needs K = 0 (none) or K >= 2"),
            std::string::npos)
      << bad.err;
  const testing::CliResult d = testing::run_cli(
      {"calibrate", "--model", model, "--log", log, "--select", "--out", out + "/default"});
  ASSERT_EQ(d.exit_code, 0) << d.err;
  EXPECT_NE(d.out.find("held-out RMS (the model search's: 5 folds x 15 shuffles by pose)"),
            std::string::npos)
      << d.out;
  EXPECT_NE(d.out.find("model selection: 13 of 27 identifiable parameters kept"), std::string::npos)
      << d.out;
  const auto jd = nlohmann::json::parse(testing::slurp(out + "/default/results.json"));
  EXPECT_TRUE(jd["model_selection"]["enabled"].get<bool>());
  // 27 parameters down to the 13 kept, and 3 models more.
  EXPECT_EQ(jd["model_selection"]["path"].size(), 18u);
  EXPECT_EQ(jd["cross_validation"]["folds"], 5);
  EXPECT_GT(jd["cross_validation"]["rms"].get<double>(), jd["rms_after"].get<double>());
  EXPECT_TRUE(jd["parameters"]["j2.a"]["held_by_selection"].get<bool>());
  EXPECT_NE(testing::slurp(out + "/default/report.html").find("held-out RMS"), std::string::npos);
  const testing::CliResult a =
      testing::run_cli({"calibrate", "--model", model, "--log", log, "--keep-all", "--folds", "0",
                        "--out", out + "/all"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const auto ja = nlohmann::json::parse(testing::slurp(out + "/all/results.json"));
  EXPECT_FALSE(ja["model_selection"]["enabled"].get<bool>());
  EXPECT_EQ(ja["identified"], 27);
  EXPECT_TRUE(ja["cross_validation"]["rms"].is_null());
  EXPECT_EQ(a.out.find("held-out RMS"), std::string::npos);
}

// A device already calibrated: the truth is the model. The data support no
// change, the selection holds everything, and that is a converged, usable
// calibration that leaves the model as it is (with a held-out error), not a
// "rank-deficient" failure.
TEST(ModelSelection, DataThatSupportNoChangeGiveAConvergedUnchangedModel) {
  const DeviceModel nominal = testing::meca500();
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  int all_held = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const Log log = simulate_log(nominal, 30, noise, seed, false, true);
    const CalibrationResult r = calibrate(nominal, log, select());
    EXPECT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
    EXPECT_TRUE(std::isfinite(r.kinematics.cv_rms)) << r.kinematics.cv_note;
    EXPECT_LE(r.kinematics.identified, 3) << "seed " << seed;
    if (r.kinematics.identified > 0) continue;
    ++all_held;
    EXPECT_NE(r.status_reason.find("support no change"), std::string::npos) << r.status_reason;
    // The note names 20 of the 27 held, then how many more (a tree's would list hundreds).
    const auto note = std::find_if(r.notes.begin(), r.notes.end(), [](const std::string& n) {
      return n.rfind("model selection held", 0) == 0;
    });
    ASSERT_NE(note, r.notes.end());
    EXPECT_EQ(std::count(note->begin(), note->end(), ','), 19) << *note;
    EXPECT_NE(note->find("and 7 more (results.json lists each parameter)"), std::string::npos)
        << *note;
    EXPECT_EQ(r.calibrated.kinematic_parameters(), nominal.kinematic_parameters());
  }
  EXPECT_GT(all_held, 0);  // seeds 1 and 3 hold all 27
}

// The same device fitted without selection or search on 14 poses (42 rows for
// 27 parameters plus the frame): its held-out error is many times the nominal
// model's with the frame fitted, and that is unusable without --strict (the
// "suspect" status, exit 3), the reason naming both figures.
TEST(ModelSelection, AFitWorseThanTheNominalModelHeldOutIsUnusable) {
  const DeviceModel nominal = testing::meca500();
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  const Log log = simulate_log(nominal, 14, noise, 5, false, true);
  CalibrationOptions o;
  o.search = false;
  o.keep_all = true;
  o.loss = RobustLoss::kNone;
  const CalibrationResult r = calibrate(nominal, log, o);
  const SuspectFit& s = r.kinematics.suspect;
  ASSERT_TRUE(std::isfinite(s.cv_ratio)) << r.status_reason;
  EXPECT_GT(s.cv_ratio, kWorseThanNominalRatio);
  EXPECT_EQ(r.status, CalibrationStatus::kSuspect);
  EXPECT_NE(r.status_reason.find("the calibration predicts new poses worse than no calibration"),
            std::string::npos)
      << r.status_reason;
  std::printf("held-out %.4f mm, %.1f times the nominal model's with its frame fitted\n",
              1e3 * r.kinematics.cv_rms, s.cv_ratio);
}

// Student's t quantile (the selection's threshold) against tabulated values
// (e.g. t_0.975 with 10 degrees of freedom is 2.228, with 3 it is 3.182) and its
// normal limit.
TEST(ModelSelection, ThresholdIsStudentsTQuantileWithBonferroni) {
  EXPECT_NEAR(significance_threshold(0.05, 1, 10), 2.2281, 1e-4);
  EXPECT_NEAR(significance_threshold(0.05, 1, 3), 3.1824, 1e-4);
  EXPECT_NEAR(significance_threshold(0.01, 1, 20), 2.8453, 1e-4);
  EXPECT_NEAR(significance_threshold(0.05, 27, 1e7), 3.11304, 1e-4);  // normal 1 - 0.05 / 54
  EXPECT_NEAR(student_t_tail(2.2281, 10), 0.05, 1e-5);
  EXPECT_TRUE(std::isinf(significance_threshold(0.05, 27, 0)));
  EXPECT_GT(significance_threshold(0.05, 27, 3), 10);  // few residual freedoms: a high bar
}

// Too few poses in a fold for the parameters: "not computable", never a number
// from a singular fold (34 distance poses of the paper's device, 28 parameters:
// 4 folds of 5 train on 27 poses).
TEST(CrossValidation, FoldsThatCannotDetermineTheParametersAreNotComputable) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  std::mt19937_64 rng(3);
  const DeviceModel truth = testing::perturbed(nominal, rng, 1e-3);
  for (const int poses : {30, 32, 34}) {
    const Log log = simulate_log(truth, poses, SimulationNoise{}, 5);
    CalibrationOptions options = keep_all();
    options.transmissions = false;
    options.instrument_zero = false;  // the device's 28, the encoder's zero known
    const CalibrationResult r = calibrate(nominal, log, options);
    ASSERT_EQ(r.kinematics.identified, 28);
    EXPECT_TRUE(std::isnan(r.kinematics.cv_rms)) << poses << ": " << r.kinematics.cv_rms;
    EXPECT_NE(r.kinematics.cv_note.find("cannot determine"), std::string::npos) << poses;
  }
}

// A 6-D pose log: the held-out RMS, like rms_after, is the position error; the
// selection's path reports the same measure (its kept model's training RMS is
// the re-fit's rms_after, its cross-validated RMS the headline's).
TEST(CrossValidation, PoseLogsReportPositionErrorsAlongTheWholePath) {
  const DeviceModel nominal = testing::meca500();
  std::mt19937_64 rng(8);
  const DeviceModel truth = testing::perturbed(nominal, rng, 1e-3);
  Log log = testing::pose_log(truth, 40, rng);
  std::normal_distribution<double> noise(0, 2e-5);
  for (int i = 0; i < log.rows; ++i) {
    for (int c = 0; c < 3; ++c) log.position(i, c) += noise(rng);
  }
  const CalibrationResult r = calibrate(nominal, log, select());
  ASSERT_EQ(r.status, CalibrationStatus::kConverged);
  const KinematicFit& k = r.kinematics;
  ASSERT_TRUE(k.model_selection);
  const auto kept =
      std::find_if(k.selection_path.begin(), k.selection_path.end(),
                   [&](const SelectionStep& s) { return s.parameters == k.identified; });
  ASSERT_NE(kept, k.selection_path.end());
  EXPECT_NEAR(kept->rms / k.rms_after, 1, 1e-4);
  EXPECT_NEAR(kept->cv_rms / k.cv_rms, 1, 1e-4);
  EXPECT_GT(k.cv_rms, k.rms_after);
}

// A note about a joint-error family says who chose it: the model search (the
// Meca500's 0deg_80cube set keeps gravity compliance, its model giving no
// masses), or the user's --joint-errors.
TEST(ModelSelection, AFamilysNoteSaysWhoChoseIt) {
  const std::string out = ::testing::TempDir() + "/hapticcal_family_note";
  std::filesystem::remove_all(out);
  const std::string model = testing::source_path("examples/meca500/meca500.yaml");
  const std::string log =
      testing::source_path("examples/meca500/cal-norm_dist_data_0deg_80cube.csv");
  const testing::CliResult searched =
      testing::run_cli({"calibrate", "--model", model, "--log", log, "--out", out + "/searched"});
  ASSERT_EQ(searched.exit_code, 0) << searched.err;
  EXPECT_NE(searched.out.find("kept geometry + compliance"), std::string::npos) << searched.out;
  EXPECT_NE(searched.out.find("note: compliance (kept by the model search): the model gives no "
                              "masses"),
            std::string::npos)
      << searched.out;
  EXPECT_EQ(searched.out.find("--joint-errors compliance"), std::string::npos) << searched.out;
  const testing::CliResult asked =
      testing::run_cli({"calibrate", "--model", model, "--log", log, "--joint-errors", "compliance",
                        "--no-search", "--out", out + "/asked"});
  ASSERT_EQ(asked.exit_code, 0) << asked.err;
  EXPECT_NE(asked.out.find("note: --joint-errors compliance: the model gives no masses"),
            std::string::npos)
      << asked.out;
}

}  // namespace
}  // namespace hapticcal
