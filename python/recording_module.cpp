// The Python module's recordings in: import_recording, `hapticcal import` as a
// function (the same request, the summary as a dict).
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/import.hpp"
#include "module_support.hpp"

namespace hapticcal::python {
namespace {

using namespace pybind11::literals;

py::dict summary(const recording::ImportResult& r) {
  py::list topics;
  for (const recording::TopicSummary& t : r.topics) {
    topics.append(py::dict("topic"_a = t.topic, "type"_a = t.type, "encoding"_a = t.encoding,
                           "messages"_a = t.messages, "first"_a = t.first, "last"_a = t.last,
                           "rate"_a = t.rate, "gaps"_a = t.gaps, "largest_gap"_a = t.largest_gap,
                           "role"_a = t.role));
  }
  return py::dict("format"_a = r.format, "topics"_a = topics, "joints"_a = r.joint_names,
                  "device_rows"_a = r.device_rows, "tracker_rows"_a = r.tracker_rows,
                  "static_rows"_a = r.static_rows, "tracker_orientation"_a = r.tracker_orientation,
                  "notes"_a = r.notes, "written"_a = r.written, "out"_a = r.out);
}

py::dict import_recording(const Text& recording, const Text& joints, const Text& tracker_topic,
                          const Text& frames, const std::optional<Names>& field,
                          const std::string& time, const Text& model, const Text& convention,
                          const Text& tracker_export, const Text& body,
                          const std::optional<Names>& markers, const Text& column_map,
                          const Text& length_unit, const Text& time_unit, double still,
                          std::optional<double> still_tolerance,
                          std::optional<double> tracker_still, double clock_offset, const Text& out,
                          bool list) {
  recording::ImportRequest request;
  request.recording = text(recording);
  request.joints_topic = text(joints);
  request.tracker_topic = text(tracker_topic);
  request.frames = text(frames);
  request.fields = names(field);
  if (time != "header" && time != "receive")
    throw InputError("", 0, "time", "'" + printable(time) + "': header or receive");
  request.stamps =
      time == "receive" ? recording::StampSource::kReceive : recording::StampSource::kHeader;
  request.model = text(model);
  request.convention = text(convention);
  request.tracker_export = text(tracker_export);
  request.export_options.body = text(body);
  request.export_options.markers = names(markers);
  request.export_options.column_map = text(column_map);
  request.export_options.length_unit = text(length_unit);
  request.export_options.time_unit = text(time_unit);
  if (!(still == 0 || (still >= 1e-3 && still <= 3600)))
    throw InputError("", 0, "static", fmt::format("{}: not 0 or in [0.001, 3600] s", still));
  if (still_tolerance && !(*still_tolerance >= 0 && *still_tolerance <= 1))
    throw InputError("", 0, "still_tolerance", fmt::format("{}: not in [0, 1]", *still_tolerance));
  request.still_seconds = still;
  request.still_tolerance = still_tolerance;
  if (tracker_still && !(*tracker_still >= 0 && *tracker_still <= 1))
    throw InputError("", 0, "tracker_still", fmt::format("{}: not in [0, 1] m", *tracker_still));
  request.tracker_still = tracker_still;
  if (!(clock_offset >= -3600 && clock_offset <= 3600))
    throw InputError("", 0, "clock_offset",
                     fmt::format("{}: not in [-3600, 3600] s", clock_offset));
  request.clock_offset = clock_offset;
  request.out = text(out);
  request.list = list;
  const auto result = interruptible([&] { return recording::run_import(request); });
  return settled([&] { return summary(result); });
}

}  // namespace

void add_recording_functions(py::module_& m) {
  m.def("import_recording", &import_recording, "recording"_a = py::none(), py::kw_only(),
        "joints"_a = py::none(), "tracker_topic"_a = py::none(), "frames"_a = py::none(),
        "field"_a = py::none(), "time"_a = "header", "model"_a = py::none(),
        "convention"_a = py::none(), "tracker_export"_a = py::none(), "body"_a = py::none(),
        "markers"_a = py::none(), "column_map"_a = py::none(), "length_unit"_a = py::none(),
        "time_unit"_a = py::none(), "static"_a = 0.0, "still_tolerance"_a = py::none(),
        "tracker_still"_a = py::none(), "clock_offset"_a = 0.0, "out"_a = py::none(),
        "list"_a = false,
        "hapticcal import: a ROS 1 bag, MCAP file, rosbag2 .db3 (or tracker_export: a Motive, "
        "Vicon or mapped "
        "CSV) into device.csv and tracker.csv (static=SECONDS: log.csv of still poses) in out; "
        "returns the "
        "summary (format, topics with their counts, rates and gaps, joints, rows, notes, written). "
        "list=True writes nothing (out, model or a topic given with it is refused); "
        "still_tolerance (default 1e-4) and tracker_still (1e-3) need static.");
}

}  // namespace hapticcal::python
