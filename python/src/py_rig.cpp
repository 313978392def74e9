// Bindings of the simulated muscle rig and the papers' signals.
#include <cmath>
#include <mutex>
#include <unordered_set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hysteron/error.hpp"
#include "hysteron/plant.hpp"
#include "hysteron/signals.hpp"
#include "more.hpp"

namespace hysteron::python {

namespace {

// The rigs whose run_pressure is under way: it runs without the GIL, so another Python thread
// may call the same rig meanwhile, and a step or reset there changed the run's result silently.
// Their other methods raise hysteron.Error instead (idle() at their start).
std::mutex busy_mutex;
std::unordered_set<const PamRig*> busy_rigs;

void idle(const PamRig& r) {
  const std::lock_guard<std::mutex> lock(busy_mutex);
  if (busy_rigs.count(&r) != 0) throw Error("PamRig: run_pressure is running in another thread");
}

// Marks `r` busy for its lifetime (run_pressure); hysteron.Error if it is already.
class BusyRig {
 public:
  explicit BusyRig(const PamRig& r) : r_(r) {
    const std::lock_guard<std::mutex> lock(busy_mutex);
    if (!busy_rigs.insert(&r_).second) throw Error("PamRig: run_pressure is running in another thread");
  }
  ~BusyRig() {
    const std::lock_guard<std::mutex> lock(busy_mutex);
    busy_rigs.erase(&r_);
  }
  BusyRig(const BusyRig&) = delete;
  BusyRig& operator=(const BusyRig&) = delete;

 private:
  const PamRig& r_;
};

PamRigParams rig_params_from(const py::object& params) {
  if (params.is_none()) return {};
  if (is_path(params)) return load_rig_params(path_arg(params, "PamRig: params"));
  return rig_params_from_json(to_json(params, "params"), "params");
}

py::dict outputs_dict(const RigOutputs& o) {
  py::dict d;
  d["time"] = o.time;
  d["contraction"] = o.contraction;
  d["contraction_measured"] = o.contraction_measured;
  d["velocity"] = o.velocity;
  d["pressure"] = o.pressure;
  d["pressure_measured"] = o.pressure_measured;
  d["inlet_open"] = o.inlet_open;
  d["exhaust_open"] = o.exhaust_open;
  d["ok"] = o.ok;
  return d;
}

std::vector<WaveSegment> segments_from(const py::list& segs) {
  std::vector<WaveSegment> out;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const std::string where = fmt::format("wave_sequence: segments[{}]", i);
    const auto d = cast_arg<py::dict>(segs[i], where, "a dict {waveform, amplitude, period, periods, offset}");
    check_dict_keys(d, {"waveform", "amplitude", "period", "periods", "offset"}, where);
    const auto field = [&]<class T>(const char* key, T& v, const char* expected) {
      if (d.contains(key)) v = cast_arg<T>(d[key], fmt::format("{}[\"{}\"]", where, key), expected);
    };
    WaveSegment w;
    std::string wf = "triangle";
    field("waveform", wf, "'triangle' or 'sine'");
    if (wf == "triangle") w.waveform = Waveform::triangle;
    else if (wf == "sine") w.waveform = Waveform::sine;
    else throw py::value_error("waveform must be 'triangle' or 'sine'");
    field("amplitude", w.amplitude, "a number");
    field("period", w.period, "a number [s]");
    if (d.contains("periods")) w.periods = int_arg(d["periods"], fmt::format("{}[\"periods\"]", where));
    field("offset", w.offset, "a number");
    out.push_back(w);
  }
  return out;
}

// step and run_pressure take MPa (gauge); the C++ clamps a command to the regulator's range (regulator.max_command,
// 0..1 MPa by default) and the supply bounds the pressure, so a command in pascals (300000.0 for 0.3 MPa) ran
// silently at the supply's limit. The mirror of reset_at_pressure's guard (which takes Pa and refuses 0 < p < 10,
// MPa given as Pa): a command of 10 or more, 10 MPa, is Pa given as MPa (regulator.max_command is at most 5 MPa).
void check_command_mpa(const PamRig& r, double p, const std::string& what) {
  if (!(p >= 10)) return;
  const PamRigParams& q = r.params();
  throw Error(fmt::format("{} = {}: the unit is MPa (gauge), not Pa (for {} Pa give {:g}); the regulator's commands "
                          "are 0 .. {:g} MPa (regulator.max_command) and the pressure stays below the supply's {:g} MPa "
                          "gauge (air.supply_pressure minus air.atmospheric_pressure)",
                          what, p, p, p * 1e-6, q.regulator.max_command * 1e-6,
                          (q.air.supply_pressure - q.air.atmospheric_pressure) * 1e-6));
}

}  // namespace

