// The Python module's recordings in: import_recording, `hapticcal import` as a
// function (the same request, the summary as a dict).
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "bound_command.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/jobs/import_job.hpp"
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

// import_recording(): `hapticcal import` (run_import) from its options' table.
const BoundCommand<recording::ImportRequest>& import_command() {
  static const BoundCommand<recording::ImportRequest> command{
      "import_recording",
      "hapticcal import: a ROS 1 bag, MCAP file, rosbag2 .db3 (or tracker_export: a Motive, "
      "Vicon or mapped CSV) into device.csv and tracker.csv (static=SECONDS: log.csv of still "
      "poses) in out; returns the summary (format, topics with their counts, rates and gaps, "
      "joints, rows, notes, written). list=True writes nothing (out, model or a topic given "
      "with it is refused); still_tolerance and tracker_still need static.",
      "dict",
      &import_options(),
      {},
      {}};
  return command;
}

py::dict import_recording(const py::args& args, const py::kwargs& kwargs) {
  const recording::ImportRequest request = request_from(import_command(), args, kwargs);
  const auto result = interruptible([&] { return hapticcal::run_import(request); });
  return settled([&] { return summary(result); });
}

}  // namespace

void add_recording_functions(py::module_& m) {
  py::options bound;
  bound.disable_function_signatures();
  m.def("import_recording", &import_recording, doc_of(import_command()).c_str());
}

}  // namespace hapticcal::python
