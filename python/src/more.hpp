#pragma once
// Helpers shared by the bindings in more.cpp and py_*.cpp.
#include <atomic>
#include <chrono>
#include <future>
#include <optional>
#include <utility>

#include "bindings.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/models.hpp"

namespace hysteron::python {

// hysteron.Model: the C++ Model and the free-form keys ("units", "note", "metadata") of the
// spec it was built from, which Model.save, to_dict, pickle and copy write back. They live here,
// beside the model: hysteron::Model (the real-time core) never sees them.
struct PyModel : Model {
  explicit PyModel(io::ModelDocument doc) : Model(std::move(doc.params)), extra(std::move(doc.extra)) {}
  io::ModelDocument document() const { return {params(), extra}; }
  nlohmann::json extra = nlohmann::json::object();  // checked as io::check_model_extra checks it
};

// A model from a dict (model-file keys), a model file path (str or os.PathLike) or a
// hysteron.Model; `what` names the argument in errors ("InverseFeedforward: model").
// model_document: with the free-form keys (a dict's or a file's, a hysteron.Model's own).
io::ModelDocument model_document(const py::handle& spec, std::string_view what);
// Why a controller (pressures in MPa) cannot run on `spec`'s document `doc` (io::input_unit_mismatch),
// naming the model file where spec is a path; "" where it can.
std::string input_unit_refusal(const py::handle& spec, const io::ModelDocument& doc);
ModelParams model_spec(const py::handle& spec, std::string_view what);
InitialState initial_state_from(const std::string& name);
// A (lo, hi) pair of numbers: TypeError naming WHAT otherwise.
std::pair<double, double> pair_arg(const py::handle& obj, std::string_view what);
py::dict metrics_dict(const FitMetrics& m);
py::dict fit_dict(const FitReport& r);

// work() without the GIL, on a thread of its own, while this (Python's) thread looks for signals
// every 100 ms: on Ctrl-C `stop` is set (work's stop_requested hook reads it; work then ends
// soon, throwing hysteron::Stopped), work's end is awaited and its result or exception dropped,
// and the signal's exception (KeyboardInterrupt) is raised. Otherwise work's result is returned
// or its exception rethrown. (Signals reach only Python's main thread: from another thread the
// work runs to its end.)
template <class Work>
auto run_interruptible(std::atomic<bool>& stop, Work work) -> decltype(work()) {
  std::optional<decltype(work())> r;
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    auto done = std::async(std::launch::async, std::move(work));
    while (done.wait_for(std::chrono::milliseconds(100)) != std::future_status::ready) {
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) {  // the signal's exception is now set in this thread
        interrupted = true;
        stop.store(true);
        break;
      }
    }
    if (interrupted) {
      try {
        (void)done.get();  // a stopped fit or run throws Stopped; a result that came first is dropped
      } catch (...) {
      }
    } else {
      r.emplace(done.get());  // the work's own failure is rethrown here
    }
  }
  if (interrupted) throw py::error_already_set();
  return std::move(*r);
}

void bind_identify(py::module_& m);    // py_identify.cpp: fit, evaluate, Rls, ...
void bind_rig(py::module_& m);         // py_rig.cpp: PamRig, signals
void bind_control(py::module_& m);     // py_control.cpp: Pid, InverseFeedforward, FeedforwardPidController
void bind_experiment(py::module_& m);  // py_experiment.cpp: run_experiment, plots, reports

}  // namespace hysteron::python
