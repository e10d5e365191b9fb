// Two-step identification: the paper's simulated study, the real Meca500 data,
// and degenerate input.
#include "hapticcal/identification/identification.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const ParameterEstimate& find(const KinematicFit& fit, const std::string& name) {
  for (const ParameterEstimate& e : fit.parameters) {
    if (e.name == name) return e;
  }
  throw std::runtime_error("no parameter " + name);
}

// Paper Tables 2 and 3, the study's noise (sigma_m by the paper's formula),
// 200 poses: the identifiability the paper reports, and every identified
// kinematic and capstan parameter within 4 standard deviations of the truth.
TEST(Identification, PaperStudyFindsThePapersIdentifiabilityAndRecoversTheTruthWithin4Sd) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const DeviceModel actual = paper_actual_device(nominal);
  const Log log = simulate_log(actual, 200, SimulationNoise{}, 1);
  const CalibrationResult r = calibrate(nominal, log, CalibrationOptions{});
  const KinematicFit& k = r.kinematics;

  EXPECT_EQ(k.identified, 28);
  for (const char* name : {"base.theta", "base.alpha", "j7.alpha"}) {
    EXPECT_FALSE(find(k, name).identifiable) << name;
    EXPECT_EQ(find(k, name).reason, "no effect on the measurements") << name;
  }
  EXPECT_FALSE(find(k, "base.d").identifiable);
  EXPECT_EQ(find(k, "base.d").reason, "dependent: its effect is that of j1.theta");
  EXPECT_TRUE(find(k, "j1.theta").identifiable);
  EXPECT_FALSE(k.rank_deficient);
  EXPECT_TRUE(k.converged);

  DeviceModel with_zero = actual;  // the simulated encoder's zero is 0
  with_zero.instrument_zero = 0.0;
  const Eigen::VectorXd truth = with_zero.kinematic_parameters();
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) continue;
    EXPECT_LT(std::abs(e.value - truth[e.slot]), 4 * e.sd)
        << e.name << " " << e.value << " truth " << truth[e.slot] << " sd " << e.sd;
  }
  ASSERT_EQ(r.transmissions.size(), 4u);
  for (const TransmissionFit& t : r.transmissions) {
    if (t.kind != TransmissionKind::kCapstan) continue;
    const Eigen::VectorXd tv = actual.links[t.joint].transmission.parameters();
    for (int i = 0; i < 5; ++i) {
      EXPECT_LT(std::abs(t.value[i] - tv[i]), 4 * t.sd[i]) << t.names[i];
    }
    EXPECT_NEAR(t.rms_after, kPaperSigmaE, 0.2 * kPaperSigmaE) << t.joint;
  }
  EXPECT_EQ(r.transmissions[3].kind, TransmissionKind::kPolynomial);
  // The residual is the simulated cable-encoder noise.
  EXPECT_NEAR(k.rms_after, kPaperSigmaMPaper, 0.2 * kPaperSigmaMPaper);
  EXPECT_GT(k.rms_before, 100 * k.rms_after);
}

// Kinematic-only calibration (paper's 44.7 % case) leaves transmission errors.
TEST(Identification, KinematicOnlyCalibrationIsWorseThanTheFullOne) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const DeviceModel actual = paper_actual_device(nominal);
  const Log log = simulate_log(actual, 200, SimulationNoise{}, 2);
  // The paper's kinematic-only case: the geometry alone, one model.
  CalibrationOptions only;
  only.transmissions = false;
  only.search = false;
  const CalibrationResult full = calibrate(nominal, log, {});
  const CalibrationResult kinematic = calibrate(nominal, log, only);
  EXPECT_TRUE(kinematic.transmissions.empty());
  EXPECT_GT(kinematic.kinematics.rms_after, 10 * full.kinematics.rms_after);
  EXPECT_LT(kinematic.kinematics.rms_after, kinematic.kinematics.rms_before);
  // The model search without encoders finds the drums' errors as gear
  // harmonics of the joints (the capstans' ratios give the motors'
  // frequencies): most of what step 1 would have fitted.
  only.search = true;
  const CalibrationResult searched = calibrate(nominal, log, only);
  ASSERT_EQ(searched.status, CalibrationStatus::kConverged) << searched.status_reason;
  const std::vector<std::string>& families = searched.kinematics.joint_error_families;
  EXPECT_NE(std::find(families.begin(), families.end(), "harmonic"), families.end());
  std::printf(
      "kinematic-only RMS residual: geometry %.4f mm, with the search's %s %.4f mm; full %.4f mm\n",
      kinematic.kinematics.rms_after * 1e3,
      families.empty() ? "geometry" : families.front().c_str(), searched.kinematics.rms_after * 1e3,
      full.kinematics.rms_after * 1e3);
  EXPECT_LT(searched.kinematics.rms_after, kinematic.kinematics.rms_after / 3);
}

