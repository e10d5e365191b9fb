// What the Python module's files share: running a job so that Ctrl-C cancels
// it, the keyword conversions (a list as Python's list or the command line's
// text; a path that may be None), and the Model the functions take and return.
#pragma once

#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <chrono>
#include <future>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal::python {

namespace py = pybind11;

// How often a running job's thread looks for Ctrl-C [ms].
inline constexpr int kSignalPollMs = 50;

// Runs a job in a worker thread (the GIL released) while this thread, the
// interpreter's, looks for signals every 50 ms: on Ctrl-C the job is cancelled
// (core/cancel.hpp) and unwinds at its solver's next iteration without
// committing its output set (the previous one stays), and KeyboardInterrupt is
// raised here; a job that finished before it saw the request returns its
// result with a RuntimeWarning.
// Says that a Ctrl-C came as a job finished: its output set is committed and
// its result stands (a RuntimeWarning, an error if warnings are errors).
inline void warn_finished_despite_ctrl_c() {
  PyErr_Clear();
  if (PyErr_WarnEx(PyExc_RuntimeWarning,
                   "hapticcal: Ctrl-C came as the job finished: its results are written", 1) != 0)
    throw py::error_already_set();
}

template <class Job>
auto interruptible(Job&& job) {
  reset_cancel();
  std::packaged_task<decltype(job())()> task(std::forward<Job>(job));
  auto result = task.get_future();
  bool interrupted = false;
  {
    py::gil_scoped_release released;
    std::thread worker(std::move(task));
    while (result.wait_for(std::chrono::milliseconds(kSignalPollMs)) != std::future_status::ready) {
      const py::gil_scoped_acquire held;
      if (PyErr_CheckSignals() != 0) {  // KeyboardInterrupt set: raised below
        interrupted = true;
        request_cancel();
        break;
      }
    }
    worker.join();
  }
  if (interrupted) {
    // The job may have finished (its output set committed) before it saw the
    // request: its result then stands, and the Ctrl-C is said, not raised as
    // if the previous results were kept.
    try {
      auto value = result.get();
      warn_finished_despite_ctrl_c();
      return value;
    } catch (const py::error_already_set&) {
      throw;
    } catch (...) {
      throw py::error_already_set();  // the KeyboardInterrupt set above
    }
  }
  return result.get();
}

// A job's result handed to Python by `convert`, after interruptible()
// returned: the job's output set is committed, so a Ctrl-C that comes while the
// result is converted (json.loads is Python code, where the interpreter raises
// KeyboardInterrupt) must not end the call as if the previous set were kept.
// The conversion is done again and the Ctrl-C said, as in interruptible(); what
// is left is the interpreter's own moment between the last check here and the
// call's return.
template <class Convert>
auto settled(Convert&& convert) {
  bool came = false;
  for (;;) {
    try {
      auto result = convert();
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (came) warn_finished_despite_ctrl_c();
      return result;
    } catch (const py::error_already_set& e) {
      if (!e.matches(PyExc_KeyboardInterrupt)) throw;
      came = true;  // each retry needs another Ctrl-C: this ends
    }
  }
}

// A job's JSON text as Python's dicts and lists (json.loads).
inline py::object parsed(const std::string& json_text) {
  return py::module_::import("json").attr("loads")(json_text);
}

// A device model and the file it came from (the path results.json names; empty
// once its parameters are changed in Python).
struct Model {
  DeviceModel model;
  std::string path;
  std::string tip, root;  // a URDF's chain, as it was loaded
};

// T as a 4x4 homogeneous matrix (model_module.cpp).
Eigen::Matrix4d homogeneous(const Frame<double>& T);

// The Model class (model_module.cpp): forward, jacobian, inverse, parameters, save, ...
void bind_model(py::module_& m);

// The recording functions (recording_module.cpp): import_recording.
void add_recording_functions(py::module_& m);
// compensate (compensate_module.cpp).
void add_compensate_function(py::module_& m);

}  // namespace hapticcal::python
