// MCAP files, read from the start through the data section: the format of
// https://mcap.dev/spec (records, chunks) and the encodings of
// https://mcap.dev/spec/registry. The summary section is not needed (nor
// trusted): every Schema, Channel and Message record of the data section is
// read in file order, chunks decompressed and their CRC-32 checked; then the
// summary's Statistics record, when there is one, must count as many messages
// on each channel as were read (a message whose channel id changed is an
// error, not a sample lost). Errors name the record's byte offset (for a
// record inside a chunk: the chunk's).
#include <fmt/format.h>
#include <zstd.h>

#include <array>
#include <cstring>
#include <limits>
#include <set>
#include <unordered_map>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"
#include "recording/byte_reader.hpp"

namespace hapticcal::recording {
namespace {

constexpr std::string_view kMagic("\x89MCAP0\r\n", 8);
constexpr std::size_t kRecordHeaderBytes = 9;  // opcode uint8, content length uint64

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kStatistics = 0x0B,
  kDataEnd = 0x0F,
};
constexpr std::size_t kFooterBytes = kRecordHeaderBytes + 20;

std::string record_name(std::uint8_t op) {
  static constexpr std::array<const char*, 16> kNames = {
      "",           "header",           "footer",
      "schema",     "channel",          "message",
      "chunk",      "message index",    "chunk index",
      "attachment", "attachment index", "statistics",
      "metadata",   "metadata index",   "summary offset",
      "data end"};
  if (op >= 1 && op < kNames.size()) return kNames[op];
  return fmt::format("record of opcode 0x{:02x}", op);
}

// CRC-32 of IEEE 802.3 (reflected polynomial 0xEDB88320, as zlib's crc32),
// eight bytes a step ("slicing by 8"): chunks and the data section are checked
// whole, so the speed matters.
using CrcTables = std::array<std::array<std::uint32_t, 256>, 8>;
constexpr CrcTables make_crc_tables() {
  CrcTables t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[0][i] = c;
  }
  for (std::size_t s = 1; s < 8; ++s)
    for (std::size_t i = 0; i < 256; ++i) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
  return t;
}
constexpr CrcTables kCrc = make_crc_tables();

