#include "recording/import_topics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <set>
#include <unordered_map>
#include <utility>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"

namespace hapticcal::recording {
namespace {

TopicKind kind_of(const std::string& type) {
  if (type == "sensor_msgs/JointState") return TopicKind::kJointState;
  if (type == "geometry_msgs/PoseStamped") return TopicKind::kPose;
  if (type == "geometry_msgs/PointStamped") return TopicKind::kPoint;
  if (type == "geometry_msgs/TransformStamped") return TopicKind::kTransform;
  if (type == "tf2_msgs/TFMessage") return TopicKind::kTf;
  return TopicKind::kOther;
}

// The first of `paths` the message has, or nullptr.
const double* first_number(const DecodedMessage& m, std::initializer_list<std::string_view> paths) {
  for (const std::string_view p : paths)
    if (const double* v = m.number(p)) return v;
  return nullptr;
}

class Collector : public RecordingVisitor {
 public:
  Collector(std::string file, const Wanted& wanted, bool offsets)
      : file_(std::move(file)), wanted_(wanted), offsets_(offsets) {}

  // A channel of a topic already seen (another publisher of a bag) joins it.
  void channel(std::uint32_t id, const Channel& channel) override {
    if (const auto seen = by_topic_.find(channel.topic); seen != by_topic_.end()) {
      const std::size_t k = seen->second;
      if (topics_[k].channel.type != channel.type && topics_[k].error.empty()) {
        topics_[k].error = fmt::format("{}: topic {} is recorded as {} and as {}", file_,
                                       printable(channel.topic, 80), topics_[k].channel.type,
                                       printable(channel.type, 80));
      }
      topics_[k].merged = true;
      index_[id] = k;
      return;
    }
    TopicBuffer buffer;
    buffer.channel = channel;
    buffer.kind = kind_of(channel.type);
    for (const FieldRequest& f : wanted_.fields)
      if (f.topic == channel.topic) buffer.kind = TopicKind::kFields;
    // A channel hapticcal cannot decode (JSON, protobuf, an IDL schema) is
    // listed, never decoded; one of a kind the import reads carries why, as
    // its error (the import's, if it is the topic imported; else a note).
    const bool decodable = channel.message_encoding.empty() || channel.message_encoding == "ros1" ||
                           channel.message_encoding == "cdr";
    if (!decodable && buffer.kind != TopicKind::kOther) {
      buffer.error = fmt::format(
          "{}: {} ({}): its messages are {}, which hapticcal does not decode (ros1, or cdr with "
          "a ros2msg definition)",
          file_, printable(channel.topic, 80), printable(channel.type, 80),
          printable(channel.message_encoding, 80));
    }
    by_topic_.emplace(channel.topic, topics_.size());
    index_[id] = topics_.size();
    topics_.push_back(std::move(buffer));
  }

  void message(std::uint32_t channel_id, std::int64_t receive_ns, std::string_view data,
               std::uint64_t offset) override {
    const auto found = index_.find(channel_id);
    if (found == index_.end())
      throw InputError(file_, 0, "",
                       fmt::format("byte {}: a message on channel {}, which was never defined",
                                   offset, channel_id));
    TopicBuffer& t = topics_[found->second];
    throw_if_cancelled();  // Python's Ctrl-C (core/cancel.hpp): a relaxed load a message
    ++t.messages;
    t.receive_ns.push_back(receive_ns);
    if (!decoded(t)) return;
    // A .db3 holds no byte offsets: its messages are named by their place.
    if (!offsets_) offset = kNoOffset;
    const std::string origin =
        fmt::format("{}: {} ({}) message {}", place(file_, offset), printable(t.channel.topic, 80),
                    t.channel.type, t.messages);
    try {
      if (!t.type) t.type = type_of(t, origin);
      const DecodedMessage m = decode_message(*t.type, data, origin);
      switch (t.kind) {
        case TopicKind::kJointState:
          return joint_state(t, m, receive_ns, offset, origin);
        case TopicKind::kTf:
          return tf(t, m, receive_ns, offset, origin);
        case TopicKind::kFields:
          return field_values(t, m, receive_ns, offset, origin);
        default:
          return pose(t, m, "", receive_ns, offset, origin, t.samples);
      }
    } catch (const InputError& e) {
      t.error = e.what();  // the import fails with it if it imports this topic
    }
  }

  // Only a topic decoded needs its messages' bytes (a .db3 fetches no others).
  bool wants_data(std::uint32_t channel_id) const override {
    const auto found = index_.find(channel_id);
    return found == index_.end() || decoded(topics_[found->second]);
  }

