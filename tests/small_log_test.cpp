// The model search on few poses: 200 simulated tracker logs of 8 to 20 poses,
// 0 to 3 of them grossly off (5-20 mm), on four robots of different kinds.
// Whenever calibrate says the calibration is usable (exit 0), its model should
// predict a separate validation log no worse than the nominal model with its
// set-up (the tracker's frame and the marker) fitted on the same poses, beyond
// the held-out error's stated uncertainty (one case of 152 does: below).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

constexpr double kNoise = 5e-5;  // m, each coordinate

struct Robot {
  std::string name;
  DeviceModel nominal;
};

std::vector<Robot> robots() {
  return {{"meca500", testing::meca500()},
          {"panda-like", testing::panda_like()},
          {"geomagic-touch", testing::builtin("geomagic-touch")},
          {"dvrk-mtm", testing::builtin("dvrk-mtm")}};
}

// The nominal model with only its set-up fitted on `log` (least squares on the
// base and the tool; the device's own parameters held).
DeviceModel nominal_with_setup(const DeviceModel& nominal, const Log& log) {
  CalibrationOptions o;
  o.search = false;
  o.keep_all = true;
  o.joint_errors = {"none"};
  o.transmissions = false;
  for (const ParameterInfo& p : nominal.parameter_info()) {
    if (p.block == ParameterBlock::kLink) o.fix.push_back(p.name);
  }
  return calibrate(nominal, log, o).calibrated;
}

struct Outcome {
  int usable = 0, refused = 0, worse = 0, false_flags = 0, clean = 0;
};

TEST(SmallLogs, AUsableCalibrationNeverPredictsWorseThanTheNominalWithItsSetUp) {
  std::mt19937_64 draw(58);
  Outcome all;
  int k = 0;
  for (const Robot& robot : robots()) {
    Outcome mine;
    for (int trial = 0; trial < 50; ++trial, ++k) {
      std::mt19937_64 rng(1000 + k);
      const int poses = 8 + trial % 13;
      const int outliers = trial % 4;
      DeviceModel truth = testing::perturbed(robot.nominal, rng, 1e-3);
      // The tracker's frame: a metre away and turned; the nominal's is the identity.
      truth.base = {0.8, -0.5, 0.3, 0.2, -0.1, 1.0};
      SimulationNoise noise;
      noise.sigma_ext = 0;
      noise.sigma_position = kNoise;
      Log cal =
          simulate_measurement_log(truth, MeasurementType::kPosition, poses, {}, noise, 2000 + k);
      std::vector<int> rows(poses);
      std::iota(rows.begin(), rows.end(), 0);
      std::shuffle(rows.begin(), rows.end(), rng);
      std::uniform_real_distribution<double> size(5e-3, 20e-3);
      for (int o = 0; o < outliers; ++o) {
        const Eigen::Vector3d dir = Eigen::Vector3d::Random().normalized();
        cal.position.row(rows[o]) += size(rng) * dir.transpose();
      }
      noise.sigma_position = 0;
      const Log val =
          simulate_measurement_log(truth, MeasurementType::kPosition, 300, {}, noise, 3000 + k);
      CalibrationResult r;
      try {
        r = calibrate(robot.nominal, cal, {});
      } catch (const InputError&) {  // too few poses for what must be fitted: exit 2
        ++mine.refused;
        continue;
      }
      if (r.status != CalibrationStatus::kConverged) {
        ++mine.refused;
        continue;
      }
      ++mine.usable;
      int left_out = 0;
      for (const OutlierPose& o : r.kinematics.robust.outliers) left_out += o.weight == 0;
      mine.clean += outliers == 0;
      if (outliers == 0 && left_out > 0) ++mine.false_flags;
      const double kept = evaluate(r.calibrated, val).figure("position")->stats.rms;
      const double setup =
          evaluate(nominal_with_setup(robot.nominal, cal), val).figure("position")->stats.rms;
      const ModelSearch& s = r.kinematics.search;
      const double stated =
          s.ran && s.kept >= 0 ? s.candidates[static_cast<size_t>(s.kept)].se : 0.0;
      if (kept > setup + stated) {
        ++mine.worse;
        std::printf(
            "  %s trial %d (%d poses, %d outliers): kept %.4f mm, nominal with set-up "
            "%.4f mm, stated +- %.4f mm; held out %.4f vs %.4f mm, %zu outliers named\n",
            robot.name.c_str(), trial, poses, outliers, kept * 1e3, setup * 1e3, stated * 1e3,
            r.kinematics.cv_rms * 1e3, s.nominal_rms * 1e3, r.kinematics.robust.outliers.size());
      }
    }
    std::printf(
        "%s: %d usable (%d worse than the nominal with its set-up; %d clean logs with a "
        "pose left out), %d refused\n",
        robot.name.c_str(), mine.usable, mine.worse, mine.false_flags, mine.refused);
    all.usable += mine.usable;
    all.refused += mine.refused;
    all.worse += mine.worse;
    all.false_flags += mine.false_flags;
    all.clean += mine.clean;
  }
  std::printf("all: %d usable, %d worse, %d refused; %d of %d usable clean logs lose a pose\n",
              all.usable, all.worse, all.refused, all.false_flags, all.clean);
  // Two cases are left, both the Touch's over its whole workspace (trial 14: 2
  // of 9 poses, trial 43: 3 of 12 poses 5-20 mm off, whose held-out errors are
  // no larger than the model's own: nothing tells them; 0.84 and 0.71 mm
  // beyond the stated uncertainty, one standard error). Before the held-out
  // outlier test and the usability rule: 11.
  EXPECT_LE(all.worse, 2);
  // Clean logs lose a pose now and then: the test's 5 % family-wise level
  // (over so few poses the robust scale is itself uncertain).
  EXPECT_LE(all.false_flags, 5);
  (void)draw;
}

