// A command's options (jobs/command_options.hpp) as a Python function's
// parameters: the required options positional (in the table's order), the rest
// keywords with the defaults the command line shows; the function's signature
// and its keywords' help are written from the table, and a call's arguments
// are read into the command's request through it, so a keyword, its default
// and its range are the command line's.
#pragma once

#include <pybind11/pybind11.h>

#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "hapticcal/jobs/command_options.hpp"
#include "module_support.hpp"

namespace hapticcal::python {

namespace py = pybind11;

template <class Request>
struct BoundCommand {
  std::string name;     // the Python function's
  std::string summary;  // its doc's first paragraph
  std::string returns;  // its return annotation
  const CommandOptions<Request>* table = nullptr;
  // The keywords the module also takes as a Model instead of a path, and how:
  // run after the table's keywords (a Model's tip and root win).
  std::set<std::string> models;
  std::function<void(Request&, const std::string&, const Model&)> take_model;
};

namespace bound_detail {

// Python's True and False, and NumPy's (numpy.bool_).
inline bool is_bool(py::handle v) {
  const std::string type = Py_TYPE(v.ptr())->tp_name;
  return py::isinstance<py::bool_>(v) || type == "numpy.bool_" || type == "numpy.bool";
}
// A whole number: an int or what stands for one (numpy.int64), not a bool.
inline bool is_int(py::handle v) { return PyIndex_Check(v.ptr()) && !is_bool(v); }
// A real number: an int, a float or NumPy's, not a bool or a text.
inline bool is_number(py::handle v) {
  return (is_int(v) || PyFloat_Check(v.ptr()) || PyNumber_Check(v.ptr())) && !is_bool(v) &&
         !py::isinstance<py::str>(v);
}
// A list, a tuple or an array of them (numpy.ndarray), not a text.
inline bool is_sequence(py::handle v) {
  return py::isinstance<py::sequence>(v) && !py::isinstance<py::str>(v) &&
         !py::isinstance<py::bytes>(v);
}

inline std::string annotation(OptionKind kind, bool numbers = false) {
  if (numbers) return "str | list[float]";
  switch (kind) {
    case OptionKind::kFlag:
      return "bool";
    case OptionKind::kWhole:
      return "int";
    case OptionKind::kNumber:
      return "float";
    case OptionKind::kText:
      return "str";
    case OptionKind::kList:
      return "list[str] | str";
  }
  return "object";
}

// A keyword's value as the command line's option would give it; a wrong type
// is Python's TypeError. A text of numbers (a point, a marker body) also takes
// a list of them, written X,Y,Z as the command line's.
template <class Request>
OptionValue value_of(const std::string& function, const CommandOption<Request>& o, py::handle v) {
  const auto wrong = [&] {
    return py::type_error(
        fmt::format("{}(): {} takes {}, not {}", function, o.name, annotation(o.kind, o.numbers),
                    py::str(py::type::of(v).attr("__name__")).cast<std::string>()));
  };
  switch (o.kind) {
    case OptionKind::kFlag:
      if (!is_bool(v)) throw wrong();
      return PyObject_IsTrue(v.ptr()) == 1;  // the field's value: search=False is --no-search
    case OptionKind::kWhole: {
      if (!is_int(v)) throw wrong();
      const long long whole =
          PyLong_AsLongLong(py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr())).ptr());
      if (whole == -1 && PyErr_Occurred()) {
        PyErr_Clear();
        throw InputError(fmt::format("{} {}: too large", o.flag(), py::str(v).cast<std::string>()));
      }
      return whole;
    }
    case OptionKind::kNumber:
      if (!is_number(v)) throw wrong();
      return py::float_(py::reinterpret_borrow<py::object>(v)).cast<double>();
    case OptionKind::kText:
      if (py::isinstance<py::str>(v)) return v.cast<std::string>();
      if (o.numbers && is_sequence(v)) {
        std::vector<std::string> items;
        for (py::handle item : v) {
          if (!is_number(item)) throw wrong();
          items.push_back(fmt::format(
              "{}", py::float_(py::reinterpret_borrow<py::object>(item)).cast<double>()));
        }
        return fmt::format("{}", fmt::join(items, ","));
      }
      throw wrong();
    case OptionKind::kList:
      if (py::isinstance<py::str>(v)) return std::vector<std::string>{v.cast<std::string>()};
      if (!is_sequence(v)) throw wrong();
      for (py::handle item : v)
        if (!py::isinstance<py::str>(item)) throw wrong();
      return v.cast<std::vector<std::string>>();
  }
  throw wrong();
}

}  // namespace bound_detail

