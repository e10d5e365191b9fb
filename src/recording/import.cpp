#include "hapticcal/recording/import.hpp"

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>
#include <unordered_map>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "recording/import_request.hpp"
#include "recording/import_streams.hpp"
#include "recording/import_topics.hpp"

namespace hapticcal::recording {
namespace {

std::string topic_text(const TopicBuffer& t) {
  return fmt::format("{} ({}, {} messages)", printable(t.channel.topic, 80), t.channel.type,
                     t.messages);
}

std::string listing(const std::vector<const TopicBuffer*>& topics) {
  std::string out;
  for (std::size_t k = 0; k < topics.size() && k < 20; ++k)
    out += (out.empty() ? "" : ", ") + topic_text(*topics[k]);
  if (topics.size() > 20)
    out += fmt::format(" and {} more (--list lists them)", topics.size() - 20);
  return out;
}

// The stream chosen: its topic's first problem, or no messages, is the import's.
void check_chosen(const TopicBuffer& t, const std::string& file, const char* option) {
  if (!t.error.empty()) throw InputError(t.error);
  if (t.messages == 0) throw InputError(file, 0, option, topic_text(t) + ": no messages to import");
}

// The --field columns of one stream (device or tracker) from one topic.
std::optional<Stream> field_stream(const std::vector<TopicBuffer>& topics,
                                   const std::vector<FieldRequest>& fields, bool device,
                                   const std::string& file) {
  std::vector<FieldRequest> mine;
  for (const FieldRequest& f : fields)
    if (f.device == device) mine.push_back(f);
  if (mine.empty()) return std::nullopt;
  for (const FieldRequest& f : mine) {
    if (f.topic != mine[0].topic) {
      throw InputError("", 0, "--field",
                       fmt::format("the {}'s columns come from one topic: {} and {}",
                                   device ? "device" : "tracker", printable(mine[0].topic, 80),
                                   printable(f.topic, 80)));
    }
  }
  Stream s;
  for (const TopicBuffer& t : topics) {
    if (t.channel.topic != mine[0].topic) continue;
    int k = 0;
    for (const FieldRequest& f : fields) {
      if (f.topic != t.channel.topic) continue;
      if (f.device == device) s.columns.push_back(f.column), s.take.push_back(k);
      s.field_paths.push_back(f.path);
      ++k;
    }
    s.topic = &t, s.samples = &t.samples, s.width = k, s.what = topic_text(t);
  }
  if (s.topic == nullptr)
    throw InputError(file, 0, "--field", "no topic " + printable(mine[0].topic, 80));
  check_chosen(*s.topic, file, "--field");
  return s;
}

// The device's stream: --field columns of q or ext, else a JointState topic.
std::optional<Stream> device_stream(const std::vector<TopicBuffer>& topics,
                                    const ImportRequest& request,
                                    const std::vector<FieldRequest>& fields,
                                    const std::string& file) {
  if (std::optional<Stream> s = field_stream(topics, fields, true, file)) {
    if (!request.model.empty() || !request.convention.empty()) {
      throw InputError("", 0, request.model.empty() ? "--convention" : "--model",
                       "applies to a JointState topic's joints, not to --field columns");
    }
    return s;
  }
  Stream s;
  std::vector<const TopicBuffer*> found;
  for (const TopicBuffer& t : topics) {
    if (!request.joints_topic.empty() ? t.channel.topic == request.joints_topic
                                      : t.kind == TopicKind::kJointState && t.messages > 0)
      found.push_back(&t);
  }
  if (!request.joints_topic.empty() && found.empty()) {
    throw InputError(file, 0, "--joints", "no topic " + printable(request.joints_topic, 80));
  }
  if (found.empty()) return std::nullopt;
  if (found.size() > 1) {
    throw InputError(
        file, 0, "--joints",
        "several JointState topics: " + listing(found) + ": name one with --joints TOPIC");
  }
  if (found[0]->kind != TopicKind::kJointState) {
    throw InputError(file, 0, "--joints",
                     topic_text(*found[0]) + " is not a sensor_msgs/JointState topic");
  }
  check_chosen(*found[0], file, "--joints");
  s.topic = found[0], s.samples = &found[0]->samples, s.what = topic_text(*found[0]);
  s.width = static_cast<int>(found[0]->names.size());
  return s;
}

// Joints by name: the model's (or the convention's) in its order, else the message's.
void match_joints(Stream& s, const ImportRequest& request, const std::optional<DeviceModel>& model,
                  ImportResult& result) {
  if (s.topic->kind != TopicKind::kJointState) return;
  const std::vector<std::string>& names = s.topic->names;
  if (request.convention.empty() && model) {
    // A device whose drivers publish its joints under its own names in their
    // own conventions: which one is the user's to say.
    std::vector<std::string> known;
    for (const Convention& c : conventions())
      if (c.device() == model->name) known.push_back(c.name());
    if (!known.empty()) {
      throw InputError(request.model, 0, "--convention",
                       fmt::format("{}'s drivers publish its joints under these names in their own "
                                   "signs and offsets: give --convention {} (or --convention none "
                                   "for the positions as published)",
                                   model->name, fmt::join(known, "|")));
    }
  }
  if (!request.convention.empty() && request.convention != "none") {
    s.convention = convention_named(request.convention);
    if (model && static_cast<int>(s.convention->readings()) != model->dof()) {
      throw InputError(request.model, 0, "--convention",
                       fmt::format("{} gives {} readings; the model has {} joints",
                                   request.convention, s.convention->readings(), model->dof()));
    }
    s.convention->bind(names, request.recording + ": " + s.what);
    for (std::size_t i = 0; i < s.convention->readings(); ++i)
      s.columns.push_back(fmt::format("q{}", i + 1));
    result.joint_names = s.convention->reading_names();
    result.notes.push_back(s.convention->note());
    return;
  }
  std::vector<std::string> wanted = names;
  if (model) {
    wanted.clear();
    for (const Link& l : model->links) wanted.push_back(l.name);
  }
  std::unordered_map<std::string_view, int> place;  // the topic's names are unique
  place.reserve(names.size());
  for (std::size_t k = 0; k < names.size(); ++k) place.emplace(names[k], static_cast<int>(k));
  for (std::size_t i = 0; i < wanted.size(); ++i) {
    const auto at = place.find(wanted[i]);
    if (at == place.end()) {
      throw InputError(
          request.model, 0, "joints",
          fmt::format("the model's joint '{}' is not among {}'s {} joints ({}){}",
                      printable(wanted[i]), request.recording + ": " + s.what, names.size(),
                      bounded_list(names), did_you_mean(wanted[i], names)));
    }
    s.take.push_back(at->second);
    s.columns.push_back(fmt::format("q{}", i + 1));
  }
  result.joint_names = wanted;
  if (!request.model.empty() && wanted.size() < names.size()) {
    result.notes.push_back(
        fmt::format("{} of the topic's {} joints are the model's; the others are left out",
                    wanted.size(), names.size()));
  }
}

// The tracker's stream: --field columns of x, y, z or distance, else a pose,
// point or transform topic (a TF topic with --frames).
std::optional<Stream> tracker_stream(const std::vector<TopicBuffer>& topics,
                                     const ImportRequest& request,
                                     const std::vector<FieldRequest>& fields,
                                     const std::string& file) {
  if (std::optional<Stream> s = field_stream(topics, fields, false, file)) return s;
  Stream s;
  const std::string parent = request.frames.empty() ? "" : frames_of(request.frames).first;
  const std::string child = request.frames.empty() ? "" : frames_of(request.frames).second;
  std::vector<std::pair<const TopicBuffer*, const Samples*>> found;
  const std::string* tf_error = nullptr;  // a TF topic that failed before giving the frames
  for (const TopicBuffer& t : topics) {
    if (!request.tracker_topic.empty() && t.channel.topic != request.tracker_topic) continue;
    if (t.kind == TopicKind::kTf) {
      if (parent.empty() && !request.tracker_topic.empty()) {  // named without its frames
        std::string pairs;
        for (const auto& [p, c] : t.frame_names)
          pairs += (pairs.empty() ? "" : ", ") + printable(p) + "," + printable(c);
        throw InputError(file, 0, "--frames",
                         topic_text(t) +
                             " holds transforms between frames: give --frames "
                             "PARENT,CHILD (" +
                             (pairs.empty() ? std::string("none decoded") : pairs) + ")");
      }
      if (parent.empty()) continue;  // a TF tree is read with --frames only
      const auto f = t.frames.find({parent, child});
      if (f != t.frames.end()) found.emplace_back(&t, &f->second);
      if (f == t.frames.end() && !t.error.empty() && tf_error == nullptr) tf_error = &t.error;
    } else if ((t.kind == TopicKind::kPose || t.kind == TopicKind::kPoint ||
                t.kind == TopicKind::kTransform) &&
               t.messages > 0) {
      found.emplace_back(&t, &t.samples);
    }
  }
  if (found.empty()) {
    if (tf_error != nullptr) throw InputError(*tf_error);
    if (!request.tracker_topic.empty() || !parent.empty()) {
      throw InputError(
          file, 0, request.tracker_topic.empty() ? "--frames" : "--tracker-topic",
          "no pose, point or transform topic " +
              (request.tracker_topic.empty() ? "" : printable(request.tracker_topic, 80) + " ") +
              (parent.empty() ? "" : "with frames " + printable(request.frames, 80)));
    }
    return std::nullopt;
  }
  if (found.size() > 1) {
    std::vector<const TopicBuffer*> list;
    for (const auto& f : found) list.push_back(f.first);
    throw InputError(file, 0, "--tracker-topic",
                     "several pose, point or transform topics: " + listing(list) +
                         ": name one with --tracker-topic TOPIC");
  }
  check_chosen(*found[0].first, file, "--tracker-topic");
  s.topic = found[0].first, s.samples = found[0].second;
  s.what = topic_text(*s.topic) +
           (parent.empty() ? "" : ", " + printable(parent) + " -> " + printable(child));
  const bool oriented = s.topic->kind != TopicKind::kPoint;
  s.width = oriented ? 7 : 3;
  s.columns = {"x", "y", "z"};
  s.take = {0, 1, 2};
  if (oriented)
    s.columns.insert(s.columns.end(), {"qw", "qx", "qy", "qz"}),
        s.take.insert(s.take.end(), {3, 4, 5, 6});
  return s;
}

// Orientations all zero (a tracker publishing positions in a pose message) are
// left out, said in a note; a mix of unit and other quaternions is an error.
void check_orientations(Stream& s, const std::string& file, ImportResult& result) {
  if (s.width != 7 || s.columns.size() != 7) return;
  const std::vector<double>& v = s.samples->values;
  std::size_t zero = 0;
  const std::size_t n = s.samples->stamp_ns.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double norm = std::sqrt(v[7 * i + 3] * v[7 * i + 3] + v[7 * i + 4] * v[7 * i + 4] +
                                  v[7 * i + 5] * v[7 * i + 5] + v[7 * i + 6] * v[7 * i + 6]);
    if (norm == 0) {
      ++zero;
    } else if (!(std::abs(norm - 1) <= 1e-3)) {
      throw InputError(
          fmt::format("{}: {} message {}: an orientation of norm {:.6g}, not a unit quaternion",
                      place(file, s.samples->offset[i]), s.what, i + 1, norm));
    }
  }
  if (zero == 0) return;
  if (zero < n) {
    throw InputError(
        fmt::format("{}: {}: {} of {} orientations are zero and the others not: positions and "
                    "orientations cannot be told apart",
                    file, s.what, zero, n));
  }
  s.columns.resize(3), s.take.resize(3);
  result.notes.push_back(
      "the tracker's orientations are all zero (positions only): tracker.csv holds t, x, y, z");
}

// A stream's stamps must increase: the CSV reader and the clocks' search need it.
void check_increasing(const Stream& s, const std::string& file, StampSource stamps) {
  const std::vector<std::int64_t>& t = s.samples->stamp_ns;
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (t[i] > t[i - 1]) continue;
    throw InputError(fmt::format(
        "{}: {} message {}: its {} stamp {} s is not after the previous message's {} s{}",
        place(file, s.samples->offset[i]), s.what, i + 1,
        stamps == StampSource::kHeader ? "header" : "recorder's", seconds_text(t[i]),
        seconds_text(t[i - 1]),
        stamps == StampSource::kHeader ? " (--time receive takes the recorder's stamps)" : ""));
  }
}

