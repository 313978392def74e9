// mpi-deadzone-switching-valves.txt: dead-zone MPI by LM; cascade with fast
// switching valves (outer position loop with inverse feedforward, inner pressure
// loop driving PWM). The paper's text is truncated before its results.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "detail.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/signals.hpp"

namespace hysteron::experiment {

namespace {

// CascadePwmController on `model` with `p`; the loop's numbers (its PID and the valves'
// pressure loop) from p.
Loop cascade(const ModelParams& model, const CascadeParams& p, std::string description) {
  auto c = std::make_shared<CascadePwmController>(model, p);
  Law law = [c](const Sample& s) {
    const double d = c->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa);
    return valves(d, c->desired_pressure());
  };
  Loop loop{std::move(law), std::move(description), p.position, {}, p.pressure, 0.0,
            LoopDesign::Kind::cascade_pwm, p.feedforward, p.pwm};
  loop.position_state = [c] { return c->position().state(); };
  loop.restart_guard = [c] { c->set_guard(c->position().params().guard); };
  return loop;
}

// The paper's cascade, its desired pressure limited to 0..p_max [MPa] (the run's limit).
CascadeParams published(double tc, double p_max) {
  CascadeParams p;
  p.feedforward.sample_time = tc;
  p.feedforward.pressure_limits = {0.0, p_max};
  p.position = gpi_paper_pid(tc, -p_max, p_max);
  p.pressure.kp = 20.0;  // duty per MPa
  p.pressure.sample_time = tc;
  p.pwm.gain = 1.0;
  return p;
}

// The compensated cascade (CascadePwmController) with the adaptive inverse as its feedforward.
Loop adaptive_cascade(const Context& c, bool frozen) {
  CascadeParams p = published(c.tc, c.pressure_max);
  p.position = position_pid(c);
  p.pressure = c.pressure_loop;
  auto a = adaptive_inverse(c, frozen);
  const double p_max = c.pressure_max;
  auto ff = std::make_shared<AdaptiveFeedforward>(a, p_max);
  // the compensated cascade (its sign, limits and faults: duty 0 on a lost pressure reading), fed the
  // adaptive inverse's feedforward
  auto cc = std::make_shared<CascadePwmController>(c.result.best_fit.model, p);
  Law law = [ff, cc](const Sample& s) {
    const double d = cc->step_feedforward(s.reference_m, ff->step(s), s.measured_m, s.pressure_mpa);
    return valves(d, cc->desired_pressure());
  };
  const std::string name = c.reference->name;
  Loop result{std::move(law),
              fmt::format("best inverse model fed {:.0f} ms ahead, {}; PID position loop by {} (Kp = {:.3g} "
                          "MPa/m, Ki = {:.3g} MPa/(m s), Kd = {:.3g} MPa s/m); PI pressure loop by a relay test (Kp = "
                          "{:.3g}/MPa, Ki = {:.3g}/(MPa s))",
                          c.result.lead_s * 1e3, adaptive_description(*a), pid_origin(c), p.position.kp, p.position.ki,
                          p.position.kd, p.pressure.kp, p.pressure.ki),
              p.position, [a, name] { return adaptive_note(*a, name); }, p.pressure, 0.0,
              LoopDesign::Kind::cascade_pwm, p.feedforward, p.pwm};
  if (!frozen) result.adaptation = adaptation_of(*a);  // frozen: the fitted inverse, fixed
  result.position_state = [cc] { return cc->position().state(); };
  result.restart_guard = [cc] { cc->set_guard(cc->position().params().guard); };
  return result;
}

}  // namespace


const Spec& mpi_pwm_spec() {
  static const Spec spec = [] {
    Spec s;
    s.name = "mpi-pwm";
    s.title = "Dead-zone MPI + cascade control with fast switching valves (mpi-deadzone-switching-valves.txt)";
    s.summary = "Modified PI with play and dead-zone operators fitted by Levenberg-Marquardt; cascade control "
                "with cheap fast switching valves (outer position loop with inverse feedforward, inner pressure "
                "loop driving PWM). The paper's text ends before its results: no published figures.";
    s.model = FitModel::mpi_deadzone;
    s.operators = 10;
    s.id_pressure = gpi_identification_pressure;
    s.id2_pressure = mpi_identification_pressure;
    s.references = [](double tc) {
      const auto period = static_cast<std::size_t>(std::lround(5.0 / tc));
      std::vector<Reference> r{{"sine", gpi_sinusoid_reference(tc, 20.0), period, period},
                               {"triangle", mpi_triangle_contraction(tc, 1), 0, 0}};
      r[1].period = r[1].ref_m.size();
      return r;
    };
    s.published = {};  // the text we have ends before the paper's results
    s.valves = true;
    s.variants = {
        {"faithful", false,
         [](const Context& c) {
           return cascade(c.result.fit.model, published(c.tc, c.pressure_max),
                          "inverse dead-zone MPI + PID position loop, P pressure loop on PWM switching valves");
         }},
        {"compensated", true,
         [](const Context& c) {
           CascadeParams p = published(c.tc, c.pressure_max);
           p.position = position_pid(c);
           p.pressure = c.pressure_loop;
           return cascade(c.result.best_fit.model, p,
                          fmt::format("best inverse model fed {:.0f} ms ahead; PID position loop by {} (Kp = {:.3g} "
                                      "MPa/m, Ki = {:.3g} MPa/(m s), Kd = {:.3g} MPa s/m); PI pressure loop by a "
                                      "relay test (Kp = {:.3g}/MPa, Ki = {:.3g}/(MPa s))",
                                      c.result.lead_s * 1e3, pid_origin(c), p.position.kp, p.position.ki,
                                      p.position.kd, p.pressure.kp, p.pressure.ki));
         }},
        {"adaptive", true, [](const Context& c) { return adaptive_cascade(c, false); }},
        {"baseline", false,
         [](const Context& c) {
           return cascade(c.result.baseline_model, published(c.tc, c.pressure_max),
                          "straight-line feedforward (no hysteresis) in the same cascade");
         }},
    };
    return s;
  }();
  return spec;
}

}  // namespace hysteron::experiment
