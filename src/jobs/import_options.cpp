// import's options (jobs/command_options.hpp): the one place their keywords,
// help, ranges and defaults are written.
#include "hapticcal/jobs/import_job.hpp"

namespace hapticcal {

namespace {

using recording::ImportRequest;

// A text option of the tracker export's (TrackerExportOptions).
CommandOption<ImportRequest> export_option(std::string name, std::string help,
                                           std::string recording::TrackerExportOptions::*field) {
  return field_option<ImportRequest>(
      std::move(name),
      std::move(help), [field](ImportRequest & r) -> auto& { return r.export_options.*field; });
}

CommandOptions<ImportRequest> import_table() {
  using R = ImportRequest;
  CommandOptions<R> t;
  auto recording = field_option<R>(
      "recording", "The recording (.bag, .mcap, .db3, or a rosbag2 folder)",
      [](R & r) -> auto& { return r.recording; });
  recording.argument = true;
  recording.positional = true;
  t.push_back(recording);
  t.push_back(field_option<R>(
      "joints", "The sensor_msgs/JointState topic (default: the only one recorded)",
      [](R & r) -> auto& { return r.joints_topic; }));
  t.push_back(field_option<R>(
      "tracker_topic",
      "The tracker's PoseStamped, PointStamped or TransformStamped topic (default: the only one), "
      "or a tf2_msgs/TFMessage topic with --frames",
      [](R & r) -> auto& { return r.tracker_topic; }));
  t.push_back(field_option<R>(
      "frames", "PARENT,CHILD: the transform of a TF topic to take as the tracker's",
      [](R & r) -> auto& { return r.frames; }));
  t.push_back(field_option<R>(
      "field",
      "COLUMN=TOPIC:PATH: a numeric field of another message as a log column (q1=/enc:data[0], "
      "distance=/cable:range); repeatable, one topic a stream",
      [](R & r) -> auto& { return r.fields; }));
  auto time = parsed_option<R>(
      "time", OptionKind::kText,
      "header (the messages' stamps, the senders' clocks) or receive (the recorder's)",
      [](R& r, const OptionValue& v, const std::string&) {
        r.stamps = std::get<std::string>(v) == "receive" ? recording::StampSource::kReceive
                                                         : recording::StampSource::kHeader;
      },
      std::string("header"));
  time.words = {"header", "receive"};
  t.push_back(time);
  t.push_back(field_option<R>(
      "model", "Match JointState names to this model's joints, in its order",
      [](R & r) -> auto& { return r.model; }));
  t.push_back(field_option<R>(
      "convention",
      "A driver's published joints mapped to the device's readings: ros-geomagic, phantom-omni, "
      "touch-common, saw-sensable-phantom (Touch), dvrk-mtm; none: as published",
      [](R & r) -> auto& { return r.convention; }));
  t.push_back(field_option<R>(
      "tracker_export",
      "A tracker's CSV export (Motive, Vicon, or a CSV with --column-map) as tracker.csv",
      [](R & r) -> auto& { return r.tracker_export; }));
  t.push_back(export_option("body",
                            "The export's rigid body, segment or object (default: the only one)",
                            &recording::TrackerExportOptions::body));
  t.push_back(field_option<R>(
      "markers", "The export's markers to take, comma-separated",
      [](R & r) -> auto& { return r.export_options.markers; }));
  t.push_back(export_option("column_map",
                            "A generic CSV's columns: t=Time,x=X,y=Y,z=Z (qw..qz, rx..rz, x1..)",
                            &recording::TrackerExportOptions::column_map));
  t.push_back(export_option("length_unit",
                            "The export's length unit where it states none (m, cm, mm, um)",
                            &recording::TrackerExportOptions::length_unit));
  t.push_back(export_option("time_unit", "The export's time unit where it states none (s, ms)",
                            &recording::TrackerExportOptions::time_unit));
  t.push_back(parsed_option<R>(
      "static", OptionKind::kNumber,
      "Write a static log (log.csv: one row a pose) instead of the streams: the windows of at "
      "least SECONDS (in [0.001, 3600] s; 0: the streams) in which the readings stay within "
      "--still-tolerance, each averaged with the tracker's samples in it",
      [](R& r, const OptionValue& v, const std::string& as) {
        const double seconds = std::get<double>(v);
        if (seconds != 0) check_option(as, seconds, OptionRange{1e-3, 3600, "s"});
        r.still_seconds = seconds;
      }));
  // Without --static these are refused by the import itself.
  t.push_back(field_option<R>(
      "still_tolerance",
      "With --static: how far a reading may move in a still window [rad or m] (default 1e-4)",
      [](R & r) -> auto& { return r.still_tolerance; }, OptionRange{0, 1}));
  t.push_back(field_option<R>(
      "tracker_still",
      "With --static: how far the tracker's samples in a still window may lie from their median "
      "[m] (default 1e-3; a window in which the tracker moved is left out)",
      [](R & r) -> auto& { return r.tracker_still; }, OptionRange{0, 1, "m"}));
  t.push_back(field_option<R>(
      "clock_offset",
      "With --static: how far the tracker's clock is ahead of the device's [s] (the import "
      "suggests it when the speeds say the clocks differ)",
      [](R & r) -> auto& { return r.clock_offset; }, OptionRange{-3600, 3600, "s"}));
  t.push_back(field_option<R>(
      "list",
      "List the recording's topics (counts, rates, span, gaps); write "
      "nothing",
      [](R & r) -> auto& { return r.list; }));
  t.push_back(field_option<R>(
      "out",
      fmt::format("Output folder (replaced as a whole when the import is complete; default {})",
                  recording::kDefaultImportOut),
      [](R & r) -> auto& { return r.out; }));
  return t;
}

}  // namespace

const CommandOptions<recording::ImportRequest>& import_options() {
  static const CommandOptions<recording::ImportRequest> table = import_table();
  return table;
}

}  // namespace hapticcal
