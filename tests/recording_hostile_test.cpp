// Hostile and careless recordings: each case of the audit of the recording
// readers and `hapticcal import` reproduced with inputs made here (ROS 1 bags
// by tests/support/ros1_bag_writer.hpp, .db3 files through libsqlite3): a
// message of 100,000 joints decodes and imports (decoding is linear in its
// size: bench/recording_bench.cpp shows the ratios); a .db3 that would make
// sqlite compute or sort what is read is refused; a message moved to another
// topic by one changed byte is named, not lost; a NaN, a joint named twice or
// an undecodable topic is refused; errors stay one short line; options
// without effect are refused. The command line runs under a 60 s watchdog
// (timeout -s KILL) and a resident-memory bound: a hang or a blow-up fails
// the test instead of stalling it.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"
#include "hapticcal/recording/ros_message.hpp"
#include "ros1_bag_writer.hpp"
#include "run_cli.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;
using recording::builtin_definition;
using recording::Encoding;
using testing::le32;

// A hang guard and a memory bound, not speed targets.
constexpr int kWatchdogSeconds = 60;
constexpr long kMaxResidentKb = 400 * 1024;
constexpr std::int64_t kT0 = 1'733'390'000'000'000'000;  // ns: December 2024

testing::CliResult cli(std::vector<std::string> args) {
  args.insert(args.begin(), {"-s", "KILL", std::to_string(kWatchdogSeconds), HAPTICCAL_CLI});
  return testing::run_program("/usr/bin/timeout", args);
}

// Exit 2, one line naming `says`, within the watchdog and the memory bound.
void expect_refused(const testing::CliResult& r, const std::string& says) {
  EXPECT_NE(r.exit_code, 137) << "killed by the watchdog after " << kWatchdogSeconds << " s";
  testing::expect_input_error(r, says);
  EXPECT_LT(r.peak_kb, kMaxResidentKb);
}

std::string folder(const std::string& name) {
  return testing::fresh_folder("recording_hostile_" + name);
}

void write(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// The files of an output folder and their contents; and the folders beside
// it (a staging folder left behind would be one).
std::map<std::string, std::string> contents(const std::string& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    out[e.path().filename()] = testing::slurp(e.path());
  return out;
}
std::size_t entries(const std::string& dir) {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), {}));
}

std::vector<std::string> joint_names(std::size_t n) {
  std::vector<std::string> out;
  for (std::size_t k = 0; k < n; ++k) out.push_back(fmt::format("j{}", k));
  return out;
}

// `device_messages` JointStates of `names` at 1 kHz (message i's joint k at
// 0.001 i + 1e-6 k, changed by `edit`), and every tenth ms a tracker's
// PoseStamped and a /diagnostics string (a topic the import does not take).
testing::Ros1BagWriter session(
    std::size_t device_messages, const std::vector<std::string>& names,
    const std::function<void(std::size_t, std::vector<double>&, double*)>& edit = {}) {
  testing::Ros1BagWriter w;
  w.connection(0, "/joint_states", "sensor_msgs/JointState",
               builtin_definition("sensor_msgs/JointState", Encoding::kRos1));
  w.connection(1, "/tracker/pose", "geometry_msgs/PoseStamped",
               builtin_definition("geometry_msgs/PoseStamped", Encoding::kRos1));
  w.connection(2, "/diagnostics", "std_msgs/String", "string data\n");
  std::vector<double> q(names.size());
  for (std::size_t i = 0; i < device_messages; ++i) {
    const std::int64_t t = kT0 + static_cast<std::int64_t>(i) * 1000000;
    for (std::size_t k = 0; k < q.size(); ++k) q[k] = 1e-3 * i + 1e-6 * k;
    double p[3] = {0.1 + 1e-4 * i, 0.2, 0.3};
    if (edit) edit(i, q, p);
    w.message(0, t, testing::ros1_joint_state(t, names, q));
    if (i % 10 == 0) {
      const double unit[4] = {1, 0, 0, 0};
      w.message(1, t + 500, testing::ros1_pose_stamped(t, p, unit));
      w.message(2, t + 700, testing::ros1_string("ok"));
    }
  }
  return w;
}

