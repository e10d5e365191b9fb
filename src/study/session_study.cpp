// `simulate` of a hand-guided session (issue 26, item 3): the two streams
// written as a real session would leave them, calibrated offset-aware (the
// clocks estimated) and offset-blind (each stamp read as device time), and
// scored on held-out static poses.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/study.hpp"

namespace hapticcal {
namespace {

// RMS position error [m] of a model on a log (evaluate's).
double position_rms(const DeviceModel& model, const Log& log) {
  return evaluate(model, log).figure("position")->stats.rms;
}

// results.json of a session study.
std::string session_json(const Scenario& sc, const SessionOptions& o, int validation_poses,
                         const SessionStudy& out) {
  using json = nlohmann::ordered_json;
  const ClockEstimate& c = out.clock;
  json j;
  j["format"] = "hapticcal-results/1";
  j["device"] = sc.nominal.name;
  j["seed"] = sc.seed;
  j["session"] = {{"seconds", o.seconds},
                  {"device_rate_hz", o.device_rate_hz},
                  {"tracker_rate_hz", o.tracker_rate_hz},
                  {"device_rows", out.device_rows},
                  {"tracker_rows", out.tracker_rows},
                  {"dropped_samples", out.dropped},
                  {"sigma_position", o.sigma_position}};
  j["truth"] = {
      {"offset", out.truth.offset}, {"drift", out.truth.drift}, {"reference", out.truth.reference}};
  j["estimate"] = {{"status", to_string(out.status)},
                   {"offset", c.clock.offset},
                   {"offset_sd", c.offset_sd},
                   {"offset_error", c.clock.offset - out.truth.offset},
                   {"drift", c.clock.drift},
                   {"drift_sd", c.drift_fitted ? json(c.drift_sd) : json(nullptr)},
                   {"drift_error", c.clock.drift - out.truth.drift},
                   {"coarse_offset", c.coarse_offset},
                   {"fit_samples", c.fit_samples},
                   {"iterations", c.iterations}};
  j["validation"] = {{"poses", validation_poses},
                     {"position_rms_nominal", out.rms_nominal},
                     {"position_rms_offset_aware", out.rms_aware},
                     {"position_rms_offset_blind", out.rms_blind},
                     {"truth_distance_offset_aware", out.truth_aware},
                     {"truth_distance_offset_blind", out.truth_blind}};
  return j.dump(2) + "\n";
}

// The terminal's lines of a session study.
std::vector<std::string> session_lines(const SessionOptions& o, int validation_poses,
                                       const SessionStudy& out) {
  const ClockEstimate& c = out.clock;
  std::vector<std::string> lines;
  lines.push_back(fmt::format(
      "Session: {:g} s of hand-guided motion, device {} rows at {:g} Hz, tracker {} rows at {:g} "
      "Hz ({} lost to dropouts), noise {:.3g} mm",
      o.seconds, out.device_rows, o.device_rate_hz, out.tracker_rows, o.tracker_rate_hz,
      out.dropped, 1e3 * o.sigma_position));
  lines.push_back(fmt::format(
      "Clocks: offset {:.4f} ms +- {:.4f} (truth {:.4f} ms){}; {}", 1e3 * c.clock.offset,
      1e3 * c.offset_sd, 1e3 * out.truth.offset,
      c.drift_fitted ? fmt::format(", drift {:.3f} ppm +- {:.3f} (truth {:.3f} ppm)",
                                   1e6 * c.clock.drift, 1e6 * c.drift_sd, 1e6 * out.truth.drift)
                     : std::string(),
      to_string(out.status)));
  lines.push_back(fmt::format(
      "Validation ({} static poses): position RMS nominal {:.4f} mm, offset-aware {:.4f} mm, "
      "offset-blind {:.4f} mm ({:.1f}x); against the truth {:.4f} mm and {:.4f} mm",
      validation_poses, 1e3 * out.rms_nominal, 1e3 * out.rms_aware, 1e3 * out.rms_blind,
      out.rms_blind / out.rms_aware, 1e3 * out.truth_aware, 1e3 * out.truth_blind));
  return lines;
}

}  // namespace

SessionStudy run_session_study(const Scenario& sc, const std::string& dir,
                               const std::function<void(int, int)>& progress) {
  // Shares of the whole: the streams 15, the calibration's stages 70, the
  // offset-blind fit and the validation 15.
  int done = -1;
  const auto at = [&](double share) {
    const int k = static_cast<int>(std::lround(100 * std::clamp(share, 0.0, 1.0)));
    if (progress && k > done) progress(done = k, 100);
  };
  at(0);
  SessionOptions o = *sc.session;
  o.sigma_position = sc.noise.sigma_position;
  SessionStudy out;
  const Session session = simulate_session(sc.actual, o, sc.seed);
  out.truth = session.clock;
  out.device_rows = session.device.rows;
  out.tracker_rows = session.tracker.rows;
  out.dropped = session.dropped;
  write_file_atomically(dir + "/device.csv", log_to_csv(session.device));
  write_file_atomically(dir + "/tracker.csv", log_to_csv(session.tracker));
  save_device(sc.nominal, dir + "/nominal.yaml");
  save_device(sc.actual, dir + "/actual.yaml");
  SimulationNoise noise = sc.noise;
  const Log validation =
      simulate_measurement_log(sc.actual, MeasurementType::kPosition, sc.validation_poses,
                               Eigen::MatrixXd(), noise, sc.seed + 1);
  write_file_atomically(dir + "/validation.csv", log_to_csv(validation));

  at(0.15);
  // As calibrate --tracker reads them: the files, not the memory.
  Log device = read_log(dir + "/device.csv"), tracker = read_log(dir + "/tracker.csv");
  // Named as in the output folder, not the staging folder that becomes it.
  device.origin = "device.csv";
  tracker.origin = "tracker.csv";
  CalibrationOptions options;
  options.transmissions = false;
  options.fix = sc.fix;
  StreamOptions stream;
  stream.search_range = sc.session_search_range;
  stream.drift = sc.session_fit_drift;
  stream.progress = [&](const std::string& stage, double share) {
    const double begin = stage == "clock search" ? 0.15 : stage == "final fit" ? 0.75 : 0.2;
    const double width = stage == "clock search" ? 0.05 : stage == "final fit" ? 0.1 : 0.55;
    at(begin + width * share);
  };
  const StreamCalibration aware = calibrate_streams(sc.nominal, device, tracker, options, stream);
  out.clock = aware.clock;
  // The truth at the estimate's reference (the first sample kept), where the
  // offset is compared.
  out.truth.offset += out.truth.drift * (out.clock.clock.reference - out.truth.reference);
  out.truth.reference = out.clock.clock.reference;
  out.status = aware.result.status;
  out.status_reason = aware.result.status_reason;
  // Offset-blind: the same samples, each tracker stamp read as device time.
  std::vector<int> rows, kept;
  const int m = std::min(stream.max_fit_samples, tracker.rows);
  for (int i = 0; i < m; ++i)
    rows.push_back(static_cast<int>(static_cast<long>(i) * tracker.rows / m));
  const ReadingInterpolator readings(device);
  const Log blind_poses = readings_at_tracker(readings, device, tracker, rows, StreamClock{}, kept);
  CalibrationOptions forced = options;
  forced.force = true;  // the blind fit's errors look implausible: that is the point
  if (blind_poses.rows < 10) {
    throw InputError(
        fmt::format("the session's tracker samples fall outside the device's "
                    "stream at their own stamps ({} within it): no offset-blind "
                    "calibration to compare",
                    blind_poses.rows));
  }
  const CalibrationResult blind = calibrate(sc.nominal, blind_poses, forced);
  at(0.95);
  save_device(aware.result.calibrated, dir + "/calibrated.yaml");
  save_device(blind.calibrated, dir + "/calibrated-offset-blind.yaml");

  out.rms_nominal = position_rms(sc.nominal, validation);
  out.rms_aware = position_rms(aware.result.calibrated, validation);
  out.rms_blind = position_rms(blind.calibrated, validation);
  // The same readings with the truth's tool points, without noise.
  Log truth = validation;
  truth.position = predicted_measurements(sc.actual, MeasurementType::kPosition, validation.q);
  out.truth_aware = position_rms(aware.result.calibrated, truth);
  out.truth_blind = position_rms(blind.calibrated, truth);

  out.json = session_json(sc, o, validation.rows, out);
  write_file_atomically(dir + "/results.json", out.json);
  at(1);

  out.lines = session_lines(o, validation.rows, out);
  out.aware = aware.result;
  out.aware_poses = aware.poses;
  return out;
}

}  // namespace hapticcal
