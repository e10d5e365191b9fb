// The records of a ROS 1 bag (format 2.0): a record's header fields and its
// framing in a block (the file, or a chunk's contents), each bound checked and
// each error naming where it is. ros1_bag.cpp walks the records these read.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hapticcal/recording/recording.hpp"
#include "recording/byte_reader.hpp"

namespace hapticcal::recording::detail {

enum Op : std::uint8_t {
  kMessageDefinition = 0x01,  // format 1.2 only
  kMessageData = 0x02,
  kBagHeader = 0x03,
  kIndexData = 0x04,
  kChunk = 0x05,
  kChunkInfo = 0x06,
  kConnection = 0x07,
};

// Where an error points: the file, the byte offset of the record (or of the
// compressed chunk holding it) and what the record is.
struct Where {
  const std::string& name;
  std::uint64_t offset = 0;
  std::string record;
  [[noreturn]] void fail(const std::string& what) const { fail_at(name, offset, record, what); }
};

std::string quoted(std::string_view text);

// A header's fields, sorted by name (names are unique).
class Header {
 public:
  // `fields` is a header's bytes after its length; `what` names it in errors
  // ("header", "connection header").
  Header(std::string_view fields, const Where& where, const char* what);

  std::optional<std::string_view> find(std::string_view name) const {
    const auto it =
        std::lower_bound(fields_.begin(), fields_.end(), name,
                         [](const auto& field, std::string_view n) { return field.first < n; });
    if (it == fields_.end() || it->first != name) return std::nullopt;
    return it->second;
  }
  std::string_view string(std::string_view name) const {
    const std::optional<std::string_view> value = find(name);
    if (!value) fail(fmt::format("no '{}' field", name));
    return *value;
  }
  template <typename T>
  T number(std::string_view name) const {
    const std::string_view value = string(name);
    if (value.size() != sizeof(T))
      fail(fmt::format("field '{}' of {} bytes, not {}", name, value.size(), sizeof(T)));
    T out;
    std::memcpy(&out, value.data(), sizeof(T));
    return out;
  }
  // A time field (uint32 sec, uint32 nsec) in nanoseconds since the epoch.
  std::int64_t time_ns(std::string_view name) const {
    const auto both = number<std::uint64_t>(name);
    const std::uint64_t sec = both & 0xffffffffu, nsec = both >> 32;
    if (nsec >= 1000000000u) fail(fmt::format("field '{}': nsec {} is not below 1e9", name, nsec));
    return static_cast<std::int64_t>(sec * 1000000000u + nsec);
  }
  [[noreturn]] void fail(const std::string& what) const {
    where_.fail(std::string(what_) + ": " + what);
  }

 private:
  std::vector<std::pair<std::string_view, std::string_view>> fields_;
  const Where& where_;
  const char* what_;
};

// One record of a block (the file, or a chunk's contents). Not copied: its
// header refers to `where`.
struct Record {
  explicit Record(Where w) : where(std::move(w)) {}
  Record(const Record&) = delete;
  Record& operator=(const Record&) = delete;

  Where where;  // the record's offset (or its chunk's) and its name
  std::uint8_t op = 0;
  std::optional<Header> header;
  std::string_view data;
  std::uint64_t data_offset = 0;  // the data's offset within the block
  std::size_t size = 0;           // header and data with their lengths
};

// The record at `pos` of `block`: the file, or a chunk's contents (decompressed
// when `compressed`). `r.where` holds the offset its errors name.
void read_record(std::string_view block, std::size_t pos, bool in_chunk, bool compressed,
                 const RecordingLimits& limits, Record& r);

}  // namespace hapticcal::recording::detail
