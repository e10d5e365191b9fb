// `hapticcal import` end to end: a simulated Touch session (the device's
// readings and a 6-D tracker's poses on two clocks) written as a ROS 1 bag by
// Debian's python3-rosbag (uncompressed, bz2, lz4), as MCAP by @mcap/core with
// Foxglove's CDR writer, and as a rosbag2 .db3 by Python's sqlite3: each import
// gives the streams the CSV path reads, number for number, and calibrate
// --tracker on them the same model; a truncated copy is one line naming the
// byte; the stamps, topics and joints are chosen as asked, never guessed.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/session.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;
using testing::run_cli;
using testing::run_program;

// The nominal Touch as a tracker sees it (a tool 12 mm off the gimbal centre)
// and a truth off it by 0.5 mm / 5 mrad, its frame 0.4 m away.
DeviceModel touch_nominal() {
  DeviceModel m = testing::builtin("geomagic-touch");
  m.tool = {0.004, -0.006, 0.010, 0, 0, 0};
  return m;
}

DeviceModel touch_truth() {
  DeviceModel m = touch_nominal();
  std::mt19937_64 rng(5);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (Link& l : m.links) {
    for (int k = 0; k < 3; ++k) l.origin[k] += 5e-4 * gauss(rng);
    for (int k = 3; k < 6; ++k) l.origin[k] += 5e-3 * gauss(rng);
  }
  m.base = {0.12, -0.35, 0.2, 0.3, -0.2, 1.1};
  return m;
}

// One session in every format, written once for the tests below.
struct Recordings {
  std::string dir;
  std::string nominal;  // the nominal model's device file
};

const Recordings& recordings() {
  static const Recordings r = [] {
    Recordings out;
    out.dir = testing::fresh_folder("import_recordings");
    out.nominal = out.dir + "/nominal.yaml";
    save_device(touch_nominal(), out.nominal);
    SessionOptions o;
    o.seconds = 30;
    o.orientation = true;
    const Session session = simulate_session(touch_truth(), o, 11);
    std::ofstream(out.dir + "/device.csv") << log_to_csv(session.device);
    std::ofstream(out.dir + "/tracker.csv") << log_to_csv(session.tracker);
    const std::string writers = std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/";
    for (const char* compression : {"none", "bz2", "lz4"}) {
      const std::string folder = out.dir + "/" + compression;
      fs::create_directories(folder);
      const testing::CliResult w =
          run_program(HAPTICCAL_DEBIAN_PYTHON, {writers + "session_bag.py", out.dir + "/device.csv",
                                                out.dir + "/tracker.csv", folder, compression});
      EXPECT_EQ(w.exit_code, 0) << w.err;
    }
    const testing::CliResult js =
        run_program("/usr/bin/node", {writers + "session_ros2.js", HAPTICCAL_NODE_MODULES,
                                      out.dir + "/device.csv", out.dir + "/tracker.csv", out.dir});
    EXPECT_EQ(js.exit_code, 0) << js.err;
    const testing::CliResult db = run_program(
        HAPTICCAL_DEBIAN_PYTHON,
        {writers + "session_db3.py", out.dir + "/session_db3.json", out.dir + "/session.db3"});
    EXPECT_EQ(db.exit_code, 0) << db.err;
    return out;
  }();
  return r;
}

std::vector<std::string> files() {
  const std::string& d = recordings().dir;
  return {d + "/none/session.bag", d + "/bz2/session.bag", d + "/lz4/session.bag",
          d + "/session.mcap", d + "/session.db3"};
}

// Every number of two logs equal (the same parse of the same text, or not).
void expect_same_log(const Log& a, const Log& b) {
  ASSERT_EQ(a.rows, b.rows);
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(a.q, b.q);
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.orientation, b.orientation);
  EXPECT_EQ(a.has_orientation, b.has_orientation);
}

