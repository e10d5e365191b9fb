// The ROS 1 bag reader (read_ros1_bag) against bags written by an independent
// writer, Debian's python3-rosbag (tests/writers/write_ros1_bag.py), with its
// side file of what it wrote; against those bags cut short or corrupted; and
// against small hand-built bags that each break one rule of the format.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"
#include "recording_visitor.hpp"
#include "run_cli.hpp"

namespace {

using hapticcal::InputError;
using hapticcal::recording::Channel;
using hapticcal::recording::Encoding;
using hapticcal::recording::read_ros1_bag;
using hapticcal::recording::read_ros1_bag_bytes;
using hapticcal::recording::RecordingLimits;
using hapticcal::recording::RecordingVisitor;
using hapticcal::testing::from_hex;
using hapticcal::testing::Seen;
using nlohmann::json;

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::uint32_t u32_at(const std::string& bytes, std::size_t offset) {
  std::uint32_t v;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

void set_u32(std::string& bytes, std::size_t offset, std::uint32_t v) {
  std::memcpy(bytes.data() + offset, &v, 4);
}

// The InputError reading `bytes` raises ("" when none); `seen` gets what was handed out.
std::string error_of(const std::string& bytes, const std::string& name,
                     const RecordingLimits& limits = {}, Seen* seen = nullptr) {
  Seen local;
  try {
    read_ros1_bag_bytes(bytes, name, seen ? *seen : local, limits);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_HAS(text, part) \
  EXPECT_NE((text).find(part), std::string::npos) << "no \"" << (part) << "\" in: " << (text)

// A bag written by python3-rosbag, its bytes and its side file (once per
// compression in this program).
struct Written {
  std::string path, bytes;
  json side;
};

const Written& written(const std::string& compression, int messages = 120) {
  static std::map<std::string, Written> cache;
  const std::string key = compression + std::to_string(messages);
  if (const auto it = cache.find(key); it != cache.end()) return it->second;
  const std::string dir =
      hapticcal::testing::fresh_folder("ros1_bag_test_" + std::to_string(::getpid()) + "_" + key);
  Written w;
  w.path = dir + "/" + compression + ".bag";
  const std::string side = dir + "/" + compression + ".json";
  const auto r = hapticcal::testing::run_program(
      HAPTICCAL_DEBIAN_PYTHON,
      {std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/write_ros1_bag.py", w.path, side,
       compression, std::to_string(messages)});
  EXPECT_EQ(r.exit_code, 0) << "python3-rosbag's writer failed: " << r.err;
  w.bytes = read_file(w.path);
  std::ifstream in(side);
  if (in) w.side = json::parse(in);
  return cache.emplace(key, std::move(w)).first->second;
}

class WrittenBag : public ::testing::TestWithParam<std::string> {};

TEST_P(WrittenBag, HandsOutEveryConnectionAndMessageAsRosbagWroteThem) {
  const Written& w = written(GetParam());
  ASSERT_FALSE(w.side.is_null());
  Seen seen;
  read_ros1_bag(w.path, seen);

  ASSERT_EQ(seen.channels.size(), w.side["connections"].size());
  for (const json& c : w.side["connections"]) {
    const Channel& channel = seen.channels.at(c["id"].get<std::uint32_t>());
    EXPECT_EQ(channel.topic, c["topic"]);
    EXPECT_EQ(channel.type, c["type"]);
    EXPECT_EQ(channel.encoding, Encoding::kRos1);
    EXPECT_EQ(channel.definition, c["message_definition"]);
    EXPECT_EQ(channel.definition, c["full_text"]) << "rosbag stores the type's _full_text";
  }
  EXPECT_EQ(seen.channels.at(0).topic, "/joint_states");
  EXPECT_EQ(seen.channels.at(1).type, "geometry_msgs/PoseStamped");

  const json& expected = w.side["messages"];
  ASSERT_EQ(seen.messages.size(), expected.size());
  ASSERT_EQ(seen.messages.size(), 240u);
  for (std::size_t k = 0; k < expected.size(); ++k) {
    const Seen::Message& m = seen.messages[k];
    EXPECT_EQ(seen.channels.at(m.id).topic, expected[k]["topic"]) << "message " << k;
    EXPECT_EQ(m.receive_ns, expected[k]["receive_ns"].get<std::int64_t>()) << "message " << k;
    EXPECT_EQ(m.data, from_hex(expected[k]["hex"])) << "message " << k;
  }
}

// An uncompressed chunk's message is at its record's offset (its data right
// after its header); a compressed chunk's at the chunk's offset.
TEST_P(WrittenBag, NamesEachMessagesRecordOrChunkByItsOffset) {
  const Written& w = written(GetParam());
  Seen seen;
  read_ros1_bag_bytes(w.bytes, "x.bag", seen);
  std::set<std::uint64_t> chunk_offsets, seen_offsets;
  for (const json& c : w.side["chunks"]) chunk_offsets.insert(c["pos"].get<std::uint64_t>());
  ASSERT_GE(chunk_offsets.size(), 10u) << "the writer's chunk_threshold gives several chunks";
  std::uint64_t last = 0;
  for (const Seen::Message& m : seen.messages) {
    EXPECT_GE(m.offset, last) << "messages in file order";
    last = m.offset;
    seen_offsets.insert(m.offset);
    if (GetParam() == "none") {
      ASSERT_LT(m.offset + 4, w.bytes.size());
      const std::uint32_t header_bytes = u32_at(w.bytes, m.offset);
      EXPECT_NE(w.bytes.substr(m.offset + 4, header_bytes).find(std::string("op=\x02", 4)),
                std::string::npos);
      EXPECT_EQ(u32_at(w.bytes, m.offset + 4 + header_bytes), m.data.size());
      EXPECT_EQ(w.bytes.substr(m.offset + 8 + header_bytes, m.data.size()), m.data);
    } else {
      EXPECT_EQ(chunk_offsets.count(m.offset), 1u) << m.offset;
    }
  }
  if (GetParam() != "none") {
    EXPECT_EQ(seen_offsets, chunk_offsets);
  }
}

// A bag cut anywhere is refused naming the record the file ends inside, before
// anything is handed out.
TEST_P(WrittenBag, RefusesATruncatedBagNamingTheCutRecord) {
  const Written& w = written(GetParam());
  const json& chunks = w.side["chunks"];
  const json& last_chunk = chunks.back();
  const auto index_pos = w.side["index_pos"].get<std::size_t>();
  struct Cut {
    std::size_t at;
    std::string expected;
  };
  const auto chunk = [&](const json& c, std::size_t plus) {
    return c["pos"].get<std::size_t>() + plus;
  };
  const std::size_t middle_of_data = last_chunk["data_pos"].get<std::size_t>() +
                                     last_chunk["compressed_size"].get<std::size_t>() / 2;
  const std::vector<Cut> cuts = {
      {15, "byte 13: record: the file ends inside the record's header length"},
      {33, "byte 13: bag header: the file ends inside the record's header"},
      {2000, "byte 13: bag header: the file ends inside the record's data of"},
      {chunk(chunks[0], 2),
       fmt::format("byte {}: record: the file ends inside", chunk(chunks[0], 0))},
      {chunk(chunks[3], 20), fmt::format("byte {}: chunk: the file ends inside the record's header",
                                         chunk(chunks[3], 0))},
      {middle_of_data,
       fmt::format("byte {}: chunk: the file ends inside the record's data", chunk(last_chunk, 0))},
      {chunk(chunks[1], 0),
       fmt::format("byte 13: bag header: index_pos {} is beyond the file's end", index_pos)},
      {index_pos,
       fmt::format(
           "byte 13: bag header: index_pos {} is the file's end: the index of its {} chunks is "
           "missing",
           index_pos, chunks.size())},
      {index_pos + 3, fmt::format("byte {}: record: the file ends inside", index_pos)},
      {index_pos + 40, fmt::format("byte {}: connection: the file ends inside", index_pos)},
      {w.bytes.size() - 3, "the file ends inside the record's data"},
  };
  for (const Cut& cut : cuts) {
    ASSERT_LT(cut.at, w.bytes.size());
    Seen seen;
    const std::string error = error_of(w.bytes.substr(0, cut.at), "cut.bag", {}, &seen);
    EXPECT_EQ(error.rfind("cut.bag: byte ", 0), 0u) << "cut at " << cut.at << ": " << error;
    EXPECT_HAS(error, cut.expected);
    EXPECT_TRUE(seen.channels.empty() && seen.messages.empty()) << "cut at " << cut.at;
  }
}

// The chunk's stated uncompressed size: larger than the bound (the uint32 field's
// largest, 4 GiB) is refused before anything is allocated.
TEST_P(WrittenBag, RefusesAChunkBeyondTheUncompressedBoundWithoutAllocatingIt) {
  const Written& w = written(GetParam());
  const json& first = w.side["chunks"][0];
  const auto pos = first["pos"].get<std::size_t>();
  std::string bytes = w.bytes;
  const std::size_t size_field = bytes.find("size=", pos);
  ASSERT_LT(size_field, first["data_pos"].get<std::size_t>());
  set_u32(bytes, size_field + 5, 0xffffffffu);
  struct rusage before {
  }, after{};
  ::getrusage(RUSAGE_SELF, &before);
  const std::string error = error_of(bytes, "huge.bag");
  ::getrusage(RUSAGE_SELF, &after);
  EXPECT_HAS(
      error,
      fmt::format("huge.bag: byte {}: chunk: 4294967295 bytes uncompressed: more than the bound of "
                  "1073741824 bytes (max_uncompressed_bytes)",
                  pos));
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 64 * 1024) << "kB more resident memory at the peak";

  RecordingLimits small;
  small.max_uncompressed_bytes = 1000;
  EXPECT_HAS(
      error_of(w.bytes, "small.bag", small),
      fmt::format(
          "small.bag: byte {}: chunk: {} bytes uncompressed: more than the bound of 1000 bytes",
          pos, first["uncompressed_size"].get<std::uint64_t>()));
}

TEST_P(WrittenBag, KeepsEveryOtherBound) {
  const Written& w = written(GetParam());
  const auto bound = [&](auto member, std::uint64_t value, const std::string& expected) {
    RecordingLimits limits;
    limits.*member = value;
    EXPECT_HAS(error_of(w.bytes, "b.bag", limits), expected);
  };
  bound(&RecordingLimits::max_file_bytes, 4096,
        "b.bag: byte 0: " + std::to_string(w.bytes.size()) +
            " bytes: more than the bound of 4096 bytes (max_file_bytes)");
  bound(&RecordingLimits::max_record_bytes, 1000,
        "more than the bound of 1000 bytes (max_record_bytes)");
  bound(&RecordingLimits::max_message_bytes, 100,
        "more than the bound of 100 bytes (max_message_bytes)");
  bound(&RecordingLimits::max_messages, 7, "more than the bound of 7 messages (max_messages)");
  RecordingLimits one_channel;
  one_channel.max_channels = 1;
  EXPECT_HAS(error_of(w.bytes, "b.bag", one_channel),
             "more than the bound of 1 connections (max_channels)");
  // The file's bound also holds for a path (the mapped file).
  Seen seen;
  RecordingLimits tiny;
  tiny.max_file_bytes = 100;
  try {
    read_ros1_bag(w.path, seen, tiny);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_HAS(std::string(e.what()), w.path);
    EXPECT_HAS(std::string(e.what()), "more than the bound of 100 bytes");
  }
}

INSTANTIATE_TEST_SUITE_P(Compressions, WrittenBag, ::testing::Values("none", "bz2", "lz4"));

// One changed byte of a message record's header in rosbag's uncompressed bag
// (its connection, its time): the chunk's messages no longer agree with the
// index data after it, an error naming the connection, its topic and the
// counts, not a message handed to another topic or lost.
TEST(WrittenBag, AMessageHeaderChangedDisagreesWithTheIndex) {
  const Written& w = written("none");
  Seen seen;
  read_ros1_bag_bytes(w.bytes, "x.bag", seen);
  ASSERT_GT(seen.messages.size(), 100u);
  std::size_t k = 100;
  while (k < seen.messages.size() && seen.messages[k].id != 0) ++k;
  ASSERT_LT(k, seen.messages.size());
  const Seen::Message& m = seen.messages[k];  // on connection 0, moved to 1 below
  ASSERT_EQ(seen.channels.count(1), 1u);
  const std::uint32_t header_bytes = u32_at(w.bytes, m.offset);
  const std::size_t conn = w.bytes.find(std::string("conn=", 5), m.offset + 4);
  const std::size_t time = w.bytes.find(std::string("time=", 5), m.offset + 4);
  ASSERT_LT(conn, m.offset + 4 + header_bytes);
  ASSERT_LT(time, m.offset + 4 + header_bytes);
  ASSERT_EQ(u32_at(w.bytes, conn + 5), 0u);
  // The chunk holding it (the last to start before it), and its messages on connection 0.
  const auto chunk_of = [&](std::uint64_t offset) {
    std::uint64_t at = 0;
    for (const json& c : w.side["chunks"])
      if (c["pos"].get<std::uint64_t>() < offset) at = c["pos"].get<std::uint64_t>();
    return at;
  };
  const std::uint64_t chunk = chunk_of(m.offset);
  std::size_t in_chunk = 0;
  for (const Seen::Message& n : seen.messages) in_chunk += n.id == 0 && chunk_of(n.offset) == chunk;
  std::string moved = w.bytes;
  set_u32(moved, conn + 5, 1);
  const std::string topic = seen.channels.at(0).topic;
  EXPECT_HAS(error_of(moved, "moved.bag"),
             fmt::format("moved.bag: byte {}: chunk: connection 0 ({}): {} messages in the chunk, "
                         "but its index data list {}",
                         chunk, topic, in_chunk - 1, in_chunk));
  std::string later = w.bytes;
  set_u32(later, time + 9, u32_at(later, time + 9) + 1);  // nsec + 1
  EXPECT_HAS(error_of(later, "later.bag"),
             fmt::format("later.bag: byte {}: chunk: connection 0 ({}): the message at byte", chunk,
                         topic));
  EXPECT_HAS(error_of(later, "later.bag"), "is not the one its index data list");
}

// The chunk of `compression` with bytes `from`..`from + n` of its data overwritten.
std::string corrupted(const Written& w, std::size_t from, std::size_t n, char with) {
  std::string bytes = w.bytes;
  const auto data_pos = w.side["chunks"][2]["data_pos"].get<std::size_t>();
  for (std::size_t i = 0; i < n; ++i) bytes[data_pos + from + i] ^= with;
  return bytes;
}

TEST(CompressedChunk, CorruptLz4DataIsAnInputErrorAtTheChunk) {
  const Written& w = written("lz4");
  const json& c = w.side["chunks"][2];
  const std::string at = fmt::format("bad.bag: byte {}: chunk: ", c["pos"].get<std::size_t>());
  EXPECT_HAS(error_of(corrupted(w, 0, 4, '\x5a'), "bad.bag"),
             at + "lz4: ");  // the frame's magic number
  const auto middle = c["compressed_size"].get<std::size_t>() / 2;
  EXPECT_HAS(error_of(corrupted(w, middle, 8, '\x5a'), "bad.bag"), at);
  // The frame's contents against the size the record states.
  std::string bytes = w.bytes;
  const std::size_t size_field = bytes.find("size=", c["pos"].get<std::size_t>());
  set_u32(bytes, size_field + 5, c["uncompressed_size"].get<std::uint32_t>() - 1);
  EXPECT_HAS(error_of(bytes, "bad.bag"), at + "lz4 data hold more than the");
  set_u32(bytes, size_field + 5, c["uncompressed_size"].get<std::uint32_t>() + 1);
  EXPECT_HAS(error_of(bytes, "bad.bag"), at + "lz4 data hold");
  // A claim no lz4 data of that length can expand to, refused before allocating.
  RecordingLimits huge;
  huge.max_uncompressed_bytes = std::uint64_t{1} << 33;
  set_u32(bytes, size_field + 5, 0xffffffffu);
  EXPECT_HAS(error_of(bytes, "bad.bag", huge), at + "size 4294967295 uncompressed: more than");
}

TEST(CompressedChunk, CorruptBz2DataIsAnInputErrorAtTheChunk) {
  const Written& w = written("bz2");
  const json& c = w.side["chunks"][2];
  const std::string at = fmt::format("bad.bag: byte {}: chunk: ", c["pos"].get<std::size_t>());
  EXPECT_HAS(error_of(corrupted(w, 0, 3, '\x5a'), "bad.bag"), at + "bz2: corrupt data");
  const auto middle = c["compressed_size"].get<std::size_t>() / 2;
  EXPECT_HAS(error_of(corrupted(w, middle, 8, '\x5a'), "bad.bag"), at + "bz2");
  std::string bytes = w.bytes;
  const std::size_t size_field = bytes.find("size=", c["pos"].get<std::size_t>());
  const auto size = c["uncompressed_size"].get<std::uint32_t>();
  set_u32(bytes, size_field + 5, size - 1);
  EXPECT_HAS(error_of(bytes, "bad.bag"),
             at + fmt::format("bz2 data hold {} bytes, the record states {}", size, size - 1));
  set_u32(bytes, size_field + 5, size + 1);
  EXPECT_HAS(error_of(bytes, "bad.bag"),
             at + fmt::format("bz2 data hold {} bytes, the record states {}", size, size + 1));
}

TEST(WrittenBag, ReadsABagWithoutMessages) {
  const Written& w = written("none", 0);
  Seen seen;
  read_ros1_bag(w.path, seen);
  EXPECT_TRUE(seen.channels.empty());
  EXPECT_TRUE(seen.messages.empty());
}

TEST(NotABag, IsAnInputErrorNamingTheFile) {
  EXPECT_HAS(error_of("", "empty.bag"), "empty.bag: byte 0: not a ROS 1 bag");
  EXPECT_HAS(error_of("time,x,y\n0,1,2\n", "log.csv"), "log.csv: byte 0: not a ROS 1 bag");
  EXPECT_HAS(error_of(std::string("\x89MCAP0\r\n", 8) + std::string(100, '\0'), "x.mcap"),
             "x.mcap: byte 0: not a ROS 1 bag");
  EXPECT_HAS(error_of("#ROSBAG V1.2\n" + std::string(100, ' '), "old.bag"),
             "old.bag: byte 0: a ROS bag of format version '1.2': only 2.0 is read");
  EXPECT_HAS(error_of("#ROSBAG V2.0\n", "magic.bag"),
             "magic.bag: byte 13: record: the file ends inside");
  Seen seen;
  const std::string dir =
      hapticcal::testing::fresh_folder("ros1_bag_test_" + std::to_string(::getpid()) + "_dir");
  for (const std::string& path : {dir + "/missing.bag", dir}) {
    try {
      read_ros1_bag(path, seen);
      ADD_FAILURE() << "no error for " << path;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ":", 0), 0u) << e.what();
    }
  }
}

// --- Hand-built bags, each breaking one rule --------------------------------

std::string u32(std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
std::string u64(std::uint64_t v) { return std::string(reinterpret_cast<const char*>(&v), 8); }
std::string field(const std::string& name, const std::string& value) {
  return u32(static_cast<std::uint32_t>(name.size() + 1 + value.size())) + name + "=" + value;
}
std::string op(int code) { return field("op", std::string(1, static_cast<char>(code))); }
std::string record(const std::string& fields, const std::string& data) {
  return u32(static_cast<std::uint32_t>(fields.size())) + fields +
         u32(static_cast<std::uint32_t>(data.size())) + data;
}
std::string time_field(const std::string& name, std::uint32_t sec, std::uint32_t nsec) {
  return field(name, u32(sec) + u32(nsec));
}

// A bag of one uncompressed chunk (one connection, one message), its index data
// and the index (the connection again and the chunk info). Each member is
// what is written; a test changes one.
struct HandBag {
  std::string connection = op(7) + field("conn", u32(0)) + field("topic", "/a");
  std::string connection_data = field("topic", "/a") + field("type", "pkg/T") +
                                field("md5sum", "0123abcd") +
                                field("message_definition", "int32 x\n");
  std::string index_connection = connection;
  std::string index_connection_data = connection_data;
  std::string message = op(2) + field("conn", u32(0)) + time_field("time", 10, 20);
  std::string message_data = u32(42);
  std::string chunk_extra;  // chunk header fields after op
  std::string bag_header_extra;
  std::optional<std::uint64_t> index_pos;
  std::uint32_t conn_count = 1;
  std::string chunk_info_data = u32(0) + u32(1);  // connection 0: one message

  std::string chunk_contents() const {
    return record(connection, connection_data) + record(message, message_data);
  }
  std::string chunk_header() const {
    return op(5) + (chunk_extra.empty()
                        ? field("compression", "none") + field("size", u32(chunk_contents().size()))
                        : chunk_extra);
  }
  std::string bag_header(std::uint64_t index) const {
    return record(op(3) + field("index_pos", u64(index)) + field("conn_count", u32(conn_count)) +
                      field("chunk_count", u32(1)) + bag_header_extra,
                  std::string(16, ' '));
  }
  std::uint64_t chunk_pos() const { return 13 + bag_header(0).size(); }
  // The message record's offset in the file.
  std::uint64_t message_offset() const {
    return chunk_pos() + 8 + chunk_header().size() + record(connection, connection_data).size();
  }
  std::string build() const {
    const std::string chunk = record(chunk_header(), chunk_contents());
    const std::string index_data =
        record(op(4) + field("ver", u32(1)) + field("conn", u32(0)) + field("count", u32(1)),
               u32(10) + u32(20) + u32(record(connection, connection_data).size()));
    const std::string index =
        record(index_connection, index_connection_data) +
        record(op(6) + field("ver", u32(1)) + field("chunk_pos", u64(chunk_pos())) +
                   time_field("start_time", 10, 20) + time_field("end_time", 10, 20) +
                   field("count", u32(chunk_info_data.size() / 8)),
               chunk_info_data);
    const std::uint64_t at = index_pos.value_or(chunk_pos() + chunk.size() + index_data.size());
    return "#ROSBAG V2.0\n" + bag_header(at) + chunk + index_data + index;
  }
};

TEST(HandBuiltBag, ReadsTheBagEveryOtherTestBreaks) {
  const HandBag bag;
  Seen seen;
  EXPECT_EQ(error_of(bag.build(), "hand.bag", {}, &seen), "");
  ASSERT_EQ(seen.channels.size(), 1u);
  EXPECT_EQ(seen.channels.at(0).topic, "/a");
  EXPECT_EQ(seen.channels.at(0).type, "pkg/T");
  EXPECT_EQ(seen.channels.at(0).definition, "int32 x\n");
  ASSERT_EQ(seen.messages.size(), 1u);
  EXPECT_EQ(seen.messages[0].receive_ns, 10'000'000'020);
  EXPECT_EQ(seen.messages[0].data, u32(42));
  EXPECT_EQ(seen.messages[0].offset, bag.message_offset());
}

// The error reading `bag`, which must start with the file and "byte".
std::string hand_error(const HandBag& bag, const RecordingLimits& limits = {}) {
  const std::string error = error_of(bag.build(), "hand.bag", limits);
  EXPECT_EQ(error.rfind("hand.bag: byte ", 0), 0u) << error;
  return error;
}

TEST(HandBuiltBag, RefusesMalformedHeaderFields) {
  const std::string at_message = fmt::format("byte {}: message data: ", HandBag().message_offset());
  HandBag bag;
  bag.message = op(2) + field("conn", u32(0)) + u32(8) + "time1234";
  EXPECT_HAS(hand_error(bag),
             fmt::format("byte {}: message data: header: field 'time1234' has no '='",
                         bag.message_offset()));
  bag = HandBag();
  bag.message += field("conn", u32(0));
  EXPECT_HAS(hand_error(bag), at_message + "header: field 'conn' appears twice");
  bag = HandBag();
  bag.message = op(2) + time_field("time", 1, 2);
  EXPECT_HAS(hand_error(bag), "message data: header: no 'conn' field");
  bag = HandBag();
  bag.message = op(2) + field("conn", u32(0)) + field("time", u32(1));
  EXPECT_HAS(hand_error(bag), "message data: header: field 'time' of 4 bytes, not 8");
  bag = HandBag();
  bag.message =
      op(2) + field("conn", u32(0)) + u32(200) + "time=12345678";  // a field past its header
  EXPECT_HAS(hand_error(bag), "message data: header: a field of 200 bytes at byte");
  bag = HandBag();
  bag.message = op(2) + field("conn", u32(0)) + time_field("time", 1, 2) + "\x01";
  EXPECT_HAS(hand_error(bag), "too few for a field's length");
  bag = HandBag();
  bag.connection_data = field("topic", "/a") + field("type", "pkg/T") + field("md5sum", "0");
  EXPECT_HAS(hand_error(bag), "connection: connection header: no 'message_definition' field");
  bag = HandBag();
  bag.chunk_extra = field("compression", "none") + field("size", u64(100'000'000'000));  // 100 GB
  EXPECT_HAS(hand_error(bag), fmt::format("byte {}: chunk: header: field 'size' of 8 bytes, not 4",
                                          bag.chunk_pos()));
  bag = HandBag();
  bag.chunk_extra = field("compression", "zstd") + field("size", u32(4));
  EXPECT_HAS(hand_error(bag), "chunk: compression 'zstd': not none, bz2 or lz4");
  bag = HandBag();
  bag.chunk_extra =
      field("compression", "none") + field("size", u32(bag.chunk_contents().size() + 1));
  EXPECT_HAS(hand_error(bag), "chunk: size");
}

// A header (its length) larger than what holds it.
TEST(HandBuiltBag, RefusesAHeaderLargerThanItsRecord) {
  HandBag bag;
  std::string bytes = bag.build();
  const std::uint64_t record = bag.message_offset();
  set_u32(bytes, record, 5000);
  const std::string error = error_of(bytes, "hand.bag");
  EXPECT_HAS(error, fmt::format("hand.bag: byte {}: message data: the chunk ends inside the "
                                "record's header of 5000 bytes",
                                record));
}

TEST(HandBuiltBag, RefusesATimeOfABillionNanoseconds) {
  HandBag bag;
  bag.message = op(2) + field("conn", u32(0)) + time_field("time", 5, 1'000'000'000);
  EXPECT_HAS(hand_error(bag),
             "message data: header: field 'time': nsec 1000000000 is not below 1e9");
}

TEST(HandBuiltBag, RefusesAMessageOnAnUnknownConnection) {
  HandBag bag;
  bag.message = op(2) + field("conn", u32(5)) + time_field("time", 1, 2);
  EXPECT_HAS(hand_error(bag),
             fmt::format("byte {}: message data: connection 5, which no connection record",
                         bag.message_offset()));
}

TEST(HandBuiltBag, RefusesAConnectionRedefinedDifferently) {
  HandBag bag;
  bag.index_connection = op(7) + field("conn", u32(0)) + field("topic", "/b");
  EXPECT_HAS(hand_error(bag), "connection: connection 0 redefined: topic '/b', before '/a'");
  bag = HandBag();
  bag.index_connection_data = field("topic", "/a") + field("type", "pkg/T") +
                              field("md5sum", "0123abcd") +
                              field("message_definition", "int64 x\n");
  EXPECT_HAS(hand_error(bag), "connection 0 redefined: message_definition");
  // The same definition again, with the optional fields a recorder adds: one channel.
  bag = HandBag();
  bag.index_connection_data += field("callerid", "/node") + field("latching", "1");
  Seen seen;
  EXPECT_EQ(error_of(bag.build(), "hand.bag", {}, &seen), "");
  EXPECT_EQ(seen.channels.size(), 1u);
}

TEST(HandBuiltBag, RefusesAnUnclosedEncryptedOrInconsistentBag) {
  HandBag bag;
  bag.index_pos = 0;
  EXPECT_HAS(hand_error(bag),
             "byte 13: bag header: index_pos 0: the recording did not close the bag");
  bag.index_pos = bag.chunk_pos() + 3;
  EXPECT_HAS(hand_error(bag),
             fmt::format("byte 13: bag header: index_pos {} is not at a record", *bag.index_pos));
  bag = HandBag();
  bag.bag_header_extra = field("encryptor", "rosbag/AesCbcEncryptor");
  EXPECT_HAS(hand_error(bag), "an encrypted bag (encryptor 'rosbag/AesCbcEncryptor') is not read");
  bag = HandBag();
  bag.conn_count = 2;
  EXPECT_HAS(hand_error(bag),
             "byte 13: bag header: conn_count 2, but the file holds 1 connections");
  bag = HandBag();
  bag.index_pos = bag.chunk_pos();  // the chunk after the index
  EXPECT_HAS(hand_error(bag),
             fmt::format("byte {}: chunk: not expected after the index", bag.chunk_pos()));
}

// The chunk info record's count a connection against the chunk's messages.
TEST(HandBuiltBag, RefusesAChunkInfoCountingOtherMessages) {
  HandBag bag;
  bag.chunk_info_data = u32(0) + u32(2);
  const std::string at = fmt::format("the chunk at byte {}: connection 0 (/a): ", bag.chunk_pos());
  EXPECT_HAS(hand_error(bag), at + "1 messages in the chunk, but its chunk info counts 2");
  bag.chunk_info_data = u32(0) + u32(1) + u32(3) + u32(1);
  EXPECT_HAS(hand_error(bag),
             fmt::format("the chunk at byte {}: connection 3 (undefined): 0 messages in the chunk, "
                         "but its chunk info counts 1",
                         bag.chunk_pos()));
}

}  // namespace
