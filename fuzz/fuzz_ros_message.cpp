// libFuzzer target: ROS message definitions and the bytes decoded with them
// (recording/ros_message.hpp). Input: one byte choosing the encoding (bit 0:
// CDR), the definition text, a NUL byte, then the message's bytes. Bad input
// must end in hapticcal::InputError; any other exception, a crash, a sanitizer
// report, a leak or a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/ros_message.hpp"

namespace rec = hapticcal::recording;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const rec::Encoding encoding = (data[0] & 1) != 0 ? rec::Encoding::kCdr : rec::Encoding::kRos1;
  const std::string_view rest(reinterpret_cast<const char*>(data + 1), size - 1);
  const std::size_t nul = rest.find('\0');
  const std::string definition(rest.substr(0, nul));
  const std::string_view message =
      nul == std::string_view::npos ? std::string_view() : rest.substr(nul + 1);
  constexpr std::size_t kMaxElements = 1u << 16;
  try {
    const auto type = rec::MessageType::parse("fuzz/Msg", definition, encoding, "fuzz");
    const rec::DecodedMessage decoded = rec::decode_message(*type, message, "fuzz", kMaxElements);
    // Every entry has a path and is found by it; the entries stay within the bound.
    if (decoded.numbers.size() + decoded.strings.size() > kMaxElements) std::abort();
    for (const auto& [path, value] : decoded.numbers)
      if (path.empty() || decoded.number(path) == nullptr) std::abort();
    for (const auto& [path, value] : decoded.strings)
      if (path.empty() || decoded.string(path) == nullptr) std::abort();
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  return 0;
}
