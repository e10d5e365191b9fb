// ROS 1 bags, format 2.0, as specified at http://wiki.ros.org/Bags/Format/2.0:
// "#ROSBAG V2.0\n", then records, each a header (uint32 length, then fields
// "name=value" each behind a uint32 length) and data (uint32 length, bytes).
// The records are walked in file order from the start; the index is checked,
// not relied on: each chunk's messages against the index data records after it
// (every message's connection, time and place) and against its chunk info
// record's count a connection, so that a changed byte of a message's header
// is an error, not a sample handed to the wrong topic or lost. A bag cut short
// (a record that the file ends inside, an index_pos beyond the end) or whose
// recording never closed (index_pos 0) is an error: nothing is guessed.
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"
#include "recording/byte_reader.hpp"
#include "recording/ros1_records.hpp"

namespace hapticcal::recording {
namespace {

constexpr std::string_view kMagic = "#ROSBAG V2.0\n";
// An lz4 frame cannot expand more: a match's length grows by at most 255 for
// each byte that encodes it (LZ4 block format), so larger claims are corrupt.
constexpr std::uint64_t kMaxLz4Expansion = 255;

using detail::Header;
using detail::kBagHeader;
using detail::kChunk;
using detail::kChunkInfo;
using detail::kConnection;
using detail::kIndexData;
using detail::kMessageData;
using detail::quoted;
using detail::read_record;
using detail::Record;
using detail::Where;

struct Connection {
  Channel channel;
  std::string md5sum;
};

// A message as a chunk holds it and as its index data state it: its
// connection, the record's offset in the chunk's (uncompressed) contents and
// its time. Sorted by connection, then offset.
struct IndexEntry {
  std::uint32_t conn = 0;
  std::uint32_t offset = 0;
  std::int64_t time_ns = 0;
  auto operator<=>(const IndexEntry&) const = default;
};

// The messages of one chunk (as read, and as its index data state them) and
// its count a connection (for its chunk info record).
struct ChunkTally {
  std::uint64_t offset = 0;  // the chunk record's
  std::vector<IndexEntry> read, indexed;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> counts;  // (conn, messages), by conn
};

class BagReader {
 public:
  BagReader(std::string_view bytes, const std::string& name, RecordingVisitor& visitor,
            const RecordingLimits& limits)
      : bytes_(bytes), name_(name), visitor_(visitor), limits_(limits) {}

  void read();

 private:
  void file_record(std::size_t pos, Record& r) const {
    read_record(bytes_, pos, false, false, limits_, r);
  }
  void check_magic() const;
  std::size_t read_bag_header();
  void check_framing(std::size_t first) const;
  void read_chunk(const Record& chunk);
  void read_connection(const Record& r);
  void read_message(const Record& r, std::size_t pos_in_chunk);
  void read_index_data(const Record& r);
  void check_chunk_index();
  void read_chunk_info(const Record& r) const;
  void check_counts() const;
  std::string topic_of(std::uint32_t conn) const;