// The message field a stream's value `k` comes from ("position[3] (joint
// 'elbow')", "pose.orientation.w", a --field path).
std::string value_field(const Stream& s, int k) {
  if (!s.field_paths.empty()) return printable(s.field_paths[static_cast<std::size_t>(k)], 80);
  static constexpr const char* kAxes[] = {"x", "y", "z", "w", "x", "y", "z"};
  switch (s.topic->kind) {
    case TopicKind::kJointState:
      return fmt::format("position[{}] (joint '{}')", k,
                         printable(s.topic->names[static_cast<std::size_t>(k)], 80));
    case TopicKind::kPoint:
      return fmt::format("point.{}", kAxes[k]);
    case TopicKind::kPose:
      return fmt::format("pose.{}.{}", k < 3 ? "position" : "orientation", kAxes[k]);
    default:
      return fmt::format("transform.{}.{}", k < 3 ? "translation" : "rotation", kAxes[k]);
  }
}

// Every value written is a number: a NaN or an infinity (a driver's fault, a
// corrupt message) is refused naming the message, its stamp and the field.
void check_finite(const Stream& s, const std::string& file) {
  std::vector<int> used = s.convention ? s.convention->positions_used() : s.take;
  const std::size_t width = static_cast<std::size_t>(s.width);
  const std::vector<double>& v = s.samples->values;
  for (std::size_t i = 0; i < s.samples->stamp_ns.size(); ++i) {
    if ((i & 4095) == 0) throw_if_cancelled();
    for (const int k : used) {
      const double value = v[i * width + static_cast<std::size_t>(k)];
      if (std::isfinite(value)) continue;
      throw InputError(
          fmt::format("{}: {} message {} (stamped {} s): {} is {}: a reading must be a number",
                      place(file, s.samples->offset[i]), s.what, i + 1,
                      seconds_text(s.samples->stamp_ns[i]), value_field(s, k), value));
    }
  }
}