TEST(Import, EachFormatGivesTheStreamsTheCsvPathReads) {
  const Recordings& r = recordings();
  // The reference: the times as the recordings hold them (nanoseconds).
  const Log device = read_log(r.dir + "/none/device_ref.csv");
  const Log tracker = read_log(r.dir + "/none/tracker_ref.csv");
  EXPECT_GT(device.rows, 29000);
  EXPECT_TRUE(tracker.has_orientation);
  for (const std::string& file : files()) {
    SCOPED_TRACE(file);
    const std::string out = file + ".import";
    const testing::CliResult c =
        run_cli({"import", file, "--model", r.nominal, "--convention", "none", "--out", out});
    ASSERT_EQ(c.exit_code, 0) << c.err;
    EXPECT_NE(c.out.find("/touch/joint_states"), std::string::npos) << c.out;
    expect_same_log(read_log(out + "/device.csv"), device);
    expect_same_log(read_log(out + "/tracker.csv"), tracker);
    const nlohmann::json summary = nlohmann::json::parse(testing::slurp(out + "/import.json"));
    EXPECT_EQ(summary["joints"],
              nlohmann::json({"waist", "shoulder", "elbow", "yaw", "pitch", "roll"}));
    for (const auto& t : summary["topics"]) {
      if (t["topic"] == "/touch/joint_states") {
        EXPECT_EQ(t["role"], "device");
        EXPECT_NEAR(t["rate"].get<double>(), 1000, 20);  // the device's 1 kHz with 20 us jitter
      }
      if (t["topic"] == "/tracker/pose") EXPECT_EQ(t["role"], "tracker");
    }
  }
}

// The acceptance: calibrate --tracker on the imported streams and on the CSV
// path's give the same model (every parameter to 1e-12).
TEST(Import, CalibrateAfterImportGivesTheCsvPathsModel) {
  const Recordings& r = recordings();
  const auto calibrate = [&](const std::string& device, const std::string& tracker,
                             const std::string& out) {
    const testing::CliResult c = run_cli({"calibrate", "--model", r.nominal, "--log", device,
                                          "--tracker", tracker, "--clock-drift", "--out", out});
    EXPECT_EQ(c.exit_code, 0) << c.err;
    return nlohmann::json::parse(testing::slurp(out + "/results.json"));
  };
  const nlohmann::json reference = calibrate(
      r.dir + "/none/device_ref.csv", r.dir + "/none/tracker_ref.csv", r.dir + "/calibrated_ref");
  for (const std::string& file : {files()[2], files()[3], files()[4]}) {
    SCOPED_TRACE(file);
    const std::string in = file + ".calibrate-import";
    ASSERT_EQ(run_cli({"import", file, "--model", r.nominal, "--convention", "none", "--out", in})
                  .exit_code,
              0);
    const nlohmann::json fit =
        calibrate(in + "/device.csv", in + "/tracker.csv", file + ".calibrated");
    ASSERT_EQ(fit["parameters"].size(), reference["parameters"].size());
    ASSERT_GT(fit["parameters"].size(), 20u);
    EXPECT_EQ(fit["status"], "converged");
    for (const auto& [name, value] : reference["parameters"].items()) {
      ASSERT_TRUE(fit["parameters"].contains(name)) << name;
      EXPECT_NEAR(fit["parameters"][name]["value"].get<double>(), value["value"].get<double>(),
                  1e-12)
          << name;
    }
    EXPECT_NEAR(fit["clock"]["offset"].get<double>(), reference["clock"]["offset"].get<double>(),
                1e-12);
  }
}

TEST(Import, ATruncatedRecordingIsOneLineNamingTheByte) {
  for (const std::string& file : files()) {
    SCOPED_TRACE(file);
    const std::string text = testing::slurp(file);
    const std::string cut = file + ".cut" + fs::path(file).extension().string();
    std::ofstream(cut, std::ios::binary) << text.substr(0, text.size() * 6 / 10);
    const testing::CliResult c = run_cli({"import", cut, "--out", file + ".cut-out"});
    EXPECT_EQ(c.exit_code, 2) << c.out;
    EXPECT_EQ(std::count(c.err.begin(), c.err.end(), '\n'), 1) << c.err;
    EXPECT_NE(c.err.find(cut), std::string::npos) << c.err;
    // A bag or MCAP names the byte offset; sqlite names its own reason.
    if (!file.ends_with(".db3")) EXPECT_NE(c.err.find("byte "), std::string::npos) << c.err;
    EXPECT_FALSE(fs::exists(file + ".cut-out/device.csv"));
  }
}