using testing::kMeca500Sets;
using testing::meca500_log;

// Real laser-tracker data: calibrate on cal-<set>, validate on val-<set>. Issue 3
// asks for 0.06 mm on every set. Keeping every identifiable parameter
// (--keep-all) reaches it on six of the seven and 0.066 mm on 0deg_80cube
// (unmodelled, non-geometric error: the fit's residual is ten times the
// tracker's repeatability), held to 0.067 mm here so that a regression still
// fails; the significance cut (--select) reaches it on all seven. The
// default (the model search) is held to 0.07 mm on each (docs/calibrate.md, "The model
// search": the sets' 10 validation poses cannot tell the search's choice from
// the cut's).
TEST(Identification, Meca500ValidationRmsAfterCalibration) {
  const DeviceModel nominal = testing::meca500_on_tracker();
  CalibrationOptions all, cut;
  all.keep_all = true;
  all.search = cut.search = false;
  cut.select = true;
  for (const char* set : kMeca500Sets) {
    const Log cal = meca500_log("cal", set), val = meca500_log("val", set);
    const CalibrationResult r = calibrate(nominal, cal, all);
    const CalibrationResult selected = calibrate(nominal, cal, cut);
    const CalibrationResult searched = calibrate(nominal, cal, {});
    EXPECT_EQ(searched.status, CalibrationStatus::kConverged) << set;
    EXPECT_LT(evaluate(searched.calibrated, val).figure("position")->stats.rms, 0.07e-3) << set;
    EXPECT_TRUE(r.kinematics.converged) << set;
    EXPECT_FALSE(r.kinematics.rank_deficient) << set;
    EXPECT_EQ(selected.status, CalibrationStatus::kConverged) << set;
    const double before = evaluate(nominal, val).figure("position")->stats.rms;
    const double after = evaluate(r.calibrated, val).figure("position")->stats.rms;
    const double after_selected = evaluate(selected.calibrated, val).figure("position")->stats.rms;
    std::printf("%-32s validation RMS %.4f mm -> %.4f mm (%d parameters), %.4f mm (--select: %d)\n",
                set, before * 1e3, after * 1e3, r.kinematics.identified, after_selected * 1e3,
                selected.kinematics.identified);
    EXPECT_GT(before, 0.7e-3) << set;
    // The one set over the 0.06 mm: see docs/calibrate.md (the residual floor).
    const double bound = std::string(set) == "norm_dist_data_0deg_80cube" ? 0.067e-3 : 0.06e-3;
    // Joints 2 and 3 are parallel: the Hayati beta of j3 is the 27th parameter,
    // and j3.d duplicates j2.d (distances along parallel axes add).
    EXPECT_EQ(r.kinematics.identified, 27) << set;
    EXPECT_TRUE(find(r.kinematics, "j3.beta").identifiable) << set;
    EXPECT_NE(find(r.kinematics, "j3.d").reason.find("dependent"), std::string::npos) << set;
    EXPECT_NE(find(r.kinematics, "j2.beta").reason.find("axes of j1 and j2 are not"),
              std::string::npos);
    EXPECT_NE(find(r.kinematics, "j1.beta").reason.find("no joint before j1"), std::string::npos);
    EXPECT_LT(after, bound) << set;
    EXPECT_LT(after_selected, 0.06e-3) << set;
    // What the selection holds it says so, and only among the 27.
    EXPECT_EQ(selected.kinematics.structurally_identified, 27) << set;
    for (const ParameterEstimate& e : selected.kinematics.parameters) {
      EXPECT_EQ(e.held_by_selection, e.reason.rfind("not supported by these data", 0) == 0)
          << e.name;
      if (e.held_by_selection) {
        EXPECT_TRUE(find(r.kinematics, e.name).identifiable) << e.name;
      }
    }
  }
  // That set's validation poses are not what limits it: calibrated on the 160 mm
  // cube at the same orientation, the model predicts them within 0.05 mm.
  const Log cal =
      read_log(testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv"));
  const Log val =
      read_log(testing::source_path("examples/meca500/val-norm_dist_data_0deg_80cube.csv"));
  const double across = evaluate(calibrate(nominal, cal, all).calibrated, val)
                            .figure("position")
                            ->stats.rms;  // one model
  std::printf("calibrated on 0deg_160cube, validated on 0deg_80cube: %.4f mm\n", across * 1e3);
  EXPECT_LT(across, 0.05e-3);
}

// examples/meca500/joint_error_models on the set over 0.06 mm, checked against
// what does not depend on it: its geometric refit (Ceres autodiff from the
// calibrated model) gives the RMS that hapticcal::evaluate computes for
// hapticcal::calibrate's model on both logs; each family of joint-angle errors
// nests the geometric model, so its calibration RMS can only be lower (least
// squares over more parameters); and the residuals of successive poses are
// uncorrelated (no drift).
TEST(Identification, Meca500JointErrorModelsNestTheGeometricFitWhichMatchesEvaluate) {
  const std::string dir = testing::source_path("examples/meca500/");
  const testing::CliResult r =
      testing::run_program(HAPTICCAL_JOINT_ERROR_MODELS,
                           dir + "meca500.yaml " + dir + "cal-norm_dist_data_0deg_80cube.csv " +
                               dir + "val-norm_dist_data_0deg_80cube.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("%s", r.out.c_str());
  std::istringstream lines(r.out);
  std::string line;
  std::vector<std::pair<double, double>> rms;  // calibration, validation [mm]
  while (std::getline(lines, line)) {
    if (line.find("converged") == std::string::npos) continue;
    EXPECT_EQ(line.find("NOT CONVERGED"), std::string::npos) << line;
    std::istringstream fields(line.substr(44));
    double cal = 0, val = 0;
    ASSERT_TRUE(fields >> cal >> val) << line;
    rms.emplace_back(cal, val);
  }
  ASSERT_EQ(rms.size(), 7u);
  // Not drift: successive poses' residuals are uncorrelated (70 poses: sd 0.12).
  const std::size_t at = r.out.find("(x, y, z):");
  ASSERT_NE(at, std::string::npos);
  std::istringstream lag1(r.out.substr(at + 10));
  for (int k = 0; k < 3; ++k) {
    double rho = 1;
    ASSERT_TRUE(lag1 >> rho);
    EXPECT_LT(std::abs(rho), 0.25);
  }
  const Log cal = read_log(dir + "cal-norm_dist_data_0deg_80cube.csv");
  const Log val = read_log(dir + "val-norm_dist_data_0deg_80cube.csv");
  CalibrationOptions every;  // the example refits the whole geometric model
  every.keep_all = true;
  every.search = false;  // one model
  const DeviceModel calibrated = calibrate(testing::meca500(), cal, every).calibrated;
  // Printed to 0.0001 mm; the two solvers stop within a few 1e-5 mm.
  EXPECT_NEAR(rms[0].first, evaluate(calibrated, cal).figure("position")->stats.rms * 1e3, 2e-4);
  EXPECT_NEAR(rms[0].second, evaluate(calibrated, val).figure("position")->stats.rms * 1e3, 2e-4);
  for (std::size_t k = 1; k < rms.size(); ++k) EXPECT_LE(rms[k].first, rms[0].first + 1e-4) << k;
}

TEST(Identification, DegenerateInputGivesAClearErrorOrARankDeficientResult) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const DeviceModel actual = paper_actual_device(nominal);
  const Log good = simulate_log(actual, 200, SimulationNoise{}, 3);

  auto rows = [&](int n) {
    Log l = good;
    l.rows = n;
    l.q.conservativeResize(n, Eigen::NoChange);
    l.ext.conservativeResize(n, Eigen::NoChange);
    l.distance.conservativeResize(n);
    l.line.resize(n);
    return l;
  };
  // Fewer residuals than candidate parameters.
  EXPECT_THROW(calibrate(nominal, rows(20), {}), InputError);

  // All rows identical: step 1 cannot fit (the readings never move) ...
  Log same = good;
  for (int r = 1; r < same.rows; ++r) {
    same.q.row(r) = same.q.row(0);
    same.ext.row(r) = same.ext.row(0);
    same.distance[r] = same.distance[0];
  }
  EXPECT_THROW(calibrate(nominal, same, {}), InputError);
  // ... and without it they are 200 repeats of one pose: too few measurements.
  CalibrationOptions no_tx;
  no_tx.transmissions = false;
  try {
    calibrate(nominal, same, no_tx);
    ADD_FAILURE() << "200 repeats of one pose were calibrated";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("too few measurements: 1 pose gives 1 residual"),
              std::string::npos)
        << e.what();
  }

  // A joint that never moves: least squares and the significance cut are
  // rank-deficient; the default's tolerance prior holds what it leaves unexcited.
  Log stuck = good;
  stuck.q.col(4).setConstant(0.1);
  const CalibrationResult held = calibrate(nominal, stuck, {});
  EXPECT_EQ(held.status, CalibrationStatus::kConverged) << held.status_reason;
  EXPECT_TRUE(held.kinematics.prior.used);
  int by_prior = 0;
  for (const ParameterEstimate& e : held.kinematics.parameters) {
    EXPECT_FALSE(e.reason.starts_with("not excited")) << e.name;
    if (e.set_by_prior) {
      ++by_prior;
      EXPECT_LT(e.data_share, 0.5) << e.name;
      EXPECT_NEAR(e.value, e.nominal, 3 * e.prior_sd) << e.name;
    }
  }
  EXPECT_GT(by_prior, 0);
  CalibrationOptions least_squares;
  least_squares.keep_all = true;
  least_squares.search = false;  // one model
  const CalibrationResult s = calibrate(nominal, stuck, least_squares);
  EXPECT_TRUE(s.kinematics.rank_deficient);
  EXPECT_EQ(s.status, CalibrationStatus::kRankDeficient);
  EXPECT_NE(s.status_reason.find("do not excite"), std::string::npos) << s.status_reason;
  bool says_why = false;
  for (const ParameterEstimate& e : s.kinematics.parameters) {
    says_why = says_why || e.reason.starts_with("not excited by these measurements");
  }
  EXPECT_TRUE(says_why);
  Log stuck_ext = good;
  stuck_ext.q.col(0).setConstant(0.1);
  EXPECT_THROW(calibrate(nominal, stuck_ext, {}), InputError);

  // A constant external encoder.
  Log dead = good;
  dead.ext.col(1).setConstant(0.3);
  try {
    calibrate(nominal, dead, {});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ext2: the external encoder never moves"),
              std::string::npos);
  }

  // A log for another device.
  EXPECT_THROW(calibrate(testing::meca500(), good, {}), InputError);
  // Unknown names to fix.
  CalibrationOptions bad_fix;
  bad_fix.fix = {"j9.a"};
  EXPECT_THROW(calibrate(nominal, good, bad_fix), InputError);
}

