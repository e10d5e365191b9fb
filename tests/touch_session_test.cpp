// A Touch session as its driver records it: the readings and the positions of
// one callback (one clock, float32 values), the stylus resting in its inkwell
// (every reading 0) and then moved by hand over the device's ranges. Nothing
// on such a session is an alarm; three bad samples at rest are named, and only
// they.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <regex>
#include <set>
#include <string>

#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/session.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

constexpr double kRestSeconds = 5;

// The driver's device a little off its drawing (0.2 mm, 2 mrad), in the
// driver's frame and at its reported point: what it records, float32.
Session touch_session() {
  const DeviceModel nominal = testing::builtin("geomagic-touch");
  DeviceModel actual = nominal;
  std::mt19937_64 rng(59);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (Link& l : actual.links) {
    for (int k = 0; k < 3; ++k) l.origin[k] += 2e-4 * gauss(rng);
    for (int k = 3; k < 6; ++k) l.origin[k] += 2e-3 * gauss(rng);
  }
  SessionOptions o;
  o.seconds = 30;
  o.rest_seconds = kRestSeconds;
  o.device_rate_hz = o.tracker_rate_hz = 100;  // one callback publishes both
  o.clock_offset = o.clock_drift = 0;
  o.device_jitter = o.tracker_jitter = 0;
  o.dropout_share = 0;
  o.sigma_position = 1e-5;
  Session s = simulate_session(actual, o, 2604);
  for (Eigen::MatrixXd* m : {&s.device.q, &s.tracker.position})
    *m = m->cast<float>().cast<double>();
  return s;
}

struct Calibration {
  testing::CliResult cli;
  std::set<int> flagged;  // the tracker lines an outlier or glitch warning names
};

// Every warning line of a terminal's output.
std::string warnings(const std::string& out) {
  std::string found;
  for (size_t at = out.find("warning:"); at != std::string::npos; at = out.find("warning:", at + 1))
    found += out.substr(at, out.find('\n', at) + 1 - at);
  return found;
}

Calibration calibrate(const Session& s, const std::string& dir) {
  write_file_atomically(dir + "/device.csv", log_to_csv(s.device));
  write_file_atomically(dir + "/tracker.csv", log_to_csv(s.tracker));
  Calibration run;
  run.cli =
      testing::run_cli({"calibrate", "--model", "geomagic-touch", "--log", dir + "/device.csv",
                        "--tracker", dir + "/tracker.csv", "--out", dir + "/out"});
  const std::regex named(R"(warning: (outlier[^:]*|.*tracker\.csv line \d+: a glitch)[^\n]*)");
  const std::regex line(R"(line (\d+))");
  const std::string& out = run.cli.out;
  for (auto w = std::sregex_iterator(out.begin(), out.end(), named); w != std::sregex_iterator();
       ++w) {
    const std::string text = w->str();
    for (auto l = std::sregex_iterator(text.begin(), text.end(), line); l != std::sregex_iterator();
         ++l)
      run.flagged.insert(std::stoi((*l)[1]));
  }
  return run;
}

TEST(TouchSession, ADriversRecordingAtRestAndMovingRaisesNoAlarm) {
  const Session s = touch_session();
  // The session goes where the old reading box (q2 0..1, q3 0.2..1.25) did not:
  // home itself (q3 = 0) and beyond.
  int outside_old_box = 0;
  for (int r = 0; r < s.device.rows; ++r)
    outside_old_box += s.device.q(r, 1) > 1.0 || s.device.q(r, 2) < 0.2 || s.device.q(r, 2) > 1.25;
  EXPECT_GT(outside_old_box, s.device.rows / 5);
  EXPECT_EQ(s.device.q.row(0).norm(), 0.0);

  const std::string dir = testing::fresh_folder("touch_session_clean");
  const Calibration run = calibrate(s, dir);
  ASSERT_EQ(run.cli.exit_code, 0) << run.cli.err << run.cli.out;
  EXPECT_EQ(warnings(run.cli.out), "") << run.cli.out;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

TEST(TouchSession, ThreeBadSamplesAtRestAreNamedAndOnlyThey) {
  Session s = touch_session();
  std::set<int> injected;
  for (const double t : {1.0, 2.5, 4.0}) {  // at rest
    int r = 0;
    while (s.tracker.t[r] < t) ++r;
    s.tracker.position(r, 0) = static_cast<float>(s.tracker.position(r, 0) + 5e-4);
    injected.insert(s.tracker.line[static_cast<size_t>(r)]);
  }
  const std::string dir = testing::fresh_folder("touch_session_outliers");
  const Calibration run = calibrate(s, dir);
  ASSERT_EQ(run.cli.exit_code, 0) << run.cli.err << run.cli.out;
  EXPECT_EQ(run.flagged, injected) << run.cli.out;
  // Nothing else: the outliers are the only warnings, and the repeats left
  // around them are still one visit (no repeatability, so no alarm from one).
  std::string rest = warnings(run.cli.out);
  for (size_t at; (at = rest.find("warning: outlier among repeats")) != std::string::npos;)
    rest.erase(at, rest.find('\n', at) + 1 - at);
  EXPECT_EQ(rest, "") << run.cli.out;
  EXPECT_NE(run.cli.out.find("no repeatability"), std::string::npos) << run.cli.out;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// Flagged samples where the hand moves fastest are said to be the clocks'
// (residuals that grow with the speed); flagged samples at rest are not. The
// fastest samples are found from the readings' own motion (the truth's speed
// of the tool from the device stream), not from the tracker the note reads.
TEST(TouchSession, OutliersAtFastMotionAreSaidToBeTheClocks) {
  const Session s = touch_session();
  const PreparedModel touch(testing::builtin("geomagic-touch"));
  std::vector<std::pair<double, int>> by_speed;  // (tool speed, tracker line)
  for (int r = 1; r + 1 < s.tracker.rows; ++r) {
    const auto row = [&](int k) { return s.device.q.row(k).transpose().eval(); };
    const double speed =
        (touch.forward(row(r + 1).data()).p - touch.forward(row(r - 1).data()).p).norm() /
        (s.device.t[r + 1] - s.device.t[r - 1]);
    by_speed.emplace_back(speed, s.tracker.line[static_cast<size_t>(r)]);
  }
  std::sort(by_speed.rbegin(), by_speed.rend());
  std::vector<int> fastest, at_rest;
  for (int k = 0; k < 6; ++k) {
    fastest.push_back(by_speed[static_cast<size_t>(20 * k)].second);
    at_rest.push_back(s.tracker.line[static_cast<size_t>(50 + 40 * k)]);  // t < 5 s
  }
  const std::string note = fast_motion_note(s.tracker, fastest);
  EXPECT_NE(note.find("6 of the 6 samples flagged as outliers are at fast motion"),
            std::string::npos)
      << note;
  EXPECT_EQ(fast_motion_note(s.tracker, at_rest), "");
  // Two of six fast is what chance gives (a quarter of the samples are): no note.
  std::vector<int> mixed(fastest.begin(), fastest.begin() + 2);
  mixed.insert(mixed.end(), at_rest.begin(), at_rest.begin() + 4);
  EXPECT_EQ(fast_motion_note(s.tracker, mixed), "");
}

}  // namespace
}  // namespace hapticcal
