// `hapticcal import`: a recording in (a ROS 1 bag, an MCAP file, a rosbag2
// .db3, or a tracker's CSV export), hapticcal's streams out: device.csv (t,
// q1..qn from a sensor_msgs/JointState topic, or numeric fields of another
// message) and tracker.csv (t, x, y, z and the orientation qw, qx, qy, qz from a
// PoseStamped, PointStamped, TransformStamped or tf2_msgs/TFMessage topic, or a
// tracker's export), which `calibrate --log device.csv --tracker tracker.csv`
// reads. Topics are chosen by type when one of a kind is recorded, else named;
// nothing is guessed: two candidates, joint names that do not match the model,
// header stamps that are zero or go back are errors naming the file, topic and
// message.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/recording/recording.hpp"
#include "hapticcal/recording/tracker_export.hpp"

namespace hapticcal::recording {

enum class StampSource {
  kHeader,   // the message's header.stamp (the sender's clock)
  kReceive,  // the recorder's stamp (a bag's record time, MCAP's log_time)
};

struct ImportRequest {
  std::string recording;     // a bag, .mcap, .db3 or rosbag2 folder; empty with tracker_export only
  std::string joints_topic;  // sensor_msgs/JointState; empty: the only one recorded
  std::string tracker_topic;  // a pose, point or transform topic; empty: the only one
  std::string frames;         // "PARENT,CHILD" of a TFMessage or TransformStamped topic
  // "COLUMN=TOPIC:PATH" (q3=/encoders:position[2], distance=/cable:data): numeric
  // fields of one other topic as the device's (q, ext) or the tracker's (x, y,
  // z, distance) columns, instead of a JointState or pose topic.
  std::vector<std::string> fields;
  StampSource stamps = StampSource::kHeader;
  std::string model;           // joints matched by name to this model's (its links' names)
  std::string convention;      // a driver's published joints mapped to the device's readings
  std::string tracker_export;  // a tracker's CSV export instead of (or beside) a recording
  TrackerExportOptions export_options;
  std::string out;  // the output folder; empty: kDefaultImportOut
  RecordingLimits limits;
  // List the recording's topics; write nothing (so an output folder, a model
  // or a topic to import given with it is refused: it would have no effect).
  bool list = false;
  // A static log (log.csv) instead of the streams: one row a window of at least
  // this many seconds in which every reading stays within still_tolerance (rad
  // or m; unset: 1e-4), the readings and the tracker's samples in it averaged.
  // 0: streams (and still_tolerance or tracker_still set is refused).
  double still_seconds = 0;
  std::optional<double> still_tolerance;
  // A still window whose tracker samples lie further than this from their
  // median [m] is left out: the tracker moved (its clock is not the device's).
  // Unset: 1e-3.
  std::optional<double> tracker_still;
  // How far the tracker's clock is ahead of the device's [s]: a still window's
  // tracker samples are those stamped within it plus this. A window whose
  // samples the speeds place at another time is left out (still_poses.cpp).
  // Nonzero without still_seconds is refused.
  double clock_offset = 0;
};

inline constexpr const char* kDefaultImportOut = "hapticcal-out/import";

// What one topic held.
struct TopicSummary {
  std::string topic, type, encoding;
  std::uint64_t messages = 0;
  double first = 0, last = 0;  // s since the import's time origin (the stamps used)
  double rate = 0;             // Hz, from the median interval
  std::uint64_t gaps = 0;      // intervals over 5 median intervals
  double largest_gap = 0;      // s
  std::string role;            // "device", "tracker" or empty (not imported)
};

struct ImportResult {
  std::string format;  // "ROS 1 bag", "MCAP", "rosbag2 sqlite3", "Motive CSV", ...
  std::vector<TopicSummary> topics;
  std::int64_t time_origin_ns = 0;       // subtracted from every stamp written
  std::vector<std::string> joint_names;  // device.csv's q1..qn, in order
  std::size_t device_rows = 0, tracker_rows = 0, static_rows = 0;
  bool tracker_orientation = false;
  std::vector<std::string> notes;    // what was chosen and why (the terminal's lines)
  std::vector<std::string> written;  // the files of the output set
  std::string out;                   // the folder written
};

// Where an import hands each file it makes, once it is made: its name in the
// output set (device.csv, tracker.csv, log.csv) and its text.
using ImportSink = std::function<void(const std::string& name, const std::string& text)>;

// Reads the recording (or the tracker's export) and hands each file it makes to
// `write`; with `list`, reads the topics only and makes none. The result's
// `written` and `out` are the job's (run_import, jobs/import_job.hpp).
ImportResult import_recording(const ImportRequest& request, const ImportSink& write);
// import.json: what was read, chosen and made.
std::string import_summary_json(const ImportRequest& request, const ImportResult& result);

}  // namespace hapticcal::recording
