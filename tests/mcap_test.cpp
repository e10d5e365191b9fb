// The MCAP reader (read_mcap, read_mcap_bytes) and the rosbag2 .db3 reader
// (read_rosbag2_db3) against files written by independent writers, each with a
// side file of what it wrote: @mcap/core's McapWriter (tests/writers/write_mcap.js:
// unchunked, and chunked uncompressed, zstd and lz4; CDR bytes by
// @foxglove/rosmsg2-serialization in tests/writers/cdr_messages.js) and Python's
// sqlite3 with rosbag2's tables (tests/writers/write_db3.py); then those files
// cut short at chosen records and corrupted.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
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
using hapticcal::recording::RecordingLimits;
using hapticcal::recording::RecordingVisitor;
using hapticcal::testing::from_hex;
using hapticcal::testing::Seen;
using nlohmann::json;
namespace rec = hapticcal::recording;

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_file(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void put_u64(std::string& bytes, std::size_t at, std::uint64_t value) {
  for (int i = 0; i < 8; ++i) bytes[at + i] = static_cast<char>((value >> (8 * i)) & 0xFF);
}

// The writers' files, written once into a fresh folder: node's MCAP files and
// the CDR messages, then Python's .db3 files of those messages.
struct Written {
  std::string dir, error;
};
const Written& written() {
  static const Written w = [] {
    Written out;
    out.dir = hapticcal::testing::fresh_folder(fmt::format("mcap_test_{}", ::getpid()));
    const std::string writers = std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/";
    const auto run = [&](const std::vector<std::string>& command) {
      const auto r = hapticcal::testing::run_program(
          command[0], std::vector<std::string>(command.begin() + 1, command.end()));
      if (r.exit_code != 0 && out.error.empty())
        out.error = fmt::format("{} {}: exit {}: {}", command[0], command[1], r.exit_code, r.err);
      return r.out;
    };
    run({"/usr/bin/node", writers + "write_mcap.js", HAPTICCAL_NODE_MODULES, out.dir});
    // cdr_messages.js prints the messages (and the decoder's cases) as JSON.
    write_file(out.dir + "/messages.json",
               run({"/usr/bin/node", writers + "cdr_messages.js", HAPTICCAL_NODE_MODULES}));
    for (const char* flavour : {"humble", "jazzy"})
      run({HAPTICCAL_DEBIAN_PYTHON, writers + "write_db3.py", out.dir + "/messages.json",
           out.dir + "/" + flavour + ".db3", flavour});
    return out;
  }();
  return w;
}

json side_file(const std::string& path) { return json::parse(file_bytes(path)); }

// The InputError of reading `path` (empty when none was thrown).
template <typename Read>
std::string error_of(Read read) {
  try {
    read();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string mcap_error(const std::string& path, const RecordingLimits& limits = {}) {
  Seen seen;
  return error_of([&] { rec::read_mcap(path, seen, limits); });
}

// The channels as the header's contract makes them of what write_mcap.js
// registered: "package/msg/Type" loses "msg/"; ros1+ros1msg and cdr+ros2msg
// (or cdr without a schema) decode; the others say what they are.
struct ExpectedChannel {
  std::string type;
  Encoding encoding;
  std::string message_encoding;
};
const std::map<std::string, ExpectedChannel> kMcapChannels = {
    {"/joint_states", {"sensor_msgs/JointState", Encoding::kCdr, "cdr"}},
    {"/tracker/pose", {"geometry_msgs/PoseStamped", Encoding::kCdr, "cdr"}},
    {"/chatter", {"std_msgs/String", Encoding::kRos1, "ros1"}},
    {"/diagnostics", {"Diagnostics", Encoding::kRos1, "json with a jsonschema schema"}},
    {"/raw", {"", Encoding::kCdr, "cdr"}},
    {"/reading", {"example_msgs/Reading", Encoding::kRos1, "cdr with a ros2idl schema"}},
};

class McapFile : public ::testing::TestWithParam<std::string> {};

TEST_P(McapFile, EveryChannelAndMessageAsWritten) {
  ASSERT_EQ(written().error, "");
  const std::string path = written().dir + "/" + GetParam() + ".mcap";
  const json side = side_file(written().dir + "/" + GetParam() + ".json");
  Seen seen;
  rec::read_mcap(path, seen);

  ASSERT_EQ(seen.channels.size(), side["channels"].size());
  for (const auto& c : side["channels"]) {
    const auto found = seen.channels.find(c["id"].get<std::uint32_t>());
    ASSERT_NE(found, seen.channels.end()) << c["topic"];
    const Channel& got = found->second;
    const ExpectedChannel& expected = kMcapChannels.at(c["topic"].get<std::string>());
    EXPECT_EQ(got.topic, c["topic"].get<std::string>());
    EXPECT_EQ(got.type, expected.type) << got.topic;
    EXPECT_EQ(got.message_encoding, expected.message_encoding) << got.topic;
    if (expected.message_encoding == "cdr" || expected.message_encoding == "ros1") {
      EXPECT_EQ(got.encoding, expected.encoding) << got.topic;
    }
    EXPECT_EQ(got.definition, c["schema_data"].get<std::string>()) << got.topic;
  }

  const auto& messages = side["messages"];
  ASSERT_EQ(seen.messages.size(), messages.size());
  std::set<std::uint64_t> chunk_offsets;
  for (const auto& chunk : side["chunks"])
    chunk_offsets.insert(chunk["offset"].get<std::uint64_t>());
  const std::string bytes = file_bytes(path);
  std::uint64_t last_offset = 0;
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const auto& m = messages[i];
    const Seen::Message& got = seen.messages[i];
    EXPECT_EQ(got.id, m["channel"].get<std::uint32_t>()) << "message " << i;
    EXPECT_EQ(got.receive_ns, std::stoll(m["log_time"].get<std::string>())) << "message " << i;
    ASSERT_EQ(got.data, from_hex(m["data"].get<std::string>())) << "message " << i;
    EXPECT_GE(got.offset, last_offset) << "message " << i;
    last_offset = got.offset;
    if (chunk_offsets.empty()) {
      // A Message record: opcode 0x05, then 8 + 2 + 4 + 8 + 8 bytes before its data (the spec's
      // layout).
      ASSERT_LT(got.offset + 31, bytes.size());
      EXPECT_EQ(bytes[got.offset], '\x05') << "message " << i;
      EXPECT_EQ(bytes.substr(got.offset + 31, got.data.size()), got.data) << "message " << i;
    } else {
      EXPECT_TRUE(chunk_offsets.count(got.offset)) << "message " << i << " at byte " << got.offset;
    }
  }
  // The same from memory, and through the format's dispatch.
  Seen from_memory, dispatched;
  rec::read_mcap_bytes(bytes, "memory.mcap", from_memory);
  EXPECT_EQ(from_memory.messages.size(), seen.messages.size());
  EXPECT_EQ(rec::recording_format(path), "MCAP");
  rec::read_recording(path, dispatched);
  EXPECT_EQ(dispatched.messages.size(), seen.messages.size());
}

INSTANTIATE_TEST_SUITE_P(Writers, McapFile,
                         ::testing::Values("unchunked", "chunked-none", "chunked-zstd",
                                           "chunked-lz4"),
                         [](const auto& info) {
                           std::string name = info.param;
                           std::erase(name, '-');
                           return name;
                         });

// `name`.mcap cut to `keep` bytes (or with `edit` applied) must be refused naming
// the file and "byte OFFSET: RECORD".
void expect_refused(const std::string& name, const std::string& bytes, std::uint64_t offset,
                    const std::string& record, const std::string& also = "",
                    const RecordingLimits& limits = {}) {
  const std::string path = written().dir + "/" + name;
  write_file(path, bytes);
  const std::string error = mcap_error(path, limits);
  ASSERT_NE(error, "") << name << ": no error";
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find(fmt::format("byte {}: {}", offset, record)), std::string::npos)
      << "expected byte " << offset << ": " << record << " in: " << error;
  EXPECT_NE(error.find(also), std::string::npos) << "expected " << also << " in: " << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
}

struct ChunkInfo {
  std::uint64_t offset, length, compressed;
  std::string compression;
  // Where the compressed records start: opcode and length (9), three
  // timestamps/sizes and the CRC (28), the compression string, the records'
  // uint64 length.
  std::uint64_t records() const { return offset + 9 + 28 + 4 + compression.size() + 8; }
};
ChunkInfo chunk_of(const json& side, std::size_t i) {
  const auto& c = side["chunks"].at(i);
  return {c["offset"].get<std::uint64_t>(), c["length"].get<std::uint64_t>(),
          c["compressed_size"].get<std::uint64_t>(), c["compression"].get<std::string>()};
}

TEST(McapTruncated, ChunkedCutAtEachKindOfPlaceNamesTheRecord) {
  ASSERT_EQ(written().error, "");
  const std::string bytes = file_bytes(written().dir + "/chunked-zstd.mcap");
  const json side = side_file(written().dir + "/chunked-zstd.json");
  ASSERT_GE(side["chunks"].size(), 6u);
  const ChunkInfo first = chunk_of(side, 0), middle = chunk_of(side, 5);
  const auto cut = [&](std::uint64_t keep, std::uint64_t offset, const std::string& record,
                       const std::string& also = "truncated") {
    SCOPED_TRACE(fmt::format("cut at {}", keep));
    expect_refused(fmt::format("cut-{}.mcap", keep), bytes.substr(0, keep), offset, record, also);
  };
  cut(4, 0, "magic", "inside MCAP's magic");
  cut(first.offset + 4, first.offset, "chunk");                        // its opcode and length
  cut(first.offset + 20, first.offset, "chunk");                       // its fields
  cut(first.records() + first.compressed / 2, first.offset, "chunk");  // its compressed records
  cut(middle.offset + 40, middle.offset, "chunk");
  cut(middle.offset + middle.length + 3, middle.offset + middle.length, "message index");
  cut(first.offset + first.length, first.offset + first.length, "", "without a Data End or Footer");
  const auto data_end = side["data_end_offset"].get<std::uint64_t>();
  cut(data_end + 5, data_end, "data end");
  cut(bytes.size() - 1, bytes.size() - 1, "magic", "does not end with MCAP's magic");
}

TEST(McapTruncated, UnchunkedCutInsideAMessageNamesIt) {
  ASSERT_EQ(written().error, "");
  const std::string bytes = file_bytes(written().dir + "/unchunked.mcap");
  const json side = side_file(written().dir + "/unchunked.json");
  const std::string payload = from_hex(side["messages"][50]["data"].get<std::string>());
  const std::size_t at = bytes.find(payload);
  ASSERT_NE(at, std::string::npos);
  ASSERT_EQ(bytes.rfind(payload), at) << "the payload is not unique";
  const std::uint64_t record = at - 31;  // opcode, length and the fields before the data
  expect_refused("cut-message-data.mcap", bytes.substr(0, at + 2), record, "message", "truncated");
  expect_refused("cut-message-header.mcap", bytes.substr(0, record + 5), record, "message",
                 "truncated");
  expect_refused("cut-message-fields.mcap", bytes.substr(0, record + 12), record, "message",
                 "truncated");
  // A changed byte of a message outside chunks: the data section's CRC-32.
  std::string edited = bytes;
  edited[at + 3] = static_cast<char>(edited[at + 3] ^ 0x40);
  expect_refused("edited-message.mcap", edited, side["data_end_offset"].get<std::uint64_t>(),
                 "data end", "the data section's CRC-32");
}

// A message record's channel id changed (and the data section's CRC-32 zeroed,
// as a writer that computes none leaves it): the summary's Statistics record
// counts another number of messages on the channel, an error naming it.
TEST(McapCorrupt, AMessageOnAnotherChannelDisagreesWithTheStatistics) {
  ASSERT_EQ(written().error, "");
  const std::string bytes = file_bytes(written().dir + "/unchunked.mcap");
  const json side = side_file(written().dir + "/unchunked.json");
  Seen seen;
  rec::read_mcap_bytes(bytes, "clean.mcap", seen);
  const Seen::Message& m = seen.messages.at(50);
  ASSERT_EQ(static_cast<unsigned char>(bytes[m.offset]), 0x05) << "a message record";
  std::uint16_t channel;
  std::memcpy(&channel, bytes.data() + m.offset + 9, 2);
  ASSERT_EQ(channel, m.id);
  std::uint16_t other = 0;
  for (const auto& [id, c] : seen.channels)
    if (id != channel) other = static_cast<std::uint16_t>(id);
  ASSERT_NE(other, channel);
  const auto on = [&](std::uint32_t id) {
    return std::count_if(seen.messages.begin(), seen.messages.end(),
                         [&](const Seen::Message& n) { return n.id == id; });
  };
  std::string edited = bytes;
  std::memcpy(edited.data() + m.offset + 9, &other, 2);
  const auto data_end = side["data_end_offset"].get<std::size_t>();
  ASSERT_EQ(edited[data_end], '\x0f');
  std::memset(edited.data() + data_end + 9, 0, 4);  // data_section_crc: 0, not computed
  Seen read;
  const std::string error = error_of([&] { rec::read_mcap_bytes(edited, "edited.mcap", read); });
  const std::uint16_t first = std::min(channel, other);
  EXPECT_NE(error.find(fmt::format("statistics: channel {} ({}): {} messages in the data section, "
                                   "but the statistics count {}",
                                   first, seen.channels.at(first).topic,
                                   on(first) + (first == other ? 1 : -1), on(first))),
            std::string::npos)
      << error;
  EXPECT_EQ(error.rfind("edited.mcap: byte ", 0), 0u) << error;
}

// An MCAP file of one schema of `schema_bytes` and `channels` channels naming
// it, built record by record (https://mcap.dev/spec): each channel is handed a
// copy of the schema.
std::string shared_schema_mcap(std::size_t schema_bytes, int channels) {
  const auto le = [](std::uint64_t v, int n) {
    std::string out;
    for (int i = 0; i < n; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
    return out;
  };
  const auto text = [&](const std::string& s) { return le(s.size(), 4) + s; };
  const auto record = [&](int op, const std::string& content) {
    return std::string(1, static_cast<char>(op)) + le(content.size(), 8) + content;
  };
  const std::string magic("\x89MCAP0\r\n", 8);
  std::string out = magic + record(0x01, text("") + text(""));
  out += record(
      0x03, le(1, 2) + text("pkg/Big") + text("ros1msg") + text(std::string(schema_bytes, '#')));
  for (int k = 1; k <= channels; ++k)
    out +=
        record(0x04, le(k, 2) + le(1, 2) + text(fmt::format("/t{}", k)) + text("ros1") + le(0, 4));
  out += record(0x0F, le(0, 4));
  out += record(0x02, le(0, 8) + le(0, 8) + le(0, 4));
  return out + magic;
}

// Many channels naming one schema: their copies within the file's size and
// max_definition_bytes more.
TEST(McapCorrupt, ChannelsCopyingALargeSchemaAreBounded) {
  const std::string bytes = shared_schema_mcap(100000, 50);
  Seen seen;
  rec::read_mcap_bytes(bytes, "shared.mcap", seen);  // 5 MB of copies: within 64 MiB
  EXPECT_EQ(seen.channels.size(), 50u);
  RecordingLimits limits;
  limits.max_definition_bytes = 1000000;
  Seen bounded;
  const std::string error =
      error_of([&] { rec::read_mcap_bytes(bytes, "shared.mcap", bounded, limits); });
  EXPECT_NE(error.find("channel: the channels' schemas add up to 1200000 bytes, more than the "
                       "file's"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("and 1000000 more (max_definition_bytes)"), std::string::npos) << error;
  EXPECT_EQ(bounded.channels.size(), 11u);
}

TEST(McapCorrupt, CompressedDataAndCrcAreChecked) {
  ASSERT_EQ(written().error, "");
  for (const std::string name : {"chunked-zstd", "chunked-lz4"}) {
    SCOPED_TRACE(name);
    const std::string bytes = file_bytes(written().dir + "/" + name + ".mcap");
    const ChunkInfo c = chunk_of(side_file(written().dir + "/" + name + ".json"), 1);
    std::string no_magic = bytes;
    no_magic.replace(c.records(), 4, std::string(4, '\0'));
    expect_refused(name + "-no-magic.mcap", no_magic, c.offset, "chunk", c.compression + ": ");
    std::string scrambled = bytes;
    for (std::uint64_t i = 0; i < 16; ++i) scrambled[c.records() + c.compressed / 2 + i] ^= 0x5A;
    expect_refused(name + "-scrambled.mcap", scrambled, c.offset, "chunk");
    std::string wrong_crc = bytes;
    wrong_crc[c.offset + 9 + 24] ^= 0x01;
    expect_refused(name + "-crc.mcap", wrong_crc, c.offset, "chunk", "CRC-32");
  }
  // Uncompressed: a changed byte of a message inside the chunk.
  const std::string bytes = file_bytes(written().dir + "/chunked-none.mcap");
  const ChunkInfo c = chunk_of(side_file(written().dir + "/chunked-none.json"), 2);
  std::string edited = bytes;
  edited[c.offset + c.length - 1] ^= 0x10;
  expect_refused("none-edited.mcap", edited, c.offset, "chunk", "the records' CRC-32");
}

TEST(McapCorrupt, HugeChunkIsRefusedWithoutAllocating) {
  ASSERT_EQ(written().error, "");
  for (const std::string name : {"chunked-zstd", "chunked-lz4", "chunked-none"}) {
    SCOPED_TRACE(name);
    std::string bytes = file_bytes(written().dir + "/" + name + ".mcap");
    const ChunkInfo c = chunk_of(side_file(written().dir + "/" + name + ".json"), 0);
    put_u64(bytes, c.offset + 9 + 16, 100'000'000'000);  // uncompressed_size: 100 GB
    expect_refused(name + "-100GB.mcap", bytes, c.offset, "chunk",
                   "100000000000 bytes uncompressed: more than the bound of 1073741824 bytes");
    if (name == "chunked-none") continue;
    // Within a raised bound, the compressed bytes still cannot hold it.
    RecordingLimits raised;
    raised.max_uncompressed_bytes = std::uint64_t{1} << 40;
    expect_refused(name + "-100GB-raised.mcap", bytes, c.offset, "chunk", "cannot hold", raised);
  }
}

TEST(McapCorrupt, UndefinedSchemaOrChannelAndBoundsAreRefused) {
  ASSERT_EQ(written().error, "");
  const std::string dir = written().dir;
  EXPECT_NE(mcap_error(dir + "/undefined-schema.mcap")
                .find("channel: channel 1 (/x) names schema 7, not defined"),
            std::string::npos)
      << mcap_error(dir + "/undefined-schema.mcap");
  EXPECT_NE(mcap_error(dir + "/undefined-channel.mcap").find("message: channel 1 is not defined"),
            std::string::npos)
      << mcap_error(dir + "/undefined-channel.mcap");

  const std::string zstd = dir + "/chunked-zstd.mcap";
  RecordingLimits limits;
  limits.max_message_bytes = 16;
  EXPECT_NE(mcap_error(zstd, limits).find("more than the bound of 16 bytes for a message"),
            std::string::npos);
  limits = {};
  limits.max_channels = 3;
  EXPECT_NE(mcap_error(zstd, limits).find("more than the bound of 3 channels"), std::string::npos);
  limits = {};
  limits.max_messages = 100;
  EXPECT_NE(mcap_error(zstd, limits).find("more than the bound of 100 messages"),
            std::string::npos);
  limits = {};
  limits.max_record_bytes = 1000;
  EXPECT_NE(mcap_error(zstd, limits).find("more than the bound of 1000 bytes for a record"),
            std::string::npos);
  limits = {};
  limits.max_file_bytes = 1000;
  EXPECT_NE(mcap_error(zstd, limits).find("more than the bound of 1000 bytes"), std::string::npos);

  Seen seen;
  const std::string junk = "\x89MCAP1\r\n and then nothing of the format";
  EXPECT_NE(error_of([&] {
              rec::read_mcap_bytes(junk, "junk.mcap", seen);
            }).find("junk.mcap: byte 0: magic: MCAP major version '1'"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              rec::read_mcap_bytes("PK\x03\x04", "zip.mcap", seen);
            }).find("not an MCAP file"),
            std::string::npos);
}

// ---- rosbag2 .db3 ----

// What write_db3.py's topics become: the type loses "msg/"; the definition is
// the message_definitions row's when it is ros2msg; a ros2idl one is named.
void expect_db3_as_written(const std::string& flavour) {
  ASSERT_EQ(written().error, "");
  const std::string path = written().dir + "/" + flavour + ".db3";
  const json side = side_file(path + ".json");
  Seen seen;
  rec::read_rosbag2_db3(path, seen);
  ASSERT_EQ(seen.channels.size(), side["topics"].size());
  for (const auto& t : side["topics"]) {
    const auto found = seen.channels.find(t["id"].get<std::uint32_t>());
    ASSERT_NE(found, seen.channels.end()) << t["name"];
    const Channel& got = found->second;
    const std::string name = t["name"].get<std::string>();
    EXPECT_EQ(got.topic, name);
    const std::map<std::string, std::string> types = {
        {"/joint_states", "sensor_msgs/JointState"},
        {"/tracker/pose", "geometry_msgs/PoseStamped"},
        {"/reading", "example_msgs/Reading"},
        {"/thing", "custom_msgs/Thing"}};
    EXPECT_EQ(got.type, types.at(name));
    if (name == "/reading") {
      EXPECT_EQ(got.message_encoding, "cdr with a ros2idl definition");
      EXPECT_EQ(got.definition, "");
    } else {
      EXPECT_EQ(got.message_encoding, "cdr") << name;
      EXPECT_EQ(got.encoding, Encoding::kCdr) << name;
      const bool ros2msg = t["definition_encoding"].get<std::string>() == "ros2msg";
      EXPECT_EQ(got.definition, ros2msg ? t["definition"].get<std::string>() : "") << name;
      if (flavour == "jazzy" && name == "/joint_states") {
        EXPECT_FALSE(got.definition.empty());
      }
    }
  }
  const auto& messages = side["messages"];
  ASSERT_EQ(seen.messages.size(), messages.size());
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const auto& m = messages[i];
    EXPECT_EQ(seen.messages[i].id, m["topic_id"].get<std::uint32_t>()) << "row " << m["id"];
    EXPECT_EQ(seen.messages[i].receive_ns, std::stoll(m["timestamp"].get<std::string>()))
        << "row " << m["id"];
    ASSERT_EQ(seen.messages[i].data, from_hex(m["data"].get<std::string>())) << "row " << m["id"];
    EXPECT_EQ(seen.messages[i].offset, 0u);
  }
}

TEST(Db3, HumbleAsWritten) { expect_db3_as_written("humble"); }
TEST(Db3, JazzyAsWritten) { expect_db3_as_written("jazzy"); }

TEST(Db3, TheFileIsNotTouched) {
  ASSERT_EQ(written().error, "");
  const std::string dir =
      hapticcal::testing::fresh_folder(fmt::format("mcap_test_db3_{}", ::getpid()));
  const std::string path = dir + "/bag_0.db3";
  std::filesystem::copy_file(written().dir + "/jazzy.db3", path);
  write_file(dir + "/metadata.yaml", "rosbag2_bagfile_information:\n  version: 5\n");
  struct stat before {
  }, after{};
  ASSERT_EQ(::stat(path.c_str(), &before), 0);
  const std::string bytes = file_bytes(path);
  Seen seen;
  EXPECT_EQ(rec::recording_format(dir), "rosbag2 sqlite3");
  rec::read_recording(dir, seen);  // the rosbag2 folder
  EXPECT_EQ(seen.messages.size(), side_file(written().dir + "/jazzy.db3.json")["messages"].size());
  ASSERT_EQ(::stat(path.c_str(), &after), 0);
  EXPECT_EQ(file_bytes(path), bytes);
  EXPECT_EQ(before.st_mtim.tv_sec, after.st_mtim.tv_sec);
  EXPECT_EQ(before.st_mtim.tv_nsec, after.st_mtim.tv_nsec);
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    files.push_back(entry.path().filename());
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files, (std::vector<std::string>{"bag_0.db3", "metadata.yaml"}));

  // A write-ahead log beside it: changes the file does not hold yet.
  write_file(path + "-wal", std::string(64, 'w'));
  const std::string error = error_of([&] { rec::read_rosbag2_db3(path, seen); });
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("bag_0.db3-wal beside it"), std::string::npos) << error;
}

