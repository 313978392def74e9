#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <span>
#include <string>
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
