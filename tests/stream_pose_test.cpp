// Hand-guided sessions with a 6-D tracker and with a marker body (the gimbal's
// rotations identified, against the truth and its sd), and a second session
// scored against a model held (evaluate --tracker: its clocks fitted, the
// offset against the truth, the error against the noise).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/jobs/evaluate_job.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/session.hpp"
#include "hapticcal/study/simulation.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// The Touch as a tracker sees it: its frame 0.4 m away and turned, the tool 12
// mm off the gimbal centre.
DeviceModel touch_nominal() {
  DeviceModel m = testing::builtin("geomagic-touch");
  m.tool = {0.004, -0.006, 0.010, 0, 0, 0};
  // Its base at the origin, not the driver's: which of a correlated pair the
  // rank test holds depends on where the base puts the chain, and the slots
  // found here must be those the fit in the tracker's frame identifies.
  m.base = {};
  return m;
}

// The slots a pose log identifies on the Touch (least squares, no selection):
// a truth off the nominal model only there is what a fit can recover slot by
// slot (elsewhere the identified slots would absorb the deviations).
std::vector<ParameterEstimate> identifiable_slots(const DeviceModel& nominal) {
  SimulationNoise noise;
  noise.sigma_position = 1e-5;
  noise.sigma_orientation = 1e-5;
  const Log poses =
      simulate_measurement_log(nominal, MeasurementType::kPose, 400, Eigen::MatrixXd(), noise, 1);
  CalibrationOptions options;
  options.transmissions = false;
  options.search = false;
  options.keep_all = true;
  const CalibrationResult fit = calibrate(nominal, poses, options);
  std::vector<ParameterEstimate> out;
  for (const ParameterEstimate& e : fit.kinematics.parameters)
    if (e.identifiable) out.push_back(e);
  return out;
}

// The truth: 0.5 mm / 5 mrad off on every identifiable slot, the tracker's
// frame far away.
DeviceModel touch_truth(const DeviceModel& nominal, const std::vector<ParameterEstimate>& slots,
                        std::uint64_t seed) {
  DeviceModel truth = nominal;
  truth.base = {0.12, -0.35, 0.2, 0.3, -0.2, 1.1};
  Eigen::VectorXd p = truth.kinematic_parameters();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (const ParameterEstimate& e : slots) {
    if (e.name.starts_with("base.")) continue;
    p[e.slot] += (e.unit == ParameterUnit::kLength ? 5e-4 : 5e-3) * gauss(rng);
  }
  truth.set_kinematic_parameters(p);
  return truth;
}

bool gimbal_rotation(const std::string& name) {
  for (const char* link : {"yaw.", "pitch.", "roll.", "tool."})
    if (name.starts_with(link))
      return name.ends_with(".roll") || name.ends_with(".pitch") || name.ends_with(".yaw");
  return false;
}

// Each identified rotation of the gimbal's links and of the tool against the
// truth: within 3 sd; returns how many were compared.
int expect_gimbal_within_3_sd(const CalibrationResult& fit, const DeviceModel& truth) {
  const Eigen::VectorXd p = truth.kinematic_parameters();
  int compared = 0;
  for (const ParameterEstimate& e : fit.kinematics.parameters) {
    if (!e.identifiable || !gimbal_rotation(e.name)) continue;
    ++compared;
    EXPECT_LT(std::abs(e.value - p[e.slot]), 3 * e.sd)
        << e.name << ": " << e.value << " vs " << p[e.slot];
    std::printf("%-12s %9.4f mrad +- %.4f (truth %9.4f)\n", e.name.c_str(), 1e3 * e.value,
                1e3 * e.sd, 1e3 * p[e.slot]);
  }
  return compared;
}

CalibrationOptions least_squares() {
  CalibrationOptions options;
  options.transmissions = false;
  options.search = false;
  options.keep_all = true;
  return options;
}

