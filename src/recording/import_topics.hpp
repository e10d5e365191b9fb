// The import's first half: a recording read once, the messages of every topic
// hapticcal could import decoded into per-topic buffers (stamps and values),
// each topic's problems named with the file, byte offset and message.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hapticcal/recording/import.hpp"
#include "hapticcal/recording/recording.hpp"
#include "hapticcal/recording/ros_message.hpp"

namespace hapticcal::recording {

enum class TopicKind { kJointState, kPose, kPoint, kTransform, kTf, kFields, kOther };

// One stream's samples: stamps [ns] and `width` values a sample.
struct Samples {
  std::vector<std::int64_t> stamp_ns;
  std::vector<std::int64_t> receive_ns;
  std::vector<double> values;
  std::vector<std::uint64_t> offset;  // each message's byte offset, for messages naming it
};

// The columns asked of a topic by --field: COLUMN=TOPIC:PATH; a device column
// (q<i>, ext<i>) or a tracker's (x, y, z, qw, qx, qy, qz, distance), with a unit
// in brackets as a log's header allows.
struct FieldRequest {
  std::string column, topic, path;
  bool device = false;
};
// InputError naming --field for a malformed one, an unknown or repeated column.
std::vector<FieldRequest> parse_fields(const std::vector<std::string>& fields);

// A topic as read: its channel, what it is, and its samples.
struct TopicBuffer {
  Channel channel;
  TopicKind kind = TopicKind::kOther;
  std::shared_ptr<const MessageType> type;
  std::uint64_t messages = 0;
  std::vector<std::int64_t> receive_ns;  // every message's (the summary's)
  // kJointState: the names of the first message (every message must have them).
  std::vector<std::string> names;
  Samples samples;                                                // not kTf
  std::map<std::pair<std::string, std::string>, Samples> frames;  // kTf: the pair asked for
  std::set<std::pair<std::string, std::string>> frame_names;      // kTf: the pairs seen (<= 100)
  // The first problem of a topic's messages: the topic is decoded no further,
  // and the import fails with it only if the topic is the one imported.
  std::string error;
  bool merged = false;  // several channels (a bag's connections) of one topic
};

// What the import wants of the recording: the topics decoded are those it may
// import (all of a kind, or the ones named); --list decodes none.
struct Wanted {
  std::string joints_topic, tracker_topic;
  std::optional<std::pair<std::string, std::string>> frames;
  std::vector<FieldRequest> fields;
  StampSource stamps = StampSource::kHeader;
  bool list = false;
};

// Reads the recording once: the topics `wanted` may import decoded (a topic of
// several channels merged, its samples in stamp order), every other one counted.
std::vector<TopicBuffer> read_topics(const std::string& path, const Wanted& wanted,
                                     const RecordingLimits& limits, std::string& format);

// A message's place in errors: "FILE: byte N", or "FILE" for a storage without
// byte offsets (a .db3: its messages are named by their number on the topic).
inline constexpr std::uint64_t kNoOffset = ~std::uint64_t{0};
std::string place(const std::string& file, std::uint64_t offset);

// The first `shown` of `items`, printable and comma-separated, then "... and N
// more" when there are more: an error naming a message's 64,000 joints stays
// one short line.
std::string bounded_list(const std::vector<std::string>& items, std::size_t shown = 8);

// The nanoseconds since the epoch as seconds, exactly as decimal text
// ("12.000000345"): the CSV reader then rounds it once, as it would the same
// time typed in a log.
std::string seconds_text(std::int64_t ns);

}  // namespace hapticcal::recording
