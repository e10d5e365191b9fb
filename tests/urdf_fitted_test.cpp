// calibrated.urdf is the best model URDF can express, fitted as such: on
// simulated robots whose truth holds what URDF cannot (joint compliance, gear
// harmonics), the URDF written is the geometry-only candidate refitted on every
// pose, not the whole model with its families dropped. Its error on another
// session is that of a calibration told to fit the geometry alone (within 10 %)
// and never worse than the nominal model with its frame fitted on that session;
// the figures calibrate prints for both models are those evaluate finds of
// each file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/calibration_outputs.hpp"
#include "hapticcal/study/simulation.hpp"
#include "support/run_cli.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

std::string arm_path() { return testing::source_path("tests/data/urdf/compliant-arm.urdf"); }

// A session of `poses` random poses of `truth` by a tracker (20 um).
std::string tracker_session(const DeviceModel& truth, int poses, std::uint64_t seed,
                            const std::string& path) {
  SimulationNoise noise;
  noise.sigma_position = 2e-5;
  Log log = simulate_log(truth, poses, noise, seed, /*distance=*/false, /*position=*/true);
  log.has_ext.assign(log.dof(), false);
  log.ext.setZero();
  write_file_atomically(path, log_to_csv(log));
  return path;
}

nlohmann::json run_json(const std::vector<std::string>& args) {
  const testing::CliResult r = testing::run_cli(args);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json();
}

// evaluate's RMS position error of `model` on `log` (--register frame: the
// measurement frame fitted on that log first).
double evaluated(const std::string& model, const std::string& log, bool register_frame = false) {
  std::vector<std::string> args = {"evaluate", "--model", model, "--log", log, "--json"};
  if (model.ends_with(".urdf")) {
    args.push_back("--tip");
    args.push_back("tool");
  }
  if (register_frame) {
    args.push_back("--register");
    args.push_back("frame");
  }
  const nlohmann::json j = run_json(args);
  return j.is_null() ? 1.0 : j["rms_position"].get<double>();
}

struct Truth {
  const char* name;
  DeviceModel model;
};

// The arm with its geometry off by up to 1 mm / 1 mrad and, on top, joint
// compliance (3e-4 to 1e-3 rad/N m) or gear harmonics of a few tenths of a
// milliradian on joints 2 and 3.
std::vector<Truth> truths() {
  const DeviceModel nominal = load_urdf(arm_path(), "tool");
  std::mt19937_64 rng(57);
  std::vector<Truth> out;
  DeviceModel compliant = testing::perturbed(nominal, rng, 1e-3);
  compliant.links[1].compliance = 3e-4;
  compliant.links[2].compliance = 5e-4;
  compliant.links[4].compliance = 1e-3;
  out.push_back({"compliance", compliant});
  DeviceModel geared = testing::perturbed(nominal, rng, 1e-3);
  for (int i : {1, 2}) {
    Harmonic h;
    h.frequencies = {1, 2};
    h.coefficients = {6e-4, -4e-4, 3e-4, 2e-4};
    geared.links[i].transmission = Transmission(h);
  }
  out.push_back({"harmonic", geared});
  return out;
}