// --- Decoding linear in the input (correctness here; the time in bench/) ---

TEST(Decoding, AJointStateOf100000JointsDecodesEveryJoint) {
  const auto names = joint_names(100000);
  std::vector<double> q(names.size());
  for (std::size_t k = 0; k < q.size(); ++k) q[k] = 0.5 * static_cast<double>(k);
  const auto type = recording::MessageType::parse(
      "sensor_msgs/JointState", builtin_definition("sensor_msgs/JointState", Encoding::kRos1),
      Encoding::kRos1, "wide.bag");
  const recording::DecodedMessage m = recording::decode_message(
      *type, testing::ros1_joint_state(kT0, names, q), "wide.bag: byte 4117: /joint_states");
  EXPECT_EQ(m.numbers.size(), 100000u + 3);  // seq, stamp.sec, stamp.nsec and the positions
  EXPECT_EQ(m.strings.size(), 100000u + 1);  // frame_id and the names
  for (const std::size_t k : {0, 1, 9999, 54321, 99999}) {
    ASSERT_NE(m.number(fmt::format("position[{}]", k)), nullptr) << k;
    EXPECT_EQ(*m.number(fmt::format("position[{}]", k)), 0.5 * static_cast<double>(k));
    ASSERT_NE(m.string(fmt::format("name[{}]", k)), nullptr) << k;
    EXPECT_EQ(*m.string(fmt::format("name[{}]", k)), names[k]);
  }
  EXPECT_EQ(m.number("position[100000]"), nullptr);
  ASSERT_NE(m.number("header.stamp.sec"), nullptr);
  EXPECT_EQ(*m.number("header.stamp.sec"), static_cast<double>(kT0 / 1000000000));
  // A decoded message copied keeps its look-ups.
  const recording::DecodedMessage copy = m;
  EXPECT_EQ(*copy.number("position[77777]"), 0.5 * 77777);
}

TEST(Decoding, ADefinitionOf100000FieldsParsesAndNamesItsDuplicate) {
  std::string text, bytes;
  for (int k = 0; k < 100000; ++k) {
    text += fmt::format("float64 f{}\n", k);
    bytes += testing::f64(k);
  }
  const auto type = recording::MessageType::parse("pkg/Wide", text, Encoding::kRos1, "wide.bag");
  const recording::DecodedMessage m = recording::decode_message(*type, bytes, "wide.bag");
  ASSERT_EQ(m.numbers.size(), 100000u);
  int found = 0;  // every field by its name
  for (int k = 0; k < 100000; ++k) {
    const double* v = m.number(fmt::format("f{}", k));
    found += v != nullptr && *v == k;
  }
  EXPECT_EQ(found, 100000);
  EXPECT_EQ(m.number("f100000"), nullptr);
  try {
    recording::MessageType::parse("pkg/Wide", text + "int32 f500\n", Encoding::kRos1, "wide.bag");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 100001: field f500 is defined twice in pkg/Wide"),
              std::string::npos)
        << e.what();
  }
}

