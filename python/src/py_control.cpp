// Bindings of the PID, the inverse feedforward, the three papers' controllers (feedforward +
// PID, open loop with a pressure loop, cascade on switching valves) and the iterative learning
// update.
#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "hysteron/compensation.hpp"
#include "hysteron/control.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/units.hpp"
#include "hysteron/learning.hpp"
#include "more.hpp"

namespace hysteron::python {

namespace {

AntiWindup anti_windup_from(const std::string& s) {
  try {
    return anti_windup_from_name(s);
  } catch (const Error& e) {
    throw py::value_error(e.what());  // a bad argument, as before
  }
}

py::dict pid_dict(const PidParams& p) {
  py::dict d;
  d["kp"] = p.kp;
  d["ki"] = p.ki;
  d["kd"] = p.kd;
  d["sample_time"] = p.sample_time;
  d["derivative_filter"] = p.derivative_filter;
  d["out_min"] = p.out_min;
  d["out_max"] = p.out_max;
  d["anti_windup"] = std::string(anti_windup_name(p.anti_windup));
  d["tracking_time"] = p.tracking_time;
  d["setpoint_weight_p"] = p.setpoint_weight_p;
  d["setpoint_weight_d"] = p.setpoint_weight_d;
  if (p.guard.enabled()) {
    py::dict g;
    g["period"] = p.guard.period;
    g["amplitude"] = p.guard.amplitude;
    g["count"] = p.guard.count;
    g["memory"] = p.guard.memory;
    g["factor"] = p.guard.factor;
    g["min_scale"] = p.guard.min_scale;
    d["guard"] = g;
  }
  return d;
}

// A limit-cycle guard from Pid(guard={...}) (the keys of Pid.params["guard"]); None: off.
PidGuard guard_from(const py::object& o) {
  PidGuard g;
  if (o.is_none()) return g;
  if (!py::isinstance<py::dict>(o)) throw Error("Pid: guard must be a dict or None");
  check_dict_keys(o.cast<py::dict>(), {"period", "amplitude", "count", "memory", "factor", "min_scale"}, "Pid: guard");
  for (const auto& [key, value] : o.cast<py::dict>()) {
    const std::string k = py::str(key);
    const double v = cast_arg<double>(value, fmt::format("Pid: guard[\"{}\"]", k), "a number");
    if (k == "period") g.period = v;
    else if (k == "amplitude") g.amplitude = v;
    else if (k == "count") g.count = v;
    else if (k == "memory") g.memory = v;
    else if (k == "factor") g.factor = v;
    else if (k == "min_scale") g.min_scale = v;
    else throw Error("Pid: guard: unknown key '" + k + "' (period, amplitude, count, memory, factor, min_scale)");
  }
  return g;
}

FeedforwardParams ff_params(const Limits& limits, double model_scale, double lag, double ts) {
  FeedforwardParams f;
  f.pressure_limits = limits;
  f.model_scale = model_scale;
  f.lag_time_constant = lag;
  f.sample_time = ts;
  return f;
}

constexpr double inf = std::numeric_limits<double>::infinity();

// The controllers' model_scale [model output units per m]: the one given, else the one the model's
// "units" imply (its output in mm: 1000, in m: 1, in um: 1e6), else 1000 (mm). One given that
// contradicts the model's length unit is refused (a model in m under the default 1000 asked the
// inverse for outputs 1000x too large, silently). A model whose input names a pressure unit other
// than MPa is refused (io::input_unit_mismatch; since 2026-12-01, a warning before): the
// controllers' pressures (limits, PID gains, commands) are in MPa.
double model_scale_of(const py::object& model, const io::ModelDocument& doc, const py::object& given,
                      std::string_view what) {
  if (const std::string why = input_unit_refusal(model, doc); !why.empty()) throw Error(fmt::format("{}: {}", what, why));
  const double per_metre = io::length_units_per_metre(doc.unit("output"));
  if (const std::string out = io::canonical_unit(doc.unit("output"));
      given.is_none() && per_metre == 0 && !out.empty() && out != "%") {
    const std::string message =
        fmt::format("{}: the model's output is in {}, not a length: the controller takes its references and "
                    "measurements as model outputs / model_scale, 1000 by default (mm per m); give model_scale=1 to "
                    "give them in {}",
                    what, out, out);
    if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0) throw py::error_already_set();
  }
  if (given.is_none()) return per_metre > 0 ? per_metre : 1000.0;
  const double scale = cast_arg<double>(given, fmt::format("{}: model_scale", what), "a number or None");
  if (const std::string why = io::model_scale_mismatch(scale, doc.unit("output")); !why.empty())
    throw Error(fmt::format("{}: {}: leave model_scale to the model (None) or give {:.10g}", what, why, per_metre));
  return scale;
}

// A controller's pid= (or pressure_pid=): a hysteron.Pid; `what` names the argument in errors.
// (A Pid at another sample time than the controller's is refused by the C++ constructors.)
PidParams pid_arg(const py::object& pid, const char* what) {
  return cast_arg<const Pid&>(pid, what,
                              "a hysteron.Pid or None (a dict of its parameters: hysteron.Pid(**d), as "
                              "Pid.params gives them)")
      .params();
}

// pressure_limits=: (lo, hi) [MPa]; None (the default): unset, both sides the model's (a TypeError
// for anything else).
Limits limits_arg(const py::object& limits, const char* where) {
  if (limits.is_none()) return {};
  const auto [lo, hi] = pair_arg(limits, fmt::format("{}: pressure_limits", where));
  return {lo, hi};
}

// The given limits resolved on the model (resolve_pressure_limits): an infinite side is the
// model's input_limits; hysteron.Error naming pressure_limits where it has none.
Limits resolved_limits(const ModelParams& model, const Limits& given, const char* where) {
  try {
    return resolve_pressure_limits(model, given);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", where, e.what()));
  }
}

std::pair<double, double> limits_pair(const Limits& l) { return {l.lo, l.hi}; }

// A count of IterativeLearning(...): an int >= min.
std::size_t count_arg(const IntArg& v, const char* name, std::uint64_t min = 0) {
  return static_cast<std::size_t>(uint_arg(v, fmt::format("IterativeLearning: {}", name), min));
}

// The fault counts and the position PID's limit-cycle guard of a controller class (`position` its
// position PID): faults, feedforward_faults, gain_scale, guard_cuts, restart_guard().
template <class C, class Position>
void def_loop_state(py::class_<C>& c, Position position) {
  c.def_property_readonly(
       "faults", [position](const C& l) { return (l.*position)().faults(); },
       "Samples the position PID held since construction or the last reset (a non-finite reference or "
       "measurement, or an overflow; the C++ pid().faults() / position().faults() and the generated C's "
       "position.faults): the command was then the feedforward plus the PID's held correction.")
      .def_property_readonly(
          "feedforward_faults", [](const C& l) { return l.feedforward().faults(); },
          "Non-finite previews the inverse feedforward ignored (holding its output) since the last reset.")
      .def_property_readonly(
          "gain_scale", [position](const C& l) { return (l.*position)().state().gain_scale; },
          "The limit-cycle guard's factor on the position PID's gains now (1: as tuned; docs/control.md, "
          "section 2).")
      .def_property_readonly(
          "guard_cuts", [position](const C& l) { return (l.*position)().state().guard_cuts; },
          "How often the limit-cycle guard cut the position PID's gains since the last reset or restart_guard().")
      .def("restart_guard", &C::restart_guard,
           "Restarts the position PID's limit-cycle guard: the gains as tuned (gain_scale 1, guard_cuts 0), no "
           "half-cycles counted, the rest of the state as it was. Real-time safe: call it once the loop's start-up "
           "transient (the muscle filling from rest) has passed, which the guard can take for a ring.");
}

}  // namespace

