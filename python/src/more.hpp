#pragma once
// Helpers shared by the bindings in more.cpp and py_*.cpp.
#include "bindings.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/models.hpp"

namespace hysteron::python {

// A model from a dict (model-file keys), a model file path or a hysteron.Model.
ModelParams model_spec(const py::handle& spec);
InitialState initial_state_from(const std::string& name);
py::dict metrics_dict(const FitMetrics& m);
py::dict fit_dict(const FitReport& r);

void bind_identify(py::module_& m);    // py_identify.cpp: fit, evaluate, Rls, ...
void bind_rig(py::module_& m);         // py_rig.cpp: PamRig, signals
void bind_control(py::module_& m);     // py_control.cpp: Pid, InverseFeedforward, FeedforwardPidController
void bind_experiment(py::module_& m);  // py_experiment.cpp: run_experiment, plots, reports

}  // namespace hysteron::python