// Long logs never form the rows x parameters Jacobian: LM and the analysis run
// on its R factor. Forced on two real and simulated problems, the fit, its
// uncertainty and its verdicts are those of the full Jacobian.
TEST(Identification, CompressedJacobianGivesTheSameCalibration) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const Log paper = simulate_log(paper_actual_device(nominal), 200, SimulationNoise{}, 5);
  const Log meca =
      read_log(testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv"));
  for (const auto& [model, log] : {std::pair{nominal, paper}, {testing::meca500(), meca}}) {
    SCOPED_TRACE(model.name);
    // The compressed path has no per-pose rows: no model selection, no cross-validation.
    CalibrationOptions full, compressed;
    compressed.max_jacobian_bytes = 0;
    full.keep_all = true;
    full.search = false;  // one model
    const CalibrationResult skipped = calibrate(model, log, compressed);
    EXPECT_FALSE(skipped.kinematics.model_selection);
    EXPECT_TRUE(std::isnan(skipped.kinematics.cv_rms));
    EXPECT_NE(skipped.kinematics.cv_note.find("compressed"), std::string::npos);
    EXPECT_FALSE(skipped.kinematics.search.ran);  // no per-pose folds either
    compressed.keep_all = true;
    compressed.search = false;  // one model
    // One model each (the search cannot run compressed).
    full.search = compressed.search = false;
    const CalibrationResult a = calibrate(model, log, full), b = calibrate(model, log, compressed);
    EXPECT_EQ(a.status, CalibrationStatus::kConverged);
    EXPECT_EQ(b.status, a.status);
    EXPECT_EQ(b.kinematics.identified_names, a.kinematics.identified_names);
    EXPECT_NEAR(b.kinematics.rms_after / a.kinematics.rms_after, 1, 1e-9);
    EXPECT_NEAR(b.kinematics.condition_number / a.kinematics.condition_number, 1, 1e-8);
    EXPECT_NEAR(b.kinematics.observability.O1 / a.kinematics.observability.O1, 1, 1e-9);
    for (size_t i = 0; i < a.kinematics.parameters.size(); ++i) {
      const ParameterEstimate &x = a.kinematics.parameters[i], &y = b.kinematics.parameters[i];
      SCOPED_TRACE(x.name);
      EXPECT_EQ(x.identifiable, y.identifiable);
      EXPECT_EQ(x.reason, y.reason);
      // Both converged to the optimum: they agree to far below the sd.
      if (x.identifiable) {
        EXPECT_NEAR(x.value, y.value, 1e-6 * x.sd);
        EXPECT_NEAR(y.sd / x.sd, 1, 1e-8);
        EXPECT_NEAR(x.max_correlation, y.max_correlation, 1e-8);
      }
    }
  }
}

