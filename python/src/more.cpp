// Bindings of identification, the rig, controllers, experiments, plots and reports.
#include "more.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/names.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/units.hpp"

namespace hysteron::python {

// A contiguous float64 array of any array-like (a copy where it is not one already).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::span<const double> as_span(const ArrayArg& a, std::string_view what) {
  if (!a.values) {
    // the dtype first: numpy casts a complex array to float64 with a ComplexWarning only
    py::array any;
    try {
      any = py::module_::import("numpy").attr("asarray")(a.obj);
    } catch (py::error_already_set& e) {  // a ragged list
      if (!e.matches(PyExc_TypeError) && !e.matches(PyExc_ValueError)) throw;
      throw_arg_type(a.obj, what, "an array of real numbers");
    }
    if (any.dtype().kind() == 'c')
      throw py::type_error(fmt::format("{}: a complex array (dtype {}): expected real numbers (numpy would drop the "
                                       "imaginary part; pass .real or abs() of it)",
                                       what, py::str(any.dtype()).cast<std::string>()));
    auto values = DoubleArray::ensure(any);
    if (!values) throw_arg_type(a.obj, what, "an array of real numbers");
    a.values = std::move(values);
  }
  const auto& v = py::reinterpret_borrow<DoubleArray>(a.values);
  const auto n = static_cast<std::size_t>(v.size());
  if (v.ndim() == 1 || (v.ndim() == 2 && (v.shape(0) == 1 || v.shape(1) == 1))) return {v.data(), n};
  std::string shape;
  for (py::ssize_t i = 0; i < v.ndim(); ++i) shape += fmt::format("{}{}", i ? ", " : "", v.shape(i));
  throw Error(fmt::format("{}: expected a one-dimensional array (or a column (N, 1) or a row (1, N)), got {}", what,
                          v.ndim() == 0 ? std::string("a scalar (shape ())") : fmt::format("shape ({})", shape)));
}

std::vector<double> as_vector(const ArrayArg& a, std::string_view what) {
  const auto s = as_span(a, what);
  return {s.begin(), s.end()};
}

bool is_path(const py::handle& obj) {
  return py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj) || py::hasattr(obj, "__fspath__");
}

std::string path_arg(const py::handle& obj, std::string_view what) {
  if (!is_path(obj)) throw_arg_type(obj, what, "a path (a str, bytes or an os.PathLike such as pathlib.Path)");
  return py::module_::import("os").attr("fsencode")(obj).cast<std::string>();  // (bytes: as they are)
}

std::span<const double> as_finite_span(const ArrayArg& a, const char* what) {
  const std::span<const double> s = as_span(a, what);
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!std::isfinite(s[i])) throw Error(fmt::format("{}[{}] = {}: not finite", what, i, s[i]));
  return s;
}

void throw_arg_type(const py::handle& obj, std::string_view what, std::string_view expected) {
  std::string repr = py::repr(obj).cast<std::string>();
  if (repr.size() > 80) repr = repr.substr(0, 77) + "...";
  throw py::type_error(fmt::format("{}: expected {}, got {} {}", what, expected,
                                   py::str(obj.get_type().attr("__name__")).cast<std::string>(), repr));
}

void throw_pickle_state(const py::handle& state, std::string_view what) {
  std::string repr = py::repr(state).cast<std::string>();
  if (repr.size() > 80) repr = repr.substr(0, 77) + "...";
  throw Error(fmt::format("{}: not a pickled state of this version of hysteron (expected ({}, parameters, "
                          "snapshot)), got {}",
                          what, pickle_format, repr));
}

void check_dict_keys(const py::dict& d, std::initializer_list<std::string_view> known, std::string_view where) {
  for (const auto& [k, v] : d) {
    const std::string key = py::str(k);
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string keys;
    for (const std::string_view n : known) keys += fmt::format("{}{}", keys.empty() ? "" : ", ", n);
    const std::string_view hint = io::closest_name(key, known);
    throw Error(fmt::format("{}: unknown key '{}'{} (the keys: {})", where, key,
                            hint.empty() ? "" : fmt::format(", did you mean '{}'?", hint), keys));
  }
}

