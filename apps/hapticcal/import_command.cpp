// `hapticcal import`: a recording or a tracker's export in, hapticcal's
// streams (device.csv, tracker.csv) and a summary (import.json) out.
#include <fmt/format.h>

#include <string>

#include "commands.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/import.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

CLI::App* add_import_command(CLI::App& app, ImportOptions& o) {
  auto* cmd = app.add_subcommand("import",
                                 "Read a recording (ROS 1 bag, MCAP, rosbag2 .db3 or folder) or a "
                                 "tracker's CSV export (OptiTrack "
                                 "Motive, Vicon, any CSV with --column-map) into device.csv and "
                                 "tracker.csv for calibrate --log "
                                 "device.csv --tracker tracker.csv");
  cmd->add_option("RECORDING", o.recording,
                  "The recording (.bag, .mcap, .db3, or a rosbag2 folder)");
  cmd->add_option("--joints", o.joints,
                  "The sensor_msgs/JointState topic (default: the only one recorded)");
  cmd->add_option(
      "--tracker-topic", o.tracker_topic,
      "The tracker's PoseStamped, PointStamped or TransformStamped topic (default: the only one), "
      "or a tf2_msgs/TFMessage topic with --frames");
  cmd->add_option("--frames", o.frames,
                  "PARENT,CHILD: the transform of a TF topic to take as the tracker's");
  cmd->add_option(
      "--field", o.fields,
      "COLUMN=TOPIC:PATH: a numeric field of another message as a log column (q1=/enc:data[0], "
      "distance=/cable:range); repeatable, one topic a stream");
  cmd->add_option("--time", o.time,
                  "header (the messages' stamps, the senders' clocks) or receive (the "
                  "recorder's)")
      ->check(CLI::IsMember({"header", "receive"}));
  cmd->add_option("--model", o.model,
                  "Match JointState names to this model's joints, in its order");
  cmd->add_option(
      "--convention", o.convention,
      "A driver's published joints mapped to the device's readings: ros-geomagic, phantom-omni, "
      "touch-common, saw-sensable-phantom (Touch), dvrk-mtm; none: as published");
  cmd->add_option(
      "--tracker-export", o.tracker_export,
      "A tracker's CSV export (Motive, Vicon, or a CSV with --column-map) as tracker.csv");
  cmd->add_option("--body", o.body,
                  "The export's rigid body, segment or object (default: the only one)");
  cmd->add_option("--markers", o.markers, "The export's markers to take, comma-separated");
  cmd->add_option("--column-map", o.column_map,
                  "A generic CSV's columns: t=Time,x=X,y=Y,z=Z (qw..qz, rx..rz, x1..)");
  cmd->add_option("--length-unit", o.length_unit,
                  "The export's length unit where it states none (m, cm, mm, um)");
  cmd->add_option("--time-unit", o.time_unit,
                  "The export's time unit where it states none (s, ms)");
  cmd->add_option("--static", o.still_seconds,
                  "Write a static log (log.csv: one row a pose) instead of the streams: "
                  "the windows of at least SECONDS in which the readings stay within "
                  "--still-tolerance, each averaged with the tracker's samples in it")
      ->check(CLI::Range(1e-3, 3600.0));
  // Without --static these are refused by the import itself (as in Python).
  cmd->add_option_function<double>(
         "--still-tolerance", [&o](double v) { o.still_tolerance = v; },
         "With --static: how far a reading may move in a still window [rad or m] (default 1e-4)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option_function<double>(
         "--tracker-still", [&o](double v) { o.tracker_still = v; },
         "With --static: how far the tracker's samples in a still window may lie from their "
         "median [m] (default 1e-3; a window in which the tracker moved is left out)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--clock-offset", o.clock_offset,
                  "With --static: how far the tracker's clock is ahead of the device's [s] "
                  "(default 0; the import suggests it when the speeds say the clocks differ)")
      ->check(CLI::Range(-3600.0, 3600.0));
  cmd->add_flag("--list", o.list,
                "List the recording's topics (counts, rates, span, gaps); write nothing");
  cmd->add_option("--out", o.out,
                  "Output folder (replaced as a whole when the import is complete; default "
                  "hapticcal-out/import)");
  cmd->footer(
      "Examples:\n"
      "  hapticcal import session.bag --model geomagic-touch --convention ros-geomagic --out "
      "session\n"
      "  hapticcal import --tracker-export take.csv --body stylus --out take");
  return cmd;
}