std::string db3_error(const std::string& path, const RecordingLimits& limits = {}) {
  Seen seen;
  return error_of([&] { rec::read_rosbag2_db3(path, seen, limits); });
}

TEST(Db3, TruncatedJunkOrCorruptIsAnInputErrorNamingTheFile) {
  ASSERT_EQ(written().error, "");
  const std::string bytes = file_bytes(written().dir + "/jazzy.db3");
  const std::string dir = written().dir;
  const auto expect = [&](const std::string& name, const std::string& content,
                          const std::string& what) {
    SCOPED_TRACE(name);
    const std::string path = dir + "/" + name;
    write_file(path, content);
    const std::string error = db3_error(path);
    ASSERT_NE(error, "");
    EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << error;
    EXPECT_NE(error.find(what), std::string::npos) << "expected " << what << " in: " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  };
  expect("half.db3", bytes.substr(0, bytes.size() / 2), "a truncated file");
  expect("header-only.db3", bytes.substr(0, 60), "shorter than SQLite's 100-byte header");
  std::mt19937 random(11);
  std::string junk(8192, '\0');
  for (char& c : junk) c = static_cast<char>(random());
  expect("junk.db3", junk, "not an SQLite 3 database");
  // SQLite's header, then junk: sqlite's own refusal.
  std::string junk_pages = bytes;
  for (std::size_t i = 100; i < junk_pages.size(); ++i) junk_pages[i] = static_cast<char>(random());
  expect("junk-pages.db3", junk_pages, "sqlite: ");
  // The middle half of the pages overwritten: the messages' pages are corrupt.
  std::string corrupt = bytes;
  for (std::size_t i = bytes.size() / 4; i < 3 * bytes.size() / 4; ++i) corrupt[i] = '\xA5';
  expect("corrupt.db3", corrupt, "sqlite: ");
  // An SQLite database that is not a rosbag2 one.
  expect("empty.db3", std::string(), "not an SQLite 3 database");
}

TEST(Db3, BoundsAreKept) {
  ASSERT_EQ(written().error, "");
  const std::string path = written().dir + "/humble.db3";
  RecordingLimits limits;
  limits.max_message_bytes = 100;
  std::string error = db3_error(path, limits);
  EXPECT_NE(error.find(": messages row "), std::string::npos) << error;
  EXPECT_NE(error.find("more than the bound of 100 bytes for a message"), std::string::npos)
      << error;
  limits = {};
  limits.max_messages = 10;
  error = db3_error(path, limits);
  EXPECT_NE(error.find("more than the bound of 10 messages"), std::string::npos) << error;
  limits = {};
  limits.max_channels = 1;
  error = db3_error(path, limits);
  EXPECT_NE(error.find("topics row 2: more than the bound of 1 topics"), std::string::npos)
      << error;
  limits = {};
  limits.max_file_bytes = 4096;
  error = db3_error(path, limits);
  EXPECT_NE(error.find("more than the bound of 4096 bytes"), std::string::npos) << error;
}

}  // namespace
