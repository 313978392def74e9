// Bindings of identification, the rig, controllers, experiments, plots and reports.
#include "more.hpp"

#include "hysteron/io/model_file.hpp"

namespace hysteron::python {

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

py::dict metrics_dict(const FitMetrics& m) {
  py::dict d;
  d["rms"] = m.rms;
  d["max"] = m.max;
  d["mae"] = m.mae;
  d["rms_percent_span"] = m.rms_percent_span;
  d["r2"] = m.r2;
  d["n"] = m.n;
  return d;
}

py::dict fit_dict(const FitReport& r) {
  py::dict d;
  d["status"] = std::string(fit_status_name(r.status));
  d["ok"] = r.ok();
  d["message"] = r.message;
  d["model_kind"] = std::string(fit_model_name(r.model_kind));
  d["model"] = r.status == FitStatus::invalid_input ? py::object(py::none()) : from_json(io::model_to_json(r.model));
  py::list params;
  for (const auto& p : r.parameters) {
    py::dict q;
    q["name"] = p.name;
    q["value"] = p.value;
    q["std_error"] = p.std_error;
    q["held"] = p.held;
    q["at_bound"] = p.at_bound;
    params.append(q);
  }
  d["parameters"] = params;
  d["train"] = metrics_dict(r.train);
  d["initial_cost"] = r.initial_cost;
  d["final_cost"] = r.final_cost;
  d["iterations"] = r.iterations;
  d["total_iterations"] = r.total_iterations;
  d["num_starts"] = r.num_starts;
  d["time_s"] = r.time_s;
  d["covariance_note"] = r.covariance_note;
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
