// libFuzzer target: rosbag2 .db3 files (hapticcal::recording::read_rosbag2_db3).
// The input is the file: written to a scratch file of this process ($TMPDIR,
// fuzz/run.sh's build/tmp) and read as a recording. Bad input must end in
// hapticcal::InputError naming the file; any other exception, a crash, a
// sanitizer report, a leak, a hang (the run's -timeout) or a blow-up (its
// -rss_limit_mb) is a finding, and so is a reader breaking its promises to
// the visitor: a channel handed out twice, a message before its channel, a
// message over the bound, more messages than the bound, more bytes of topic
// names and data handed out than the file holds (a view, a generated column
// or a default standing for many rows would compute them), or more bytes of
// definitions than the file and max_definition_bytes.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"
#include "scratch_file.hpp"

namespace {

namespace hr = hapticcal::recording;

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_db3: %s\n", what);
  std::abort();
}

class Checker : public hr::RecordingVisitor {
 public:
  Checker(const hr::RecordingLimits& limits, std::size_t file_bytes)
      : limits_(limits), file_bytes_(file_bytes) {}

  void channel(std::uint32_t id, const hr::Channel& channel) override {
    if (!ids_.insert(id).second) finding("a channel handed out twice");
    if (ids_.size() > limits_.max_channels) finding("more channels than max_channels");
    handed_ += channel.topic.size();
    definitions_ += channel.definition.size();
    if (definitions_ > file_bytes_ + limits_.max_definition_bytes)
      finding("more definitions handed out than the file and max_definition_bytes");
  }
  void message(std::uint32_t id, std::int64_t, std::string_view data, std::uint64_t) override {
    if (ids_.count(id) == 0) finding("a message before its channel");
    if (data.size() > limits_.max_message_bytes) finding("a message beyond max_message_bytes");
    if (++messages_ > limits_.max_messages) finding("more messages than max_messages");
    handed_ += data.size();
    if (handed_ > file_bytes_) finding("more names and data handed out than the file holds");
    volatile char sink = 0;  // the view must be readable during the call
    for (const char c : data) sink = static_cast<char>(sink ^ c);
  }

 private:
  const hr::RecordingLimits& limits_;
  std::size_t file_bytes_;
  std::set<std::uint32_t> ids_;
  std::uint64_t messages_ = 0, handed_ = 0, definitions_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& scratch = write_scratch_file("fuzz_db3", "db3", data, size);
  hr::RecordingLimits limits;
  limits.max_message_bytes = std::uint64_t{1} << 20;
  limits.max_channels = 64;
  limits.max_messages = 100000;
  limits.max_definition_bytes = std::uint64_t{1} << 20;
  Checker checker(limits, size);
  try {
    hr::read_rosbag2_db3(scratch, checker, limits);
  } catch (const hapticcal::InputError& e) {
    if (std::string_view(e.what()).rfind(scratch + ":", 0) != 0)
      finding("an error that does not start with the file");
  }
  return 0;
}
