// The Python module's compensate (jobs/compensate_job.hpp): the command line's
// job from keywords.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "bound_command.hpp"
#include "hapticcal/jobs/compensate_job.hpp"
#include "module_support.hpp"

namespace hapticcal::python {

using namespace pybind11::literals;

namespace {

// compensate(): the command line's job (jobs/compensate_job.hpp) from its
// options' table.
const BoundCommand<CompensateRequest>& compensate_command() {
  static const BoundCommand<CompensateRequest> command{
      "compensate",
      "hapticcal compensate: a program's targets for a controller that runs the nominal model "
      "(compensated.csv and results.json in out); returns dict(results, lines, out).",
      "dict",
      &compensate_options(),
      {},
      {}};
  return command;
}

}  // namespace

void add_compensate_function(py::module_& m) {
  py::options bound;
  bound.disable_function_signatures();
  m.def(
      "compensate",
      [](const py::args& args, const py::kwargs& kwargs) {
        const CompensateRequest request = request_from(compensate_command(), args, kwargs);
        const CompensateJob job = interruptible([&] { return run_compensate_job(request); });
        return settled([&] {
          return py::dict("results"_a = parsed(job.results_json), "lines"_a = job.lines,
                          "out"_a = request.out);
        });
      },
      doc_of(compensate_command()).c_str());
}

}  // namespace hapticcal::python