void bind_rig(py::module_& m) {
  m.def(
      "rig_params", [](const py::object& params) { return from_json(rig_params_to_json(rig_params_from(params))); },
      py::arg("params") = py::none(),
      "Complete rig parameter dict (defaults filled in) from a partial dict, a JSON file path or None.");

  m.def(
      "rig_statics",
      [](const py::object& params) {
        py::dict d = from_json(rig_statics_to_json(rig_statics(rig_params_from(params))));
        for (const char* column : {"pressure_pa", "rising_m", "falling_m"})
          d[column] = py::array_t<double>(py::cast<py::sequence>(d[column]));
        d["units"] = from_json(rig_units_to_json());
        return d;
      },
      py::arg("params") = py::none(),
      "What a rig's parameters imply at rest (as `hysteron rig`; docs/plant.md): stroke end, return force (weight "
      "+ spring) at rest and at the stroke end, the vented load's terminal speed under it at rest and at the stroke end "
      "(None without damping), the command "
      "limits, the rising branch's lift-off pressure (None: none within the supply), the static map on the rising and "
      "falling branches (SI units), every parameter's unit ('units', by path), 'unusable': why the experiments "
      "refuse the rig ('' if they do not), and where the vented muscle stalls after a hold at the top of its reach "
      "('vented_stall_m', 'creep_return_speed_m_s', 'weak_return': the warning, '' if none; docs/plant.md).");

  py::class_<PamRig>(m, "PamRig", R"doc(
Simulated rig: a Festo DMSP-20-500 pneumatic muscle lifting a hanging mass (and an
optional return spring: load.spring_rate, load.spring_preload), fed
by a proportional pressure regulator or by PWM switching valves (docs/plant.md).

PamRig(params=None, seed=1): params is a dict with optional sections "muscle",
"hysteresis", "air", "regulator", "valves", "load", "sensors", "simulation"
(see hysteron.rig_params()), or the path of such a JSON file. SI units inside;
run_pressure takes and returns MPa and mm. Runs are reproducible bit for bit
for a given seed. While run_pressure runs (without the GIL), the rig's other methods raise
hysteron.Error from another thread.)doc")
      .def(
          "__copy__",
          [](const PamRig& self) {
            idle(self);
            return PamRig(self);
          },
          "A copy in the same state.")
      .def(
          "__deepcopy__",
          [](const PamRig& self, const py::handle&) {
            idle(self);
            return PamRig(self);
          },
          py::arg("memo"), "A copy in the same state.")
      .def(py::init([](const py::object& params, const IntArg& seed) {
             return PamRig(rig_params_from(params), uint_arg(seed, "PamRig: seed"));
           }),
           py::arg("params") = py::none(), py::arg("seed") = 1)
      .def(
          "reset",
          [](PamRig& r) {
            idle(r);
            r.reset();
          },
          "Vented muscle at rest, t = 0, RNG re-seeded.")
      .def("reset_at_pressure",
           [](PamRig& r, double p) {
             idle(r);
             finite_arg(p, "PamRig.reset_at_pressure: p_gauge");
             // the C++ clamps to what the supply can give; a value outside is a mistake (often MPa given as Pa)
             const AirParams& a = r.params().air;
             const double hi = a.supply_pressure - a.atmospheric_pressure;
             const std::string range = fmt::format("0 .. {} Pa, gauge pressure in pascals up to the rig's "
                                                   "air.supply_pressure {} Pa abs minus air.atmospheric_pressure {} Pa",
                                                   hi, a.supply_pressure, a.atmospheric_pressure);
             if (p > 0 && p < 10)
               throw Error(fmt::format("PamRig.reset_at_pressure: p_gauge = {} Pa: the unit is Pa, not MPa (for {} "
                                       "MPa give {:g}; {})",
                                       p, p, p * 1e6, range));
             if (p < 0 || p > hi)
               throw Error(fmt::format("PamRig.reset_at_pressure: p_gauge = {} Pa is outside {}", p, range));
             r.reset_at_pressure(p);
           },
           py::arg("p_gauge"),
           "Static equilibrium at gauge pressure p_gauge [Pa] (pascals, unlike run_pressure's MPa): 0 (vented) up "
           "to the supply's gauge pressure (params['air']['supply_pressure'] - "
           "params['air']['atmospheric_pressure']); hysteron.Error outside, and for 0 < p_gauge < 10 (MPa given as "
           "Pa).")
      .def(
          "step",
          [](PamRig& r, double pressure_command, double pwm_duty, const std::string& mode) {
            idle(r);
            check_command_mpa(r, pressure_command, "PamRig.step: pressure_command");
            RigInputs in;
            in.pressure_command = pressure_command;
            in.pwm_duty = pwm_duty;
            if (mode == "regulator") in.mode = Actuation::regulator;
            else if (mode == "switching_valves") in.mode = Actuation::switching_valves;
            else throw py::value_error("mode must be 'regulator' or 'switching_valves'");
            return outputs_dict(r.step(in));
          },
          py::arg("pressure_command") = 0.0, py::arg("pwm_duty") = 0.0, py::arg("mode") = "regulator",
          "One rig step of dt: pressure_command [MPa gauge, unlike reset_at_pressure's Pa] (regulator; clamped to "
          "0 .. regulator.max_command, the pressure bounded by the supply; hysteron.Error for 10 or more, Pa given as "
          "MPa) or pwm_duty in [-1, 1] (switching_valves). Returns the outputs (SI units: m, Pa gauge).")
      .def(
          "run_pressure",
          [](PamRig& r, const ArrayArg& profile, double control_period) {
            const auto checked = as_finite_span(profile, "run_pressure: profile");
            const std::vector<double> p(checked.begin(), checked.end());  // a copy: the run is without the GIL
            for (std::size_t i = 0; i < p.size(); ++i)
              check_command_mpa(r, p[i], fmt::format("PamRig.run_pressure: profile[{}]", i));
            // A period that is not a whole number of rig steps was rounded silently.
            const auto every = control_steps(control_period, r.dt(), "run_pressure");
            std::vector<double> t, cmd, pr, x, xm;
            for (auto* v : {&t, &cmd, &pr, &x, &xm}) v->reserve(p.size());
            const BusyRig busy(r);  // until the run's end: another thread's step or reset raises
            {
              py::gil_scoped_release release;
              RigInputs in;
              long steps = 0;
              for (double u : p) {
                in.pressure_command = u;
                RigOutputs o;
                for (long k = 0; k < every; ++k) {
                  o = r.step(in);
                  // Ctrl-C: Python's signal handlers run when the GIL is taken back
                  // (every 2^14 rig steps, ~1 ms of work).
                  if ((++steps & 0x3fff) == 0) {
                    py::gil_scoped_acquire gil;
                    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
                  }
                }
                t.push_back(o.time);
                cmd.push_back(u);
                pr.push_back(o.pressure_measured * 1e-6);
                x.push_back(o.contraction * 1e3);
                xm.push_back(o.contraction_measured * 1e3);
              }
            }
            r.check();
            py::dict d;
            d["t"] = to_numpy(t);
            d["pressure_command_mpa"] = to_numpy(cmd);
            d["pressure_mpa"] = to_numpy(pr);
            d["contraction_mm"] = to_numpy(x);
            d["contraction_measured_mm"] = to_numpy(xm);
            return d;
          },
          py::arg("profile"), py::arg("control_period") = 1e-3,
          R"doc(Drive the regulator with a pressure profile [MPa gauge], one value per control_period [s]
(clamped to 0 .. regulator.max_command, the pressure bounded by the supply; hysteron.Error for a value of 10 or
more: Pa given as MPa).
Returns numpy arrays logged at the end of each period: t [s], pressure_command_mpa,
pressure_mpa (measured), contraction_mm (true), contraction_measured_mm.
Raises hysteron.Error if the simulation diverges.)doc")
      .def_property_readonly(
          "time",
          [](const PamRig& r) {
            idle(r);
            return r.time();
          },
          "Simulated time [s].")
      .def_property_readonly("dt", &PamRig::dt, "Rig step [s].")
      .def_property_readonly("seed", &PamRig::seed, "Seed of the sensor-noise generator.")
      .def_property_readonly(
          "ok",
          [](const PamRig& r) {
            idle(r);
            return r.ok();
          },
          "False once the simulation diverged.")
      .def_property_readonly(
          "params", [](const PamRig& r) { return from_json(rig_params_to_json(r.params())); }, "Parameter dict.")
      .def_property_readonly(
          "state",
          [](const PamRig& r) {
            idle(r);
            const RigState& s = r.state();
            py::dict d;
            d["pressure"] = s.pressure;
            d["contraction"] = s.contraction;
            d["velocity"] = s.velocity;
            d["bouc_wen"] = s.bouc_wen;
            d["creep"] = s.creep;
            d["regulator_setpoint"] = s.regulator_setpoint;
            return d;
          },
          "The continuous state (SI units, pressure absolute).")
      .def("__repr__", [](const PamRig& r) {
        {
          const std::lock_guard<std::mutex> lock(busy_mutex);
          if (busy_rigs.count(&r) != 0) return fmt::format("PamRig(seed={}, dt={}, running)", r.seed(), r.dt());
        }
        return fmt::format("PamRig(seed={}, dt={}, time={}, ok={})", r.seed(), r.dt(), r.time(), r.ok() ? "True" : "False");
      });

  m.def(
      "wave_sequence", [](const py::list& segments, double dt) { return to_numpy(wave_sequence(segments_from(segments), dt)); },
      py::arg("segments"), py::arg("dt"),
      "Concatenated waves sampled at dt; segments: dicts {waveform: 'triangle'|'sine', amplitude, period, periods, offset}.");
  m.def(
      "gpi_identification_pressure", [](double dt) { return to_numpy(gpi_identification_pressure(dt)); },
      py::arg("dt"), "GPI paper Fig. 4: 0.2 Hz triangles, amplitude 0.6 down to 0.1 MPa [MPa].");
  m.def(
      "mpi_identification_pressure", [](double dt) { return to_numpy(mpi_identification_pressure(dt)); },
      py::arg("dt"), "Asymmetric-MPI paper identification input [MPa].");
  m.def(
      "gpi_sinusoid_reference",
      [](double dt, double duration, double rest_length) {
        return to_numpy(gpi_sinusoid_reference(dt, duration, rest_length));
      },
      py::arg("dt"), py::arg("duration"), py::arg("rest_length") = 0.5,
      "GPI paper Eq. 18 / Table 4 reference as a contraction [m].");
  m.def(
      "mpi_triangle_contraction",
      [](double dt, const IntArg& n) {
        return to_numpy(mpi_triangle_contraction(dt, int_arg(n, "mpi_triangle_contraction: periods_each")));
      },
      py::arg("dt"), py::arg("periods_each") = 1, "Asymmetric-MPI paper triangle references 40/35/30 mm [m].");
  m.def(
      "mpi_sine_contraction",
      [](double dt, const IntArg& n) {
        return to_numpy(mpi_sine_contraction(dt, int_arg(n, "mpi_sine_contraction: periods_each")));
      },
      py::arg("dt"),
      py::arg("periods_each") = 1, "Asymmetric-MPI paper sine references 40/35/30 mm [m].");
}

}  // namespace hysteron::python