// Python's positional parameters: the required options, then the others marked
// positional, each in the table's order.
template <class Request>
std::vector<const CommandOption<Request>*> positional_options(const CommandOptions<Request>& t) {
  std::vector<const CommandOption<Request>*> positional;
  for (const CommandOption<Request>& o : t)
    if (o.required) positional.push_back(&o);
  for (const CommandOption<Request>& o : t)
    if (o.positional && !o.required) positional.push_back(&o);
  return positional;
}

// The function's doc: its signature line (as pybind11 writes one), its summary,
// and each keyword's help.
template <class Request>
std::string doc_of(const BoundCommand<Request>& c) {
  std::vector<std::string> parameters, helps;
  std::vector<const CommandOption<Request>*> in_order = positional_options(*c.table);
  const size_t positional = in_order.size();
  for (const CommandOption<Request>& o : *c.table)
    if (!o.required && !o.positional) in_order.push_back(&o);
  for (size_t i = 0; i < in_order.size(); ++i) {
    const CommandOption<Request>& o = *in_order[i];
    if (i == positional) parameters.push_back("*");
    std::string parameter =
        o.name + ": " +
        (c.models.count(o.name) ? "Model | str" : bound_detail::annotation(o.kind, o.numbers));
    if (o.kind == OptionKind::kFlag) {
      parameter += o.negated ? " = True" : " = False";
    } else if (o.shown && std::holds_alternative<std::string>(*o.shown)) {
      parameter += " = '" + shown_text(*o.shown) + "'";
    } else if (o.shown) {
      parameter += " = " + shown_text(*o.shown);
    } else if (!o.required) {
      parameter += " | None = None";
    }
    parameters.push_back(parameter);
    helps.push_back(fmt::format("{}: {}", o.name, o.help));
  }
  return fmt::format("{}({}) -> {}\n\n{}\n\n{}\n", c.name, fmt::join(parameters, ", "), c.returns,
                     c.summary, fmt::join(helps, "\n"));
}

// A call's arguments read into a request: positional ones are the required
// options in order; None is a keyword not given; anything else unknown, given
// twice or missing is Python's TypeError, a bad value InputError (ValueError)
// naming the command line's option, as the other commands' messages do.
template <class Request>
Request request_from(const BoundCommand<Request>& c, const py::args& args,
                     const py::kwargs& kwargs) {
  const std::vector<const CommandOption<Request>*> positional = positional_options(*c.table);
  if (args.size() > positional.size()) {
    throw py::type_error(fmt::format("{}() takes {} positional arguments but {} were given", c.name,
                                     positional.size(), args.size()));
  }
  std::vector<std::pair<std::string, py::handle>> given;
  for (size_t i = 0; i < args.size(); ++i) given.emplace_back(positional[i]->name, args[i]);
  for (const auto& [key, value] : kwargs) {
    const std::string name = py::str(key);
    for (const auto& [earlier, _] : given) {
      if (earlier == name)
        throw py::type_error(
            fmt::format("{}() got multiple values for argument '{}'", c.name, name));
    }
    given.emplace_back(name, value);
  }
  for (const CommandOption<Request>* o : positional) {
    if (!o->required) continue;
    bool found = false;
    for (const auto& [name, value] : given) found = found || (name == o->name && !value.is_none());
    if (!found)
      throw py::type_error(fmt::format("{}() missing required argument: '{}'", c.name, o->name));
  }
  Request request;
  std::vector<std::pair<std::string, py::handle>> models;
  std::set<std::string> set;
  for (const auto& [name, value] : given) {
    const CommandOption<Request>* o = find_option(*c.table, name);
    if (!o)
      throw py::type_error(
          fmt::format("{}() got an unexpected keyword argument '{}'", c.name, name));
    if (value.is_none()) continue;
    if (c.models.count(name) && py::isinstance<Model>(value)) {
      models.emplace_back(name, value);
      set.insert(name);
      continue;
    }
    const OptionValue read = bound_detail::value_of(c.name, *o, value);
    set_option(*o, request, read, o->flag());
    // A flag given as its default (clock_drift=False) is not an option used.
    if (o->kind != OptionKind::kFlag || std::get<bool>(read) != o->negated) set.insert(name);
  }
  for (const auto& [name, value] : models)
    c.take_model(request, name, py::cast<const Model&>(value));
  for (const CommandOption<Request>& o : *c.table) {
    if (!o.needs.empty() && set.count(o.name) && !set.count(o.needs))
      throw InputError(
          fmt::format("{}: needs {}", o.flag(), find_option(*c.table, o.needs)->flag()));
  }
  return request;
}

}  // namespace hapticcal::python
