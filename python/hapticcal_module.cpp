// The Python module `hapticcal`: the command line's commands as functions with
// numpy arrays in and out. Like apps/hapticcal, a thin shell over the library:
// options are mapped onto the same library calls, results come back as the
// same JSON the command line writes (parsed into dicts). Bad input raises
// ValueError with the command line's message (InputError, a
// std::invalid_argument); I/O errors raise OSError.
#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <future>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "bound_command.hpp"
#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/jobs/evaluate_job.hpp"
#include "hapticcal/jobs/force_job.hpp"
#include "hapticcal/jobs/iso_plan_job.hpp"
#include "hapticcal/jobs/plan_job.hpp"
#include "hapticcal/jobs/simulate_job.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/calibration_outputs.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/study.hpp"
#include "module_support.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace hapticcal::python {
namespace {

// What `hapticcal calibrate` computes, with the results.json it would write.
struct Calibration {
  std::optional<Model> model;  // the calibrated model, if usable (exit 0)
  std::string status, status_reason;
  bool usable = false;
  double rms_before = 0, rms_after = 0, cv_rms = 0;
  py::dict parameters;
  py::object results;  // results.json, parsed
  std::vector<std::string> notes;
  std::vector<std::string> lines;  // the command line's summary (calibration_lines)
  py::object search;               // results.json's model_search
  // A usable chain's: the model in the device's own frame (device.yaml) and
  // the device's frame in the measurement frame (setup.yaml's device_frame).
  std::optional<Model> device_model;
  std::optional<Eigen::Matrix4d> device_frame;
};

// calibrate(): the command line's job (jobs/calibrate_job.hpp) from its options'
// table; the model may be a Model (its URDF's tips and root with it).
const BoundCommand<CalibrateRequest>& calibrate_command() {
  static const BoundCommand<CalibrateRequest> command{
      "calibrate",
      "hapticcal calibrate: the two-step identification of a log, its model found by the model "
      "search (search=False: exactly the model the other keywords name). Does not raise when "
      "the calibration is not usable (the command line's exit 3): .usable is False, .model "
      "None.",
      "Calibration",
      &calibrate_options(),
      {"model"},
      [](CalibrateRequest& request, const std::string&, const Model& m) {
        request.nominal = m.model;
        request.model = m.path;
        request.tip = m.tip;
        request.root = m.root;
      }};
  return command;
}

Calibration calibration(const CalibrateJob& job, const CalibrateRequest& request);

Calibration calibrate(const py::args& args, const py::kwargs& kwargs) {
  const CalibrateRequest request = request_from(calibrate_command(), args, kwargs);
  CalibrateJob job;
  job = interruptible([&] { return run_calibrate_job(request); });
  return settled([&] { return calibration(job, request); });
}

// The Python view of a calibrate job's outcome.
Calibration calibration(const CalibrateJob& job, const CalibrateRequest& request) {
  const CalibrationResult& result = job.result;
  const std::string& json = job.results_json;
  Calibration c;
  c.usable = result.status == CalibrationStatus::kConverged;
  c.status = to_string(result.status);
  c.status_reason = result.status_reason;
  const KinematicFit& k = result.kinematics;
  c.rms_before = k.rms_before;
  c.rms_after = k.rms_after;
  c.cv_rms = k.cv_rms;
  for (const ParameterEstimate& e : k.parameters) {
    c.parameters[py::str(e.name)] =
        py::dict("value"_a = e.value, "nominal"_a = e.nominal, "sd"_a = e.sd,
                 "identifiable"_a = e.identifiable, "reason"_a = e.reason);
  }
  c.notes = result.notes;
  c.lines = job.lines;
  c.results = parsed(json);
  c.search = c.results.attr("get")("model_search");
  // A tree keeps the URDF it writes back into and its tips (calibrate it again).
  if (c.usable) {
    c.model = result.calibrated.tree()
                  ? Model{result.calibrated, request.model, request.tip, request.root}
                  : Model{result.calibrated, "", "", ""};
  }
  if (job.device_frame) {
    c.device_model = Model{job.device_frame->split.device, "", "", ""};
    c.device_frame = homogeneous(job.device_frame->split.device_in_measurement);
  }
  return c;
}

// evaluate(): the command line's job (jobs/evaluate_job.hpp) from its options'
// table; the model and the reference may be Models.
const BoundCommand<EvaluateRequest>& evaluate_command() {
  static const BoundCommand<EvaluateRequest> command{
      "evaluate",
      "hapticcal evaluate --json: the same keys, in metres ('clock' in the result with a "
      "tracker, 'iso9283' with an ISO 9283 plan).",
      "dict",
      &evaluate_options(),
      {"model", "reference"},
      [](EvaluateRequest& request, const std::string& name, const Model& m) {
        if (name == "model") {
          request.given = m.model;
          request.model = m.path;
        } else {
          request.given_reference = m.model;
          request.reference = m.path;
        }
      }};
  return command;
}

py::object evaluate(const py::args& args, const py::kwargs& kwargs) {
  const EvaluateRequest request = request_from(evaluate_command(), args, kwargs);
  EvaluateJob job;
  job = interruptible([&] { return run_evaluate_job(request); });
  return settled([&] { return parsed(job.json); });
}

// plan(iso9283=True): the standard's test cube (jobs/iso_plan_job.hpp).
py::dict iso_plan(const IsoPlanRequest& request, const std::string& out) {
  IsoPlanJob job;
  job = interruptible([&] { return run_iso_plan_job(request, out); });
  Eigen::MatrixXd readings(static_cast<Eigen::Index>(job.plan.poses.size()), job.model.dof());
  for (size_t k = 0; k < job.plan.poses.size(); ++k)
    readings.row(static_cast<Eigen::Index>(k)) = job.plan.poses[k].readings.transpose();
  return settled([&] {
    return py::dict("plan"_a = parsed(job.json), "readings"_a = readings, "out"_a = out,
                    "files"_a = std::vector<std::string>{out + "/plan.csv", out + "/iso9283.json",
                                                         out + "/report.html"});
  });
}

// plan(): the command line's jobs (jobs/plan_job.hpp, jobs/iso_plan_job.hpp)
// from its options' table; a Model given is its file.
const BoundCommand<PlanCommandRequest>& plan_command() {
  static const BoundCommand<PlanCommandRequest> command{
      "plan",
      "hapticcal plan: writes plan.csv, plan.json and the report into out; returns "
      "dict(plan=plan.json parsed, readings=poses x dof array, out, files). iso9283=True: the "
      "ISO 9283 test cube instead, plan the parsed iso9283.json, readings those of P1..P5.",
      "dict",
      &plan_options(),
      {"model"},
      [](PlanCommandRequest& request, const std::string&, const Model& m) {
        if (m.path.empty())
          throw InputError("plan: the model must be a file (save a Model changed in Python first)");
        request.plan.model = request.iso.model = m.path;
      }};
  return command;
}

py::dict plan(const py::args& args, const py::kwargs& kwargs) {
  const PlanCommandRequest command = request_from(plan_command(), args, kwargs);
  check_plan_command(command);
  if (command.iso9283) return iso_plan(command.iso, command.out);
  const PlanRequest& request = command.plan;
  const std::string& out = command.out;
  PlanJob job;
  job = interruptible([&] { return run_plan_job(request, out); });
  const std::string& json = job.json;
  const Plan& result = job.plan;
  return settled([&] {
    return py::dict("plan"_a = parsed(json), "readings"_a = result.readings, "out"_a = out,
                    "files"_a = std::vector<std::string>{out + "/plan.csv", out + "/plan.json",
                                                         out + "/report.html"});
  });
}

// simulate(): the command line's job (jobs/simulate_job.hpp) from its options' table.
const BoundCommand<SimulateRequest>& simulate_command() {
  static const BoundCommand<SimulateRequest> command{
      "simulate",
      "hapticcal simulate: writes its files into out; returns dict(results=results.json "
      "parsed, out, files).",
      "dict",
      &simulate_options(),
      {},
      {}};
  return command;
}

py::dict simulate(const py::args& args, const py::kwargs& kwargs) {
  const SimulateRequest request = request_from(simulate_command(), args, kwargs);
  SimulateJob job;
  job = interruptible([&] { return run_simulate_job(request); });
  const std::string& out = request.out;
  return settled([&] {
    return py::dict("results"_a = parsed(job.results_json), "out"_a = out,
                    "files"_a = std::vector<std::string>{
                        out + "/results.json", out + "/report.html", out + "/calibrated.yaml"});
  });
}

// force(): the command line's job (jobs/force_job.hpp) from its options' table.
const BoundCommand<ForceRequest>& force_command() {
  static const BoundCommand<ForceRequest> command{
      "force",
      "hapticcal force: the virtual-wall study into out; returns dict(results=results.json "
      "parsed, out).",
      "dict",
      &force_options(),
      {},
      {}};
  return command;
}

py::dict force(const py::args& args, const py::kwargs& kwargs) {
  const ForceRequest request = request_from(force_command(), args, kwargs);
  ForceJob job;
  job = interruptible([&] { return run_force_job(request); });
  return settled(
      [&] { return py::dict("results"_a = parsed(job.results_json), "out"_a = request.out); });
}

// convert(): the command line's job (jobs/force_job.hpp) from its options' table.
const BoundCommand<ConvertRequest>& convert_command() {
  static const BoundCommand<ConvertRequest> command{
      "convert",
      "hapticcal convert: a device file to URDF or back; returns dict(out, name, dof, "
      "with_transmission).",
      "dict",
      &convert_options(),
      {},
      {}};
  return command;
}

py::dict convert(const py::args& args, const py::kwargs& kwargs) {
  const ConvertRequest request = request_from(convert_command(), args, kwargs);
  const ConvertJob job = run_convert_job(request);
  return py::dict("out"_a = request.out, "name"_a = job.model.name, "dof"_a = job.model.dof(),
                  "with_transmission"_a = job.with_transmission);
}

}  // namespace
}  // namespace hapticcal::python