  std::vector<TopicBuffer> take() { return std::move(topics_); }

 private:
  // Whether a message of `t` is decoded: a topic the import may take (of a
  // kind it reads, not failed, named or not excluded by a name), none to list.
  bool decoded(const TopicBuffer& t) const {
    if (wanted_.list || !t.error.empty()) return false;
    switch (t.kind) {
      case TopicKind::kJointState:
        return wanted_.joints_topic.empty() || wanted_.joints_topic == t.channel.topic;
      case TopicKind::kPose:
      case TopicKind::kPoint:
      case TopicKind::kTransform:
        return wanted_.tracker_topic.empty() || wanted_.tracker_topic == t.channel.topic;
      case TopicKind::kTf:  // with --frames, or named (to name its pairs)
        return wanted_.tracker_topic.empty() ? wanted_.frames.has_value()
                                             : wanted_.tracker_topic == t.channel.topic;
      case TopicKind::kFields:
        return true;
      default:
        return false;
    }
  }

  std::shared_ptr<const MessageType> type_of(const TopicBuffer& t,
                                             const std::string& origin) const {
    std::string definition = t.channel.definition;
    if (definition.empty()) definition = builtin_definition(t.channel.type, t.channel.encoding);
    if (definition.empty()) {
      throw InputError(origin + ": the recording holds no definition of " +
                       printable(t.channel.type, 80) +
                       " and hapticcal knows none: record with the message definitions (rosbag2 "
                       "Iron or later, MCAP) or import its fields another way");
    }
    return MessageType::parse(t.channel.type, definition, t.channel.encoding, origin);
  }

  // The stamp asked for: the header's (`prefix` + "header.stamp") or the recorder's.
  std::int64_t stamp(const DecodedMessage& m, const std::string& prefix, std::int64_t receive_ns,
                     const std::string& origin) const {
    if (wanted_.stamps == StampSource::kReceive) return receive_ns;
    const std::string s = prefix + "header.stamp.";
    const double* sec = first_number(m, {s + "sec", s + "secs"});
    const double* nsec = first_number(m, {s + "nanosec", s + "nsec", s + "nsecs"});
    if (sec == nullptr || nsec == nullptr)
      throw InputError(origin + ": no header stamp: --time receive takes the recorder's");
    if (*sec == 0 && *nsec == 0) {
      throw InputError(origin +
                       ": the header stamp is 0 (the sender did not stamp the message): "
                       "--time receive takes the recorder's");
    }
    if (!(*nsec >= 0 && *nsec < 1e9 && *nsec == std::floor(*nsec)))
      throw InputError(fmt::format("{}: header stamp nanoseconds {}", origin, *nsec));
    // Whole seconds within what nanoseconds since 1970 hold in 64 bits (year 2262).
    if (!(std::abs(*sec) <= 9.2e9 && *sec == std::floor(*sec)))
      throw InputError(fmt::format("{}: header stamp seconds {}", origin, *sec));
    return static_cast<std::int64_t>(*sec) * 1000000000 + static_cast<std::int64_t>(*nsec);
  }

  static void add(Samples& s, std::int64_t stamp, std::int64_t receive, std::uint64_t offset) {
    s.stamp_ns.push_back(stamp);
    s.receive_ns.push_back(receive);
    s.offset.push_back(offset);
  }

  // `prefix`[k]: a path of an array's element, built in one buffer.
  const std::string& element(const char* prefix, std::size_t k) {
    path_.assign(prefix);
    path_ += '[';
    char digits[24];
    path_.append(digits, std::to_chars(digits, digits + sizeof digits, k).ptr);
    path_ += ']';
    return path_;
  }

  void joint_state(TopicBuffer& t, const DecodedMessage& m, std::int64_t receive_ns,
                   std::uint64_t offset, const std::string& origin) {
    std::vector<std::string> names;
    for (std::size_t k = 0;; ++k) {
      const std::string* name = m.string(element("name", k));
      if (name == nullptr) break;
      names.push_back(*name);
    }
    if (t.samples.stamp_ns.empty()) {
      if (names.empty()) throw InputError(origin + ": a JointState without joint names");
      check_unique(names, origin);
      t.names = names;
    } else if (names != t.names) {
      throw InputError(
          fmt::format("{}: its joints ({} names, the first '{}') differ from the topic's first "
                      "message's ({}, '{}'): one topic, one set of joints",
                      origin, names.size(), names.empty() ? "" : printable(names[0]),
                      t.names.size(), printable(t.names[0])));
    }
    if (m.number(element("position", names.size())) != nullptr ||
        m.number(element("position", names.size() - 1)) == nullptr) {
      std::size_t positions = 0;
      while (m.number(element("position", positions)) != nullptr) ++positions;
      throw InputError(
          fmt::format("{}: {} joint names and {} positions", origin, names.size(), positions));
    }
    add(t.samples, stamp(m, "", receive_ns, origin), receive_ns, offset);
    for (std::size_t k = 0; k < names.size(); ++k)
      t.samples.values.push_back(*m.number(element("position", k)));
  }

