// gpi-lm-feedforward-pid.txt: GPI (n = 10) fitted by LM on the major loop of the
// Fig. 4 input; inverse feedforward + PID of Table 3 (Fig. 10) tracking Eq. 18 /
// Table 4; published Table 5.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "detail.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/signals.hpp"

namespace hysteron::experiment {

namespace {

// FeedforwardPidController on `model` with `pid`, its pressure limited to 0..p_max [MPa].
Loop ff_pid_loop(const ModelParams& model, double tc, double p_max, const PidParams& pid, std::string description) {
  FeedforwardParams ff;
  ff.sample_time = tc;
  ff.pressure_limits = {0.0, p_max};
  auto c = std::make_shared<FeedforwardPidController>(model, ff, pid);
  Loop loop{[c, p_max](const Sample& s) { return regulator(c->step(s.reference_m, s.preview_m, s.measured_m), p_max); },
            std::move(description), pid};
  loop.feedforward = ff;
  loop.position_state = [c] { return c->pid().state(); };
  loop.restart_guard = [c] { c->set_guard(c->pid().params().guard); };
  return loop;
}

// The compensated loop (FeedforwardPidController) with the adaptive inverse as its feedforward.
Loop adaptive_ff_pid(const Context& c, bool frozen) {
  const PidParams pid = position_pid(c);
  auto a = adaptive_inverse(c, frozen);
  const double p_max = c.pressure_max;
  auto ff = std::make_shared<AdaptiveFeedforward>(a, p_max);
  // the compensated loop's controller (its sign, limits and hold), fed the adaptive inverse's feedforward
  FeedforwardParams ffp;
  ffp.sample_time = c.tc;
  ffp.pressure_limits = {0.0, p_max};
  auto fb = std::make_shared<FeedforwardPidController>(c.result.best_fit.model, ffp, pid);
  Law law = [ff, fb, p_max](const Sample& s) {
    return regulator(fb->step_feedforward(s.reference_m, ff->step(s), s.measured_m), p_max);
  };
  const std::string name = c.reference->name;
  Loop result{std::move(law),
              fmt::format("best inverse model fed {:.0f} ms ahead, {}; PID tuned by {} (Kp = {:.3g} MPa/m, "
                          "Ki = {:.3g} MPa/(m s), Kd = {:.3g} MPa s/m)",
                          c.result.lead_s * 1e3, adaptive_description(*a), pid_origin(c), pid.kp, pid.ki, pid.kd),
              pid, [a, name] { return adaptive_note(*a, name); }};
  result.feedforward.pressure_limits = {0.0, p_max};
  if (!frozen) result.adaptation = adaptation_of(*a);  // frozen: the fitted inverse, fixed
  result.position_state = [fb] { return fb->pid().state(); };
  result.restart_guard = [fb] { fb->set_guard(fb->pid().params().guard); };
  return result;
}

}  // namespace


const Spec& gpi_pid_spec() {
  static const Spec spec = [] {
    Spec s;
    s.name = "gpi-pid";
    s.title = "GPI model + inverse feedforward + PID (gpi-lm-feedforward-pid.txt, Fig. 10, Tables 3-5)";
    s.summary = "GPI (n = 10, tanh envelope) fitted by Levenberg-Marquardt on the major loop of the paper's "
                "Fig. 4 pressure input; inverse feedforward + PID tracking the Eq. 18 sinusoid (Table 4, 0.2 Hz, "
                "45 mm amplitude); compared with the paper's Table 5.";
    s.model = FitModel::gpi;
    s.operators = 10;
    s.id_pressure = gpi_identification_pressure;
    s.id2_pressure = mpi_identification_pressure;
    s.references = [](double tc) {
      // Eq. 18 / Table 4: one warm-up period (the muscle starts vented, 5 mm away), three scored.
      const auto period = static_cast<std::size_t>(std::lround(5.0 / tc));
      return std::vector<Reference>{{"sine", gpi_sinusoid_reference(tc, 20.0), period, period}};
    };
    s.published = {"gpi-lm-feedforward-pid.txt, Table 5", {{"", 2.659, 0.7358, 0.8701}}};
    s.variants = {
        {"faithful", false,
         [](const Context& c) {
           const PidParams paper = gpi_paper_pid(c.tc, -c.pressure_max, c.pressure_max);
           return ff_pid_loop(c.result.fit.model, c.tc, c.pressure_max, paper,
                              "inverse GPI feedforward + PID of Table 3 (Kp = 0.05 V/mm, Ki = 0.01 V/(mm s))");
         }},
        {"compensated", true,
         [](const Context& c) {
           const PidParams pid = position_pid(c);
           return ff_pid_loop(c.result.best_fit.model, c.tc, c.pressure_max, pid,
                              fmt::format("best inverse model fed {:.0f} ms ahead, PID tuned by {} "
                                          "(Kp = {:.3g} MPa/m, Ki = {:.3g} MPa/(m s), Kd = {:.3g} MPa s/m)",
                                          c.result.lead_s * 1e3, pid_origin(c), pid.kp, pid.ki, pid.kd));
         }},
        {"adaptive", true, [](const Context& c) { return adaptive_ff_pid(c, false); }},
        {"baseline", false,
         [](const Context& c) {
           const PidParams paper = gpi_paper_pid(c.tc, -c.pressure_max, c.pressure_max);
           return ff_pid_loop(c.result.baseline_model, c.tc, c.pressure_max, paper,
                              "straight-line feedforward (no hysteresis) + PID of Table 3");
         }},
    };
    return s;
  }();
  return spec;
}

}  // namespace hysteron::experiment