PYBIND11_MODULE(hapticcal, m) {
  using namespace hapticcal::python;
  using hapticcal::DeviceModel;
  m.doc() =
      "Kinematic calibration of haptic devices and robots (the hapticcal command line as "
      "functions). Lengths in metres, angles in radians.";
  py::register_exception<hapticcal::IoError>(m, "IoError", PyExc_OSError);
  // A job cancelled from another thread's Ctrl-C (interruptible).
  py::register_exception<hapticcal::Cancelled>(m, "Cancelled", PyExc_KeyboardInterrupt);

  bind_model(m);
  add_recording_functions(m);
  add_compensate_function(m);

  m.def(
      "load_model",
      [](const std::string& path, std::optional<std::string> tip, std::optional<std::string> root) {
        return Model{hapticcal::load_model(path, tip.value_or(""), root.value_or("")), path,
                     tip.value_or(""), root.value_or("")};
      },
      "path"_a, "tip"_a = py::none(), "root"_a = py::none(),
      "A device file (YAML) or a URDF (.urdf, with tip and root as --tip and --root; "
      "several tips, comma-separated, its tree)");

  py::class_<Calibration>(m, "CalibrationResult")
      .def_readonly("model", &Calibration::model, "The calibrated Model, None if not usable")
      .def_readonly("status", &Calibration::status, "results.json's status")
      .def_readonly("status_reason", &Calibration::status_reason)
      .def_readonly("usable", &Calibration::usable,
                    "status == 'converged' (the command line's exit 0; else its exit 3)")
      .def_readonly("rms_before", &Calibration::rms_before, "Training RMS residual, nominal [m]")
      .def_readonly("rms_after", &Calibration::rms_after, "Training RMS residual, calibrated [m]")
      .def_readonly("cv_rms", &Calibration::cv_rms, "K-fold held-out RMS [m] (nan if none)")
      .def_readonly("parameters", &Calibration::parameters,
                    "name -> dict(value, nominal, sd, identifiable, reason)")
      .def_readonly("results", &Calibration::results, "results.json of the command line, parsed")
      .def_readonly("notes", &Calibration::notes)
      .def_readonly("device_model", &Calibration::device_model,
                    "A usable chain's calibrated Model in the device's own frame (device.yaml: "
                    "the base and joint 1 as the nominal model places them), ending at "
                    "tool_point; None for a tree or an unusable calibration")
      .def_readonly("device_frame", &Calibration::device_frame,
                    "T_measurement_device (4x4): the device's frame in the measurement frame "
                    "(setup.yaml's device_frame), or None")
      .def_readonly("search", &Calibration::search,
                    "The model search: every candidate with its held-out RMS [m] and standard "
                    "error, the one kept (results.json's model_search)")
      .def_readonly("lines", &Calibration::lines,
                    "The summary the command line prints, a line each");

  {
    // The signatures and the keywords' help are the options tables' (doc_of).
    py::options bound;
    bound.disable_function_signatures();
    m.def("calibrate", &calibrate, doc_of(calibrate_command()).c_str());
    m.def("evaluate", &evaluate, doc_of(evaluate_command()).c_str());
    m.def("simulate", &simulate, doc_of(simulate_command()).c_str());
    m.def("force", &force, doc_of(force_command()).c_str());
    m.def("convert", &convert, doc_of(convert_command()).c_str());
    m.def("plan", &plan, doc_of(plan_command()).c_str());
  }
}