// --time receive takes the recorder's stamps: the tracker's messages were
// recorded 4 ms after their stamps and the joints' 1.5 ms after theirs, so the
// tracker's times move 2.5 ms against the device's.
TEST(Import, ReceiveTimeIsTheRecordersStamps) {
  const Recordings& r = recordings();
  for (const std::string& file : {files()[0], files()[3]}) {
    SCOPED_TRACE(file);
    const std::string out = file + ".receive";
    const testing::CliResult c = run_cli({"import", file, "--time", "receive", "--out", out});
    ASSERT_EQ(c.exit_code, 0) << c.err;
    const Log device = read_log(out + "/device.csv"), tracker = read_log(out + "/tracker.csv");
    const Log device_ref = read_log(r.dir + "/none/device_ref.csv"),
              tracker_ref = read_log(r.dir + "/none/tracker_ref.csv");
    ASSERT_EQ(device.rows, device_ref.rows);
    ASSERT_EQ(tracker.rows, tracker_ref.rows);
    // Each stream moved by its latency (less a common origin).
    const Eigen::ArrayXd moved_device = (device.t - device_ref.t).array();
    const Eigen::ArrayXd moved_tracker = (tracker.t - tracker_ref.t).array();
    EXPECT_LT(moved_device.maxCoeff() - moved_device.minCoeff(), 1e-9);
    EXPECT_LT(moved_tracker.maxCoeff() - moved_tracker.minCoeff(), 1e-9);
    EXPECT_NEAR(moved_tracker[0] - moved_device[0], 0.0025, 1e-9);
    // Without --model the joints are the message's, in its order: 7 with the gripper.
    EXPECT_EQ(device.dof(), 7);
  }
}