// A clean Meca500 log of `poses` poses in the tracker's frame (0.05 mm noise).
Log meca500_log(int poses, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  DeviceModel truth = testing::perturbed(testing::meca500(), rng, 1e-3);
  truth.base = {0.8, -0.5, 0.3, 0.2, -0.1, 1.0};
  SimulationNoise noise;
  noise.sigma_ext = 0;
  noise.sigma_position = kNoise;
  return simulate_measurement_log(truth, MeasurementType::kPosition, poses, {}, noise, seed);
}

// One pose 15 mm off among 12: held out, it stands out; it is named by its log
// line (weight 0), the calibration fitted again without it, and said so.
TEST(SmallLogs, AGrossPoseAmongFewIsNamedAndLeftOut) {
  Log log = meca500_log(12, 4);
  log.position.row(5) += Eigen::RowVector3d(0.015, 0, 0);
  const CalibrationResult r = calibrate(testing::meca500(), log, {});
  const std::vector<OutlierPose>& named = r.kinematics.robust.outliers;
  ASSERT_FALSE(named.empty());
  EXPECT_EQ(named.front().lines, std::vector<int>{log.line[5]});
  EXPECT_EQ(named.front().weight, 0);
  EXPECT_EQ(r.kinematics.poses, 11);
  EXPECT_NE(r.notes.front().find("calibrated again without it"), std::string::npos)
      << r.notes.front();
  // Without the test, the pose stays in.
  CalibrationOptions kept_in;
  kept_in.held_out_outlier_rounds = 0;
  EXPECT_EQ(calibrate(testing::meca500(), log, kept_in).kinematics.poses, 12);
}

// With 10 poses a fold's 8 cannot determine every parameter least squares
// estimates; those directions are held at the prior's centre for that fold,
// so every geometry candidate has a held-out error.
TEST(SmallLogs, AFoldShortOfExcitingAParameterIsScoredNotDropped) {
  const CalibrationResult r = calibrate(testing::meca500(), meca500_log(10, 5), {});
  ASSERT_TRUE(r.kinematics.search.ran);
  int least_squares = 0;
  for (const SearchCandidate& c : r.kinematics.search.candidates) {
    if (!c.families.empty()) continue;
    EXPECT_TRUE(std::isfinite(c.cv_rms)) << to_string(c.estimator) << ": " << c.note;
    least_squares += c.estimator == Estimator::kLeastSquares;
  }
  EXPECT_EQ(least_squares, 1);
}

// The held-out error is printed with its standard error, and with a warning
// where the poses are too few to trust it (fewer than three measured rows a
// parameter); 70 poses of the same robot get none.
TEST(SmallLogs, FewPosesPrintTheHeldOutUncertaintyAndAWarning) {
  const std::string dir = testing::fresh_folder("small_log_cli");
  write_file_atomically(dir + "/few.csv", log_to_csv(meca500_log(12, 6)));
  write_file_atomically(dir + "/meca500.yaml",
                        read_file(testing::source_path("examples/meca500/meca500.yaml")));
  const testing::CliResult few =
      testing::run_cli({"calibrate", "--model", dir + "/meca500.yaml", "--log", dir + "/few.csv",
                        "--out", dir + "/few"});
  ASSERT_EQ(few.exit_code, 0) << few.err;
  const std::regex held_out(
      R"(held-out RMS \(the model search's: [^)]*\): [0-9.]+ \+- [0-9.]+ mm)");
  EXPECT_TRUE(std::regex_search(few.out, held_out)) << few.out;
  EXPECT_NE(few.out.find("warning: the held-out error rests on 12 poses"), std::string::npos)
      << few.out;
  const testing::CliResult many = testing::run_cli(
      {"calibrate", "--model", dir + "/meca500.yaml", "--log",
       testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv"), "--out",
       dir + "/many"});
  ASSERT_EQ(many.exit_code, 0) << many.err;
  EXPECT_TRUE(std::regex_search(many.out, held_out)) << many.out;
  EXPECT_EQ(many.out.find("warning: the held-out error rests on"), std::string::npos);
}

}  // namespace
}  // namespace hapticcal