std::string stream_csv(const Stream& s, std::int64_t origin, const std::string& comment) {
  std::string out = comment;
  out += "t";
  for (const std::string& c : s.columns) out += "," + c;
  out += "\n";
  const std::size_t n = s.samples->stamp_ns.size();
  std::vector<double> values;
  for (std::size_t i = 0; i < n; ++i) {
    if ((i & 4095) == 0) throw_if_cancelled();  // Python's Ctrl-C (core/cancel.hpp)
    out += seconds_text(s.samples->stamp_ns[i] - origin);
    row_values(s, i, values);
    for (const double v : values) out += fmt::format(",{}", v);
    out += "\n";
  }
  return out;
}

TopicSummary summary_of(const TopicBuffer& t, const std::vector<std::int64_t>& stamps,
                        std::int64_t origin) {
  TopicSummary s;
  s.topic = t.channel.topic, s.type = t.channel.type, s.messages = t.messages;
  s.encoding = t.channel.encoding == Encoding::kRos1 ? "ros1" : "cdr";
  if (stamps.empty()) return s;
  s.first = 1e-9 * static_cast<double>(stamps.front() - origin);
  s.last = 1e-9 * static_cast<double>(stamps.back() - origin);
  std::vector<std::int64_t> dt;
  for (std::size_t i = 1; i < stamps.size(); ++i) dt.push_back(stamps[i] - stamps[i - 1]);
  if (dt.empty()) return s;
  std::vector<std::int64_t> sorted = dt;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double median = 1e-9 * static_cast<double>(sorted[sorted.size() / 2]);
  s.rate = median > 0 ? 1 / median : 0;
  for (const std::int64_t d : dt) {
    const double gap = 1e-9 * static_cast<double>(d);
    if (median > 0 && gap > 5 * median) ++s.gaps, s.largest_gap = std::max(s.largest_gap, gap);
  }
  return s;
}