TEST(Import, TopicsAndJointsAreChosenNotGuessed) {
  const Recordings& r = recordings();
  const std::string bag = files()[0];
  // A topic that is not there, a model whose joints the topic lacks.
  testing::CliResult c = run_cli({"import", bag, "--joints", "/joint_states", "--out", bag + ".x"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("no topic /joint_states"), std::string::npos) << c.err;
  c = run_cli({"import", bag, "--model", "dvrk-mtm", "--convention", "none", "--out", bag + ".x"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("'outer_yaw' is not among"), std::string::npos) << c.err;
  // The Touch's drivers publish its joints under its own names in their own
  // signs: the model alone does not say which; nothing is guessed.
  c = run_cli({"import", bag, "--model", "geomagic-touch", "--out", bag + ".x"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("give --convention ros-geomagic|"), std::string::npos) << c.err;
  // Options that would do nothing are refused, with one line.
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--markers", "a,b,c"},
        {"--body", "stylus"},
        {"--field", "bogus=/touch/joint_states:position[0]"},
        {"--field", "q1=/touch/joint_states:position[0]", "--field",
         "q1=/touch/joint_states:position[1]"},
        {"--still-tolerance", "1e-3"},
        {"--convention", "ros-geomagic", "--model", "dvrk-mtm"}}) {
    std::vector<std::string> all = {"import", bag, "--out", bag + ".x"};
    all.insert(all.end(), args.begin(), args.end());
    const testing::CliResult refused = run_cli(all);
    EXPECT_EQ(refused.exit_code, 2) << args[0] << ": " << refused.out;
    EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  }
  // A TF topic is read with --frames only; then it is the tracker's stream.
  c = run_cli({"import", bag, "--model", r.nominal, "--convention", "none", "--tracker-topic",
               "/tf", "--frames", "world,table", "--out", bag + ".tf"});
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_GT(read_log(bag + ".tf/tracker.csv").rows, 10);
  // --list writes nothing (not even the default output folder) and names every topic.
  const std::string listing = testing::fresh_folder("import_list");
  c = testing::run_cli_in(listing, {"import", bag, "--list"});
  ASSERT_EQ(c.exit_code, 0) << c.err;
  for (const char* topic : {"/touch/joint_states", "/tracker/pose", "/tf", "/rosout_note"})
    EXPECT_NE(c.out.find(topic), std::string::npos) << c.out;
  EXPECT_TRUE(fs::is_empty(listing));
  // A field by its path: the gripper's position as q1 of another stream.
  c = run_cli(
      {"import", bag, "--field", "q1=/touch/joint_states:position[1]", "--out", bag + ".field"});
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const Log field = read_log(bag + ".field/device.csv");
  EXPECT_EQ(field.dof(), 1);
  EXPECT_EQ(field.q(0, 0), 0.25);
  c = run_cli({"import", bag, "--field", "q1=/touch/joint_states:postion[1]", "--out", bag + ".x"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("did you mean 'position[1]'"), std::string::npos) << c.err;
}

// Motive's and Vicon's exports of one trajectory (written from their
// documented layouts) import to the same tracker stream.
TEST(Import, MotiveAndViconExportsImportToTheSameStream) {
  const std::string dir = testing::fresh_folder("import_exports");
  const testing::CliResult w = run_program(
      HAPTICCAL_DEBIAN_PYTHON,
      {std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/write_tracker_exports.py", dir});
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const auto imported = [&](const std::string& file, const std::string& body) {
    const testing::CliResult c = run_cli({"import", "--tracker-export", dir + "/" + file, "--body",
                                          body, "--out", dir + "/" + file + ".out"});
    EXPECT_EQ(c.exit_code, 0) << c.err;
    return read_log(dir + "/" + file + ".out/tracker.csv");
  };
  const Log motive = imported("motive_quat_mm.csv", "stylus");
  const Log vicon = imported("vicon_nexus.csv", "Subject:stylus");
  ASSERT_GT(motive.rows, 250);
  ASSERT_EQ(motive.rows, vicon.rows);
  EXPECT_TRUE(motive.has_orientation && vicon.has_orientation);
  EXPECT_EQ(motive.t, vicon.t);
  EXPECT_LT((motive.position - vicon.position).cwiseAbs().maxCoeff(), 1e-12);
  for (int r = 0; r < motive.rows; ++r) {  // a quaternion up to its sign
    const double dot = motive.orientation.row(r).dot(vicon.orientation.row(r));
    EXPECT_NEAR(std::abs(dot), 1.0, 1e-12) << r;
  }
}

// A robot stopping at `poses` random poses: 1 s still at each, 0.5 s moving to
// the next (linear in the readings); readings at 1 kHz, the tracker's 6-D poses
// at 100 Hz 0.3 ms later, each stamped `ahead` s ahead of the readings' clock.
// Written as a ROS 1 bag (lz4) into `dir`.
std::vector<Eigen::VectorXd> still_session(const DeviceModel& truth, int poses, double ahead,
                                           const std::string& dir) {
  const PreparedModel prepared(truth);
  std::mt19937_64 rng(9);
  std::vector<Eigen::VectorXd> targets;
  for (int k = 0; k < poses; ++k) targets.push_back(testing::random_readings(truth, rng));
  const auto readings_at = [&](double t) {
    const int k = std::min(static_cast<int>(t / 1.5), poses - 1);
    const double into = t - 1.5 * k;
    if (into <= 1.0 || k == poses - 1) return targets[static_cast<size_t>(k)];
    const double s = (into - 1.0) / 0.5;
    return Eigen::VectorXd((1 - s) * targets[static_cast<size_t>(k)] +
                           s * targets[static_cast<size_t>(k + 1)]);
  };
  std::string device = "t,q1,q2,q3,q4,q5,q6\n", tracker = "t,x,y,z,qw,qx,qy,qz\n";
  for (int r = 0; r <= 1500 * poses - 500; ++r) {
    const Eigen::VectorXd q = readings_at(0.001 * r);
    device += fmt::format("{}", 0.001 * r);
    for (int j = 0; j < 6; ++j) device += fmt::format(",{}", q[j]);
    device += "\n";
    if (r % 10 != 0) continue;
    const Frame<double> T = prepared.forward(readings_at(0.001 * r + 3e-4).data());
    const Eigen::Quaterniond o(T.R);
    tracker += fmt::format("{},{},{},{},{},{},{},{}\n", 0.001 * r + 3e-4 + ahead, T.p[0], T.p[1],
                           T.p[2], o.w(), o.x(), o.y(), o.z());
  }
  fs::create_directories(dir);
  std::ofstream(dir + "/device.csv") << device;
  std::ofstream(dir + "/tracker.csv") << tracker;
  const testing::CliResult w = run_program(
      HAPTICCAL_DEBIAN_PYTHON, {std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/session_bag.py",
                                dir + "/device.csv", dir + "/tracker.csv", dir, "lz4"});
  EXPECT_EQ(w.exit_code, 0) << w.err;
  return targets;
}

// A robot that stops at poses while a tracker records: --static writes one row
// a still window, its readings and the tracker's samples in it averaged.
TEST(Import, StillPosesMakeAStaticLog) {
  const std::string dir = testing::fresh_folder("import_static");
  const DeviceModel truth = touch_truth();
  const PreparedModel prepared(truth);
  const int poses = 12;
  const std::vector<Eigen::VectorXd> targets = still_session(truth, poses, 0, dir);
  const testing::CliResult c =
      run_cli({"import", dir + "/session.bag", "--model", recordings().nominal, "--convention",
               "none", "--static", "0.5", "--out", dir + "/out"});
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_NE(c.out.find("log.csv: 12 still poses"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("0 whose tracker samples are of another time\n"), std::string::npos)
      << c.out;
  const Log log = read_log(dir + "/out/log.csv");
  ASSERT_EQ(log.rows, poses);
  EXPECT_TRUE(log.has_orientation);
  for (int k = 0; k < poses; ++k) {
    SCOPED_TRACE(k);
    const Eigen::VectorXd& q = targets[static_cast<size_t>(k)];
    EXPECT_LT((log.q.row(k).transpose() - q).cwiseAbs().maxCoeff(), 1e-12);
    const Frame<double> T = prepared.forward(q.data());
    EXPECT_LT((log.position.row(k).transpose() - T.p).norm(), 1e-12);
    const Eigen::Quaterniond o(T.R);
    EXPECT_NEAR(
        std::abs(log.orientation.row(k).dot(Eigen::RowVector4d(o.w(), o.x(), o.y(), o.z()))), 1.0,
        1e-12);
  }
  EXPECT_FALSE(fs::exists(dir + "/out/device.csv"));
  // Each dwell is 1.000 s: none is cut short by the window before it.
  const testing::CliResult whole =
      run_cli({"import", dir + "/session.bag", "--model", recordings().nominal, "--convention",
               "none", "--static", "0.9995", "--out", dir + "/whole"});
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_EQ(read_log(dir + "/whole/log.csv").rows, poses);
  // The tracker's clock 0.7 s ahead: the windows whose tracker samples are of
  // another time are left out (all but the first: before the first motion),
  // never averaged into a pose, and the offset is named.
  still_session(truth, poses, 0.7, dir + "/ahead");
  const testing::CliResult moved =
      run_cli({"import", dir + "/ahead/session.bag", "--model", recordings().nominal,
               "--convention", "none", "--static", "0.5", "--out", dir + "/moved"});
  ASSERT_EQ(moved.exit_code, 0) << moved.err;
  EXPECT_NE(moved.out.find("11 whose tracker samples are of another time; the tracker's clock "
                           "seems 0.70"),
            std::string::npos)
      << moved.out;
  const Log first = read_log(dir + "/moved/log.csv");
  ASSERT_EQ(first.rows, 1);
  EXPECT_LT((first.position.row(0).transpose() - prepared.forward(targets[0].data()).p).norm(),
            1e-12);
  // No still window that long: refused, naming what it found.
  const testing::CliResult none =
      run_cli({"import", dir + "/session.bag", "--model", recordings().nominal, "--convention",
               "none", "--static", "2", "--out", dir + "/none"});
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("no window of at least 2 s"), std::string::npos) << none.err;
}

// The tracker's clock one pose period (1.5 s) ahead: each still window holds
// the tracker still at the pose before, so no window shows motion; the speeds
// (the model's tool point from the readings against the tracker's) name the
// lag, the import refuses, and --clock-offset pairs every pose with its own.
TEST(Import, StaticWindowsOfAnotherPoseAreFoundByTheSpeeds) {
  const std::string dir = testing::fresh_folder("import_static_period");
  const DeviceModel truth = touch_truth();
  const PreparedModel prepared(truth);
  const int poses = 60;
  const std::vector<Eigen::VectorXd> targets = still_session(truth, poses, 1.5, dir);
  save_device(touch_nominal(), dir + "/nominal.yaml");
  const auto import = [&](const std::vector<std::string>& more, const std::string& out) {
    std::vector<std::string> args = {"import", dir + "/session.bag", "--convention",
                                     "none",   "--static",           "0.5",
                                     "--out",  dir + "/" + out};
    args.insert(args.end(), more.begin(), more.end());
    return run_cli(args);
  };
  const testing::CliResult refused = import({"--model", dir + "/nominal.yaml"}, "refused");
  EXPECT_EQ(refused.exit_code, 2) << refused.out;
  EXPECT_NE(refused.err.find("with another time's tracker samples); the tracker's clock seems 1.5"),
            std::string::npos)
      << refused.err;
  EXPECT_EQ(refused.err.find('\n'), refused.err.size() - 1) << refused.err;
  EXPECT_FALSE(fs::exists(dir + "/refused"));
  const std::size_t at = refused.err.find("give --clock-offset ");
  ASSERT_NE(at, std::string::npos) << refused.err;
  const double suggested = std::stod(refused.err.substr(at + 20));
  EXPECT_NEAR(suggested, 1.5, 0.005);
  fmt::print("suggested --clock-offset {}\n", suggested);
  // Without a model the readings' own speed cannot tell one pose's motion from
  // the next's: the windows pass, and the import says what it could not see.
  const testing::CliResult blind = import({}, "blind");
  EXPECT_EQ(blind.exit_code, 0) << blind.err;
  EXPECT_NE(blind.out.find("the clocks were compared by the readings' own speed (no --model): a "
                           "tracker a whole pose period off passes so"),
            std::string::npos)
      << blind.out;
  const testing::CliResult c =
      import({"--model", dir + "/nominal.yaml", "--clock-offset", "1.5"}, "offset");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_NE(c.out.find("log.csv: 60 still poses"), std::string::npos) << c.out;
  const Log log = read_log(dir + "/offset/log.csv");
  ASSERT_EQ(log.rows, poses);
  for (int k = 0; k < poses; ++k) {
    const Eigen::VectorXd& q = targets[static_cast<size_t>(k)];
    EXPECT_LT((log.q.row(k).transpose() - q).cwiseAbs().maxCoeff(), 1e-12) << k;
    EXPECT_LT((log.position.row(k).transpose() - prepared.forward(q.data()).p).norm(), 1e-12) << k;
  }
  // --clock-offset shifts a static log's tracker only.
  const testing::CliResult streams =
      run_cli({"import", dir + "/session.bag", "--clock-offset", "1.5", "--out", dir + "/s"});
  EXPECT_EQ(streams.exit_code, 2);
  EXPECT_NE(streams.err.find("--clock-offset"), std::string::npos) << streams.err;
}

// A driver's convention maps its published joints back to the device file's
// readings: the drivers' own formulas (restated in Python) forward, the
// convention's inverse back, for every Touch driver and the dVRK MTM.
TEST(Import, DriverConventionsGiveTheDevicesReadings) {
  const std::string dir = testing::fresh_folder("import_conventions");
  const std::string writer = std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/convention_bag.py";
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-1.2, 1.2);
  for (const int dof : {6, 7}) {
    const std::string folder = fmt::format("{}/dof{}", dir, dof);
    fs::create_directories(folder);
    Eigen::MatrixXd readings(50, dof);
    std::string csv = "t";
    for (int j = 1; j <= dof; ++j) csv += fmt::format(",q{}", j);
    csv += "\n";
    for (int r = 0; r < readings.rows(); ++r) {
      csv += fmt::format("{}", 0.001 * r);
      for (int j = 0; j < dof; ++j) csv += fmt::format(",{}", readings(r, j) = angle(rng));
      csv += "\n";
    }
    std::ofstream(folder + "/readings.csv") << csv;
    const testing::CliResult w =
        run_program(HAPTICCAL_DEBIAN_PYTHON, {writer, folder + "/readings.csv", folder});
    ASSERT_EQ(w.exit_code, 0) << w.err;
    const std::vector<std::string> conventions =
        dof == 6 ? std::vector<std::string>{"ros-geomagic", "phantom-omni", "touch-common",
                                            "saw-sensable-phantom"}
                 : std::vector<std::string>{"dvrk-mtm"};
    for (const std::string& convention : conventions) {
      SCOPED_TRACE(convention);
      const std::string out = folder + "/" + convention;
      const testing::CliResult c = run_cli(
          {"import", folder + "/" + convention + ".bag", "--convention", convention, "--out", out});
      ASSERT_EQ(c.exit_code, 0) << c.err;
      EXPECT_NE(c.out.find("joints mapped by the convention " + convention), std::string::npos)
          << c.out;
      const Log log = read_log(out + "/device.csv");
      ASSERT_EQ(log.dof(), dof);
      EXPECT_LT((log.q - readings).cwiseAbs().maxCoeff(), 1e-12) << convention;
    }
  }
  // A convention whose joints the topic lacks, an unknown one.
  testing::CliResult c = run_cli(
      {"import", dir + "/dof6/ros-geomagic.bag", "--convention", "dvrk-mtm", "--out", dir + "/x"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("'outer_yaw' is not among"), std::string::npos) << c.err;
  c = run_cli({"import", dir + "/dof6/ros-geomagic.bag", "--convention", "ros-geomagik", "--out",
               dir + "/x"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("did you mean 'ros-geomagic'"), std::string::npos) << c.err;
}

// A session imported with the wrong driver's convention (phantom_omni's bag
// read as ros_geomagic's: the roll's sign flipped and a turn off): calibrate
// names the device log's readings and the convention, not the tracker's clock
// (which the speeds found) nor degrees (a recording's joint states are radians).
TEST(Import, AWrongConventionIsNamedAsTheLikelyCause) {
  const Recordings& r = recordings();
  const std::string dir = testing::fresh_folder("import_wrong_convention");
  const testing::CliResult w =
      run_program(HAPTICCAL_DEBIAN_PYTHON,
                  {std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/convention_bag.py",
                   r.dir + "/device.csv", dir});
  ASSERT_EQ(w.exit_code, 0) << w.err;
  for (const std::string& convention : {std::string("phantom-omni"), std::string("ros-geomagic")}) {
    SCOPED_TRACE(convention);
    const std::string out = dir + "/" + convention;
    const testing::CliResult i = run_cli({"import", dir + "/phantom-omni.bag", "--model", r.nominal,
                                          "--convention", convention, "--out", out});
    ASSERT_EQ(i.exit_code, 0) << i.err;
    const testing::CliResult c =
        run_cli({"calibrate", "--model", r.nominal, "--log", out + "/device.csv", "--tracker",
                 r.dir + "/tracker.csv", "--out", out + "/cal"});
    if (convention == "phantom-omni") {  // the driver's own: calibrated
      EXPECT_EQ(c.exit_code, 0) << c.err;
      continue;
    }
    EXPECT_EQ(c.exit_code, 2) << c.out;
    EXPECT_NE(c.err.find(out + "/device.csv: q6: "), std::string::npos) << c.err;
    EXPECT_NE(c.err.find("the readings were mapped at import by --convention ros-geomagic: another "
                         "driver's signs and offsets give such readings"),
              std::string::npos)
        << c.err;
    EXPECT_EQ(c.err.find("[deg]"), std::string::npos) << c.err;
    EXPECT_EQ(c.err.find("tracker.csv"), std::string::npos) << c.err;
    EXPECT_FALSE(fs::exists(out + "/cal"));
  }
}

}  // namespace
}  // namespace hapticcal
