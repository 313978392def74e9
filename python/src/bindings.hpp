#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <initializer_list>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace hysteron::python {

namespace py = pybind11;

// Arguments a signature takes as the caller passed them (any object; help() shows the type
// named here), converted in the body by the one helper that names the argument in its errors,
// instead of pybind11's "incompatible function arguments": ArrayArg by as_span, IntArg by
// uint_arg / int_arg, PathArg by path_arg.
struct ArrayArg {
  static constexpr auto py_name = py::detail::const_name("numpy.ndarray[numpy.float64]");
  py::object obj;
  mutable py::object values;  // the float64 array as_span made (it holds the span's data)
};
struct IntArg {
  static constexpr auto py_name = py::detail::const_name("int");
  py::object obj;
};
struct PathArg {
  static constexpr auto py_name = py::detail::const_name("os.PathLike");
  py::object obj;
};

// The values of a one-dimensional array of real numbers (a numpy array, a list; a float64
// C-contiguous array is not copied: the span is its buffer); a column (N, 1) or a row (1, N)
// (scipy.io.loadmat's vectors) is taken as its N values. TypeError "WHAT: ..." for a complex
// array (numpy would drop the imaginary part with a warning only) or what is no array of
// numbers; hysteron::Error "WHAT: expected a one-dimensional array (or (N, 1), (1, N)), got
// shape (3, 2)" for another shape.
std::span<const double> as_span(const ArrayArg& a, std::string_view what);
// as_span, copied: for work without the GIL, while another thread may change the caller's array.
std::vector<double> as_vector(const ArrayArg& a, std::string_view what);
// as_span, and every value finite: hysteron::Error "WHAT[i] = nan: not finite" otherwise.
std::span<const double> as_finite_span(const ArrayArg& a, const char* what);
// A scalar argument that must be finite: hysteron::Error "WHAT = nan: not finite" otherwise.
double finite_arg(double v, const char* what);

// An integer argument in [min, max] (a Python int or a numpy integer; not a bool, not a float):
// TypeError "WHAT: expected an integer >= 0, got float 2.5"; hysteron::Error (a ValueError) "WHAT
// must be a positive integer, got -1" (min 1) or "WHAT must be an integer >= 0, got -1", or "WHAT =
// N is too large (at most MAX)". int_arg: the same into an int (at most 2**31 - 1).
std::uint64_t uint_arg(const py::handle& obj, std::string_view what, std::uint64_t min = 0,
                       std::uint64_t max = std::numeric_limits<std::uint64_t>::max());
inline std::uint64_t uint_arg(const IntArg& a, std::string_view what, std::uint64_t min = 0,
                              std::uint64_t max = std::numeric_limits<std::uint64_t>::max()) {
  return uint_arg(a.obj, what, min, max);
}
inline int int_arg(const py::handle& obj, std::string_view what, int min = 0) {
  return static_cast<int>(uint_arg(obj, what, static_cast<std::uint64_t>(min), std::numeric_limits<int>::max()));
}
inline int int_arg(const IntArg& a, std::string_view what, int min = 0) { return int_arg(a.obj, what, min); }

// A path argument: a str, bytes or an os.PathLike (pathlib.Path), as the file system's bytes
// (os.fsencode: a name that is not UTF-8 too); TypeError naming WHAT otherwise. is_path:
// whether obj is one.
bool is_path(const py::handle& obj);
std::string path_arg(const py::handle& obj, std::string_view what);
inline std::string path_arg(const PathArg& a, std::string_view what) { return path_arg(a.obj, what); }

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

// copy.copy and copy.deepcopy of a bound class: the C++ copy, its state included.
template <class C>
C def_copy(C c) {
  using T = typename C::type;
  c.def("__copy__", [](const T& self) { return T(self); }, "A copy in the same state.");
  c.def("__deepcopy__", [](const T& self, const py::handle&) { return T(self); }, py::arg("memo"),
        "A copy in the same state.");
  return c;
}

// pickle of a bound class T with snapshot() / restore(): the state is the tuple (pickle_format,
// spec(t), t.snapshot()), and make(spec) builds the object again (of the same parameters, from the one
// serialisable form it has: a model's JSON, ...) before restore() sets its state. WHAT names
// the class in errors.
constexpr int pickle_format = 1;
[[noreturn]] void throw_pickle_state(const py::handle& state, std::string_view what);
template <class C, class Spec, class Make>
C def_pickle(C c, const char* what, Spec spec, Make make) {
  using T = typename C::type;
  c.def(py::pickle([spec](const T& t) { return py::make_tuple(pickle_format, spec(t), t.snapshot()); },
                   [make, what](const py::tuple& state) {
                     if (state.size() != 3 || !py::int_(pickle_format).equal(state[0]))
                       throw_pickle_state(state, what);
                     T t = make(state[1]);
                     t.restore(cast_arg<std::vector<double>>(state[2], fmt::format("{}: pickled state", what),
                                                             "a list of numbers"));
                     return t;
                   }));
  return c;
}

void bind_models(py::module_& m);  // models.cpp: Model, Inverse, model files
void bind_more(py::module_& m);    // more.cpp: fit, rig, controllers, experiments (as they exist)

}  // namespace hysteron::python

namespace pybind11::detail {
// The casters of ArrayArg, IntArg, PathArg: any object, as it is.
template <class T>
struct any_object_caster {
  PYBIND11_TYPE_CASTER(T, T::py_name);
  bool load(handle src, bool) {
    value.obj = reinterpret_borrow<object>(src);
    return true;
  }
  static handle cast(const T& v, return_value_policy, handle) { return v.obj.inc_ref(); }
};
template <> struct type_caster<hysteron::python::ArrayArg> : any_object_caster<hysteron::python::ArrayArg> {};
template <> struct type_caster<hysteron::python::IntArg> : any_object_caster<hysteron::python::IntArg> {};
template <> struct type_caster<hysteron::python::PathArg> : any_object_caster<hysteron::python::PathArg> {};
}  // namespace pybind11::detail
