// The Python module's Model class (bind_model): a device model with its file,
// its forward and inverse kinematics and Jacobians, and its parameters by name.
#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "module_support.hpp"

namespace hapticcal::python {

using namespace pybind11::literals;

namespace {

Eigen::VectorXd readings(const Model& m, const Eigen::VectorXd& q) {
  if (q.size() != m.model.dof()) {
    throw InputError(fmt::format("q has {} values, the model {} joints", q.size(), m.model.dof()));
  }
  return q;
}

py::dict parameters(const DeviceModel& model) {
  const Eigen::VectorXd values = model.kinematic_parameters();
  py::dict out;
  for (const ParameterInfo& p : model.parameter_info()) out[py::str(p.name)] = values[p.slot];
  return out;
}

void set_parameters(Model& m, const std::map<std::string, double>& values) {
  Eigen::VectorXd p = m.model.kinematic_parameters();
  const std::vector<ParameterInfo> info = m.model.parameter_info();
  for (const auto& [name, value] : values) {
    const auto it = std::find_if(info.begin(), info.end(),
                                 [&](const ParameterInfo& i) { return i.name == name; });
    if (it == info.end())
      throw InputError(fmt::format("{}: not a kinematic parameter of {}", name, m.model.name));
    p[it->slot] = value;
  }
  m.model.set_kinematic_parameters(p);
  m.path.clear();
}

}  // namespace

Eigen::Matrix4d homogeneous(const Frame<double>& T) {
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topLeftCorner<3, 3>() = T.R;
  out.topRightCorner<3, 1>() = T.p;
  return out;
}

// A tip of the model (ValueError out of range).
int tip_of(const Model& s, int tip) {
  if (tip < 0 || tip >= s.model.tips())
    throw py::value_error(fmt::format("tip {}: the model has {} tip(s)", tip, s.model.tips()));
  return tip;
}

// The Model class: a device model with its file, forward kinematics and
// Jacobians, its parameters by name.
void bind_model(py::module_& m) {
  py::class_<Model>(m, "Model")
      .def_property_readonly("name", [](const Model& s) { return s.model.name; })
      .def_property_readonly("dof", [](const Model& s) { return s.model.dof(); })
      .def_property_readonly(
          "path", [](const Model& s) { return s.path; },
          "The file it was loaded from ('' if made or changed in Python)")
      .def_property_readonly(
          "tips",
          [](const Model& s) {
            std::vector<std::string> names;
            for (int t = 0; t < s.model.tips(); ++t) names.push_back(s.model.tip_name(t));
            return names;
          },
          "The tips' names: a tree's (calibrate with tip='A,B'), or a chain's one")
      .def(
          "forward",
          [](const Model& s, const Eigen::VectorXd& q, int tip) {
            const Eigen::VectorXd r = readings(s, q);
            return homogeneous(hapticcal::PreparedModel(s.model).forward(r.data(), tip_of(s, tip)));
          },
          "q"_a, "tip"_a = 0,
          "T_meas_tool (4x4) of tip `tip` (a tree's; 0 for a chain) from the joint readings q "
          "(transmissions applied)")
      .def(
          "jacobian",
          [](const Model& s, const Eigen::VectorXd& q, const std::string& frame, int tip) {
            const Eigen::VectorXd r = readings(s, q);
            if (frame != "measurement" && frame != "tool") {
              throw hapticcal::InputError(
                  fmt::format("frame '{}': expected measurement or tool", frame));
            }
            hapticcal::Jacobian6<double> J(6, s.model.dof());
            hapticcal::PreparedModel(s.model).forward_jacobian(
                r.data(), tip_of(s, tip),
                frame == "tool" ? hapticcal::JacobianFrame::kTool
                                : hapticcal::JacobianFrame::kMeasurement,
                J.data());
            return Eigen::MatrixXd(J);
          },
          "q"_a, "frame"_a = "measurement", "tip"_a = 0,
          "Geometric Jacobian (6 x dof: linear velocity over angular) of tip `tip` w.r.t. the "
          "joint values (a tree's: zero for the joints off the tip's path)")
      .def(
          "compensate",
          [](const Model& s, const Eigen::VectorXd& q) {
            return s.model.compensate(readings(s, q));
          },
          "q"_a,
          "The joint values q + dtheta(q): the readings through the transmission models (a "
          "coupled model: C (q + dtheta(q)))")
      .def(
          "reading_jacobian",
          [](const Model& s, const Eigen::VectorXd& q) {
            return Eigen::MatrixXd(s.model.reading_jacobian(readings(s, q)));
          },
          "q"_a,
          "d theta / d q = C diag(1 + dtheta'(q)) (dof x dof): jacobian(q) @ reading_jacobian(q) "
          "is the Jacobian w.r.t. the readings, its transpose maps a wrench to the actuators")
      .def(
          "inverse",
          [](const Model& s, const Eigen::Matrix4d& target, const Eigen::VectorXd& q0,
             bool orientation, int tip) {
            const Eigen::VectorXd start = readings(s, q0);
            hapticcal::Frame<double> T;
            T.R = target.topLeftCorner<3, 3>();
            T.p = target.topRightCorner<3, 1>();
            hapticcal::InverseOptions o;
            o.orientation = orientation;
            o.tip = tip_of(s, tip);
            std::vector<double> lower(static_cast<size_t>(s.model.dof())), upper(lower);
            hapticcal::reading_limits(s.model, lower.data(), upper.data());
            Eigen::VectorXd q(s.model.dof());
            const hapticcal::InverseResult r =
                hapticcal::inverse_kinematics(hapticcal::PreparedModel(s.model), T, start.data(),
                                              q.data(), o, lower.data(), upper.data());
            return py::dict("q"_a = q, "status"_a = hapticcal::to_string(r.status),
                            "converged"_a = r.status != hapticcal::InverseStatus::kNotConverged,
                            "iterations"_a = r.iterations, "position_error"_a = r.position_error,
                            "rotation_error"_a = r.rotation_error,
                            "smallest_singular_value"_a = r.smallest_singular_value,
                            "outside_limit"_a = r.outside_limit < 0
                                                    ? py::object(py::none())
                                                    : py::object(py::int_(r.outside_limit)));
          },
          "target"_a, "q0"_a, "orientation"_a = true, "tip"_a = 0,
          "The readings at which tip `tip` is at `target` (T_meas_tool, 4x4; its rotation "
          "ignored without orientation), by damped least squares from the readings q0: a dict "
          "of q, status ('converged', 'near a singularity', 'outside the joint limits', 'not "
          "converged'), iterations, position_error [m], rotation_error [rad], "
          "smallest_singular_value and outside_limit (a joint's index, or None). Every effect "
          "of the model is in it; a solution outside the limits is returned, not clipped")
      .def_property_readonly(
          "coupling",
          [](const Model& s) {
            return s.model.coupled()
                       ? Eigen::MatrixXd(s.model.coupling)
                       : Eigen::MatrixXd(Eigen::MatrixXd::Identity(s.model.dof(), s.model.dof()));
          },
          "C of theta = C (q + dtheta(q)) (the identity for an uncoupled model)")
      .def(
          "parameters", [](const Model& s) { return parameters(s.model); },
          "The kinematic parameters by dotted name (j1.a, tool.x, ...)")
      .def("set_parameters", &set_parameters, "values"_a,
           "Sets kinematic parameters by dotted name (ValueError for an unknown name)")
      .def(
          "save",
          [](const Model& s, const std::string& path) { hapticcal::save_device(s.model, path); },
          "path"_a, "Writes the model as a device file (YAML)")
      .def("to_yaml", [](const Model& s) { return hapticcal::device_to_yaml(s.model); })
      .def("__repr__", [](const Model& s) {
        return fmt::format("<hapticcal.Model '{}', {} joints>", s.model.name, s.model.dof());
      });
}

}  // namespace hapticcal::python