TEST(Identification, FixAndFreeChangeTheCandidates) {
  const DeviceModel nominal = testing::builtin("baser-7dof");
  const std::vector<int> all = candidate_slots(nominal, {}, {});
  EXPECT_EQ(all.size(), 32u + 6u);  // base 4, links 7 x 4, tool 6; no betas
  const std::vector<int> fewer = candidate_slots(nominal, {"j2.a", "j3.d"}, {"j2.beta"});
  EXPECT_EQ(fewer.size(), all.size() - 1);
  const ChainStructure s = nominal.structure();
  EXPECT_NE(std::find(fewer.begin(), fewer.end(), s.link_slot(1) + kLinkBeta), fewer.end());
  EXPECT_EQ(std::find(fewer.begin(), fewer.end(), s.link_slot(1) + kLinkA), fewer.end());
  // Links come before the tool, the tool before the base.
  EXPECT_EQ(all.front(), s.link_slot(0) + kLinkA);
  EXPECT_LT(all.back(), s.base_slots());
}

// Hayati's beta where a joint axis is parallel to its neighbour, from the
// nominal geometry: MDH j3 (Meca500 joints 2 and 3), DH j2 (PHANToM joints 2
// and 3), none on the paper's device, whose last link (alpha 0) has no next joint.
TEST(Identification, HayatiBetaIsACandidateOnlyBetweenParallelAxes) {
  auto partners = [](const DeviceModel& m) {
    std::vector<std::pair<int, int>> out;
    for (int i = 0; i < m.dof(); ++i) {
      if (const auto p = parallel_axis_partner(m, i)) out.emplace_back(i, *p);
    }
    return out;
  };
  using Pairs = std::vector<std::pair<int, int>>;
  EXPECT_EQ(partners(testing::meca500()), (Pairs{{2, 1}}));
  EXPECT_EQ(partners(testing::builtin("phantom-premium-1.5")), (Pairs{{1, 2}}));
  EXPECT_EQ(partners(testing::builtin("baser-7dof")), Pairs{});
  // Within 5 degrees counts as parallel (a calibrated model as the nominal).
  DeviceModel tilted = testing::meca500();
  tilted.links[2].alpha = 0.08;
  EXPECT_EQ(partners(tilted), (Pairs{{2, 1}}));
  tilted.links[2].alpha = 0.1;
  EXPECT_EQ(partners(tilted), Pairs{});

  const DeviceModel meca = testing::meca500();
  const ChainStructure s = meca.structure();
  const std::vector<int> slots = candidate_slots(meca, {}, {});
  for (int i = 0; i < meca.dof(); ++i) {
    const bool candidate =
        std::find(slots.begin(), slots.end(), s.link_slot(i) + kLinkBeta) != slots.end();
    EXPECT_EQ(candidate, i == 2) << meca.links[i].name;
  }
}