  std::string_view bytes_;
  const std::string& name_;
  RecordingVisitor& visitor_;
  const RecordingLimits& limits_;
  std::uint64_t index_pos_ = 0;
  std::uint32_t conn_count_ = 0, chunk_count_ = 0;
  std::unordered_map<std::uint32_t, Connection> connections_;
  std::vector<std::uint64_t> chunk_offsets_;  // increasing
  std::vector<ChunkTally> chunks_;            // counts only, once checked against the index
  std::uint64_t messages_ = 0;
};

void BagReader::check_magic() const {
  const Where w{name_, 0, ""};
  if (bytes_.substr(0, kMagic.size()) == kMagic) return;
  constexpr std::string_view kAnyVersion = "#ROSBAG V";
  if (bytes_.substr(0, kAnyVersion.size()) == kAnyVersion) {
    const std::string_view rest = bytes_.substr(kAnyVersion.size(), 8);
    w.fail(fmt::format(
        "a ROS bag of format version {}: only 2.0 is read (`rosbag fix` converts a 1.2 bag)",
        quoted(rest.substr(0, rest.find('\n')))));
  }
  w.fail("not a ROS 1 bag: it does not start with \"#ROSBAG V2.0\\n\"");
}

// The bag header record after the magic; returns the offset after it.
std::size_t BagReader::read_bag_header() {
  Record r(Where{name_, kMagic.size(), ""});
  file_record(kMagic.size(), r);
  if (r.op != kBagHeader) r.where.fail("the first record is not the bag header");
  index_pos_ = r.header->number<std::uint64_t>("index_pos");
  conn_count_ = r.header->number<std::uint32_t>("conn_count");
  chunk_count_ = r.header->number<std::uint32_t>("chunk_count");
  if (const auto encryptor = r.header->find("encryptor"))
    r.where.fail(fmt::format("an encrypted bag (encryptor {}) is not read", quoted(*encryptor)));
  if (index_pos_ == 0)
    r.where.fail(
        "index_pos 0: the recording did not close the bag (`rosbag reindex` writes its index)");
  return kMagic.size() + r.size;
}

// Every top-level record complete, index_pos at one of them (or at the end)
// and as many chunks and chunk infos as the bag header states: a truncated bag
// is reported before anything is handed out.
void BagReader::check_framing(std::size_t first) const {
  const Where w{name_, kMagic.size(), "bag header"};
  std::uint64_t chunks = 0, chunk_infos = 0;
  bool index_found = false;
  for (std::size_t pos = first;;) {
    index_found = index_found || index_pos_ == pos;
    if (pos >= bytes_.size()) break;
    throw_if_cancelled();  // a host's Ctrl-C (core/cancel.hpp): a relaxed load a record
    Record r(Where{name_, pos, ""});
    file_record(pos, r);
    chunks += r.op == kChunk;
    chunk_infos += r.op == kChunkInfo;
    pos += r.size;
  }
  if (index_pos_ > bytes_.size())
    w.fail(fmt::format("index_pos {} is beyond the file's end at byte {} (a truncated bag)",
                       index_pos_, bytes_.size()));
  if (!index_found) w.fail(fmt::format("index_pos {} is not at a record", index_pos_));
  if (chunks != chunk_count_)
    w.fail(fmt::format("chunk_count {}, but the file holds {} chunks", chunk_count_, chunks));
  if (index_pos_ == bytes_.size() && chunk_count_ > 0)
    w.fail(fmt::format(
        "index_pos {} is the file's end: the index of its {} chunks is missing (a truncated bag)",
        index_pos_, chunk_count_));
  if (chunk_infos != chunk_count_)
    w.fail(fmt::format("chunk_count {}, but the index holds {} chunk info records", chunk_count_,
                       chunk_infos));
}

void BagReader::read() {
  if (bytes_.size() > limits_.max_file_bytes)
    fail_at(name_, 0, "",
            fmt::format("{} bytes: more than the bound of {} bytes (max_file_bytes)", bytes_.size(),
                        limits_.max_file_bytes));
  check_magic();
  const std::size_t first = read_bag_header();
  check_framing(first);
  for (std::size_t pos = first; pos < bytes_.size();) {
    Record r(Where{name_, pos, ""});
    file_record(pos, r);
    const bool before_index = pos < index_pos_;
    if (!(before_index && r.op == kIndexData)) check_chunk_index();  // the last chunk's is read
    if (before_index && r.op == kChunk) {
      read_chunk(r);
    } else if (before_index && r.op == kIndexData) {
      read_index_data(r);
    } else if (!before_index && r.op == kConnection) {
      read_connection(r);
    } else if (!before_index && r.op == kChunkInfo) {
      read_chunk_info(r);
    } else {
      r.where.fail(fmt::format("not expected {} the index at index_pos {}",
                               before_index ? "before" : "after", index_pos_));
    }
    pos += r.size;
  }
  check_chunk_index();
  check_counts();
}

void BagReader::read_chunk(const Record& chunk) {
  const Where& w = chunk.where;
  const std::string_view compression = chunk.header->string("compression");
  const auto size = chunk.header->number<std::uint32_t>("size");
  if (size > limits_.max_uncompressed_bytes)
    w.fail(fmt::format(
        "{} bytes uncompressed: more than the bound of {} bytes (max_uncompressed_bytes)", size,
        limits_.max_uncompressed_bytes));
  std::string buffer;
  std::string_view contents;
  const bool compressed = compression != "none";
  if (!compressed) {
    if (chunk.data.size() != size)
      w.fail(fmt::format("size {} uncompressed, but the uncompressed data hold {} bytes", size,
                         chunk.data.size()));
    contents = chunk.data;
  } else if (compression == "lz4") {
    if (size > kMaxLz4Expansion * chunk.data.size())
      w.fail(fmt::format("size {} uncompressed: more than {} bytes of lz4 data can hold", size,
                         chunk.data.size()));
    buffer = decompress_lz4_frame(chunk.data, size, name_, w.offset, w.record);
    contents = buffer;
  } else if (compression == "bz2") {
    buffer = decompress_bz2(chunk.data, size, name_, w.offset, w.record);
    contents = buffer;
  } else {
    w.fail(fmt::format("compression {}: not none, bz2 or lz4", quoted(compression)));
  }
  chunk_offsets_.push_back(w.offset);
  chunks_.push_back({w.offset, {}, {}, {}});
  for (std::size_t pos = 0; pos < contents.size();) {
    throw_if_cancelled();
    // Records of an uncompressed chunk are reported at their own offset in the
    // file; those of a compressed one at the chunk's, with their place in it.
    Record r(Where{name_, compressed ? w.offset : chunk.data_offset + pos, ""});
    read_record(contents, pos, true, compressed, limits_, r);
    if (r.op == kConnection) {
      read_connection(r);
    } else if (r.op == kMessageData) {
      read_message(r, pos);
    } else {
      r.where.fail("not expected inside a chunk");
    }
    pos += r.size;
  }
}

void BagReader::read_connection(const Record& r) {
  const auto id = r.header->number<std::uint32_t>("conn");
  Connection c;
  c.channel.topic = r.header->string("topic");
  const Header fields(r.data, r.where, "connection header");
  c.channel.type = fields.string("type");
  c.channel.encoding = Encoding::kRos1;
  c.channel.definition = fields.string("message_definition");
  c.md5sum = fields.string("md5sum");
  if (c.channel.topic.empty()) r.header->fail("the topic is empty");
  if (c.channel.type.empty()) fields.fail("the type is empty");
  const auto known = connections_.find(id);
  if (known != connections_.end()) {
    const Connection& k = known->second;
    const auto differ = [&](const char* what, const std::string& before, const std::string& now) {
      if (before != now)
        r.where.fail(fmt::format("connection {} redefined: {} {}, before {}", id, what, quoted(now),
                                 quoted(before)));
    };
    differ("topic", k.channel.topic, c.channel.topic);
    differ("type", k.channel.type, c.channel.type);
    differ("md5sum", k.md5sum, c.md5sum);
    differ("message_definition", k.channel.definition, c.channel.definition);
    return;
  }
  if (connections_.size() >= limits_.max_channels)
    r.where.fail(
        fmt::format("more than the bound of {} connections (max_channels)", limits_.max_channels));
  const Channel& channel = connections_.emplace(id, std::move(c)).first->second.channel;
  visitor_.channel(id, channel);
}

void BagReader::read_message(const Record& r, std::size_t pos_in_chunk) {
  const auto id = r.header->number<std::uint32_t>("conn");
  const std::int64_t receive_ns = r.header->time_ns("time");
  chunks_.back().read.push_back({id, static_cast<std::uint32_t>(pos_in_chunk), receive_ns});
  if (connections_.count(id) == 0)
    r.where.fail(fmt::format("connection {}, which no connection record before it defines", id));
  if (r.data.size() > limits_.max_message_bytes)
    r.where.fail(
        fmt::format("a message of {} bytes: more than the bound of {} bytes (max_message_bytes)",
                    r.data.size(), limits_.max_message_bytes));
  if (messages_ >= limits_.max_messages)
    r.where.fail(
        fmt::format("more than the bound of {} messages (max_messages)", limits_.max_messages));
  ++messages_;
  visitor_.message(id, receive_ns, r.data, r.where.offset);
}

// An index data record: the messages of one connection in the chunk before it
// (time and offset in the chunk each), kept for check_chunk_index.
void BagReader::read_index_data(const Record& r) {
  const auto version = r.header->number<std::uint32_t>("ver");
  const auto id = r.header->number<std::uint32_t>("conn");
  const auto count = r.header->number<std::uint32_t>("count");
  if (version != 1) r.header->fail(fmt::format("version {}, not 1", version));
  if (connections_.count(id) == 0)
    r.where.fail(fmt::format("connection {}, which no connection record before it defines", id));
  if (r.data.size() != std::uint64_t{count} * 12)
    r.where.fail(fmt::format("{} entries of 12 bytes, but {} bytes of data", count, r.data.size()));
  if (chunks_.empty()) r.where.fail("index data before any chunk");
  std::vector<IndexEntry>& indexed = chunks_.back().indexed;
  for (std::size_t k = 0; k < count; ++k) {
    std::uint32_t sec, nsec, offset;
    std::memcpy(&sec, r.data.data() + 12 * k, 4);
    std::memcpy(&nsec, r.data.data() + 12 * k + 4, 4);
    std::memcpy(&offset, r.data.data() + 12 * k + 8, 4);
    if (nsec >= 1000000000u)
      r.where.fail(fmt::format("entry {}: nsec {} is not below 1e9", k, nsec));
    indexed.push_back({id, offset, std::int64_t{sec} * 1000000000 + nsec});
  }
}

std::string BagReader::topic_of(std::uint32_t conn) const {
  const auto found = connections_.find(conn);
  return fmt::format(
      "connection {} ({})", conn,
      found == connections_.end() ? "undefined" : printable(found->second.channel.topic, 80));
}

// (conn, messages) of entries sorted by connection.
std::vector<std::pair<std::uint32_t, std::uint32_t>> counts_of(
    const std::vector<IndexEntry>& entries) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  for (const IndexEntry& e : entries) {
    if (out.empty() || out.back().first != e.conn) out.emplace_back(e.conn, 0);
    ++out.back().second;
  }
  return out;
}

// The messages of the last chunk read against its index data: the same
// connections, counts, offsets and times, else an error at the chunk naming
// the connection (a message's header changed, or the index).
void BagReader::check_chunk_index() {
  if (chunks_.empty()) return;
  ChunkTally& c = chunks_.back();
  if (c.read.empty() && c.indexed.empty()) return;  // checked, or a chunk without messages
  std::sort(c.read.begin(), c.read.end());
  std::sort(c.indexed.begin(), c.indexed.end());
  c.counts = counts_of(c.read);
  const auto listed = counts_of(c.indexed);
  const Where w{name_, c.offset, "chunk"};
  for (std::size_t i = 0, j = 0; i < c.counts.size() || j < listed.size();) {
    const bool from_read =
        j == listed.size() || (i < c.counts.size() && c.counts[i].first <= listed[j].first);
    const std::uint32_t conn = from_read ? c.counts[i].first : listed[j].first;
    const std::uint32_t read =
        i < c.counts.size() && c.counts[i].first == conn ? c.counts[i++].second : 0;
    const std::uint32_t indexed =
        j < listed.size() && listed[j].first == conn ? listed[j++].second : 0;
    if (read != indexed)
      w.fail(fmt::format(
          "{}: {} messages in the chunk, but its index data list {} (a corrupt bag: a message's "
          "connection or the index changed)",
          topic_of(conn), read, indexed));
  }
  for (std::size_t k = 0; k < c.read.size(); ++k) {
    const IndexEntry& a = c.read[k];
    const IndexEntry& b = c.indexed[k];
    if (a == b) continue;
    w.fail(fmt::format(
        "{}: the message at byte {} of the chunk, time {} ns, is not the one its index data "
        "list (byte {}, time {} ns): a corrupt bag",
        topic_of(a.conn), a.offset, a.time_ns, b.offset, b.time_ns));
  }
  // Their memory freed (assigning {} would keep it): only the counts are kept.
  std::vector<IndexEntry>().swap(c.read);
  std::vector<IndexEntry>().swap(c.indexed);
}

void BagReader::read_chunk_info(const Record& r) const {
  const auto version = r.header->number<std::uint32_t>("ver");
  const auto chunk_pos = r.header->number<std::uint64_t>("chunk_pos");
  r.header->time_ns("start_time");
  r.header->time_ns("end_time");
  const auto count = r.header->number<std::uint32_t>("count");
  if (version != 1) r.header->fail(fmt::format("version {}, not 1", version));
  const auto at = std::lower_bound(chunk_offsets_.begin(), chunk_offsets_.end(), chunk_pos);
  if (at == chunk_offsets_.end() || *at != chunk_pos)
    r.where.fail(fmt::format("chunk_pos {} is not a chunk's offset", chunk_pos));
  if (r.data.size() != std::uint64_t{count} * 8)
    r.where.fail(fmt::format("{} entries of 8 bytes, but {} bytes of data", count, r.data.size()));
  // Its count a connection against the chunk's messages.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> stated(count);
  for (std::size_t k = 0; k < count; ++k) {
    std::memcpy(&stated[k].first, r.data.data() + 8 * k, 4);
    std::memcpy(&stated[k].second, r.data.data() + 8 * k + 4, 4);
  }
  std::sort(stated.begin(), stated.end());
  const auto& read = chunks_[static_cast<std::size_t>(at - chunk_offsets_.begin())].counts;
  if (stated == read) return;
  std::size_t k = 0;
  while (k < stated.size() && k < read.size() && stated[k] == read[k]) ++k;
  const std::uint32_t conn = k == read.size()     ? stated[k].first
                             : k == stated.size() ? read[k].first
                                                  : std::min(stated[k].first, read[k].first);
  const auto count_of = [&](const auto& list) {
    for (const auto& [c, n] : list)
      if (c == conn) return n;
    return std::uint32_t{0};
  };
  r.where.fail(fmt::format(
      "the chunk at byte {}: {}: {} messages in the chunk, but its chunk info counts {} (a corrupt "
      "bag)",
      chunk_pos, topic_of(conn), count_of(read), count_of(stated)));
}

// The bag header's count of connections against the file's (its chunks are
// counted by check_framing).
void BagReader::check_counts() const {
  const Where w{name_, kMagic.size(), "bag header"};
  if (connections_.size() != conn_count_)
    w.fail(fmt::format("conn_count {}, but the file holds {} connections", conn_count_,
                       connections_.size()));
}

}  // namespace

void read_ros1_bag_bytes(std::string_view bytes, const std::string& name, RecordingVisitor& visitor,
                         const RecordingLimits& limits) {
  BagReader(bytes, name, visitor, limits).read();
}

void read_ros1_bag(const std::string& path, RecordingVisitor& visitor,
                   const RecordingLimits& limits) {
  const MappedFile file(path, limits.max_file_bytes);
  read_ros1_bag_bytes(file.bytes(), path, visitor, limits);
}

}  // namespace hapticcal::recording