  // One name, one joint: a JointState naming a joint twice has no one reading for it.
  static void check_unique(const std::vector<std::string>& names, const std::string& origin) {
    std::unordered_map<std::string_view, std::size_t> first;
    first.reserve(names.size());
    for (std::size_t k = 0; k < names.size(); ++k) {
      const auto [at, inserted] = first.emplace(names[k], k);
      if (!inserted) {
        throw InputError(fmt::format(
            "{}: the joint '{}' is named twice (name[{}] and name[{}]): one name, one joint",
            origin, printable(names[k], 80), at->second, k));
      }
    }
  }

  // A pose, point or transform at `prefix` (a TFMessage's "transforms[k].").
  void pose(TopicBuffer& t, const DecodedMessage& m, const std::string& prefix,
            std::int64_t receive_ns, std::uint64_t offset, const std::string& origin,
            Samples& out) {
    const bool transform = t.kind == TopicKind::kTransform || t.kind == TopicKind::kTf;
    const std::string p = prefix + (transform                     ? "transform.translation."
                                    : t.kind == TopicKind::kPoint ? "point."
                                                                  : "pose.position.");
    const std::string q = prefix + (transform ? "transform.rotation." : "pose.orientation.");
    add(out, stamp(m, prefix, receive_ns, origin), receive_ns, offset);
    const bool oriented = t.kind != TopicKind::kPoint;
    for (const char* axis : {"x", "y", "z"}) {
      const double* v = m.number(p + axis);
      if (v == nullptr) throw InputError(origin + ": no field " + p + axis);
      out.values.push_back(*v);
    }
    if (!oriented) return;
    for (const char* axis : {"w", "x", "y", "z"}) {
      const double* v = m.number(q + axis);
      if (v == nullptr) throw InputError(origin + ": no field " + q + axis);
      out.values.push_back(*v);
    }
  }

  void tf(TopicBuffer& t, const DecodedMessage& m, std::int64_t receive_ns, std::uint64_t offset,
          const std::string& origin) {
    for (std::size_t k = 0;; ++k) {
      const std::string prefix = element("transforms", k) + ".";
      const std::string* parent = m.string(prefix + "header.frame_id");
      const std::string* child = m.string(prefix + "child_frame_id");
      if (parent == nullptr || child == nullptr) break;
      if (t.frame_names.size() < 100) t.frame_names.insert({*parent, *child});
      if (!wanted_.frames || *wanted_.frames != std::make_pair(*parent, *child)) continue;
      pose(t, m, prefix, receive_ns, offset, fmt::format("{}: transforms[{}]", origin, k),
           t.frames[{*parent, *child}]);
    }
  }

  void field_values(TopicBuffer& t, const DecodedMessage& m, std::int64_t receive_ns,
                    std::uint64_t offset, const std::string& origin) {
    const bool header =
        m.number("header.stamp.sec") != nullptr || m.number("header.stamp.secs") != nullptr;
    if (wanted_.stamps == StampSource::kHeader && !header) {
      throw InputError(origin +
                       ": no header stamp (a message without a header): --time receive takes "
                       "the recorder's");
    }
    add(t.samples, stamp(m, "", receive_ns, origin), receive_ns, offset);
    for (const FieldRequest& f : wanted_.fields) {
      if (f.topic != t.channel.topic) continue;
      const double* v = m.number(f.path);
      if (v == nullptr) {
        std::vector<std::string> known;
        for (const auto& [path, value] : m.numbers) known.push_back(path);
        throw InputError(fmt::format("{}: no numeric field '{}'{}", origin, printable(f.path, 80),
                                     did_you_mean(f.path, known)));
      }
      t.samples.values.push_back(*v);
    }
  }

