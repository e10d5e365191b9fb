// The records of a ROS 1 bag (ros1_records.hpp): a header's fields parsed and
// checked, and a record's framing read from a block.
#include "recording/ros1_records.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hapticcal/core/error.hpp"

namespace hapticcal::recording::detail {
namespace {

// Far above any header a recorder writes (about six fields); keeps a hostile
// header's field list (and the duplicate search over it) small.
constexpr std::size_t kMaxHeaderFields = 4096;

const char* op_name(std::uint8_t op) {
  switch (op) {
    case kMessageDefinition:
      return "message definition";
    case kMessageData:
      return "message data";
    case kBagHeader:
      return "bag header";
    case kIndexData:
      return "index data";
    case kChunk:
      return "chunk";
    case kChunkInfo:
      return "chunk info";
    case kConnection:
      return "connection";
    default:
      return nullptr;
  }
}

// The op of a header (or of a cut one) when a sound field before any unsound
// one holds it: only to name the record in errors.
std::optional<std::uint8_t> op_of_partial_header(std::string_view fields) {
  std::size_t pos = 0;
  while (fields.size() - pos >= 4) {
    std::uint32_t length;
    std::memcpy(&length, fields.data() + pos, 4);
    if (length > fields.size() - pos - 4) break;
    const std::string_view field = fields.substr(pos + 4, length);
    if (field.size() == 4 && field.substr(0, 3) == "op=")
      return static_cast<std::uint8_t>(field[3]);
    pos += 4 + std::size_t{length};
  }
  return std::nullopt;
}

}  // namespace

std::string quoted(std::string_view text) { return "'" + printable(std::string(text)) + "'"; }

Header::Header(std::string_view fields, const Where& where, const char* what)
    : where_(where), what_(what) {
  std::size_t pos = 0;
  while (pos < fields.size()) {
    const std::size_t left = fields.size() - pos;
    if (left < 4)
      fail(fmt::format("{} byte(s) after the last field, too few for a field's length", left));
    std::uint32_t length;
    std::memcpy(&length, fields.data() + pos, 4);
    if (length > left - 4)
      fail(fmt::format("a field of {} bytes at byte {} of the header, {} left", length, pos,
                       left - 4));
    const std::string_view field = fields.substr(pos + 4, length);
    const std::size_t equals = field.find('=');
    if (equals == std::string_view::npos) fail(fmt::format("field {} has no '='", quoted(field)));
    if (equals == 0) fail(fmt::format("field {} has no name", quoted(field)));
    if (fields_.size() == kMaxHeaderFields)
      fail(fmt::format("more than {} fields", kMaxHeaderFields));
    fields_.emplace_back(field.substr(0, equals), field.substr(equals + 1));
    pos += 4 + std::size_t{length};
  }
  std::sort(fields_.begin(), fields_.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  const auto twice =
      std::adjacent_find(fields_.begin(), fields_.end(),
                         [](const auto& a, const auto& b) { return a.first == b.first; });
  if (twice != fields_.end()) fail(fmt::format("field {} appears twice", quoted(twice->first)));
}

void read_record(std::string_view block, std::size_t pos, bool in_chunk, bool compressed,
                 const RecordingLimits& limits, Record& r) {
  const Where& w = r.where;
  const char* block_name = in_chunk ? "chunk" : "file";
  const auto name_record = [&](const char* name) {
    r.where.record =
        compressed ? fmt::format("chunk: {} at byte {} uncompressed", name, pos) : name;
  };
  name_record("record");
  const std::size_t left = block.size() - pos;
  if (left < 4)
    w.fail(fmt::format("the {} ends inside the record's header length ({} of 4 bytes)", block_name,
                       left));
  std::uint32_t header_bytes;
  std::memcpy(&header_bytes, block.data() + pos, 4);
  if (header_bytes > limits.max_record_bytes)
    w.fail(fmt::format("a header of {} bytes: more than the bound of {} bytes (max_record_bytes)",
                       header_bytes, limits.max_record_bytes));
  if (header_bytes > left - 4) {
    if (const auto op = op_of_partial_header(block.substr(pos + 4)); op && op_name(*op))
      name_record(op_name(*op));
    w.fail(fmt::format("the {} ends inside the record's header of {} bytes ({} left)", block_name,
                       header_bytes, left - 4));
  }
  const std::string_view header = block.substr(pos + 4, header_bytes);
  // Named by its op (when that field is sound) also in errors of its other fields.
  if (const auto op = op_of_partial_header(header); op && op_name(*op)) name_record(op_name(*op));
  r.header.emplace(header, w, "header");
  r.op = r.header->number<std::uint8_t>("op");
  const char* name = op_name(r.op);
  if (name == nullptr) w.fail(fmt::format("unknown op 0x{:02x}", r.op));
  name_record(name);
  const std::size_t after_header = left - 4 - header_bytes;
  if (after_header < 4)
    w.fail(fmt::format("the {} ends inside the record's data length ({} of 4 bytes)", block_name,
                       after_header));
  std::uint32_t data_bytes;
  std::memcpy(&data_bytes, block.data() + pos + 4 + header_bytes, 4);
  if (std::uint64_t{header_bytes} + data_bytes > limits.max_record_bytes)
    w.fail(fmt::format(
        "{} bytes of header and data: more than the bound of {} bytes (max_record_bytes)",
        std::uint64_t{header_bytes} + data_bytes, limits.max_record_bytes));
  if (data_bytes > after_header - 4)
    w.fail(fmt::format("the {} ends inside the record's data of {} bytes ({} left)", block_name,
                       data_bytes, after_header - 4));
  r.data_offset = pos + 8 + header_bytes;
  r.data = block.substr(r.data_offset, data_bytes);
  r.size = 8 + std::size_t{header_bytes} + data_bytes;
}

}  // namespace hapticcal::recording::detail