nlohmann::json summary_json(const ImportRequest& request, const ImportResult& r) {
  nlohmann::json topics = nlohmann::json::array();
  for (const TopicSummary& t : r.topics) {
    topics.push_back({{"topic", t.topic},
                      {"type", t.type},
                      {"encoding", t.encoding},
                      {"messages", t.messages},
                      {"first", t.first},
                      {"last", t.last},
                      {"rate", t.rate},
                      {"gaps", t.gaps},
                      {"largest_gap", t.largest_gap},
                      {"role", t.role}});
  }
  return {{"recording", request.recording},
          {"tracker_export", request.tracker_export},
          {"format", r.format},
          {"stamps", request.stamps == StampSource::kHeader ? "header" : "receive"},
          {"time_origin", seconds_text(r.time_origin_ns)},
          {"topics", topics},
          {"joints", r.joint_names},
          {"device_rows", r.device_rows},
          {"tracker_rows", r.tracker_rows},
          {"tracker_orientation", r.tracker_orientation},
          {"static_rows", r.static_rows},
          {"notes", r.notes}};
}

std::string export_csv(const TrackerStream& s) {
  std::string out = "# hapticcal import of " + s.source + "\nt";
  const bool markers = !s.marker_names.empty();
  if (markers) {
    for (std::size_t k = 1; k <= s.marker_names.size(); ++k)
      out += fmt::format(",x{0},y{0},z{0}", k);
  } else {
    out += ",x,y,z";
    if (!s.q.empty()) out += ",qw,qx,qy,qz";
  }
  out += "\n";
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    out += fmt::format("{}", s.t[i]);
    if (markers) {
      for (const auto& m : s.markers[i]) out += fmt::format(",{},{},{}", m[0], m[1], m[2]);
    } else {
      out += fmt::format(",{},{},{}", s.p[i][0], s.p[i][1], s.p[i][2]);
      if (!s.q.empty())
        out += fmt::format(",{},{},{},{}", s.q[i][0], s.q[i][1], s.q[i][2], s.q[i][3]);
    }
    out += "\n";
  }
  return out;
}