double finite_arg(double v, const char* what) {
  if (!std::isfinite(v)) throw Error(fmt::format("{} = {}: not finite", what, v));
  return v;
}

io::ModelDocument model_document(const py::handle& spec, std::string_view what) {
  if (is_path(spec)) return io::read_model_document(path_arg(spec, what));
  if (py::isinstance<PyModel>(spec)) return spec.cast<const PyModel&>().document();
  if (!py::isinstance<py::dict>(spec))
    throw_arg_type(spec, what, "a model dict (the model-file keys), a model file path or a hysteron.Model");
  return io::model_document_from_json(to_json(spec, what), std::string(what));
}

std::string input_unit_refusal(const py::handle& spec, const io::ModelDocument& doc) {
  const std::string why = io::input_unit_mismatch(doc.unit("input"));
  if (why.empty()) return why;
  return is_path(spec) ? fmt::format("model {}: {}", path_arg(spec, "model"), why) : fmt::format("model: {}", why);
}

ModelParams model_spec(const py::handle& spec, std::string_view what) {
  if (py::isinstance<PyModel>(spec)) return spec.cast<const PyModel&>().params();
  return model_document(spec, what).params;
}

std::uint64_t uint_arg(const py::handle& obj, std::string_view what, std::uint64_t min, std::uint64_t max) {
  const std::string expected = min == 1 ? "a positive integer" : fmt::format("an integer >= {}", min);
  if (py::isinstance<py::bool_>(obj) || !PyIndex_Check(obj.ptr())) throw_arg_type(obj, what, expected);
  const auto i = py::reinterpret_steal<py::int_>(PyNumber_Index(obj.ptr()));
  if (!i) throw py::error_already_set();
  const auto compare = [&](std::uint64_t bound, int op) {
    const int r = PyObject_RichCompareBool(i.ptr(), py::int_(bound).ptr(), op);
    if (r < 0) throw py::error_already_set();
    return r != 0;
  };
  const std::string text = py::repr(i).cast<std::string>();
  // (hysteron.Error, a ValueError, as the C++ range checks the binding used to leave it to)
  if (compare(min, Py_LT)) throw Error(fmt::format("{} must be {}, got {}", what, expected, text));
  if (compare(max, Py_GT)) throw Error(fmt::format("{} = {} is too large (at most {})", what, text, max));
  return i.cast<std::uint64_t>();
}

std::pair<double, double> pair_arg(const py::handle& obj, std::string_view what) {
  return cast_arg<std::pair<double, double>>(obj, what, "(lo, hi), two numbers");
}

InitialState initial_state_from(const std::string& name) {
  if (name == "virgin") return InitialState::virgin;
  if (name == "relaxed") return InitialState::relaxed;
  throw py::value_error("initial_state must be 'virgin' or 'relaxed', not '" + name + "'");
}

// Results go to Python through the one serialization layer (hysteron/io/results.hpp):
// the dicts have the keys and values of the CLI's JSON (NaN and infinity become None).
py::dict metrics_dict(const FitMetrics& m) { return from_json(io::to_json(m)); }

py::dict fit_dict(const FitReport& r) {
  py::dict d = from_json(io::to_json(r));
  if (r.status == FitStatus::invalid_input) {  // nothing was fitted or scored: no metrics, not zeros (a perfect fit)
    d["train"] = py::none();
    d["reference"] = py::none();
  }
  d["ok"] = r.ok();
  d["report"] = r.full_report();
  return d;
}

void bind_more(py::module_& m) {
  bind_identify(m);
  bind_rig(m);
  bind_control(m);
  bind_experiment(m);
}

}  // namespace hysteron::python
