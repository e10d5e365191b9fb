// libFuzzer target: ROS 1 bags (hapticcal::recording::read_ros1_bag_bytes), with
// bounds small enough for the fuzzer's memory (a chunk of at most 8 MiB
// uncompressed). Bad input must end in hapticcal::InputError; any other
// exception, a crash, a sanitizer report, a leak or a hang is a finding. So is a
// reader that breaks its promises to the visitor: a channel handed out twice, a
// message before its channel, a message beyond max_message_bytes or an offset
// beyond the input, more channels or messages than the bounds.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"

namespace {

namespace hr = hapticcal::recording;

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_ros1_bag: %s\n", what);
  std::abort();
}

class Checker : public hr::RecordingVisitor {
 public:
  Checker(const hr::RecordingLimits& limits, std::size_t input_bytes)
      : limits_(limits), input_bytes_(input_bytes) {}

  void channel(std::uint32_t id, const hr::Channel& channel) override {
    if (!ids_.insert(id).second) finding("a channel handed out twice");
    if (ids_.size() > limits_.max_channels) finding("more channels than max_channels");
    if (channel.topic.empty() || channel.type.empty()) finding("a channel without topic or type");
    if (channel.encoding != hr::Encoding::kRos1)
      finding("a ROS 1 bag's channel not in ROS 1 encoding");
  }
  void message(std::uint32_t id, std::int64_t receive_ns, std::string_view data,
               std::uint64_t offset) override {
    if (ids_.count(id) == 0) finding("a message before its channel");
    if (data.size() > limits_.max_message_bytes) finding("a message beyond max_message_bytes");
    if (++messages_ > limits_.max_messages) finding("more messages than max_messages");
    if (offset >= input_bytes_) finding("a message's offset beyond the input");
    if (receive_ns < 0) finding("a negative receive time");
    volatile char sink = 0;  // the view must be readable during the call
    for (const char c : data) sink = static_cast<char>(sink ^ c);
  }

 private:
  const hr::RecordingLimits& limits_;
  std::size_t input_bytes_;
  std::set<std::uint32_t> ids_;
  std::uint64_t messages_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hr::RecordingLimits limits;
  limits.max_record_bytes = std::uint64_t{4} << 20;
  limits.max_uncompressed_bytes = std::uint64_t{8} << 20;
  limits.max_message_bytes = std::uint64_t{1} << 20;
  limits.max_channels = 64;
  limits.max_messages = 100000;
  Checker checker(limits, size);
  try {
    hr::read_ros1_bag_bytes(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.bag",
                            checker, limits);
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  return 0;
}
