// Bounded reading of binary records: every read checks what is left and throws
// an InputError naming the file, the byte offset and the record being read.
// Shared by the recording readers (ROS 1 bag, MCAP) and the message decoder.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "hapticcal/recording/recording.hpp"

namespace hapticcal::recording {

// "NAME: byte OFFSET: RECORD: what" as an InputError (one line; the parts the
// caller knows).
[[noreturn]] void fail_at(const std::string& name, std::uint64_t offset, const std::string& record,
                          const std::string& what);

// A little-endian cursor over `bytes`, whose first byte is at `base` in the file
// (a chunk's contents decompressed: the chunk's offset, every read then reported
// at the chunk). `record` names what is being read in errors.
class ByteReader {
 public:
  ByteReader(std::string_view bytes, const std::string& name, std::uint64_t base,
             bool offsets_inside = true)
      : bytes_(bytes), name_(name), base_(base), offsets_inside_(offsets_inside) {}

  std::size_t position() const { return pos_; }
  std::size_t left() const { return bytes_.size() - pos_; }
  bool done() const { return pos_ == bytes_.size(); }
  // The file offset of the cursor (of the block's start when the block is a
  // decompressed chunk).
  std::uint64_t offset() const { return offsets_inside_ ? base_ + pos_ : base_; }
  const std::string& name() const { return name_; }
  void set_record(std::string record) { record_ = std::move(record); }
  const std::string& record() const { return record_; }

  [[noreturn]] void fail(const std::string& what) const { fail_at(name_, offset(), record_, what); }

  template <typename T>
  T read() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T), "a field");
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;  // the readers run on little-endian machines (checked at compile time)
  }
  std::uint8_t u8() { return read<std::uint8_t>(); }
  std::uint16_t u16() { return read<std::uint16_t>(); }
  std::uint32_t u32() { return read<std::uint32_t>(); }
  std::uint64_t u64() { return read<std::uint64_t>(); }
  // n bytes as a view into the block.
  std::string_view bytes(std::uint64_t n, const char* what) {
    need(n, what);
    const std::string_view out = bytes_.substr(pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::size_t>(n);
    return out;
  }
  void skip(std::uint64_t n, const char* what) { bytes(n, what); }
  // Throws naming `what` unless n bytes are left.
  void need(std::uint64_t n, const char* what) const;

 private:
  std::string_view bytes_;
  const std::string& name_;
  std::uint64_t base_ = 0;
  bool offsets_inside_ = true;
  std::size_t pos_ = 0;
  std::string record_;
};

// A file's bytes, mapped read-only (an InputError naming the file when it is
// not a regular file, cannot be opened or exceeds `max_bytes`).
class MappedFile {
 public:
  MappedFile(const std::string& path, std::uint64_t max_bytes);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::string_view bytes() const { return {data_, size_}; }

 private:
  const char* data_ = nullptr;
  std::size_t size_ = 0;
};

// ROS 2's "package/msg/Type" as "package/Type"; any other name as it is (the
// MCAP and .db3 readers' channel types).
std::string normalised_type(std::string_view name);

// Decompressors for chunks. `expected` is the uncompressed size the record
// states (checked against limits.max_uncompressed_bytes by the caller first);
// the result must have exactly that size. Errors name `name`, `offset` and
// `record`.
std::string decompress_lz4_frame(std::string_view in, std::uint64_t expected,
                                 const std::string& name, std::uint64_t offset,
                                 const std::string& record);
std::string decompress_zstd(std::string_view in, std::uint64_t expected, const std::string& name,
                            std::uint64_t offset, const std::string& record);
std::string decompress_bz2(std::string_view in, std::uint64_t expected, const std::string& name,
                           std::uint64_t offset, const std::string& record);

}  // namespace hapticcal::recording
