// Bindings of the core models and inverses.
#include <fmt/format.h>

#include <cmath>

#include "bindings.hpp"
#include "more.hpp"
#include "hysteron/error.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/models.hpp"

namespace hysteron::python {

// A Python dict/list (numpy scalars and arrays included, via their tolist())
// as JSON. NaN, infinities and objects JSON cannot hold are hysteron.Error.
namespace {
// The path of the first NaN or infinite float in a dict / list / tuple / array tree ("" if none):
// the key a JSON conversion refused (e.g. input_limits[0] = -inf, where None is an unbounded side).
std::string non_finite_path(const py::handle& o, const std::string& at, int depth = 0) {
  if (depth > 64) return {};
  if (py::isinstance<py::dict>(o)) {
    for (const auto& [k, v] : py::reinterpret_borrow<py::dict>(o)) {
      const std::string key = py::str(k).cast<std::string>();
      if (std::string p = non_finite_path(v, at.empty() ? key : at + "." + key, depth + 1); !p.empty()) return p;
    }
    return {};
  }
  if (py::isinstance<py::str>(o) || py::isinstance<py::bytes>(o)) return {};
  if (py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o) || py::hasattr(o, "tolist")) {
    const py::object items = py::hasattr(o, "tolist") ? o.attr("tolist")() : py::reinterpret_borrow<py::object>(o);
    if (!py::isinstance<py::list>(items) && !py::isinstance<py::tuple>(items)) return non_finite_path(items, at, depth + 1);
    std::size_t i = 0;
    for (const auto& v : items) {
      if (std::string p = non_finite_path(v, fmt::format("{}[{}]", at, i), depth + 1); !p.empty()) return p;
      ++i;
    }
    return {};
  }
  if (py::isinstance<py::float_>(o) && !std::isfinite(o.cast<double>()))
    return fmt::format("{} = {}", at.empty() ? "the value" : at, py::str(o).cast<std::string>());
  return {};
}
}  // namespace

nlohmann::json to_json(const py::handle& obj, std::string_view what) {
  using namespace pybind11::literals;
  const auto dumps = py::module_::import("json").attr("dumps");
  const py::cpp_function numpy_to_python([](py::handle o) -> py::object {
    if (py::hasattr(o, "tolist")) return o.attr("tolist")();
    throw py::type_error(fmt::format("a {} is not a number, string, list or dict",
                                     py::str(o.get_type().attr("__name__")).cast<std::string>()));
  });
  std::string text;
  try {
    text = dumps(obj, "default"_a = numpy_to_python, "allow_nan"_a = false).cast<std::string>();
  } catch (py::error_already_set& e) {
    // the exception's own message, not e.what() (which carries a Python traceback)
    const std::string message = py::str(e.value()).cast<std::string>();
    if (message.find("Out of range float") != std::string::npos) {
      const std::string at = non_finite_path(obj, "");
      throw Error(fmt::format("{}: {} is NaN or infinite (JSON and model files hold finite numbers only; an unbounded "
                              "side of input_limits is None)",
                              what, at.empty() ? std::string("a value") : at));
    }
    throw Error(fmt::format("{}: cannot convert to JSON: {}", what, message));
  }
  return io::parse_json(text, std::string(what));
}