// A session of a 6-D tracker (positions and orientations, 0.1 mm and 1 mrad):
// the gimbal's rotations within 3 sd of the truth, the clocks found.
TEST(StreamPose, ASixDimensionalSessionIdentifiesTheGimbalWithinThreeSd) {
  const DeviceModel nominal = touch_nominal();
  const DeviceModel truth = touch_truth(nominal, identifiable_slots(nominal), 42);
  SessionOptions o;
  o.seconds = 120;
  o.orientation = true;
  const Session session = simulate_session(truth, o, 17);
  ASSERT_TRUE(session.tracker.has_orientation);
  StreamOptions stream;
  stream.drift = true;
  const StreamCalibration fit =
      calibrate_streams(nominal, session.device, session.tracker, least_squares(), stream);
  ASSERT_EQ(fit.result.status, CalibrationStatus::kConverged) << fit.result.status_reason;
  EXPECT_TRUE(fit.poses.has_orientation);
  EXPECT_LT(std::abs(fit.clock.clock.offset - o.clock_offset), 3 * fit.clock.offset_sd + 2e-5)
      << fit.clock.clock.offset << " +- " << fit.clock.offset_sd;
  EXPECT_GE(expect_gimbal_within_3_sd(fit.result, truth), 6);
}

// Three markers on the stylus instead of a pose: the body's poses aligned as a
// 6-D tracker's; the rotations as well, with the body given and estimated.
TEST(StreamPose, AMarkerBodySessionIdentifiesTheGimbalWithinThreeSd) {
  const DeviceModel nominal = touch_nominal();
  const DeviceModel truth = touch_truth(nominal, identifiable_slots(nominal), 43);
  SessionOptions o;
  o.seconds = 120;
  o.sigma_position = 5e-5;
  o.marker_body.resize(3, 3);
  o.marker_body << 0.03, 0.0, -0.01,  //
      0.0, 0.04, 0.01,                //
      0.01, 0.0, 0.05;
  const Session session = simulate_session(truth, o, 19);
  ASSERT_EQ(session.tracker.marker_count, 3);
  CalibrationOptions options = least_squares();
  options.marker_body = o.marker_body;
  StreamOptions stream;
  stream.drift = true;  // the session's clocks drift 20 ppm apart
  const StreamCalibration fit =
      calibrate_streams(nominal, session.device, session.tracker, options, stream);
  ASSERT_EQ(fit.result.status, CalibrationStatus::kConverged) << fit.result.status_reason;
  EXPECT_EQ(fit.result.marker_body.cols(), 3);
  EXPECT_LT(std::abs(fit.clock.clock.offset - o.clock_offset), 3 * fit.clock.offset_sd + 1e-4);
  EXPECT_GE(expect_gimbal_within_3_sd(fit.result, truth), 6);
  // The body estimated from the session: the fit still converges, the clock the same.
  const StreamCalibration estimated =
      calibrate_streams(nominal, session.device, session.tracker, least_squares(), stream);
  ASSERT_EQ(estimated.result.status, CalibrationStatus::kConverged)
      << estimated.result.status_reason;
  EXPECT_NEAR(estimated.clock.clock.offset, fit.clock.clock.offset, 3 * fit.clock.offset_sd + 1e-4);
}