std::uint32_t crc32(std::string_view data) {
  std::uint32_t crc = 0xFFFFFFFFu;
  const auto* p = reinterpret_cast<const unsigned char*>(data.data());
  std::size_t n = data.size();
  for (; n >= 8; p += 8, n -= 8) {
    if ((n & ((1u << 24) - 8)) == 0) throw_if_cancelled();  // every 16 MiB: a whole file's CRC
    std::uint32_t lo, hi;
    std::memcpy(&lo, p, 4);
    std::memcpy(&hi, p + 4, 4);
    lo ^= crc;
    crc = kCrc[7][lo & 0xFF] ^ kCrc[6][(lo >> 8) & 0xFF] ^ kCrc[5][(lo >> 16) & 0xFF] ^
          kCrc[4][lo >> 24] ^ kCrc[3][hi & 0xFF] ^ kCrc[2][(hi >> 8) & 0xFF] ^
          kCrc[1][(hi >> 16) & 0xFF] ^ kCrc[0][hi >> 24];
  }
  for (; n > 0; ++p, --n) crc = kCrc[0][(crc ^ *p) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

std::string read_string(ByteReader& r, const char* field) {
  const std::uint32_t n = r.u32();
  return std::string(r.bytes(n, field));
}

struct SchemaRecord {
  std::string name, encoding, data;
  bool operator==(const SchemaRecord&) const = default;
};

struct ChannelRecord {
  std::uint16_t schema_id = 0;
  std::string topic, message_encoding;
  bool operator==(const ChannelRecord&) const = default;
};

// One record's place: its opcode, content and the offset of its opcode byte.
struct Record {
  std::uint8_t op = 0;
  std::string_view content;
  std::uint64_t offset = 0;
};

class McapReader {
 public:
  McapReader(std::string_view bytes, const std::string& name, RecordingVisitor& visitor,
             const RecordingLimits& limits)
      : bytes_(bytes), name_(name), visitor_(visitor), limits_(limits) {}

  void read();

 private:
  // The record at `pos` of `block` (whose first byte is at `base` in the file;
  // `in_chunk`: errors name the chunk at `base`).
  Record next_record(std::string_view block, std::size_t pos, std::uint64_t base,
                     bool in_chunk) const;
  void dispatch(const Record& record, ByteReader& r, std::uint64_t message_offset);
  void schema(ByteReader& r);
  void channel(ByteReader& r);
  void message(ByteReader& r, std::uint64_t offset);
  void chunk(ByteReader& r, std::uint64_t offset);
  std::string chunk_records(ByteReader& r, std::uint64_t uncompressed_bytes,
                            const std::string& compression, std::string_view stored);
  void end_of_data(const Record& record, std::size_t end);
  void check_statistics(std::size_t data_end);
  void statistics(ByteReader& r) const;

  std::string_view bytes_;
  const std::string& name_;
  RecordingVisitor& visitor_;
  const RecordingLimits& limits_;
  std::unordered_map<std::uint16_t, SchemaRecord> schemas_;
  std::unordered_map<std::uint16_t, ChannelRecord> channels_;
  std::unordered_map<std::uint16_t, std::uint64_t> counts_;  // messages read a channel
  std::uint64_t messages_ = 0;
  std::uint64_t definition_bytes_ = 0;  // the schemas handed out with the channels
};

Record McapReader::next_record(std::string_view block, std::size_t pos, std::uint64_t base,
                               bool in_chunk) const {
  Record record;
  record.op = static_cast<std::uint8_t>(block[pos]);
  record.offset = in_chunk ? base : base + pos;
  // The record's name in errors, made only for one.
  const auto fail = [&](const std::string& what) {
    fail_at(name_, record.offset,
            in_chunk
                ? fmt::format("chunk: {} at byte {} of its records", record_name(record.op), pos)
                : record_name(record.op),
            what);
  };
  const std::size_t left = block.size() - pos;
  if (left < kRecordHeaderBytes)
    fail(fmt::format("record header of {} bytes, {} left (a truncated file)", kRecordHeaderBytes,
                     left));
  if (record.op == 0) fail("opcode 0x00 is not valid (a corrupt file)");
  std::uint64_t length;
  std::memcpy(&length, block.data() + pos + 1, sizeof length);
  if (length > left - kRecordHeaderBytes)
    fail(fmt::format("{} bytes of content, {} left (a truncated file)", length,
                     left - kRecordHeaderBytes));
  if (length > limits_.max_record_bytes)
    fail(fmt::format("{} bytes: more than the bound of {} bytes for a record", length,
                     limits_.max_record_bytes));
  record.content = block.substr(pos + kRecordHeaderBytes, static_cast<std::size_t>(length));
  return record;
}

void McapReader::read() {
  if (bytes_.size() < kMagic.size() && kMagic.starts_with(bytes_))
    fail_at(name_, 0, "magic",
            fmt::format("the file ends inside MCAP's magic ({} of 8 bytes)", bytes_.size()));
  if (!bytes_.starts_with(kMagic)) {
    if (bytes_.starts_with("\x89MCAP") && bytes_.size() >= 6)
      fail_at(name_, 0, "magic",
              fmt::format("MCAP major version '{}': hapticcal reads version '0'",
                          printable(std::string(1, bytes_[5]))));
    fail_at(name_, 0, "magic", "not an MCAP file (it does not start with MCAP's magic)");
  }
  std::size_t pos = kMagic.size();
  for (bool first = true;; first = false) {
    throw_if_cancelled();  // a host's Ctrl-C (core/cancel.hpp): a relaxed load a record
    if (pos == bytes_.size())
      fail_at(name_, pos, "",
              "the file ends without a Data End or Footer record (a truncated file)");
    const Record record = next_record(bytes_, pos, 0, false);
    pos += kRecordHeaderBytes + record.content.size();
    if (first && record.op != kHeader)
      fail_at(name_, record.offset, record_name(record.op),
              "the first record is not a Header (a corrupt file)");
    if (record.op == kDataEnd || record.op == kFooter) return end_of_data(record, pos);
    ByteReader r(record.content, name_, record.offset, false);
    r.set_record(record_name(record.op));
    dispatch(record, r, record.offset);
  }
}

void McapReader::dispatch(const Record& record, ByteReader& r, std::uint64_t message_offset) {
  switch (record.op) {
    case kSchema:
      return schema(r);
    case kChannel:
      return channel(r);
    case kMessage:
      return message(r, message_offset);
    case kChunk:
      return chunk(r, record.offset);
    default:
      return;  // attachments, metadata, indexes and opcodes of later versions: not needed
  }
}

// The Data End record (its CRC-32 of everything before it checked) or a Footer
// without one; then the file must end with the magic, else it was cut short.
void McapReader::end_of_data(const Record& record, std::size_t end) {
  if (record.op == kDataEnd) {
    ByteReader r(record.content, name_, record.offset, false);
    r.set_record("data end");
    const std::uint32_t stated = r.u32();
    const std::uint32_t actual = stated == 0 ? 0 : crc32(bytes_.substr(0, record.offset));
    if (actual != stated)
      r.fail(fmt::format(
          "the data section's CRC-32 is {:08x}, the record states {:08x} (a corrupt file)", actual,
          stated));
  } else if (bytes_.substr(end, kMagic.size()) != kMagic) {
    fail_at(name_, end, "magic",
            "the footer is not followed by MCAP's magic (a truncated or corrupt file)");
  }
  if (bytes_.size() < end + kMagic.size() || !bytes_.ends_with(kMagic))
    fail_at(name_, bytes_.size(), "magic",
            "the file does not end with MCAP's magic (a truncated file)");
  check_statistics(record.op == kDataEnd ? end : record.offset);
}

// The Footer before the closing magic locates the summary section; its
// Statistics record, if any, must count what the data section held.
void McapReader::check_statistics(std::size_t data_end) {
  if (bytes_.size() < data_end + kFooterBytes + kMagic.size())
    fail_at(name_, data_end, "footer", "no room for the Footer record (a truncated file)");
  const std::size_t footer = bytes_.size() - kMagic.size() - kFooterBytes;
  const Record f = next_record(bytes_, footer, 0, false);
  if (f.op != kFooter || f.content.size() != 20)
    fail_at(name_, footer, record_name(f.op),
            "not the Footer record the file must end with (a corrupt file)");
  ByteReader r(f.content, name_, footer, false);
  r.set_record("footer");
  const std::uint64_t summary_start = r.u64();
  const std::uint64_t summary_offset_start = r.u64();
  if (summary_start == 0) return;  // no summary section
  const std::uint64_t summary_end = summary_offset_start != 0 ? summary_offset_start : footer;
  if (summary_start < data_end || summary_start > summary_end || summary_end > footer)
    r.fail(fmt::format(
        "summary_start {} and summary_offset_start {}: not within the summary section's bytes {} "
        "to {} (a corrupt file)",
        summary_start, summary_offset_start, data_end, footer));
  const std::string_view summary = bytes_.substr(0, summary_end);
  for (std::size_t pos = summary_start; pos < summary.size();) {
    const Record record = next_record(summary, pos, 0, false);
    if (record.op == kStatistics) {
      ByteReader s(record.content, name_, record.offset, false);
      s.set_record("statistics");
      statistics(s);
    }
    pos += kRecordHeaderBytes + record.content.size();
  }
}

// A Statistics record's message counts against the messages read.
void McapReader::statistics(ByteReader& r) const {
  const std::uint64_t message_count = r.u64();
  r.skip(2 + 4 + 4 + 4 + 4 + 8 + 8, "counts and times");  // schemas .. message_end_time
  const std::uint32_t map_bytes = r.u32();
  if (map_bytes % 10 != 0)
    r.fail(fmt::format("channel_message_counts of {} bytes: not entries of 10", map_bytes));
  ByteReader map(r.bytes(map_bytes, "channel_message_counts"), r.name(), r.offset(), false);
  map.set_record(r.record());
  std::unordered_map<std::uint16_t, std::uint64_t> stated;
  while (!map.done()) {
    const std::uint16_t id = map.u16();
    stated[id] = map.u64();
  }
  const auto fail = [&](std::uint16_t id, std::uint64_t read, std::uint64_t counted) {
    const auto c = channels_.find(id);
    r.fail(fmt::format(
        "channel {} ({}): {} messages in the data section, but the statistics count {} (a "
        "corrupt file: a message's channel or the summary changed)",
        id, c == channels_.end() ? "undefined" : printable(c->second.topic, 80), read, counted));
  };
  std::set<std::uint16_t> ids;  // in order: the first channel that differs is named
  for (const auto& [id, n] : counts_) ids.insert(id);
  for (const auto& [id, n] : stated) ids.insert(id);
  for (const std::uint16_t id : ids) {
    const auto read = counts_.find(id);
    const auto counted = stated.find(id);
    const std::uint64_t a = read == counts_.end() ? 0 : read->second;
    const std::uint64_t b = counted == stated.end() ? 0 : counted->second;
    if (a != b) fail(id, a, b);
  }
  if (message_count != messages_)
    r.fail(fmt::format("message_count {}, but the data section holds {} messages (a corrupt file)",
                       message_count, messages_));
}

void McapReader::schema(ByteReader& r) {
  const std::uint16_t id = r.u16();
  SchemaRecord s;
  s.name = read_string(r, "name");
  s.encoding = read_string(r, "encoding");
  s.data = read_string(r, "data");
  if (id == 0) return;  // invalid by the specification: ignored, as it says
  const auto [it, inserted] = schemas_.try_emplace(id, s);
  if (!inserted && !(it->second == s))
    r.fail(fmt::format("schema {} is defined twice, differently ('{}' and '{}')", id,
                       printable(it->second.name), printable(s.name)));
}

// The Channel as hapticcal hands it out: the encodings it decodes are "ros1"
// messages with a ros1msg schema and "cdr" ones with a ros2msg schema (or
// without a schema: the import layer may know the type); anything else is
// described in message_encoding for the import layer's refusal.
Channel make_channel(const ChannelRecord& c, const SchemaRecord* schema) {
  Channel out;
  out.topic = c.topic;
  out.message_encoding = c.message_encoding;
  if (schema != nullptr) {
    out.type = normalised_type(schema->name);
    out.definition = schema->data;
  }
  const std::string schema_encoding = schema != nullptr ? schema->encoding : "";
  if (c.message_encoding == "ros1" && (schema == nullptr || schema_encoding == "ros1msg")) {
    out.encoding = Encoding::kRos1;
  } else if (c.message_encoding == "cdr" && (schema == nullptr || schema_encoding == "ros2msg")) {
    out.encoding = Encoding::kCdr;
  } else if (schema != nullptr) {
    out.message_encoding = fmt::format("{} with a {} schema", c.message_encoding,
                                       schema_encoding.empty() ? "''" : schema_encoding);
  }
  return out;
}

void McapReader::channel(ByteReader& r) {
  const std::uint16_t id = r.u16();
  ChannelRecord c;
  c.schema_id = r.u16();
  c.topic = read_string(r, "topic");
  c.message_encoding = read_string(r, "message_encoding");
  r.skip(r.u32(), "metadata");
  const SchemaRecord* schema = nullptr;
  if (c.schema_id != 0) {
    const auto found = schemas_.find(c.schema_id);
    if (found == schemas_.end())
      r.fail(fmt::format("channel {} ({}) names schema {}, not defined before it (a corrupt file)",
                         id, printable(c.topic), c.schema_id));
    schema = &found->second;
  }
  const auto known = channels_.find(id);
  if (known != channels_.end()) {
    if (known->second == c) return;  // a repeated channel, as allowed
    r.fail(fmt::format("channel {} is defined twice, differently ('{}' and '{}')", id,
                       printable(known->second.topic), printable(c.topic)));
  }
  if (channels_.size() >= limits_.max_channels)
    r.fail(fmt::format("more than the bound of {} channels", limits_.max_channels));
  definition_bytes_ += schema == nullptr ? 0 : schema->data.size();
  if (definition_bytes_ > bytes_.size() + limits_.max_definition_bytes)
    r.fail(fmt::format(
        "the channels' schemas add up to {} bytes, more than the file's {} bytes and {} more "
        "(max_definition_bytes): many channels naming a large schema",
        definition_bytes_, bytes_.size(), limits_.max_definition_bytes));
  channels_.emplace(id, c);
  visitor_.channel(id, make_channel(c, schema));
}

void McapReader::message(ByteReader& r, std::uint64_t offset) {
  const std::uint16_t channel_id = r.u16();
  r.u32();  // sequence
  const std::uint64_t log_time_ns = r.u64();
  r.u64();  // publish_time
  if (channels_.find(channel_id) == channels_.end())
    r.fail(
        fmt::format("channel {} is not defined before its message (a corrupt file)", channel_id));
  if (r.left() > limits_.max_message_bytes)
    r.fail(fmt::format("{} bytes of data: more than the bound of {} bytes for a message", r.left(),
                       limits_.max_message_bytes));
  if (log_time_ns > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
    r.fail(fmt::format("log_time {} ns is beyond the year 2262", log_time_ns));
  if (++messages_ > limits_.max_messages)
    r.fail(fmt::format("more than the bound of {} messages", limits_.max_messages));
  ++counts_[channel_id];
  const std::string_view data = r.bytes(r.left(), "data");
  visitor_.message(channel_id, static_cast<std::int64_t>(log_time_ns), data, offset);
}

void McapReader::chunk(ByteReader& r, std::uint64_t offset) {
  r.u64();  // message_start_time
  r.u64();  // message_end_time
  const std::uint64_t uncompressed_bytes = r.u64();
  const std::uint32_t stated_crc = r.u32();
  const std::string compression = read_string(r, "compression");
  const std::string_view stored = r.bytes(r.u64(), "records");
  const std::string owned = chunk_records(r, uncompressed_bytes, compression, stored);
  const std::string_view records = compression.empty() ? stored : std::string_view(owned);
  if (stated_crc != 0) {
    const std::uint32_t actual = crc32(records);
    if (actual != stated_crc)
      r.fail(fmt::format("the records' CRC-32 is {:08x}, the chunk states {:08x} (a corrupt file)",
                         actual, stated_crc));
  }
  for (std::size_t pos = 0; pos < records.size();) {
    throw_if_cancelled();
    const Record record = next_record(records, pos, offset, true);
    ByteReader inner(record.content, name_, offset, false);
    inner.set_record(
        fmt::format("chunk: {} at byte {} of its records", record_name(record.op), pos));
    if (record.op == kSchema || record.op == kChannel || record.op == kMessage) {
      dispatch(record, inner, offset);
    } else if (record.op < 0x80) {
      inner.fail("not allowed inside a chunk (a corrupt file)");
    }  // opcodes 0x80-0xFF are applications' own: skipped
    pos += kRecordHeaderBytes + record.content.size();
  }
}

// A chunk's records decompressed (empty when stored uncompressed: `stored` is
// they). The stated size is checked against the bound and against what the
// stored bytes can expand to before anything is allocated.
std::string McapReader::chunk_records(ByteReader& r, std::uint64_t uncompressed_bytes,
                                      const std::string& compression, std::string_view stored) {
  if (uncompressed_bytes > limits_.max_uncompressed_bytes)
    r.fail(fmt::format("{} bytes uncompressed: more than the bound of {} bytes for a chunk",
                       uncompressed_bytes, limits_.max_uncompressed_bytes));
  if (compression.empty()) {
    if (stored.size() != uncompressed_bytes)
      r.fail(fmt::format("{} bytes of uncompressed records, the chunk states {}", stored.size(),
                         uncompressed_bytes));
    return {};
  }
  if (compression != "lz4" && compression != "zstd")
    r.fail(
        fmt::format("compression '{}': hapticcal reads zstd, lz4 or none", printable(compression)));
  // lz4 expands a byte into at most 255, zstd a 4-byte block into 128 KiB.
  const std::uint64_t most_per_byte = compression == "lz4" ? 256 : 32768;
  if (uncompressed_bytes / most_per_byte > stored.size() + 64)
    r.fail(fmt::format(
        "{} compressed bytes cannot hold the {} bytes the chunk states (a corrupt file)",
        stored.size(), uncompressed_bytes));
  if (compression == "lz4")
    return decompress_lz4_frame(stored, uncompressed_bytes, name_, r.offset(), r.record());
  // The first frame's stated size (when it states one) cannot exceed the chunk's.
  const unsigned long long first_frame = ZSTD_getFrameContentSize(stored.data(), stored.size());
  if (first_frame == ZSTD_CONTENTSIZE_ERROR)
    r.fail("zstd: the records do not start with a zstd frame");
  if (first_frame != ZSTD_CONTENTSIZE_UNKNOWN && first_frame > uncompressed_bytes)
    r.fail(fmt::format("zstd: a frame of {} bytes, the chunk states {} (a corrupt file)",
                       first_frame, uncompressed_bytes));
  return decompress_zstd(stored, uncompressed_bytes, name_, r.offset(), r.record());
}

}  // namespace

void read_mcap_bytes(std::string_view bytes, const std::string& name, RecordingVisitor& visitor,
                     const RecordingLimits& limits) {
  if (bytes.size() > limits.max_file_bytes)
    fail_at(name, 0, "",
            fmt::format("{} bytes: more than the bound of {} bytes", bytes.size(),
                        limits.max_file_bytes));
  McapReader(bytes, name, visitor, limits).read();
}

void read_mcap(const std::string& path, RecordingVisitor& visitor, const RecordingLimits& limits) {
  const MappedFile file(path, limits.max_file_bytes);
  read_mcap_bytes(file.bytes(), path, visitor, limits);
}

}  // namespace hapticcal::recording