  std::string file_;
  const Wanted& wanted_;
  bool offsets_ = true;  // the reader gives byte offsets (not a .db3)
  std::vector<TopicBuffer> topics_;
  std::unordered_map<std::string, std::size_t> by_topic_;  // a topic's place in topics_
  std::map<std::uint32_t, std::size_t> index_;
  std::string path_;  // element()'s buffer
};

}  // namespace

namespace {

// A --field column's name without its unit: "q3[deg]" -> "q3".
std::string column_name(const std::string& column) { return column.substr(0, column.find('[')); }

bool numbered(const std::string& name, const char* prefix) {
  const std::size_t n = std::strlen(prefix);
  return name.size() > n && name.compare(0, n, prefix) == 0 && name[n] != '0' &&
         name.find_first_not_of("0123456789", n) == std::string::npos && name.size() - n <= 3;
}

// A topic's samples in stamp order (several publishers of one topic interleave
// by arrival); a stable sort, so equal stamps stay as recorded (and are refused
// later as not increasing).
void sort_by_stamp(Samples& s) {
  const std::size_t n = s.stamp_ns.size();
  if (n == 0) return;
  const std::size_t width = s.values.size() / n;
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return s.stamp_ns[a] < s.stamp_ns[b]; });
  Samples sorted;
  for (const std::size_t i : order) {
    sorted.stamp_ns.push_back(s.stamp_ns[i]);
    sorted.receive_ns.push_back(s.receive_ns[i]);
    sorted.offset.push_back(s.offset[i]);
    sorted.values.insert(sorted.values.end(),
                         s.values.begin() + static_cast<std::ptrdiff_t>(i * width),
                         s.values.begin() + static_cast<std::ptrdiff_t>((i + 1) * width));
  }
  s = std::move(sorted);
}

}  // namespace

std::vector<FieldRequest> parse_fields(const std::vector<std::string>& fields) {
  std::vector<FieldRequest> out;
  for (const std::string& f : fields) {
    const std::size_t eq = f.find('=');
    const std::size_t colon = eq == std::string::npos ? std::string::npos : f.find(':', eq);
    if (eq == 0 || colon == std::string::npos || colon == eq + 1 || colon + 1 == f.size()) {
      throw InputError(
          "", 0, "--field",
          "'" + printable(f, 80) + "': not COLUMN=TOPIC:PATH (e.g. q1=/encoders:position[0])");
    }
    FieldRequest r{f.substr(0, eq), f.substr(eq + 1, colon - eq - 1), f.substr(colon + 1)};
    const std::string name = column_name(r.column);
    r.device = numbered(name, "q") || numbered(name, "ext");
    static const std::set<std::string> tracker = {"x",  "y",  "z",  "qw",
                                                  "qx", "qy", "qz", "distance"};
    if (!r.device && tracker.count(name) == 0) {
      throw InputError(
          "", 0, "--field",
          "'" + printable(r.column, 40) +
              "': not a column a log has (q1.., ext1.. for the device's stream; x, y, z, "
              "qw, qx, qy, qz, distance for the tracker's)");
    }
    for (const FieldRequest& other : out) {
      if (column_name(other.column) == name)
        throw InputError("", 0, "--field", "'" + printable(name, 40) + "': given twice");
    }
    out.push_back(std::move(r));
  }
  return out;
}

std::vector<TopicBuffer> read_topics(const std::string& path, const Wanted& wanted,
                                     const RecordingLimits& limits, std::string& format) {
  format = recording_format(path);
  Collector collector(path, wanted, format != "rosbag2 sqlite3");
  read_recording(path, collector, limits);
  std::vector<TopicBuffer> topics = collector.take();
  for (TopicBuffer& t : topics) {
    if (!t.merged) continue;
    sort_by_stamp(t.samples);
    for (auto& [pair, samples] : t.frames) sort_by_stamp(samples);
  }
  return topics;
}

std::string place(const std::string& file, std::uint64_t offset) {
  return offset == kNoOffset ? file : fmt::format("{}: byte {}", file, offset);
}

std::string bounded_list(const std::vector<std::string>& items, std::size_t shown) {
  std::string out;
  for (std::size_t k = 0; k < items.size() && k < shown; ++k)
    out += (k == 0 ? "" : ", ") + printable(items[k], 80);
  if (items.size() > shown) out += fmt::format(", ... and {} more", items.size() - shown);
  return out;
}

std::string seconds_text(std::int64_t ns) {
  const bool negative = ns < 0;
  const std::uint64_t magnitude =
      negative ? 0 - static_cast<std::uint64_t>(ns) : static_cast<std::uint64_t>(ns);
  return fmt::format("{}{}.{:09d}", negative ? "-" : "", magnitude / 1000000000,
                     magnitude % 1000000000);
}

}  // namespace hapticcal::recording