// evaluate --tracker: a model calibrated on one session, scored on a second of
// the same truth on other clocks: the second offset within 3 sd of its truth,
// the error within 10 % of the noise (0.1 mm a coordinate: 0.173 mm).
TEST(StreamPose, ASecondSessionIsScoredWithItsOwnClocks) {
  const DeviceModel nominal = touch_nominal();
  const DeviceModel truth = touch_truth(nominal, identifiable_slots(nominal), 44);
  SessionOptions first;
  first.seconds = 120;
  const Session one = simulate_session(truth, first, 23);
  StreamOptions stream;
  stream.drift = true;
  const StreamCalibration fit =
      calibrate_streams(nominal, one.device, one.tracker, least_squares(), stream);
  ASSERT_EQ(fit.result.status, CalibrationStatus::kConverged) << fit.result.status_reason;

  SessionOptions second = first;
  second.clock_offset = -2.437;
  second.clock_drift = -35e-6;
  const Session two = simulate_session(truth, second, 29);
  const std::string dir = testing::fresh_folder("stream_pose_second");
  std::ofstream(dir + "/device.csv") << log_to_csv(two.device);
  std::ofstream(dir + "/tracker.csv") << log_to_csv(two.tracker);
  save_device(fit.result.calibrated, dir + "/calibrated.yaml");

  EvaluateRequest request;
  request.model = dir + "/calibrated.yaml";
  request.log = dir + "/device.csv";
  request.tracker = dir + "/tracker.csv";
  request.stream.drift = true;
  const EvaluateJob job = run_evaluate_job(request);
  ASSERT_TRUE(job.alignment);
  const ClockEstimate& c = job.alignment->clock;
  // The truth's offset is at tracker time tracker_start; the estimate's at the
  // tracker's first sample (2.4 s later: 85 us more at -35 ppm).
  const double truth_offset =
      second.clock_offset + second.clock_drift * (c.clock.reference - second.tracker_start);
  EXPECT_LT(std::abs(c.clock.offset - truth_offset), 3 * c.offset_sd)
      << c.clock.offset << " +- " << c.offset_sd;
  EXPECT_LT(std::abs(c.clock.drift - second.clock_drift), 3 * c.drift_sd)
      << c.clock.drift << " +- " << c.drift_sd;
  ASSERT_TRUE(job.evaluation.figure("position"));
  const double noise = std::sqrt(3.0) * second.sigma_position;
  const double rms = job.evaluation.figure("position")->stats.rms;
  EXPECT_LT(std::abs(rms - noise), 0.1 * noise) << rms << " vs noise " << noise;
  std::printf(
      "second session: offset %.4f ms +- %.4f (truth %.4f), drift %.3f ppm +- %.3f (truth %.1f); "
      "RMS "
      "%.4f mm against a noise of %.4f mm on %d samples\n",
      1e3 * c.clock.offset, 1e3 * c.offset_sd, 1e3 * truth_offset, 1e6 * c.clock.drift,
      1e6 * c.drift_sd, 1e6 * second.clock_drift, 1e3 * rms, 1e3 * noise, c.fit_samples);
  // The nominal model scores far worse on the same session: the clocks do not hide a bad model.
  EvaluateRequest nominal_request = request;
  nominal_request.model.clear();
  nominal_request.given = nominal;
  nominal_request.given->base = truth.base;
  const EvaluateJob nominal_job = run_evaluate_job(nominal_request);
  EXPECT_GT(nominal_job.evaluation.figure("position")->stats.rms, 3 * rms);

  // The command line: the clocks first, "clock" in the JSON.
  const testing::CliResult r =
      testing::run_cli({"evaluate", "--model", request.model, "--log", request.log, "--tracker",
                        request.tracker, "--clock-drift", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json json = nlohmann::json::parse(r.out);
  EXPECT_NEAR(json["clock"]["offset"].get<double>(), c.clock.offset, 1e-9);
  EXPECT_NEAR(json["rms_position"].get<double>(), rms, 1e-12);
  // With a folder: the report's Clocks section and its figure of the residual against the offset.
  const testing::CliResult written =
      testing::run_cli({"evaluate", "--model", request.model, "--log", request.log, "--tracker",
                        request.tracker, "--clock-drift", "--out", dir + "/evaluated"});
  ASSERT_EQ(written.exit_code, 0) << written.err;
  EXPECT_NE(written.out.find("clocks (the model held): offset"), std::string::npos) << written.out;
  const std::string report = testing::slurp(dir + "/evaluated/report.html");
  EXPECT_NE(report.find("<h2>Clocks</h2>"), std::string::npos);
  EXPECT_NE(report.find("Residual of the model held against the offset"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir + "/evaluated/figures/clock_offset.svg"));
}

}  // namespace
}  // namespace hapticcal
