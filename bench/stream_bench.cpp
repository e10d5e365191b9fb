// Issue 26, item 5: a one-hour hand-guided session (the Touch, 1 kHz readings:
// 3.6 M device rows; a tracker at 120 Hz: 432 k rows) calibrated with its
// clocks (offset and drift) in at most 60 s and 1 GB (peak memory measured
// with /usr/bin/time -v, docs/streams.md "Scale"). The reference in the same process: a static
// calibration of as many poses as the stream's fit uses (10 000).
#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/study/session.hpp"
#include "hapticcal/study/simulation.hpp"
#include "ratio_main.hpp"
#include "test_models.hpp"

namespace {

using namespace hapticcal;

DeviceModel touch_actual() {
  DeviceModel m = testing::builtin("geomagic-touch");
  m.base = {0.12, -0.35, 0.2, 0.3, -0.2, 1.1};
  m.tool = {0.004, -0.006, 0.010, 0, 0, 0};
  m.links[1].origin[2] += 4e-4;
  m.links[2].origin[2] -= 3e-4;
  m.links[3].origin[1] += 5e-4;
  return m;
}

void BM_Stream_OneHour(benchmark::State& state) {
  const DeviceModel nominal = testing::builtin("geomagic-touch");
  SessionOptions o;
  o.seconds = 3600;
  const Session session = simulate_session(touch_actual(), o, 1);
  CalibrationOptions options;
  options.transmissions = false;
  StreamOptions stream;
  stream.drift = true;
  for (auto _ : state) {
    const StreamCalibration fit =
        calibrate_streams(nominal, session.device, session.tracker, options, stream);
    if (fit.result.status != CalibrationStatus::kConverged) state.SkipWithError("not converged");
    state.counters["offset_error_us"] = 1e6 * (fit.clock.clock.offset - session.clock.offset);
    state.counters["drift_error_ppm"] = 1e6 * (fit.clock.clock.drift - session.clock.drift);
    state.counters["tracker_rows"] = session.tracker.rows;
  }
  state.counters["device_rows"] = session.device.rows;
}

void BM_Stream_StaticReference(benchmark::State& state) {
  const DeviceModel nominal = testing::builtin("geomagic-touch");
  SimulationNoise noise;
  noise.sigma_position = 1e-4;
  const Log log = simulate_measurement_log(touch_actual(), MeasurementType::kPosition, 10000,
                                           Eigen::MatrixXd(), noise, 2);
  CalibrationOptions options;
  options.transmissions = false;
  for (auto _ : state) {
    const CalibrationResult r = calibrate(nominal, log, options);
    benchmark::DoNotOptimize(r.kinematics.rms_after);
  }
}

// A 10-minute session whose device times are milliseconds read as seconds
// (the CSV texts in memory): reading both logs and refusing them, against
// reading them alone. The refusal comes before any grid is sized, so it costs
// about what reading the input does.
struct MillisecondSession {
  std::string device, tracker;
  MillisecondSession() {
    SessionOptions o;
    o.seconds = 600;
    Session session = simulate_session(touch_actual(), o, 3);
    session.device.t *= 1e3;
    device = log_to_csv(session.device);
    tracker = log_to_csv(session.tracker);
  }
};

const MillisecondSession& millisecond_session() {
  static const MillisecondSession s;
  return s;
}

void BM_Stream_MillisecondsRefused(benchmark::State& state) {
  const MillisecondSession& s = millisecond_session();
  const DeviceModel nominal = testing::builtin("geomagic-touch");
  for (auto _ : state) {
    const Log device = parse_log(s.device, "device.csv"),
              tracker = parse_log(s.tracker, "tracker.csv");
    try {
      calibrate_streams(nominal, device, tracker, CalibrationOptions{}, StreamOptions{});
      state.SkipWithError("not refused");
    } catch (const InputError&) {
    }
  }
}

void BM_Stream_ReadLogs(benchmark::State& state) {
  const MillisecondSession& s = millisecond_session();
  for (auto _ : state) {
    const Log device = parse_log(s.device, "device.csv"),
              tracker = parse_log(s.tracker, "tracker.csv");
    benchmark::DoNotOptimize(device.rows + tracker.rows);
  }
}

BENCHMARK(BM_Stream_OneHour)->Unit(benchmark::kSecond)->Iterations(1)->Repetitions(3);
BENCHMARK(BM_Stream_StaticReference)->Unit(benchmark::kSecond)->Iterations(1)->Repetitions(3);
BENCHMARK(BM_Stream_MillisecondsRefused)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(5);
BENCHMARK(BM_Stream_ReadLogs)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(5);

}  // namespace

int main(int argc, char** argv) {
  return hapticcal::bench::ratio_main(
      argc, argv,
      hapticcal::bench::Pairs{{"BM_Stream_OneHour", "BM_Stream_StaticReference"},
                              {"BM_Stream_MillisecondsRefused", "BM_Stream_ReadLogs"}});
}