// Every topic's summary: the imported ones on the import's time origin (the
// stamps written), the others on the recorder's clock from the recording's
// first message.
void summarise(const std::vector<TopicBuffer>& topics, const std::optional<Stream>& device,
               const std::optional<Stream>& tracker, std::int64_t origin, ImportResult& result) {
  std::int64_t first_receive = std::numeric_limits<std::int64_t>::max();
  for (const TopicBuffer& t : topics)
    if (!t.receive_ns.empty()) first_receive = std::min(first_receive, t.receive_ns.front());
  for (const TopicBuffer& t : topics) {
    const Stream* role = device && device->topic == &t     ? &*device
                         : tracker && tracker->topic == &t ? &*tracker
                                                           : nullptr;
    TopicSummary s = role ? summary_of(t, role->samples->stamp_ns, origin)
                          : summary_of(t, t.receive_ns, first_receive);
    s.role = role == nullptr ? "" : role == &*device ? "device" : "tracker";
    if (!t.error.empty() && role == nullptr)
      result.notes.push_back(
          fmt::format("{} not imported: {}", printable(t.channel.topic, 80), t.error));
    result.topics.push_back(std::move(s));
  }
}

}  // namespace

ImportResult import_recording(const ImportRequest& request, const ImportSink& write) {
  const std::vector<FieldRequest> fields = parse_fields(request.fields);
  check_request(request, fields);
  ImportResult result;
  std::vector<TopicBuffer> topics;
  const std::string& file = request.recording;
  if (!file.empty())
    topics = read_topics(file, wanted_of(request, fields), request.limits, result.format);
  if (request.list) {
    summarise(topics, std::nullopt, std::nullopt, 0, result);
    return result;
  }
  std::optional<Stream> device, tracker;
  if (!file.empty()) {
    device = device_stream(topics, request, fields, file);
    if (request.tracker_export.empty()) tracker = tracker_stream(topics, request, fields, file);
  }
  if (!file.empty() && !device && !tracker && request.tracker_export.empty()) {
    std::vector<const TopicBuffer*> all;
    for (const TopicBuffer& t : topics) all.push_back(&t);
    throw InputError(file, 0, "",
                     "no JointState, pose, point or transform topic to import (topics: " +
                         (all.empty() ? std::string("none") : listing(all)) +
                         "); --field COLUMN=TOPIC:PATH reads others");
  }
  const std::optional<DeviceModel> model =
      device && !request.model.empty() ? std::optional(load_model(request.model)) : std::nullopt;
  if (device) match_joints(*device, request, model, result);
  for (const std::optional<Stream>* s : {&device, &tracker}) {
    if (!*s) continue;
    check_finite(**s, file);
    check_increasing(**s, file, request.stamps);
  }
  if (tracker) check_orientations(*tracker, file, result);
  // One origin for both streams: their offset is what the clocks' search finds.
  std::int64_t origin = std::numeric_limits<std::int64_t>::max();
  for (const std::optional<Stream>* s : {&device, &tracker})
    if (*s && !(*s)->samples->stamp_ns.empty())
      origin = std::min(origin, (*s)->samples->stamp_ns.front());
  if (origin == std::numeric_limits<std::int64_t>::max()) {
    origin = 0;
    for (const TopicBuffer& t : topics)
      if (!t.receive_ns.empty())
        origin = origin == 0 ? t.receive_ns.front() : std::min(origin, t.receive_ns.front());
  }
  result.time_origin_ns = origin;
  summarise(topics, device, tracker, origin, result);

  // Said in the files' comment: calibrate names it when the readings do not fit the model.
  const std::string convention =
      request.convention.empty() ? "" : "; --convention " + request.convention;
  const std::string what = file.empty() ? "" : fmt::format("{} ({})", file, result.format);
  if (request.still_seconds > 0) {
    if (!device || !tracker) {
      throw InputError(
          file, 0, "--static",
          "a static log needs the device's readings and the tracker's samples from the recording");
    }
    const std::string comment =
        fmt::format("# hapticcal import of {}: still poses of {} and {}; {} stamps less {} s{}\n",
                    what, device->what, tracker->what,
                    request.stamps == StampSource::kHeader ? "header" : "recorder's",
                    seconds_text(origin), convention);
    write("log.csv", static_csv(*device, *tracker, request, model ? &*model : nullptr, origin,
                                comment, result));
    device.reset(), tracker.reset();
  }
  if (device) {
    result.device_rows = device->samples->stamp_ns.size();
    const std::string comment =
        fmt::format("# hapticcal import of {}: {}; {} stamps less {} s; joints: {}{}\n", what,
                    device->what, request.stamps == StampSource::kHeader ? "header" : "recorder's",
                    seconds_text(origin), fmt::join(result.joint_names, ", "), convention);
    write("device.csv", stream_csv(*device, origin, comment));
  }
  if (tracker) {
    result.tracker_rows = tracker->samples->stamp_ns.size();
    result.tracker_orientation = tracker->columns.size() == 7;
    const std::string comment = fmt::format(
        "# hapticcal import of {}: {}; {} stamps less {} s\n", what, tracker->what,
        request.stamps == StampSource::kHeader ? "header" : "recorder's", seconds_text(origin));
    write("tracker.csv", stream_csv(*tracker, origin, comment));
  }
  if (!request.tracker_export.empty()) {
    const TrackerStream s = read_tracker_export(request.tracker_export, request.export_options);
    if (result.format.empty()) result.format = s.source;
    result.tracker_rows = s.t.size();
    result.tracker_orientation = !s.q.empty();
    result.notes.push_back(
        fmt::format("{}: {} samples{}", s.source, s.t.size(),
                    s.lost > 0 ? fmt::format(", {} lost (occluded) left out", s.lost) : ""));
    write("tracker.csv", export_csv(s));
  }
  return result;
}

std::string import_summary_json(const ImportRequest& request, const ImportResult& result) {
  return summary_json(request, result).dump(2) + "\n";
}

}  // namespace hapticcal::recording
