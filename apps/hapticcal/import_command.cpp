// `hapticcal import`: a recording or a tracker's export in, hapticcal's
// streams (device.csv, tracker.csv) and a summary (import.json) out.
#include <fmt/format.h>

#include <string>

#include "commands.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/jobs/import_job.hpp"
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
  o.bound.bind(cmd, import_options());
  cmd->footer(
      "Examples:\n"
      "  hapticcal import session.bag --model geomagic-touch --convention ros-geomagic --out "
      "session\n"
      "  hapticcal import --tracker-export take.csv --body stylus --out take");
  return cmd;
}

int run_import(const ImportOptions& o) {
  recording::ImportRequest request;
  o.bound.apply(request);
  const recording::ImportResult r = hapticcal::run_import(request);
  if (!r.format.empty())
    fmt::print(
        "{}: {}\n",
        printable(request.recording.empty() ? request.tracker_export : request.recording, 200),
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
  if (request.list) return 0;
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
  fmt::print("wrote {}/: {}\n", request.out.empty() ? recording::kDefaultImportOut : request.out,
             fmt::join(r.written, ", "));
  return 0;
}

}  // namespace hapticcal::cli
