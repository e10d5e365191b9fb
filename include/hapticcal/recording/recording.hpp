// Recordings as robots are recorded: ROS 1 bags (format 2.0), MCAP files and
// rosbag2's sqlite3 storage (.db3). A reader walks a file once and hands each
// channel (a topic, its message type, encoding and definition) and each message
// (its channel, the recorder's time and the serialised bytes) to a visitor;
// decoding the bytes is ros_message.hpp's. Every problem with a file is an
// InputError whose message names the file, the byte offset and the record
// ("bag.bag: byte 4120: chunk: lz4 data end before the chunk's 2048 bytes");
// nothing is guessed and no bound is exceeded (RecordingLimits).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace hapticcal::recording {

// How a channel's messages are serialised.
enum class Encoding {
  kRos1,  // ROS 1: little-endian, unaligned, uint32 lengths
  kCdr,   // ROS 2: OMG CDR (XCDR1) with its 4-byte encapsulation header
};

// A topic as recorded. `type` is normalised to "package/Type" (ROS 2's
// "package/msg/Type" loses its "msg/"); `definition` is the message definition
// as stored (ROS 1's connection header, MCAP's ros1msg or ros2msg schema,
// rosbag2's message_definitions table), empty when the file holds none.
// `message_encoding` is the encoding as the file names it: "ros1" or "cdr" when
// hapticcal can decode the messages (then `encoding` says which); anything else
// ("json with a jsonschema schema", "cdr with a ros2idl schema", a .db3's "cdr
// with a ros2idl definition", "protobuf") is a channel hapticcal cannot
// decode, handed out all the same (its messages too) so that the import layer
// can refuse its topic naming the encoding. Empty means `encoding` says it all
// (a format with one encoding: a ROS 1 bag).
struct Channel {
  std::string topic;
  std::string type;
  Encoding encoding = Encoding::kRos1;
  std::string definition;
  std::string message_encoding;
};

// The bounds every reader keeps (docs/development.md, "Bounded input"). A file beyond one is
// an InputError naming the bound, never a larger allocation.
struct RecordingLimits {
  std::uint64_t max_file_bytes = std::uint64_t{64} << 30;   // 64 GiB
  std::uint64_t max_record_bytes = std::uint64_t{1} << 30;  // a record or chunk as stored: 1 GiB
  std::uint64_t max_uncompressed_bytes = std::uint64_t{1} << 30;  // a chunk decompressed: 1 GiB
  std::uint64_t max_message_bytes = std::uint64_t{64} << 20;      // one message's payload: 64 MiB
  std::uint32_t max_channels = 10000;
  // The channels' definitions handed out in all, beyond the file's own size:
  // many channels may name one schema (a .db3's type, an MCAP schema), each
  // handed a copy; 10,000 naming one of 16 MiB would be 160 GB.
  std::uint64_t max_definition_bytes = std::uint64_t{64} << 20;
  std::uint64_t max_messages = std::uint64_t{100} << 20;  // 100 M messages
};

// What a reader hands out. `channel` is called once for each channel before the
// first message on it; `id` is the reader's own number for it (a bag's
// connection id, an MCAP channel id, a topic's row id). `receive_ns` is the
// recorder's stamp (a bag's record time, MCAP's log_time, rosbag2's timestamp)
// in nanoseconds since the epoch; `offset` the byte offset in the file of the
// message's record (for a message inside a compressed chunk: the chunk's
// offset), used in error messages. The data view is valid during the call only.
class RecordingVisitor {
 public:
  virtual ~RecordingVisitor() = default;
  virtual void channel(std::uint32_t id, const Channel& channel) = 0;
  virtual void message(std::uint32_t channel_id, std::int64_t receive_ns, std::string_view data,
                       std::uint64_t offset) = 0;
  // Whether message() needs the data of this channel's messages: a reader
  // that must fetch them (a .db3) hands out an empty view for a channel that
  // does not (a topic only counted, --list).
  virtual bool wants_data(std::uint32_t /*channel_id*/) const { return true; }
};

// The file's format by its first bytes: "ROS 1 bag", "MCAP", "rosbag2 sqlite3";
// an InputError naming the file when it is none of them (a rosbag2 folder: its
// .db3 or .mcap file is read; metadata.yaml alone is not needed).
std::string recording_format(const std::string& path);

// Reads a whole recording, dispatching on recording_format.
void read_recording(const std::string& path, RecordingVisitor& visitor,
                    const RecordingLimits& limits = {});

// The readers, from a file and (for the fuzz targets and tests) from memory;
// `name` is the file named in errors.
void read_ros1_bag(const std::string& path, RecordingVisitor& visitor,
                   const RecordingLimits& limits = {});
void read_ros1_bag_bytes(std::string_view bytes, const std::string& name, RecordingVisitor& visitor,
                         const RecordingLimits& limits = {});
void read_mcap(const std::string& path, RecordingVisitor& visitor,
               const RecordingLimits& limits = {});
void read_mcap_bytes(std::string_view bytes, const std::string& name, RecordingVisitor& visitor,
                     const RecordingLimits& limits = {});
void read_rosbag2_db3(const std::string& path, RecordingVisitor& visitor,
                      const RecordingLimits& limits = {});

}  // namespace hapticcal::recording