// A tilt of j3's axis in the plane of the parallel j2 and j3 axes, which the
// four MDH parameters cannot express: with j3.beta as a candidate it is
// recovered within 4 sd and the fit reaches the tracker noise; held at zero, the
// other parameters cannot absorb it.
TEST(Identification, MdhBetaBetweenParallelAxesIsRecovered) {
  const DeviceModel nominal = testing::meca500();
  std::mt19937_64 rng(11);
  DeviceModel actual = testing::perturbed(nominal, rng, 1e-3);
  for (int i = 0; i < actual.dof(); ++i) actual.links[i].beta = 0;
  actual.links[2].beta = 2e-3;
  SimulationNoise noise;
  noise.sigma_position = 5e-6;
  const Log log = simulate_log(actual, 100, noise, 5, false, true);
  const CalibrationResult r = calibrate(nominal, log, {});
  ASSERT_TRUE(r.kinematics.converged);
  EXPECT_EQ(r.kinematics.identified, 27);
  const ParameterEstimate& beta = find(r.kinematics, "j3.beta");
  ASSERT_TRUE(beta.identifiable);
  EXPECT_LT(std::abs(beta.value - 2e-3), 4 * beta.sd) << beta.value << " +- " << beta.sd;
  EXPECT_LT(r.kinematics.rms_after, 1.5 * noise.sigma_position * std::sqrt(3.0));

  CalibrationOptions without;
  without.fix = {"j3.beta"};
  const CalibrationResult held = calibrate(nominal, log, without);
  std::printf("j3.beta %.4f +- %.4f mrad (truth 2); RMS %.4f mm, %.4f mm with j3.beta held\n",
              beta.value * 1e3, beta.sd * 1e3, r.kinematics.rms_after * 1e3,
              held.kinematics.rms_after * 1e3);
  EXPECT_GT(held.kinematics.rms_after, 5 * r.kinematics.rms_after);
}