TEST(UrdfFitted, CalibratedUrdfIsTheGeometryFittedAsSuch) {
  for (const Truth& truth : truths()) {
    SCOPED_TRACE(truth.name);
    const std::string dir = testing::fresh_folder(std::string("urdf_fitted_") + truth.name);
    const std::string cal = tracker_session(truth.model, 150, 1, dir + "/cal.csv");
    const std::string val = tracker_session(truth.model, 150, 2, dir + "/val.csv");
    const std::string out = dir + "/out", geometry_out = dir + "/geometry";
    const testing::CliResult r = testing::run_cli(std::vector<std::string>{
        "calibrate", "--model", arm_path(), "--tip", "tool", "--log", cal, "--out", out});
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    const testing::CliResult g = testing::run_cli(
        std::vector<std::string>{"calibrate", "--model", arm_path(), "--tip", "tool", "--log", cal,
                                 "--joint-errors", "none", "--out", geometry_out});
    ASSERT_EQ(g.exit_code, 0) << g.out << g.err;
    const nlohmann::json results = nlohmann::json::parse(testing::slurp(out + "/results.json"));
    // The truth holds a family: the search keeps it, and says what the URDF holds.
    ASSERT_FALSE(results["joint_errors"].is_null()) << r.out;
    ASSERT_TRUE(results.contains("geometry_model")) << r.out;
    const nlohmann::json& gm = results["geometry_model"];
    EXPECT_TRUE(gm["usable"].get<bool>());
    EXPECT_NE(r.out.find("geometry alone (what calibrated.urdf"), std::string::npos) << r.out;
    ASSERT_TRUE(fs::exists(out + "/calibrated.urdf"));

    // Another session: the URDF against a geometry-only calibration's URDF
    // and the nominal with its frame fitted on that session.
    const double urdf = evaluated(out + "/calibrated.urdf", val);
    const double geometry_only = evaluated(geometry_out + "/calibrated.urdf", val);
    const double nominal = evaluated(arm_path(), val, /*register_frame=*/true);
    const double whole = evaluated(out + "/calibrated.yaml", val);
    std::printf(
        "[ figures  ] %s: another session's RMS: calibrated.urdf %.4f mm, a geometry-only "
        "calibration's %.4f mm, nominal with its frame %.4f mm, calibrated.yaml %.4f mm\n",
        truth.name, urdf * 1e3, geometry_only * 1e3, nominal * 1e3, whole * 1e3);
    EXPECT_LE(urdf, 1.10 * geometry_only);
    EXPECT_LT(urdf, nominal);
    EXPECT_LT(whole, urdf);  // the families the URDF cannot hold are worth having

    // The figures printed for each model are evaluate's of its file on the
    // calibration's own poses.
    EXPECT_NEAR(evaluated(out + "/calibrated.urdf", cal), gm["rms_after"].get<double>(), 1e-9);
    EXPECT_NEAR(evaluated(out + "/calibrated.yaml", cal), results["rms_after"].get<double>(), 1e-9);
    EXPECT_NEAR(gm["families_add"].get<double>(),
                gm["cv_rms"].get<double>() - results["cross_validation"]["rms"].get<double>(),
                1e-15);
  }
}

// Where the geometry alone does not beat the nominal model with its set-up on
// held-out poses, no calibrated.urdf is written and one line says why; the
// whole model is written as ever.
TEST(UrdfFitted, NoUrdfWhereTheGeometryAloneIsNoBetterThanTheNominal) {
  const std::vector<Truth> all = truths();
  const std::string dir = testing::fresh_folder("urdf_fitted_refused");
  const std::string cal = tracker_session(all.front().model, 150, 3, dir + "/cal.csv");
  const DeviceModel nominal = load_urdf(arm_path(), "tool");
  const std::string urdf_text = read_file(arm_path(), FileKind::kUrdf);
  CalibrationOptions options;
  const Log log = read_log(cal);
  CalibrationResult result = calibrate(nominal, log, options);
  ASSERT_EQ(result.status, CalibrationStatus::kConverged) << result.status_reason;
  ASSERT_TRUE(result.geometry);
  auto geometry = std::make_shared<CalibrationResult>(*result.geometry);
  geometry->status = CalibrationStatus::kImplausible;
  geometry->status_reason = "the geometry alone predicts held-out poses no better (a test's)";
  result.geometry = geometry;
  OutputSet out(dir + "/out", "calibrate");
  const CalibrationOutputs written = write_calibration_outputs(
      out, result, nominal, log, options, {arm_path(), cal, urdf_text, "tool", "", {}, false});
  EXPECT_FALSE(written.urdf_written);
  EXPECT_FALSE(fs::exists(dir + "/out/calibrated.urdf"));
  EXPECT_TRUE(fs::exists(dir + "/out/calibrated.yaml"));
  EXPECT_NE(std::find(result.notes.begin(), result.notes.end(),
                      "no calibrated.urdf written: the geometry alone predicts held-out poses no "
                      "better (a test's)"),
            result.notes.end());
}

}  // namespace
}  // namespace hapticcal
