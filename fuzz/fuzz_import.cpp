// libFuzzer target: the import's reading of a recording (read_topics,
// src/recording/import_topics.hpp): a ROS 1 bag, an MCAP file or a .db3 (by
// its first bytes), every JointState, pose, point, transform and TF topic
// decoded with the recording's definitions (or the built-in ones) and its
// samples kept, as `hapticcal import` does before choosing the streams. The
// input is written to a scratch file of this process ($TMPDIR). Bad input
// must end in hapticcal::InputError (a topic's problem is kept as its error);
// any other exception, a crash, a sanitizer report, a leak, a hang (the run's
// -timeout: a message of 100,000 joints, a definition of 100,000 fields fit
// in its -max_len) or a blow-up (-rss_limit_mb) is a finding, and so is a
// topic's samples out of step with its messages.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hapticcal/core/error.hpp"
#include "recording/import_topics.hpp"
#include "scratch_file.hpp"

namespace {

namespace hr = hapticcal::recording;

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_import: %s\n", what);
  std::abort();
}

void check(const hr::Samples& s, std::uint64_t messages, bool joint_state) {
  const std::size_t n = s.stamp_ns.size();
  if (n > messages || s.receive_ns.size() != n || s.offset.size() != n)
    finding("samples out of step with the messages");
  if (n > 0 && (s.values.size() % n != 0 || (!joint_state && s.values.size() / n > 7)))
    finding("values out of step with the samples");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& scratch = write_scratch_file("fuzz_import", "rec", data, size);
  hr::RecordingLimits limits;
  limits.max_record_bytes = std::uint64_t{8} << 20;
  limits.max_uncompressed_bytes = std::uint64_t{16} << 20;
  limits.max_message_bytes = std::uint64_t{8} << 20;
  limits.max_channels = 64;
  limits.max_messages = 100000;
  hr::Wanted wanted;
  wanted.frames = std::make_pair(std::string("map"), std::string("tool"));
  std::string format;
  try {
    for (const hr::TopicBuffer& t : hr::read_topics(scratch, wanted, limits, format)) {
      if (t.receive_ns.size() != t.messages) finding("a topic's count out of step");
      check(t.samples, t.messages, t.kind == hr::TopicKind::kJointState);
      for (const auto& [pair, samples] : t.frames) check(samples, ~std::uint64_t{0}, false);
      if (t.kind == hr::TopicKind::kJointState && !t.samples.stamp_ns.empty() &&
          t.samples.values.size() != t.names.size() * t.samples.stamp_ns.size())
        finding("a JointState's positions out of step with its names");
    }
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  return 0;
}