TEST(Import, ThirtyMessagesOf100000JointsImportWithinTheWatchdog) {
  const std::string dir = folder("wide");
  write(dir + "/wide.bag", session(30, joint_names(100000)).bytes(10));
  const testing::CliResult r = cli({"import", dir + "/wide.bag", "--out", dir + "/out"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(r.out.size(), 2000u) << "the terminal's summary lists a few joints, not 100,000";
  EXPECT_NE(r.out.find("q1..q100000 = j0, j1,"), std::string::npos) << r.out;
  std::ifstream csv(dir + "/out/device.csv");
  std::string line;
  std::vector<std::string> rows;
  while (std::getline(csv, line))
    if (!line.empty() && line[0] != '#') rows.push_back(line);
  ASSERT_EQ(rows.size(), 31u);
  EXPECT_EQ(std::count(rows[0].begin(), rows[0].end(), ','), 100000);
  EXPECT_EQ(rows[0].substr(rows[0].size() - 8), ",q100000");
  // Message 29's last joint: 0.029 + 0.099999.
  const double last = std::stod(rows[30].substr(rows[30].rfind(',') + 1));
  EXPECT_NEAR(last, 1e-3 * 29 + 1e-6 * 99999, 1e-15);
}

// Twenty messages of 25,000 transforms (a scan for each transform's fields
// took over a minute).
TEST(Import, ATfMessageOf25000TransformsGivesThePairAsked) {
  testing::Ros1BagWriter w;
  w.connection(0, "/tf", "tf2_msgs/TFMessage",
               builtin_definition("tf2_msgs/TFMessage", Encoding::kRos1));
  for (int i = 0; i < 20; ++i) {
    std::vector<testing::Transform> ts(25000);
    for (std::size_t k = 0; k < ts.size(); ++k) {
      ts[k].parent = "map";
      ts[k].child = fmt::format("link{}", k);
      ts[k].p[0] = static_cast<double>(k) + 0.001 * i;
    }
    const std::int64_t t = kT0 + i * 10000000;
    w.message(0, t, testing::ros1_tf_message(t, ts));
  }
  const std::string dir = folder("tf");
  write(dir + "/tf.bag", w.bytes());
  const testing::CliResult r =
      cli({"import", dir + "/tf.bag", "--frames", "map,link24999", "--out", dir + "/out"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string csv = testing::slurp(dir + "/out/tracker.csv");
  EXPECT_NE(csv.find("\n0.190000000,24999.019,0,0,1,0,0,0\n"), std::string::npos) << csv;
}

// A message type of 300,000 fields, its last one read by --field (a duplicate
// check of each field against the others took minutes).
TEST(Import, AMessageOf300000FieldsIsReadWithinTheWatchdog) {
  std::string definition, data;
  for (int k = 0; k < 300000; ++k) {
    definition += fmt::format("float64 f{}\n", k);
    data += testing::f64(0.5 * k);
  }
  testing::Ros1BagWriter w;
  w.connection(0, "/wide", "pkg/Wide", definition);
  for (int i = 0; i < 3; ++i) w.message(0, kT0 + i * 1000000, data);
  const std::string dir = folder("fields");
  write(dir + "/fields.bag", w.bytes());
  const testing::CliResult r = cli({"import", dir + "/fields.bag", "--field", "q1=/wide:f299999",
                                    "--time", "receive", "--out", dir + "/out"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(testing::slurp(dir + "/out/device.csv").find("\n0.002000000,149999.5\n"),
            std::string::npos);
}

// --- One changed byte: a message moved to another topic ---------------------

TEST(Import, AMessageMovedToAnotherTopicIsNamedNotLost) {
  const std::string dir = folder("moved");
  const std::string bytes = session(3000, joint_names(6)).bytes(1000);
  write(dir + "/good.bag", bytes);
  ASSERT_EQ(cli({"import", dir + "/good.bag", "--out", dir + "/out"}).exit_code, 0);
  const auto before = contents(dir + "/out");
  // The 1500th message record on connection 0 moved to connection 2 (/diagnostics).
  const std::string header = le32(4) + "op=\x02" + le32(9) + "conn=" + le32(0);
  std::size_t at = 0;
  for (int k = 0; k < 1500; ++k) at = bytes.find(header, at + 1);
  ASSERT_NE(at, std::string::npos);
  std::string moved = bytes;
  moved[at + header.size() - 4] = 2;
  write(dir + "/moved.bag", moved);
  const testing::CliResult r = cli({"import", dir + "/moved.bag", "--out", dir + "/out"});
  // Its chunk of 1000 records holds 834 JointStates.
  expect_refused(r,
                 "chunk: connection 0 (/joint_states): 833 messages in the chunk, but its "
                 "index data list 834");
  EXPECT_EQ(contents(dir + "/out"), before) << "the previous output is kept";
  EXPECT_EQ(entries(dir), 3u) << "no staging folder left beside it";
}

// --- Silent wrong values ------------------------------------------------------

TEST(Import, NanAndInfinityAreRefusedNamingTheMessageAndField) {
  const std::string dir = folder("nan");
  write(dir + "/good.bag", session(2000, joint_names(6)).bytes());
  ASSERT_EQ(cli({"import", dir + "/good.bag", "--out", dir + "/out"}).exit_code, 0);
  const auto before = contents(dir + "/out");
  const auto nan_joint = [](std::size_t i, std::vector<double>& q, double*) {
    if (i == 1234) q[3] = std::numeric_limits<double>::quiet_NaN();
  };
  write(dir + "/nan.bag", session(2000, joint_names(6), nan_joint).bytes());
  expect_refused(cli({"import", dir + "/nan.bag", "--out", dir + "/out"}),
                 "/joint_states (sensor_msgs/JointState, 2000 messages) message 1235 (stamped "
                 "1733390001.234000000 s): position[3] (joint 'j3') is nan: a reading must be a "
                 "number");
  const auto inf_tracker = [](std::size_t i, std::vector<double>&, double* p) {
    if (i == 70) p[1] = -std::numeric_limits<double>::infinity();
  };
  write(dir + "/inf.bag", session(2000, joint_names(6), inf_tracker).bytes());
  expect_refused(cli({"import", dir + "/inf.bag", "--out", dir + "/out"}),
                 "/tracker/pose (geometry_msgs/PoseStamped, 200 messages) message 8 (stamped "
                 "1733390000.070000000 s): pose.position.y is -inf");
  // A NaN in a joint the model does not take (a gripper) is not written: no error.
  const auto nan_gripper = [](std::size_t i, std::vector<double>& q, double*) {
    if (i == 5) q[6] = std::numeric_limits<double>::quiet_NaN();
  };
  const std::vector<std::string> touch = {"waist", "shoulder", "elbow",  "yaw",
                                          "pitch", "roll",     "gripper"};
  write(dir + "/gripper.bag", session(200, touch, nan_gripper).bytes());
  EXPECT_EQ(cli({"import", dir + "/gripper.bag", "--model", "geomagic-touch", "--convention",
                 "none", "--out", dir + "/gripper"})
                .exit_code,
            0);
  EXPECT_EQ(contents(dir + "/out"), before);
  EXPECT_EQ(entries(dir), 6u) << "the bags, out and gripper: no staging folder";
}

TEST(Import, AJointNamedTwiceIsRefused) {
  const std::string dir = folder("twice");
  write(dir + "/twice.bag", session(100, {"a", "b", "c", "b"}).bytes());
  expect_refused(cli({"import", dir + "/twice.bag", "--out", dir + "/out"}),
                 "/joint_states (sensor_msgs/JointState) message 1: the joint 'b' is named twice "
                 "(name[1] and name[3]): one name, one joint");
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

// --- Errors one short line; options without effect refused ----------------

TEST(Import, AMissingJointOfA64000JointMessageIsOneShortLine) {
  const std::string dir = folder("missing");
  write(dir + "/wide.bag", session(3, joint_names(64000)).bytes());
  for (const char* convention : {"none", "ros-geomagic"}) {
    SCOPED_TRACE(convention);
    const testing::CliResult r = cli({"import", dir + "/wide.bag", "--model", "geomagic-touch",
                                      "--convention", convention, "--out", dir + "/out"});
    expect_refused(r, "'waist' is not among ");
    EXPECT_NE(r.err.find(dir + "/wide.bag: /joint_states (sensor_msgs/JointState, 3 messages)'s "),
              std::string::npos)
        << r.err.substr(0, 400);
    EXPECT_NE(r.err.find("j0, j1, j2, j3, j4, j5, j6, j7, ... and 63992 more"), std::string::npos)
        << r.err.substr(0, 400);
    EXPECT_LT(r.err.size(), 600u);
  }
}

TEST(Import, OptionsWithoutEffectAreRefusedInOneLine) {
  const std::string dir = folder("options");
  write(dir + "/s.bag", session(20, joint_names(6)).bytes());
  const std::string bag = dir + "/s.bag";
  expect_refused(cli({"import", bag, "--list", "--out", dir + "/out"}),
                 "--list: lists the recording's topics and writes nothing: --out would have no "
                 "effect with it");
  expect_refused(cli({"import", bag, "--list", "--model", "geomagic-touch", "--joints", "/j"}),
                 "--list: lists the recording's topics and writes nothing: --model, --joints would "
                 "have no effect with it");
  EXPECT_FALSE(fs::exists(dir + "/out"));
  expect_refused(cli({"import", bag, "--still-tolerance", "1e-3", "--out", dir + "/out"}),
                 "--still-tolerance: applies to the still windows of a static log: give --static "
                 "SECONDS");
  expect_refused(cli({"import", bag, "--tracker-still", "1e-3", "--out", dir + "/out"}),
                 "--tracker-still: applies to the still windows of a static log");
  const testing::CliResult listed = cli({"import", bag, "--list"});
  EXPECT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_NE(listed.out.find("/diagnostics"), std::string::npos) << listed.out;
}

// --- rosbag2 .db3 files that would make sqlite compute or sort ---------------

// A .db3 made with libsqlite3: rosbag2's tables (Humble's), or others.
class Db3File {
 public:
  explicit Db3File(const std::string& path) {
    fs::remove(path);
    EXPECT_EQ(sqlite3_open(path.c_str(), &db_), SQLITE_OK);
  }
  ~Db3File() { sqlite3_close(db_); }
  void exec(const std::string& sql) {
    char* error = nullptr;
    EXPECT_EQ(sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK)
        << sql.substr(0, 200) << ": " << (error != nullptr ? error : "");
    sqlite3_free(error);
  }
  void topics(const std::string& rows) {
    exec(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
        "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL)");
    exec("INSERT INTO topics VALUES " + rows);
  }
  void rosbag2_messages() {
    exec(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp "
        "INTEGER NOT NULL, data BLOB NOT NULL)");
  }
  void message(std::int64_t id, std::int64_t topic, std::int64_t stamp, const std::string& data) {
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db_, "INSERT INTO messages VALUES (?1, ?2, ?3, ?4)", -1, &s, nullptr);
    sqlite3_bind_int64(s, 1, id);
    sqlite3_bind_int64(s, 2, topic);
    sqlite3_bind_int64(s, 3, stamp);
    sqlite3_bind_blob(s, 4, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(s), SQLITE_DONE);
    sqlite3_finalize(s);
  }

 private:
  sqlite3* db_ = nullptr;
};

const char* const kPoseTopic = "(1, '/tracker/pose', 'geometry_msgs/msg/PoseStamped', 'cdr', '')";

// geometry_msgs/PoseStamped in CDR (little endian), as rmw_fastrtps writes it.
std::string cdr_pose_stamped(std::int64_t stamp_ns, const double p[3]) {
  std::string out("\x00\x01\x00\x00", 4);
  out += le32(static_cast<std::uint32_t>(stamp_ns / 1000000000)) +
         le32(static_cast<std::uint32_t>(stamp_ns % 1000000000)) + le32(8) +
         std::string("tracker\0", 8);
  while ((out.size() - 4) % 8 != 0) out += '\0';
  for (const double v : {p[0], p[1], p[2], 0.0, 0.0, 0.0, 1.0}) out += testing::f64(v);
  return out;
}

// The audit's files: a few kilobytes whose messages sqlite would compute on
// reading (and sort, for ORDER BY), gigabytes of temporary files and memory.
TEST(Db3, ViewsVirtualTablesAndGeneratedColumnsAreRefused) {
  const std::string dir = folder("db3_computed");
  const std::string rows =
      "WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n WHERE i < 100000) ";
  {
    Db3File db(dir + "/view.db3");
    db.topics(kPoseTopic);
    db.exec("CREATE VIEW messages AS " + rows +
            "SELECT i AS id, 1 AS topic_id, i AS timestamp, randomblob(1000000) AS data FROM n "
            "ORDER BY data");
  }
  {
    Db3File db(dir + "/generated.db3");
    db.topics(kPoseTopic);
    db.exec(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, "
        "data BLOB AS (zeroblob(50000000)) VIRTUAL)");
    db.exec("INSERT INTO messages(id, topic_id, timestamp) " + rows +
            "SELECT i, 1, -i FROM n WHERE i <= 3000");
  }
  {
    Db3File db(dir + "/virtual.db3");
    db.topics(kPoseTopic);
    db.exec("CREATE VIRTUAL TABLE messages USING fts4(id, topic_id, timestamp, data)");
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"view", "table messages: a view, not a table (rosbag2 writes a table)"},
      {"generated", "table messages: column data is generated (computed on reading)"},
      {"virtual", "table messages: a virtual table (computed on reading)"}};
  for (const auto& [name, says] : cases) {
    SCOPED_TRACE(name);
    const std::string file = dir + "/" + name + ".db3";
    EXPECT_LT(fs::file_size(file), 300u * 1024) << "a small file";
    expect_refused(cli({"import", file, "--list"}), says);
    expect_refused(cli({"import", file, "--out", dir + "/out"}), says);
  }
}

// The bytes written by this process so far (/proc/self/io's wchar: every
// write(), temporary files included).
std::uint64_t bytes_written() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::uint64_t value = 0;
  while (io >> key >> value)
    if (key == "wchar:") return value;
  return 0;
}

struct Kept : recording::RecordingVisitor {
  std::vector<std::pair<std::int64_t, std::size_t>> messages;  // stamp, bytes
  std::uint64_t sum = 0;
  void channel(std::uint32_t, const recording::Channel&) override {}
  void message(std::uint32_t, std::int64_t receive_ns, std::string_view data,
               std::uint64_t) override {
    messages.emplace_back(receive_ns, data.size());
    for (const char c : data) sum += static_cast<unsigned char>(c);
  }
};

// Rows stored out of time order without rosbag2's timestamp index: rosbag2
// plays them by timestamp, and so does the reader, without sqlite sorting
// (and spilling) the data: no temporary file is written.
TEST(Db3, AnUnsortedTableIsReadInTimeOrderWithoutTemporaryFiles) {
  const std::string path = folder("db3_unsorted") + "/unsorted.db3";
  constexpr int kRows = 640;
  std::uint64_t sum = 0;
  {
    Db3File db(path);
    db.topics("(1, '/blob', 'std_msgs/msg/ByteMultiArray', 'cdr', '')");
    db.rosbag2_messages();
    db.exec("BEGIN");
    for (int k = 0; k < kRows; ++k) {
      std::string data(64 * 1024, static_cast<char>(k));
      sum += static_cast<std::uint64_t>(static_cast<unsigned char>(k)) * data.size();
      db.message(k + 1, 1, kT0 - k, data);  // the last row first in time
    }
    db.exec("COMMIT");
  }
  Kept kept;
  const std::uint64_t before = bytes_written();
  recording::read_rosbag2_db3(path, kept);
  const std::uint64_t written = bytes_written() - before;
  EXPECT_LT(written, 1u << 20) << "bytes written while reading 40 MB of messages";
  ASSERT_EQ(kept.messages.size(), static_cast<std::size_t>(kRows));
  EXPECT_TRUE(std::is_sorted(kept.messages.begin(), kept.messages.end()));
  EXPECT_EQ(kept.messages.front().first, kT0 - (kRows - 1));
  EXPECT_EQ(kept.sum, sum);
}

// A column's default stands for every row stored without it: a file of a few
// hundred kilobytes whose rows would hand out 200 MB. More text and data than
// the file holds is refused before any of it is copied.
TEST(Db3, MoreDataThanTheFileHoldsIsRefused) {
  const std::string path = folder("db3_default") + "/default.db3";
  {
    Db3File db(path);
    db.topics("(1, '/blob', 'std_msgs/msg/ByteMultiArray', 'cdr', '')");
    db.exec(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp "
        "INTEGER NOT NULL)");
    db.exec(
        "INSERT INTO messages WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n "
        "WHERE i < 2000) SELECT i, 1, i FROM n");
    std::string hex;
    for (int k = 0; k < 100000; ++k) hex += "ab";
    db.exec("PRAGMA writable_schema = ON");
    db.exec(
        "UPDATE sqlite_master SET sql = 'CREATE TABLE messages(id INTEGER PRIMARY KEY, "
        "topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL DEFAULT "
        "x''" +
        hex + "'')' WHERE name = 'messages'");
    db.exec("PRAGMA writable_schema = OFF");
  }
  EXPECT_LT(fs::file_size(path), 400u * 1024);
  Kept kept;
  try {
    recording::read_rosbag2_db3(path, kept);
    ADD_FAILURE() << "no error; " << kept.messages.size() << " messages";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(": messages row "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("more data than the file's bytes hold"), std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(kept.messages.empty()) << "refused before any message is handed out";
}

// Topics of one type share its definition: each is handed a copy, within the
// file's size and max_definition_bytes more.
TEST(Db3, TopicsSharingALargeDefinitionAreBounded) {
  const std::string path = folder("db3_shared") + "/shared.db3";
  {
    Db3File db(path);
    std::string rows;
    for (int k = 1; k <= 50; ++k)
      rows += fmt::format("{}({}, '/t{}', 'pkg/msg/Big', 'cdr', '')", k > 1 ? ", " : "", k, k);
    db.topics(rows);
    db.exec(
        "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, "
        "encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, "
        "type_description_hash TEXT NOT NULL)");
    db.exec("INSERT INTO message_definitions VALUES (1, 'pkg/msg/Big', 'ros2msg', '" +
            std::string(100000, '#') + "', '')");
    db.rosbag2_messages();
  }
  Kept kept;
  recording::read_rosbag2_db3(path, kept);  // 5 MB of copies: within 64 MiB
  recording::RecordingLimits limits;
  limits.max_definition_bytes = 1000000;
  try {
    recording::read_rosbag2_db3(path, kept, limits);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("topics row "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the topics' definitions add up to"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("and 1000000 more (max_definition_bytes)"),
              std::string::npos)
        << e.what();
  }
}

// A JointState topic the import cannot decode (its definition IDL, not .msg)
// beside a tracker's: refused naming the topic and why, not a tracker.csv
// alone without a word.
TEST(Import, AnUndecodableJointStateTopicIsRefusedInOneLine) {
  const std::string dir = folder("undecodable");
  {
    Db3File db(dir + "/idl.db3");
    db.topics(std::string(kPoseTopic) +
              ", (2, '/joint_states', 'sensor_msgs/msg/JointState', 'cdr', '')");
    db.exec(
        "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, "
        "encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, "
        "type_description_hash TEXT NOT NULL)");
    db.exec(
        "INSERT INTO message_definitions VALUES (1, 'sensor_msgs/msg/JointState', 'ros2idl', "
        "'module sensor_msgs { module msg { struct JointState { double x; }; }; };', '')");
    db.rosbag2_messages();
    for (int k = 0; k < 50; ++k) {
      const std::int64_t t = kT0 + k * 10000000;
      const double p[3] = {0.01 * k, 0.2, 0.3};
      db.message(2 * k + 1, 1, t, cdr_pose_stamped(t, p));
      db.message(2 * k + 2, 2, t, std::string(40, '\x01'));
    }
  }
  expect_refused(cli({"import", dir + "/idl.db3", "--out", dir + "/out"}),
                 "/joint_states (sensor_msgs/JointState): its messages are cdr with a ros2idl "
                 "definition, which hapticcal does not decode");
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

}  // namespace
}  // namespace hapticcal
