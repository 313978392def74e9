#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace hysteron::python {

namespace py = pybind11;

// A contiguous float64 copy of any array-like (numpy array, list).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

inline std::span<const double> as_span(const DoubleArray& a) {
  if (a.ndim() != 1) throw py::value_error("expected a one-dimensional array");
  return {a.data(), static_cast<std::size_t>(a.size())};
}

// as_span, and every value finite: hysteron::Error "WHAT[i] = nan: not finite" otherwise.
std::span<const double> as_finite_span(const DoubleArray& a, const char* what);
// A scalar argument that must be finite: hysteron::Error "WHAT = nan: not finite" otherwise.
double finite_arg(double v, const char* what);

// Arguments the bindings convert themselves (a tuple, a dict's value, a hysteron.Pid): pybind11's
// own failure is a RuntimeError "Unable to cast Python instance to C++ type" that names neither
// the argument nor what it takes. cast_arg raises TypeError "WHAT: expected EXPECTED, got TYPE
// REPR" instead.
[[noreturn]] void throw_arg_type(const py::handle& obj, std::string_view what, std::string_view expected);
template <class T>
T cast_arg(const py::handle& obj, std::string_view what, std::string_view expected) {
  if constexpr (std::is_same_v<T, py::dict>) {  // (a cast would try dict(obj): "cannot convert dictionary update ...")
    if (!py::isinstance<py::dict>(obj)) throw_arg_type(obj, what, expected);
    return py::reinterpret_borrow<py::dict>(obj);
  }
  try {
    return obj.cast<T>();
  } catch (const py::cast_error&) {
    throw_arg_type(obj, what, expected);
  } catch (py::error_already_set& e) {  // a py::object type (numpy array) is made by its constructor
    if (!e.matches(PyExc_TypeError) && !e.matches(PyExc_ValueError)) throw;
    throw_arg_type(obj, what, expected);
  }
}

// Every key of d is one of `known`: else hysteron::Error "WHERE: unknown key 'K', did you mean
// 'C'? (the keys: ...)", as the rig's and a loop's readers say it.
void check_dict_keys(const py::dict& d, std::initializer_list<std::string_view> known, std::string_view where);

inline py::array_t<double> to_numpy(const std::vector<double>& v) {
  py::array_t<double> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

// Python object (dict/list/number/str) <-> JSON, through the json module.
nlohmann::json to_json(const py::handle& obj);
py::object from_json(const nlohmann::json& j);

void bind_models(py::module_& m);  // models.cpp: Model, Inverse, model files
void bind_more(py::module_& m);    // more.cpp: fit, rig, controllers, experiments (as they exist)

}  // namespace hysteron::python