TEST(Identification, RowSampleIsReproducibleDistinctAndSorted) {
  const std::vector<int> a = sample_rows(1000, 200, 42), b = sample_rows(1000, 200, 42);
  EXPECT_EQ(a, b);
  EXPECT_EQ(std::set<int>(a.begin(), a.end()).size(), 200u);
  EXPECT_TRUE(std::is_sorted(a.begin(), a.end()));
  EXPECT_NE(a, sample_rows(1000, 200, 43));
  EXPECT_EQ(sample_rows(10, 0, 1).size(), 10u);
}

TEST(Identification, CommandWritesALoadableModelAndResults) {
  const std::string out = ::testing::TempDir() + "/calibrate_cli";
  std::filesystem::remove_all(out);
  const auto r = testing::run_cli(
      "calibrate --model " + testing::source_path("examples/meca500/meca500.yaml") + " --log " +
      testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv") +
      " --samples 50 --seed 7 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("held at nominal"), std::string::npos);
  const DeviceModel calibrated = load_device(out + "/calibrated.yaml");
  EXPECT_EQ(calibrated.dof(), 6);
  const auto j = nlohmann::json::parse(read_file(out + "/results.json"));
  EXPECT_EQ(j["poses"], 50);  // --samples counts poses: 50 of 70, 3 rows each
  EXPECT_EQ(j["rows_used"], 150);
  EXPECT_EQ(j["status"], "converged");
  EXPECT_EQ(j["seed"], 7);
  for (const char* key : {"condition_number", "observability", "rms_before", "rms_after"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  const auto& p = j["parameters"]["j2.a"];
  for (const char* key : {"nominal", "value", "sd", "identifiable"})
    EXPECT_TRUE(p.contains(key)) << key;
  EXPECT_FALSE(j["parameters"]["tool.roll"]["identifiable"].get<bool>());
  // Bad input: exit 2, one line, and no output written.
  const std::string bad = ::testing::TempDir() + "/calibrate_bad";
  std::filesystem::remove_all(bad);
  const auto e = testing::run_cli(
      "calibrate --model " + testing::source_path("data/devices/baser-7dof.yaml") + " --log " +
      testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv") + " --out " +
      bad);
  EXPECT_EQ(e.exit_code, 2);
  EXPECT_EQ(e.err.find('\n'), e.err.size() - 1) << e.err;
  EXPECT_FALSE(std::filesystem::exists(bad));
  std::filesystem::remove_all(out);
}

// An unknown tracker frame (issue 11): the Meca500 with its base pose set to the
// identity - metres and tens of degrees from T_base.txt - calibrates to the
// validation RMS of the calibration that starts from T_base.txt, because the
// base is first registered in closed form (Horn / Kabsch) and LM finds the same
// minimum. The note says so; with T_base.txt no registration happens.
TEST(Identification, Meca500WithUnknownTrackerFrameCalibratesLikeWithItsBasePose) {
  const DeviceModel known = testing::meca500_on_tracker();
  const DeviceModel unknown = testing::meca500();  // the example: the robot's own frame
  ASSERT_EQ(unknown.base, (std::array<double, 6>{}));
  ASSERT_GT(Eigen::Vector3d(known.base[0], known.base[1], known.base[2]).norm(), 0.1);
  for (const char* set : kMeca500Sets) {
    SCOPED_TRACE(set);
    const Log cal = meca500_log("cal", set), val = meca500_log("val", set);
    CalibrationOptions all;  // the same parameters on both sides
    all.keep_all = true;
    all.search = false;  // one model
    const CalibrationResult a = calibrate(known, cal, all);
    const CalibrationResult b = calibrate(unknown, cal, all);
    EXPECT_FALSE(a.kinematics.frame_registered);
    EXPECT_TRUE(b.kinematics.frame_registered);
    EXPECT_EQ(b.status, CalibrationStatus::kConverged) << b.status_reason;
    const bool noted = std::any_of(b.notes.begin(), b.notes.end(), [](const std::string& n) {
      return n.find("registered in closed form") != std::string::npos;
    });
    EXPECT_TRUE(noted);
    const double rms_a = evaluate(a.calibrated, val).figure("position")->stats.rms;
    const double rms_b = evaluate(b.calibrated, val).figure("position")->stats.rms;
    EXPECT_NEAR(rms_b, rms_a, 1e-8);
    EXPECT_NEAR(b.kinematics.rms_after, a.kinematics.rms_after, 1e-8);
  }
}

// A simulated 6-D pose log (position + orientation) of a device whose base and
// tool rotations differ from nominal. Positions alone cannot see the tool's
// rotation (the tool point does not move with it); poses identify it, and the
// base and tool rotations come back to the truth.
TEST(Identification, PoseMeasurementsIdentifyToolRotationsThatPositionsCannot) {
  std::mt19937_64 rng(11);
  DeviceModel nominal = testing::meca500_on_tracker();
  nominal.tool = {0.01, -0.02, 0.05, 0, 0, 0};
  DeviceModel truth = testing::perturbed(nominal, rng, 0.002);
  truth.tool[3] = 0.03;
  truth.tool[4] = -0.02;
  truth.tool[5] = 0.04;
  truth.base[3] += 0.01;
  truth.base[5] -= 0.02;
  const PreparedModel actual(truth);
  const Log log = testing::pose_log(truth, 300, rng);
  const CalibrationResult pose = calibrate(nominal, log, {});
  ASSERT_EQ(pose.status, CalibrationStatus::kConverged) << pose.status_reason;
  EXPECT_EQ(pose.kinematics.type, MeasurementType::kPose);
  Log positions = log;
  positions.has_orientation = false;
  positions.orientation.resize(0, 4);
  const CalibrationResult position = calibrate(nominal, positions, {});
  EXPECT_EQ(position.kinematics.type, MeasurementType::kPosition);
  for (const char* name : {"tool.roll", "tool.pitch"}) {
    SCOPED_TRACE(name);
    EXPECT_FALSE(find(position.kinematics, name).identifiable);
    EXPECT_NE(find(position.kinematics, name).reason.find("no effect"), std::string::npos);
    EXPECT_TRUE(find(pose.kinematics, name).identifiable);
  }
  // The tool's yaw turns about the last joint's axis: j6.theta's effect, in both.
  EXPECT_NE(find(pose.kinematics, "tool.yaw").reason.find("dependent"), std::string::npos);
  // Exact measurements: on new configurations the calibrated tool frame is the
  // truth's, orientation included; with positions alone the orientation is not.
  const PreparedModel from_poses(pose.calibrated), from_positions(position.calibrated);
  double pose_fit = 0, position_fit = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::VectorXd q = testing::random_readings(truth, rng);
    const Frame<double> want = actual.forward(q.data());
    pose_fit = std::max(pose_fit, (from_poses.forward(q.data()).R - want.R).norm() +
                                      (from_poses.forward(q.data()).p - want.p).norm());
    position_fit = std::max(position_fit, (from_positions.forward(q.data()).R - want.R).norm());
  }
  EXPECT_LT(pose_fit, 1e-8);
  EXPECT_GT(position_fit, 0.01);
  EXPECT_LT(pose.kinematics.rms_after, 1e-9);
}

// The Meca500 through its converted URDF (issue 11): every joint an origin + axis
// (7 parameters, over-parametrised; the base folded into joint 1's origin, the
// tool into a fixed joint) calibrates to the validation RMS of the MDH model
// within 1 um on all 7 sets: the rank test holds what is redundant and the
// calibrated kinematics are the same.
TEST(Identification, Meca500ThroughItsUrdfValidatesLikeTheMdhModel) {
  const DeviceModel mdh = testing::meca500();
  const DeviceModel urdf = parse_urdf(device_to_urdf(mdh), "meca500.urdf", "tool");
  ASSERT_EQ(urdf.links[0].geometry, Geometry::kOrigin);
  for (const char* set : kMeca500Sets) {
    SCOPED_TRACE(set);
    const Log cal = meca500_log("cal", set), val = meca500_log("val", set);
    CalibrationOptions all;  // both parametrisations whole (their t-values differ)
    all.keep_all = true;
    all.search = false;  // one model
    const CalibrationResult a = calibrate(mdh, cal, all);
    const CalibrationResult b = calibrate(urdf, cal, all);
    EXPECT_EQ(b.status, CalibrationStatus::kConverged) << b.status_reason;
    const double rms_a = evaluate(a.calibrated, val).figure("position")->stats.rms;
    const double rms_b = evaluate(b.calibrated, val).figure("position")->stats.rms;
    std::printf("%-32s validation RMS: MDH %.5f mm, URDF %.5f mm (%d and %d parameters)\n", set,
                rms_a * 1e3, rms_b * 1e3, a.kinematics.identified, b.kinematics.identified);
    EXPECT_NEAR(rms_b, rms_a, 1e-6);
  }
}

// The public stages, called one by one, are calibrate: the same identified
// slots and parameters on the Meca500 (issue 11). An empty selection solves
// nothing and says so.
TEST(Identification, StagesCalledOneByOneReproduceCalibrate) {
  const DeviceModel nominal = testing::meca500_on_tracker();
  const Log log =
      read_log(testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv"));
  CalibrationOptions all;
  all.keep_all = true;
  all.search = false;  // one model
  const CalibrationResult whole = calibrate(nominal, log, all);

  const std::vector<std::vector<int>> groups = repeated_poses(log);
  std::vector<int> repeats;
  for (const auto& g : groups) repeats.push_back(static_cast<int>(g.size()));
  const Log poses = average_repeats(log, groups);
  DeviceModel model = nominal;
  std::vector<std::string> notes;
  EXPECT_TRUE(fit_transmissions(model, poses, {}, notes).empty());  // no ext<i> columns
  KinematicProblem problem = kinematic_problem(model, poses, repeats, {});
  EXPECT_EQ(problem.type, MeasurementType::kPosition);
  EXPECT_EQ(problem.rows, log.rows);
  const std::vector<int> candidates = candidate_slots(model, {}, {});
  EXPECT_FALSE(register_measurement_frame(problem, candidates, notes));  // T_base.txt is close
  const IdentifiabilityAnalysis analysis = analyze_identifiability(problem, candidates);
  EXPECT_EQ(static_cast<int>(analysis.identified.size()), whole.kinematics.identified);
  const KinematicSolution solution = solve_kinematics(problem, analysis.identified);
  EXPECT_EQ(solution.termination, SolveTermination::kConverged) << solution.message;
  EXPECT_LT((solution.parameters - whole.calibrated.kinematic_parameters()).cwiseAbs().maxCoeff(),
            1e-12);
  const KinematicSolution none = solve_kinematics(problem, {});
  EXPECT_EQ(none.termination, SolveTermination::kNothingToSolve);
  EXPECT_EQ(none.parameters, model.kinematic_parameters());
}

// A mocap rigid body whose frame is turned 0.2 rad from the nominal tool (far
// beyond the reach check's 5 %, were the rotation rows counted as error): the
// pose log is accepted, the reported RMS errors are position errors, and the
// tool frame is recovered.
TEST(Identification, PoseLogWithAToolFarTurnedIsCalibrated) {
  std::mt19937_64 rng(12);
  DeviceModel nominal = testing::meca500();
  DeviceModel truth = nominal;
  truth.tool[3] = 0.2;
  truth.tool[4] = -0.15;
  const Log log = testing::pose_log(truth, 200, rng);
  const CalibrationResult r = calibrate(nominal, log, {});
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  EXPECT_LT(r.kinematics.rms_before, 1e-12);  // the tool point itself is where it was
  EXPECT_NEAR(r.calibrated.tool[3], 0.2, 1e-9);
  EXPECT_NEAR(r.calibrated.tool[4], -0.15, 1e-9);
  EXPECT_LT(evaluate(r.calibrated, log).figure("orientation")->stats.max, 1e-9);
}

}  // namespace
}  // namespace hapticcal
