// The Python module's compensate (jobs/compensate_job.hpp): the command line's
// job from keywords.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "hapticcal/jobs/compensate_job.hpp"
#include "module_support.hpp"

namespace hapticcal::python {

using namespace pybind11::literals;

void add_compensate_function(py::module_& m) {
  m.def(
      "compensate",
      [](const std::string& model, const std::string& nominal, const std::string& targets,
         double load, const Text& columns, const Text& tip, const Text& root, const Text& out) {
        CompensateRequest request;
        request.model = model;
        request.nominal = nominal;
        request.targets = targets;
        request.columns = text(columns);
        request.tip = text(tip);
        request.root = text(root);
        request.options.load = load;  // checked by the job (with_load)
        request.out = out.value_or("hapticcal-out/compensate");
        const CompensateJob job = interruptible([&] { return run_compensate_job(request); });
        return settled([&] {
          return py::dict(
              "results"_a = py::module_::import("json").attr("loads")(job.results_json),
              "lines"_a = job.lines, "out"_a = request.out);
        });
      },
      "model"_a, "nominal"_a, "targets"_a, py::kw_only(), "load"_a = 0.0, "columns"_a = py::none(),
      "tip"_a = py::none(), "root"_a = py::none(), "out"_a = py::none(),
      "hapticcal compensate: a program's targets for a controller that runs the nominal model "
      "(compensated.csv and results.json in `out`, default hapticcal-out/compensate); returns "
      "{results, lines, out}");
}

}  // namespace hapticcal::python