int run_import(const ImportOptions& o) {
  recording::ImportRequest request;
  request.recording = o.recording;
  request.joints_topic = o.joints;
  request.tracker_topic = o.tracker_topic;
  request.frames = o.frames;
  request.fields = o.fields;
  request.stamps =
      o.time == "receive" ? recording::StampSource::kReceive : recording::StampSource::kHeader;
  request.model = o.model;
  request.convention = o.convention;
  request.tracker_export = o.tracker_export;
  request.export_options.body = o.body;
  if (!o.markers.empty()) {
    std::size_t start = 0;
    while (start <= o.markers.size()) {
      const std::size_t comma = std::min(o.markers.find(',', start), o.markers.size());
      request.export_options.markers.push_back(o.markers.substr(start, comma - start));
      start = comma + 1;
    }
  }
  request.export_options.column_map = o.column_map;
  request.export_options.length_unit = o.length_unit;
  request.export_options.time_unit = o.time_unit;
  request.out = o.out;
  request.list = o.list;
  request.still_seconds = o.still_seconds;
  request.still_tolerance = o.still_tolerance;
  request.tracker_still = o.tracker_still;
  request.clock_offset = o.clock_offset;
  const recording::ImportResult r = recording::run_import(request);
  if (!r.format.empty())
    fmt::print("{}: {}\n", printable(o.recording.empty() ? o.tracker_export : o.recording, 200),
               r.format);
  if (!r.topics.empty()) {
    fmt::print("{:<32} {:<32} {:>9} {:>10} {:>10} {:>9} {:>5} {}\n", "topic", "type", "messages",
               "first [s]", "last [s]", "rate [Hz]", "gaps", "imported as");
    for (const recording::TopicSummary& t : r.topics) {
      fmt::print(
          "{:<32} {:<32} {:>9} {:>10.3f} {:>10.3f} {:>9.1f} {:>5} {}\n", printable(t.topic, 32),
          t.type, t.messages, t.first, t.last, t.rate, t.gaps,
          t.role.empty()
              ? "-"
              : t.role + (t.gaps > 0 ? fmt::format(" (largest gap {:.3f} s)", t.largest_gap) : ""));
    }
  }
  for (const std::string& note : r.notes) fmt::print("{}\n", note);
  if (o.list) return 0;
  if (r.device_rows > 0) {
    // At most the first joints' names: a recording may name 100,000.
    constexpr std::size_t kShown = 12;
    const std::size_t n = r.joint_names.size();
    std::string names;
    for (std::size_t k = 0; k < n && k < kShown; ++k)
      names += (k == 0 ? "" : ", ") + printable(r.joint_names[k], 80);
    if (n > kShown) names += fmt::format(", ... and {} more", n - kShown);
    fmt::print("device.csv: {} rows, q1..q{} = {}\n", r.device_rows, n, names);
  }
  if (r.static_rows > 0) fmt::print("log.csv: {} still poses\n", r.static_rows);
  if (r.tracker_rows > 0)
    fmt::print("tracker.csv: {} rows, {}\n", r.tracker_rows,
               r.tracker_orientation ? "positions and orientations" : "positions");
  fmt::print("wrote {}/: {}\n", o.out.empty() ? recording::kDefaultImportOut : o.out,
             fmt::join(r.written, ", "));
  return 0;
}

}  // namespace hapticcal::cli
