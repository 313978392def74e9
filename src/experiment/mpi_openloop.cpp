// mpi-asymmetric-openloop.txt: asymmetric MPI (20 operators) on the 0.5..0.3 MPa
// input; open-loop inverse + proportional pressure loop; triangle and sine
// references 40/35/30 mm; published maximum errors 1.29 mm (triangle), 1.38 mm (sine).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include "detail.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/signals.hpp"

namespace hysteron::experiment {

namespace {

constexpr double kPressureGain = 0.5;  // the paper's k_p of the pressure loop

// OpenLoopController on `model` with `p`; the loop's numbers (its PID and pressure loop) from p.
Loop open_loop(const ModelParams& model, const OpenLoopParams& p, std::string description) {
  auto c = std::make_shared<OpenLoopController>(model, p);
  const double p_max = p.feedforward.pressure_limits.hi;
  Law law = [c, p_max](const Sample& s) {
    return regulator(c->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa), p_max);
  };
  Loop loop{std::move(law), std::move(description), p.position, {}, std::nullopt, p.pressure_gain,
            LoopDesign::Kind::open_loop, p.feedforward};
  loop.position_state = [c] { return c->position().state(); };
  loop.restart_guard = [c] { c->set_guard(c->position().params().guard); };
  return loop;
}

// The paper's loop, its pressure limited to 0..p_max [MPa] (the run's limit).
OpenLoopParams published(double tc, double p_max) {
  OpenLoopParams p;
  p.feedforward.sample_time = tc;
  p.feedforward.pressure_limits = {0.0, p_max};
  p.pressure_gain = kPressureGain;
  return p;
}

// The compensated loop (OpenLoopController with its PID position correction) with the
// adaptive inverse as its feedforward.
Loop adaptive_open_loop(const Context& c, bool frozen) {
  OpenLoopParams p = published(c.tc, c.pressure_max);
  p.position = position_pid(c);
  auto a = adaptive_inverse(c, frozen);
  const double p_max = c.pressure_max;
  auto ff = std::make_shared<AdaptiveFeedforward>(a, p_max);
  // the compensated loop's controller (its sign, limits and pressure loop), fed the adaptive inverse's feedforward
  auto ol = std::make_shared<OpenLoopController>(c.result.best_fit.model, p);
  const double kp = p.pressure_gain;
  Law law = [ff, ol, p_max](const Sample& s) {
    return regulator(ol->step_feedforward(s.reference_m, ff->step(s), s.measured_m, s.pressure_mpa), p_max);
  };
  const std::string name = c.reference->name;
  Loop result{std::move(law),
              fmt::format("best inverse model fed {:.0f} ms ahead, {}; pressure loop (k_p = {:g}) + PID position "
                          "correction tuned by {} (Kp = {:.3g} MPa/m, Ki = {:.3g} MPa/(m s), Kd = {:.3g} MPa s/m)",
                          c.result.lead_s * 1e3, adaptive_description(*a), p.pressure_gain, pid_origin(c),
                          p.position.kp, p.position.ki, p.position.kd),
              p.position, [a, name] { return adaptive_note(*a, name); }, std::nullopt, kp,
              LoopDesign::Kind::open_loop, p.feedforward};
  if (!frozen) result.adaptation = adaptation_of(*a);  // frozen: the fitted inverse, fixed
  result.position_state = [ol] { return ol->position().state(); };
  result.restart_guard = [ol] { ol->set_guard(ol->position().params().guard); };
  return result;
}

}  // namespace


const Spec& mpi_openloop_spec() {
  static const Spec spec = [] {
    Spec s;
    s.name = "mpi-openloop";
    s.title = "Asymmetric MPI + open-loop inverse + proportional pressure loop (mpi-asymmetric-openloop.txt, Fig. 6)";
    s.summary = "Asymmetric modified PI (20 ascending/descending operators) fitted on the 0.5..0.3 MPa triangle "
                "input; open-loop inverse compensation with a proportional pressure loop tracking the paper's "
                "triangle and sine references of 40, 35 and 30 mm; compared with its maximum errors.";
    s.model = FitModel::mpi_asym;
    s.operators = 20;
    s.id_pressure = mpi_identification_pressure;
    s.id2_pressure = gpi_identification_pressure;
    s.pressure_loop_gain = kPressureGain;
    s.references = [](double tc) {
      std::vector<Reference> r{{"triangle", mpi_triangle_contraction(tc, 1), 0, 0},
                               {"sine", mpi_sine_contraction(tc, 1), 0, 0}};
      for (auto& x : r) x.period = x.ref_m.size();  // the 40/35/30 mm sequence repeats
      return r;
    };
    s.published = {"mpi-asymmetric-openloop.txt, Results", {{"triangle", 1.29}, {"sine", 1.38}}};
    s.variants = {
        {"faithful", false,
         [](const Context& c) {
           return open_loop(c.result.fit.model, published(c.tc, c.pressure_max),
                            "inverse asymmetric MPI, open loop, proportional pressure loop (k_p = 0.5)");
         }},
        {"compensated", true,
         [](const Context& c) {
           // the paper's pressure loop, through which the rig was identified (Spec::pressure_loop_gain),
           // and the PID from the relay test (and gain trial) on it
           OpenLoopParams p = published(c.tc, c.pressure_max);
           p.position = position_pid(c);
           return open_loop(c.result.best_fit.model, p,
                            fmt::format("best inverse model fed {:.0f} ms ahead, pressure loop (k_p = {:g}) + PID "
                                        "position correction tuned by {} (Kp = {:.3g} MPa/m, Ki = {:.3g} MPa/(m s), "
                                        "Kd = {:.3g} MPa s/m)",
                                        c.result.lead_s * 1e3, p.pressure_gain, pid_origin(c), p.position.kp,
                                        p.position.ki, p.position.kd));
         }},
        {"adaptive", true, [](const Context& c) { return adaptive_open_loop(c, false); }},
        {"baseline", false,
         [](const Context& c) {
           return open_loop(c.result.baseline_model, published(c.tc, c.pressure_max),
                            "straight-line open-loop inverse (no hysteresis), proportional pressure loop");
         }},
    };
    return s;
  }();
  return spec;
}

}  // namespace hysteron::experiment