void bind_control(py::module_& m) {
  auto pid_class = def_copy(py::class_<Pid>(m, "Pid", R"doc(
Discrete PID (Eq. 17 of the GPI paper) with output limits, anti-windup
("none", "conditional", "back_calculation"), derivative filter and setpoint
weights. step() never allocates; a non-finite input holds the last output. copy.copy,
copy.deepcopy and pickle keep the state too (pickle: the parameters as Pid.params and the
state as numbers).)doc"));
  def_pickle(
      pid_class, "Pid", [](const Pid& p) { return pid_dict(p.params()); },
      [](const py::handle& params) {
        return py::type::of<Pid>()(**cast_arg<py::dict>(params, "pickled Pid", "a dict")).cast<Pid>();
      });
  pid_class
      .def(py::init([](double kp, double ki, double kd, double sample_time, double derivative_filter, double out_min,
                       double out_max, const std::string& anti_windup, double tracking_time, double b, double c,
                       const py::object& guard) {
             PidParams p;
             p.kp = kp;
             p.ki = ki;
             p.kd = kd;
             p.sample_time = sample_time;
             p.derivative_filter = derivative_filter;
             p.out_min = out_min;
             p.out_max = out_max;
             p.anti_windup = anti_windup_from(anti_windup);
             p.tracking_time = tracking_time;
             p.setpoint_weight_p = b;
             p.setpoint_weight_d = c;
             p.guard = guard_from(guard);
             return Pid(p);
           }),
           py::arg("kp") = 0.0, py::arg("ki") = 0.0, py::arg("kd") = 0.0, py::arg("sample_time") = 1e-3,
           py::arg("derivative_filter") = 0.0, py::arg("out_min") = -inf, py::arg("out_max") = inf,
           py::arg("anti_windup") = "conditional", py::arg("tracking_time") = 0.0, py::arg("setpoint_weight_p") = 1.0,
           py::arg("setpoint_weight_d") = 0.0, py::arg("guard") = py::none())
      .def_static(
          "gpi_paper", [](double ts, double lo, double hi) { return Pid(gpi_paper_pid(ts, lo, hi)); },
          py::arg("sample_time") = 1e-3, py::arg("out_min") = -0.6, py::arg("out_max") = 0.6,
          "Table 3 of the GPI paper in SI/MPa units (K_p = 5 MPa/m, K_i = 1 MPa/(m s)).")
      .def("step", &Pid::step, py::arg("setpoint"), py::arg("measurement"), py::arg("feedforward") = 0.0,
           "One sample; returns the clamped output.")
      .def(
          "reset", [](Pid& p, double u0) { p.reset(finite_arg(u0, "Pid.reset: u0")); }, py::arg("u0") = 0.0,
          "Zero state, optionally starting bumplessly at output u0 (finite); the gains as tuned, faults and "
          "guard_cuts 0.")
      .def_property_readonly("output", &Pid::output, "The last (clamped) output.")
      .def_property_readonly("integral", [](const Pid& p) { return p.state().integral; },
                             "The integrator's state (in output units).")
      .def_property_readonly("saturated", [](const Pid& p) { return p.state().saturated; },
                             "True if the last output was clamped.")
      .def_property_readonly("faults", &Pid::faults,
                             "Samples held (a non-finite input or an overflow) since construction or the last reset.")
      .def(
          "set_guard",
          [](Pid& p, double period, double amplitude, double count, double memory, double factor, double min_scale) {
            p.set_guard(PidGuard{period, amplitude, count, memory, factor, min_scale});
          },
          py::arg("period"), py::arg("amplitude"), py::arg("count") = 5.0, py::arg("memory") = 5.0,
          py::arg("factor") = 0.63, py::arg("min_scale") = 0.25,
          "The limit-cycle guard (docs/control.md, section 2): half-cycles of the error no longer than period "
          "(T_u [s]) with an integral of |e| dt above amplitude * period / pi count; at `count` (decaying with "
          "time constant memory * period) the gains are multiplied by factor, not below min_scale. period = 0: "
          "off. Restarts the guard; raises hysteron.Error on invalid numbers.")
      .def("restart_guard", &Pid::restart_guard,
           "Restarts the limit-cycle guard (the gains as tuned, no cuts, no half-cycles counted); the rest of "
           "the state goes on. Real-time safe.")
      .def_property_readonly("gain_scale", [](const Pid& p) { return p.state().gain_scale; },
                             "The limit-cycle guard's factor on the gains now (1: as tuned).")
      .def_property_readonly("guard_cuts", [](const Pid& p) { return p.state().guard_cuts; },
                             "How often the limit-cycle guard cut the gains since the last reset.")
      .def_property_readonly("params", [](const Pid& p) { return pid_dict(p.params()); },
                             "The parameters as a dict (the constructor's keyword arguments).")
      .def("__repr__", [](const Pid& p) {
        const PidParams& q = p.params();
        return fmt::format("Pid(kp={}, ki={}, kd={}, sample_time={}, out_min={}, out_max={}, anti_windup='{}')", q.kp,
                           q.ki, q.kd, q.sample_time, q.out_min, q.out_max, anti_windup_name(q.anti_windup));
      });

  def_copy(py::class_<InverseFeedforward>(m, "InverseFeedforward", R"doc(
Inverse-model feedforward: desired contraction [m] -> pressure command [MPa],
clamped to pressure_limits; model output units are model_scale per metre (1000
for a model fitted in mm); optional compensation of a first-order lag.
pressure_limits: (lo, hi) [MPa]; None (the default), or an infinite side, is the model's
input_limits (a fitted model's training input range); a model without them (a hand-written
model file) raises hysteron.Error: give your actuator's.)doc"))
      .def(py::init([](const py::object& model, const py::object& limits, const py::object& scale_obj, double lag,
                       double ts) {
             const io::ModelDocument doc = model_document(model, "InverseFeedforward: model");
             const ModelParams& mp = doc.params;
             const double scale = model_scale_of(model, doc, scale_obj, "InverseFeedforward");
             const Limits given = limits_arg(limits, "InverseFeedforward");
             return InverseFeedforward(mp, ff_params(resolved_limits(mp, given, "InverseFeedforward"), scale, lag, ts));
           }),
           py::arg("model"), py::arg("pressure_limits") = py::none(), py::arg("model_scale") = py::none(),
           py::arg("lag_time_constant") = 0.0, py::arg("sample_time") = 1e-3)
      .def("step", &InverseFeedforward::step, py::arg("desired_m"), "Pressure [MPa] for the desired contraction [m].")
      .def_property_readonly(
          "pressure_limits", [](const InverseFeedforward& c) { return limits_pair(c.pressure_limits()); },
          "The (lo, hi) [MPa] the commands are clamped to: the given ones, or the model's.")
      .def("reset", &InverseFeedforward::reset, "Back to the virgin state of the inverse (and no lag history).")
      .def_property_readonly("feedback_sign", &InverseFeedforward::feedback_sign,
                             "+1 where the model's output increases with its input, -1 where it decreases: the "
                             "controllers' position PIDs act on feedback_sign * (r - y) (PID gains are magnitudes).")
      .def_property_readonly("saturated", &InverseFeedforward::saturated,
                             "True if the last command was clamped to pressure_limits.")
      .def("__repr__", [](const InverseFeedforward& f) {
        const FeedforwardParams& q = f.params();
        return fmt::format("InverseFeedforward(pressure_limits=({}, {}), model_scale={}, lag_time_constant={}, "
                           "sample_time={})",
                           q.pressure_limits.lo, q.pressure_limits.hi, q.model_scale, q.lag_time_constant,
                           q.sample_time);
      });

  auto ff_pid_class = def_copy(py::class_<FeedforwardPidController>(m, "FeedforwardPidController", R"doc(
GPI paper Fig. 10: p_cmd = clamp(FF(y_d) + PID(y_d - y)) [MPa], the PID's
anti-windup aware of the total command. pid: a hysteron.Pid (its parameters
are used; default: Pid.gpi_paper(), output limits +-pressure_limits[1]).
pressure_limits: (lo, hi) [MPa]; None (the default), or an infinite side, is the model's
input_limits (a fitted model's training input range); a model without them (a hand-written
model file) raises hysteron.Error: give your actuator's.)doc"))
      .def(py::init([](const py::object& model, const py::object& pid, const py::object& limits_obj,
                       const py::object& scale_obj, double lag, double ts) {
             const io::ModelDocument doc = model_document(model, "FeedforwardPidController: model");
             const ModelParams& mp = doc.params;
             const double scale = model_scale_of(model, doc, scale_obj, "FeedforwardPidController");
             const Limits given = limits_arg(limits_obj, "FeedforwardPidController");
             std::optional<PidParams> pp;
             if (!pid.is_none()) pp = pid_arg(pid, "FeedforwardPidController: pid");
             const Limits limits = resolved_limits(mp, given, "FeedforwardPidController");
             if (!pp) pp = gpi_paper_pid(ts, -limits.hi, limits.hi);
             return FeedforwardPidController(mp, ff_params(limits, scale, lag, ts), *pp);
           }),
           py::arg("model"), py::arg("pid") = py::none(), py::arg("pressure_limits") = py::none(),
           py::arg("model_scale") = py::none(), py::arg("lag_time_constant") = 0.0, py::arg("sample_time") = 1e-3)
      .def("step", &FeedforwardPidController::step, py::arg("reference_m"), py::arg("preview_m"),
           py::arg("measured_m"), "One control sample; returns the pressure command [MPa].")
      .def_property_readonly(
          "pressure_limits", [](const FeedforwardPidController& c) { return limits_pair(c.pressure_limits()); },
          "The (lo, hi) [MPa] the commands are clamped to: the given ones, or the model's.")
      .def("reset", &FeedforwardPidController::reset, "Back to the virgin state (inverse, lag history and PID).")
      .def("__repr__", [](const FeedforwardPidController&) {
        return std::string("FeedforwardPidController(inverse feedforward + PID, GPI paper Fig. 10)");
      });
  def_loop_state(ff_pid_class, &FeedforwardPidController::pid);

  auto open_loop_class = def_copy(py::class_<OpenLoopController>(m, "OpenLoopController", R"doc(
Asymmetric-MPI paper, Fig. 6: open-loop inverse compensation with a proportional
pressure loop, p_cmd = clamp(p_d + pressure_gain (p_d - p_measured)) [MPa], p_d =
FF(preview) (+ PID(y_d - y), clamped, if pid is given: hysteron's compensated
variant; its output limited to +-(p_max - p_min)). mpi-openloop's loops
(result.json "loop": "open_loop"; docs/deploy.md).
pressure_limits: (lo, hi) [MPa]; None (the default), or an infinite side, is the model's
input_limits (a fitted model's training input range); a model without them (a hand-written
model file) raises hysteron.Error: give your actuator's.)doc"))
      .def(py::init([](const py::object& model, const py::object& pid, double pressure_gain,
                       const py::object& limits, const py::object& scale_obj, double lag, double ts) {
             const io::ModelDocument doc = model_document(model, "OpenLoopController: model");
             const ModelParams& mp = doc.params;
             const double scale = model_scale_of(model, doc, scale_obj, "OpenLoopController");
             const Limits given = limits_arg(limits, "OpenLoopController");
             OpenLoopParams p;
             p.position.sample_time = ts;  // (unused without gains)
             if (!pid.is_none()) p.position = pid_arg(pid, "OpenLoopController: pid");
             p.feedforward = ff_params(resolved_limits(mp, given, "OpenLoopController"), scale, lag, ts);
             p.pressure_gain = pressure_gain;
             return OpenLoopController(mp, p);
           }),
           py::arg("model"), py::arg("pid") = py::none(), py::arg("pressure_gain") = 0.5,
           py::arg("pressure_limits") = py::none(), py::arg("model_scale") = py::none(),
           py::arg("lag_time_constant") = 0.0, py::arg("sample_time") = 1e-3)
      .def("step", &OpenLoopController::step, py::arg("reference_m"), py::arg("preview_m"), py::arg("measured_m"),
           py::arg("pressure_mpa"),
           "One control sample (pressure_mpa: the measured gauge pressure); returns the regulator's command [MPa].")
      .def_property_readonly(
          "pressure_limits", [](const OpenLoopController& c) { return limits_pair(c.pressure_limits()); },
          "The (lo, hi) [MPa] the commands are clamped to: the given ones, or the model's.")
      .def("reset", &OpenLoopController::reset, "Back to the virgin state (inverse, lag history and PID).")
      .def("__repr__", [](const OpenLoopController&) {
        return std::string("OpenLoopController(inverse feedforward + pressure loop, asymmetric-MPI paper Fig. 6)");
      });
  def_loop_state(open_loop_class, &OpenLoopController::position);

  auto cascade_class = def_copy(py::class_<CascadePwmController>(m, "CascadePwmController", R"doc(
Dead-zone MPI paper: cascade on fast switching valves. Outer loop p_d =
clamp(FF(preview) + pid(y_d - y)) [MPa] (default pid: Pid.gpi_paper()); inner loop
u = pressure_pid(p_d - p_measured) limited to [-1, 1] (default: the paper's P loop,
kp = 20 per MPa); then the PWM modulator (pwm: a dict of gain, deadband, min_duty,
max_duty, resolution; missing keys take the defaults 1, 0, 0, 1, 0). step() returns the
duty in [-1, 1] (> 0 inlet, < 0 exhaust). mpi-pwm's loops ("loop": "cascade_pwm").
pressure_limits: (lo, hi) [MPa]; None (the default), or an infinite side, is the model's
input_limits (a fitted model's training input range); a model without them (a hand-written
model file) raises hysteron.Error: give your actuator's.)doc"))
      .def(py::init([](const py::object& model, const py::object& pid, const py::object& pressure_pid,
                       const py::object& pwm, const py::object& limits_obj, const py::object& scale_obj, double lag,
                       double ts) {
             const io::ModelDocument doc = model_document(model, "CascadePwmController: model");
             const ModelParams& mp = doc.params;
             const double scale = model_scale_of(model, doc, scale_obj, "CascadePwmController");
             const Limits given = limits_arg(limits_obj, "CascadePwmController");
             CascadeParams p;
             if (!pid.is_none()) p.position = pid_arg(pid, "CascadePwmController: pid");
             if (pressure_pid.is_none()) {
               p.pressure.kp = 20.0;
               p.pressure.sample_time = ts;
             } else {
               p.pressure = pid_arg(pressure_pid, "CascadePwmController: pressure_pid");
             }
             if (!pwm.is_none()) {
               const auto d = cast_arg<py::dict>(pwm, "CascadePwmController: pwm",
                                                 "a dict of gain, deadband, min_duty, max_duty, resolution, or None");
               check_dict_keys(d, {"gain", "deadband", "min_duty", "max_duty", "resolution"},
                               "CascadePwmController: pwm");
               for (const auto& [k, v] : d) {
                 const std::string key = py::str(k);
                 const double x = cast_arg<double>(v, fmt::format("CascadePwmController: pwm[\"{}\"]", key), "a number");
                 if (key == "gain") p.pwm.gain = x;
                 else if (key == "deadband") p.pwm.deadband = x;
                 else if (key == "min_duty") p.pwm.min_duty = x;
                 else if (key == "max_duty") p.pwm.max_duty = x;
                 else if (key == "resolution") p.pwm.resolution = x;
                 else
                   throw py::value_error(fmt::format("pwm: unknown key \"{}\" (expected gain, deadband, min_duty, "
                                                     "max_duty, resolution)",
                                                     key));
               }
             }
             const Limits limits = resolved_limits(mp, given, "CascadePwmController");
             p.feedforward = ff_params(limits, scale, lag, ts);
             if (pid.is_none()) p.position = gpi_paper_pid(ts, -limits.hi, limits.hi);
             return CascadePwmController(mp, p);
           }),
           py::arg("model"), py::arg("pid") = py::none(), py::arg("pressure_pid") = py::none(),
           py::arg("pwm") = py::none(), py::arg("pressure_limits") = py::none(),
           py::arg("model_scale") = py::none(), py::arg("lag_time_constant") = 0.0, py::arg("sample_time") = 1e-3)
      .def("step", &CascadePwmController::step, py::arg("reference_m"), py::arg("preview_m"), py::arg("measured_m"),
           py::arg("pressure_mpa"), "One control sample; returns the PWM duty in [-1, 1].")
      .def_property_readonly("desired_pressure", &CascadePwmController::desired_pressure,
                             "The outer loop's p_d [MPa] of the last step.")
      .def_property_readonly(
          "pressure_limits", [](const CascadePwmController& c) { return limits_pair(c.pressure_limits()); },
          "The (lo, hi) [MPa] the commands are clamped to: the given ones, or the model's.")
      .def("reset", &CascadePwmController::reset, "Back to the virgin state (inverse, both PIDs, the duty).")
      .def("__repr__", [](const CascadePwmController&) {
        return std::string("CascadePwmController(feedforward + PID position loop, PI pressure loop, PWM valves)");
      })
      .def_property_readonly(
          "pressure_faults", [](const CascadePwmController& c) { return c.pressure().faults(); },
          "Samples the pressure PID held since the last reset (a non-finite pressure measurement: the duty was "
          "then 0, both valves closed, and the position PID held; the C++ pressure().faults(), the generated "
          "C's pressure.faults).");
  def_loop_state(cascade_class, &CascadePwmController::position);

  def_copy(py::class_<IterativeLearning>(m, "IterativeLearning", R"doc(
Iterative learning control for a periodic reference of `period` samples (docs/control.md,
section 3): a correction c is added to a closed loop's reference (and its feedforward's
preview) and learnt from the tracking error over the periods,
c_{j+1}(k) = sum_m q_m [c_j(k+m) + gain e_j(k+m+lead)], q the binomial Q-filter of
half-width `half_width`. Each sample: correction(0) (and correction(preview) for the
feedforward), run the loop on r + c, then step(r - y). rise_tolerance, hold_after_cuts and
max_gain set the supervisor (the learning variant: 0, 3, and up to 0.5: the largest gain
whose bound holds on the identified loop). step() never allocates; a
non-finite error is learnt as 0 and counted (faults), an update that overflows keeps the
sample's correction of the period before (overflows). Invalid parameters raise
hysteron.Error naming the field.)doc"))
      .def(py::init([](const IntArg& period, double gain, const IntArg& lead, const IntArg& half_width,
                       const IntArg& lookahead, double max_correction, double rise_tolerance,
                       const IntArg& hold_after_cuts, double max_gain) {
             LearningParams p;
             p.period = count_arg(period, "period", 1);
             p.gain = gain;
             p.lead = count_arg(lead, "lead");
             p.half_width = count_arg(half_width, "half_width");
             p.lookahead = count_arg(lookahead, "lookahead");
             p.max_correction = max_correction;
             p.rise_tolerance = rise_tolerance;
             p.hold_after_cuts = count_arg(hold_after_cuts, "hold_after_cuts");
             p.max_gain = max_gain;
             return IterativeLearning(p);
           }),
           py::arg("period"), py::arg("gain") = 0.5, py::arg("lead") = 0, py::arg("half_width") = 0,
           py::arg("lookahead") = 0, py::arg("max_correction") = inf, py::arg("rise_tolerance") = inf,
           py::arg("hold_after_cuts") = 0, py::arg("max_gain") = 0.0)
      .def(
          "correction",
          [](const IterativeLearning& l, const IntArg& ahead_arg) {
            const std::uint64_t ahead = uint_arg(ahead_arg, "IterativeLearning.correction: ahead");
            if (ahead > l.params().lookahead)
              throw py::value_error(fmt::format("correction: ahead = {} is beyond lookahead = {}", ahead,
                                                l.params().lookahead));
            return l.correction(ahead);
          },
          py::arg("ahead") = 0,
          "The correction to add to the reference `ahead` samples after the current one (ahead <= lookahead).")
      .def("step", &IterativeLearning::step, py::arg("error"),
           "Records the tracking error r - y of the current sample and advances one sample.")
      .def(
          "reset",
          [](IterativeLearning& l, const std::optional<ArrayArg>& correction) {
            if (correction) l.reset(as_span(*correction, "IterativeLearning.reset: correction"));
            else l.reset();
          },
          py::arg("correction") = py::none(),
          "Zero corrections, back to phase 0 of period 0. With correction (period values, the loop's units): "
          "period 0 applies it instead of zeros and learning goes on from it (a warm start from a correction "
          "learnt before, e.g. an experiment's correction_mm over its last period, in metres); hysteron.Error, "
          "the state unchanged, if it does not have period values or one is not finite.")
      .def_property_readonly("phase", &IterativeLearning::phase, "The sample's index in the period.")
      .def_property_readonly("iteration", &IterativeLearning::iteration, "Completed periods.")
      .def_property_readonly("gain", &IterativeLearning::gain, "The learning gain L in use.")
      .def_property_readonly("gain_cuts", &IterativeLearning::gain_cuts,
                             "Times the supervisor restored the best correction and halved L.")
      .def_property_readonly("gain_raises", &IterativeLearning::gain_raises,
                             "Times the supervisor doubled L after a best period.")
      .def_property_readonly("held", &IterativeLearning::held, "True once the best correction is held.")
      .def_property_readonly("faults", &IterativeLearning::faults, "Non-finite errors learnt as 0.")
      .def_property_readonly("overflows", &IterativeLearning::overflows,
                             "Updates whose sum overflowed (finite errors of the order of 1e308): the sample kept "
                             "its correction of the period before, so a correction is never inf or NaN.")
      .def("__repr__", [](const IterativeLearning& l) {
        const LearningParams& q = l.params();
        return fmt::format("IterativeLearning(period={}, gain={}, lead={}, half_width={}, lookahead={}, "
                           "rise_tolerance={}, hold_after_cuts={}, max_gain={})",
                           q.period, q.gain, q.lead, q.half_width, q.lookahead, q.rise_tolerance, q.hold_after_cuts,
                           q.max_gain);
      });
}

}  // namespace hysteron::python
