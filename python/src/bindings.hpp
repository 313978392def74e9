#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <nlohmann/json.hpp>

#include <filesystem>
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

// The values of a one-dimensional array; a column (N, 1) or a row (1, N) (scipy.io.loadmat's
// vectors) is taken as its N values (the array is C-contiguous). Any other shape is
// hysteron::Error "WHAT: expected a one-dimensional array (or (N, 1), (1, N)), got shape (3, 2)".
std::span<const double> as_span(const DoubleArray& a, std::string_view what);

// as_span, and every value finite: hysteron::Error "WHAT[i] = nan: not finite" otherwise.
std::span<const double> as_finite_span(const DoubleArray& a, const char* what);
// A scalar argument that must be finite: hysteron::Error "WHAT = nan: not finite" otherwise.
double finite_arg(double v, const char* what);

// A path argument: a str or an os.PathLike (pathlib.Path; os.fspath); a TypeError naming WHAT
// otherwise. is_path: whether obj is one.
bool is_path(const py::handle& obj);
std::string path_arg(const py::handle& obj, std::string_view what);

// An output or input path argument a signature takes: a str or an os.PathLike (pybind11 converts).
using PathArg = std::filesystem::path;

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

// Python object (dict/list/number/str) <-> JSON, through the json module; `what` names the
// argument in errors ("Model: spec: a PosixPath is not a number, string, list or dict").
nlohmann::json to_json(const py::handle& obj, std::string_view what = "Python object");
py::object from_json(const nlohmann::json& j);

void bind_models(py::module_& m);  // models.cpp: Model, Inverse, model files
void bind_more(py::module_& m);    // more.cpp: fit, rig, controllers, experiments (as they exist)

}  // namespace hysteron::python
