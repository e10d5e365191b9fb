// libFuzzer target: MCAP files (hapticcal::recording::read_mcap_bytes). Bad
// input must end in hapticcal::InputError naming the file and a byte offset;
// any other exception, a crash, a sanitizer report, a leak or a hang is a
// finding, and so is a reader breaking its contract with the visitor (a
// message before its channel, a channel handed out twice, a message over the
// bound, an offset outside the file). An input that does not start with MCAP's
// magic is taken as the records of an uncompressed chunk and wrapped in a file
// (the chunk's CRC-32 zero: not checked), so that mutated records are parsed
// rather than stopped by the CRC (seed: fuzz/seeds/mcap/chunk-records.bin).
// The chunk bound is lowered so that a claimed size costs the fuzzer little
// time (the bounds themselves are tested in tests/mcap_test.cpp).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"

namespace {

using hapticcal::recording::Channel;
using hapticcal::recording::RecordingLimits;

struct Checked : hapticcal::recording::RecordingVisitor {
  std::size_t file_bytes = 0;
  std::uint64_t max_message_bytes = 0;
  std::set<std::uint32_t> channels;
  std::uint64_t sum = 0;

  void channel(std::uint32_t id, const Channel& channel) override {
    if (!channels.insert(id).second) std::abort();  // handed out twice
    sum += channel.topic.size() + channel.type.size() + channel.definition.size();
  }
  void message(std::uint32_t id, std::int64_t receive_ns, std::string_view data,
               std::uint64_t offset) override {
    if (channels.count(id) == 0 || receive_ns < 0 || data.size() > max_message_bytes ||
        offset >= file_bytes)
      std::abort();
    for (const char c : data) sum += static_cast<unsigned char>(c);  // every byte readable
  }
};

// `value` little-endian in `bytes` bytes (zeros past its eighth).
void put(std::string& out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>(i < 8 ? (value >> (8 * i)) & 0xFF : 0);
}

// A file of one uncompressed chunk holding `records`: magic, Header, Chunk
// (https://mcap.dev/spec), Data End and Footer without CRCs, magic.
std::string wrapped(std::string_view records) {
  const std::string magic("\x89MCAP0\r\n", 8);
  std::string out = magic;
  out += '\x01';
  put(out, 8, 8);
  put(out, 0, 8);  // profile and library: empty
  out += '\x06';
  put(out, 8 + 8 + 8 + 4 + 4 + 8 + records.size(), 8);
  put(out, 0, 8);  // message_start_time
  put(out, 0, 8);  // message_end_time
  put(out, records.size(), 8);
  put(out, 0, 4);  // uncompressed_crc: not checked
  put(out, 0, 4);  // compression: none
  put(out, records.size(), 8);
  out += records;
  out += '\x0f';
  put(out, 4, 8);
  put(out, 0, 4);
  out += '\x02';
  put(out, 20, 8);
  put(out, 0, 20);
  return out + magic;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::string file = input.starts_with("\x89MCAP") ? std::string(input) : wrapped(input);
  const std::string_view bytes(file);
  RecordingLimits limits;
  limits.max_uncompressed_bytes = 16u << 20;
  Checked visitor;
  visitor.file_bytes = bytes.size();
  visitor.max_message_bytes = limits.max_message_bytes;
  try {
    hapticcal::recording::read_mcap_bytes(bytes, "fuzz.mcap", visitor, limits);
  } catch (const hapticcal::InputError& e) {
    const std::string what = e.what();
    if (what.rfind("fuzz.mcap: byte ", 0) != 0 || what.find('\n') != std::string::npos)
      std::abort();
  }
  return 0;
}
