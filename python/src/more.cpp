// Bindings of identification, the rig, controllers, experiments, plots and reports.
#include "more.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/names.hpp"
#include "hysteron/io/results.hpp"

namespace hysteron::python {

std::span<const double> as_finite_span(const DoubleArray& a, const char* what) {
  const std::span<const double> s = as_span(a);
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

ModelParams model_spec(const py::handle& spec) {
  if (py::isinstance<py::str>(spec)) return io::read_model_file(spec.cast<std::string>());
  if (py::isinstance<Model>(spec)) return spec.cast<const Model&>().params();
  return io::model_from_json(to_json(spec), "model");
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