py::object from_json(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

void bind_models(py::module_& m) {
  static PyObject* error_type = py::register_exception<Error>(m, "Error", PyExc_ValueError).ptr();
  // (registered after, so tried first) the message decoded as os.fsdecode does: a file name
  // that is not UTF-8 appears as the str the caller passed, not as a UnicodeDecodeError
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      const std::string_view text = e.what();
      const auto message = py::reinterpret_steal<py::object>(
          PyUnicode_DecodeUTF8(text.data(), static_cast<py::ssize_t>(text.size()), "surrogateescape"));
      if (message) PyErr_SetObject(error_type, message.ptr());
    }
  });
  m.attr("Error").attr("__doc__") =
      "Every error of hysteron (bad input, bad parameters, unreadable or unwritable files), with the C++ message "
      "naming what and where. A subclass of ValueError.";

  // pickle: the model file's JSON (io::model_to_json, io::model_document_from_json; a Model's with
  // its free-form keys) and Model::snapshot()
  const auto model_json = [](const ModelParams& p) { return io::model_to_json(p).dump(); };
  const auto document_from = [](const py::handle& text) {
    return io::model_document_from_json(
        io::parse_json(cast_arg<std::string>(text, "pickled model", "a str"), "pickled model"), "pickled model");
  };
  const auto model_from = [=](const py::handle& text) { return document_from(text).params; };

  auto model_class = def_copy(py::class_<PyModel>(m, "Model", R"doc(
A hysteresis model (pi, gpi, mpi-deadzone, mpi-asym, preisach, kp, bouc-wen, maxwell-slip,
rate-pi) run sample by sample.

Model(spec) takes a dict with the model-file keys, e.g.
``{"model": "gpi", "n": 10, "c": [c0, c1, c2, c3], "q": q, "rho": rho, "tau": tau, "alpha": alpha}``,
the path of a model JSON file (a str or an os.PathLike such as pathlib.Path), or a
hysteron.Model (a copy of its parameters, in the virgin state). Starts in the virgin state
y_i0 = 0. The free-form keys of the spec ("units", "note", "metadata"; checked as a model file's:
"units" an object of strings such as {"input": "kPa", "output": "N"}, "note" a string) are kept
with the model: units shows them, and save(), to_dict(), Model(m), copy and pickle write them
back, so that the CLI still checks a record's units against a model saved here. copy.copy,
copy.deepcopy and pickle keep the state too (bit for bit: the parameters through the model
file's JSON, the state, last output and fault count as numbers).)doc"));
  def_pickle(model_class, "Model",
             [](const PyModel& s) { return io::model_to_json(s.document()).dump(); },
             [=](const py::handle& spec) { return PyModel(document_from(spec)); });
  model_class
      .def(py::init([](const py::object& spec) { return PyModel(model_document(spec, "Model: spec")); }), py::arg("spec"))
      .def_property_readonly("name", [](const PyModel& s) { return std::string(s.name()); },
                             "The model kind: 'pi', 'gpi', 'mpi-deadzone', 'mpi-asym', 'preisach', 'kp', 'bouc-wen', "
                             "'maxwell-slip' or 'rate-pi'.")
      .def_property_readonly("num_operators", [](const PyModel& s) { return s.num_operators(); }, "Number of play operators.")
      .def("step", [](PyModel& s, double x) { return s.step(x); }, py::arg("x"),
           "One sample: the output for input x (updates the state). A NaN or infinite x (or one so large the "
           "output could overflow) leaves the state unchanged, returns the previous output and is counted in "
           "faults; simulate() raises hysteron.Error on such an input instead.")
      .def_property_readonly("faults", [](const PyModel& s) { return s.faults(); },
                             "Number of inputs step() ignored (NaN, infinite or beyond the model's input bound) "
                             "since the last reset (reset() and reset_relaxed() set it to 0).")
      .def(
          "simulate",
          [](PyModel& s, const ArrayArg& x) { return to_numpy(s.simulate(as_span(x, "Model.simulate: x"))); },
          py::arg("x"), "Outputs for an input array, continuing from the current state.")
      .def("reset", [](PyModel& s) { s.reset(); }, "Back to the virgin state.")
      .def(
          "reset_relaxed", [](PyModel& self, double x0) { self.reset_relaxed(finite_arg(x0, "Model.reset_relaxed: x0")); },
          py::arg("x0"), "Start at rest at input x0 (finite).")
      .def_property_readonly("state", [](const PyModel& s) { return to_numpy(s.state().y); },
                             "Operator outputs y_i.")
      .def_property_readonly(
          "units",
          [](const PyModel& s) -> py::object {
            const auto u = s.extra.find("units");
            return u == s.extra.end() ? py::object(py::none()) : from_json(*u);
          },
          "The units the model file records, its \"units\" (a new dict, e.g. {'input': 'kPa', 'output': 'N'}; "
          "hysteron fit and hysteron.fit(units=...) write them), or None. The CLI's evaluate, simulate and "
          "invert refuse a record whose columns name other units.")
      .def("to_dict", [](const PyModel& s) { return from_json(io::model_to_json(s.document())); },
           "The model's parameters as a dict with the model-file keys (docs/model-files.md), and its free-form "
           "keys (\"units\", \"note\", \"metadata\") where it has them; Model(m.to_dict()) is the same model.")
      .def(
          "save",
          [](const PyModel& s, const PathArg& path) {
            io::write_model_file(path_arg(path, "Model.save: path"), s.document());
          },
           py::arg("path"),
           "Write the model file (JSON) to path (a str or an os.PathLike), with the free-form keys (\"units\", "
           "\"note\", \"metadata\") the model was built with, atomically: on an error the old file is left as "
           "it was.")
      .def("__repr__", [](const PyModel& s) {
        if (!has_pi_structure(s.params()))
          return fmt::format("<hysteron.Model {} with {} state entries>", s.name(), s.state().y.size());
        return fmt::format("<hysteron.Model {} with {} operators>", s.name(), s.num_operators());
      });

  auto inverse_class = def_copy(py::class_<Inverse>(m, "Inverse", R"doc(
Exact inverse of a model: desired output -> input. Analytical for pi, gpi and
mpi-deadzone, maxwell-slip (Eqs. 9-11), exact per-sample bracketing for mpi-asym,
preisach, kp, bouc-wen and rate-pi.
Outputs beyond reach saturate at the input limits (lo, hi).
Inverse(spec, limits=None): spec as for Model (a dict, a model file path, or a hysteron.Model),
limits None for the model's input_limits; or a hysteron.Inverse: its model and limits (limits=
replaces them), in the virgin state. copy.copy, copy.deepcopy and pickle keep the state too (bit
for bit).)doc"));
  def_pickle(
      inverse_class, "Inverse",
      [=](const Inverse& s) {
        const Limits& l = s.options().input_limits;
        return py::make_tuple(model_json(s.params()), l.lo, l.hi);
      },
      [=](const py::handle& spec) {
        const auto t = cast_arg<std::tuple<py::object, double, double>>(spec, "pickled Inverse", "(model, lo, hi)");
        return Inverse(model_from(std::get<0>(t)), InverseOptions{{std::get<1>(t), std::get<2>(t)}});
      });
  inverse_class
      .def(py::init([](const py::object& spec, py::object limits) {
             const bool copy = py::isinstance<Inverse>(spec);  // (the C++ Inverse keeps its params and options)
             InverseOptions opt = copy ? spec.cast<const Inverse&>().options() : InverseOptions{};
             if (!limits.is_none()) {
               const auto l = cast_arg<std::pair<double, double>>(limits, "Inverse: limits",
                                                                  "(lo, hi), two numbers, or None for no limits");
               opt.input_limits = {l.first, l.second};
             }
             return Inverse(copy ? spec.cast<const Inverse&>().params() : model_spec(spec, "Inverse: spec"), opt);
           }),
           py::arg("spec"), py::arg("limits") = py::none())
      .def("step", &Inverse::step, py::arg("y_desired"),
           "One sample: the input that makes the model reach y_desired (clamped to the limits; "
           "updates the state). A finite y_desired beyond reach, however large, saturates at the limit in its "
           "direction; a NaN or an infinite y_desired (+inf and -inf too) holds the previous input, leaves the "
           "state unchanged and is counted in faults; simulate() raises hysteron.Error on such a value instead.")
      .def_property_readonly("faults", &Inverse::faults,
                             "Number of non-finite y_desired step() ignored (or desired outputs beyond a double's "
                             "range) since the last reset (reset() and start_from() set it to 0).")
      .def(
          "simulate",
          [](Inverse& s, const ArrayArg& y) { return to_numpy(s.simulate(as_span(y, "Inverse.simulate: y"))); },
          py::arg("y"), "Inputs for an array of desired outputs, continuing from the current state.")
      .def("reset", py::overload_cast<>(&Inverse::reset), "Back to the virgin state.")
      .def(
          "start_from",
          [](Inverse& s, const PyModel& model) { s.reset(model.state()); }, py::arg("model"),
          "Start consistently from a forward model's current state.")
      .def_property_readonly("saturated", &Inverse::saturated, "True if the last step hit an input limit.")
      .def_property_readonly("limits", [](const Inverse& s) { return std::make_pair(s.limits().lo, s.limits().hi); },
                             "Input limits (lo, hi) the inverse saturates at.")
      .def("__repr__", [](const Inverse& s) {
        return fmt::format("<hysteron.Inverse limits=({}, {})>", s.limits().lo, s.limits().hi);
      });
}

}  // namespace hysteron::python
