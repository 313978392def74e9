// What the experiments share: rig runs, fits, the tracking loop (detail.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron::experiment {

RigInputs regulator(double p) {
  RigInputs in;
  in.mode = Actuation::regulator;
  in.pressure_command = std::clamp(p, 0.0, kPressureMax);
  return in;
}

RigInputs valves(double duty, double desired_mpa) {
  RigInputs in;
  in.mode = Actuation::switching_valves;
  in.pwm_duty = std::clamp(duty, -1.0, 1.0);
  in.pressure_command = desired_mpa;
  return in;
}

IdentificationRun identification_run(const PamRigParams& rp, std::uint64_t seed, const std::vector<double>& pressure,
                                     double tc, const Actuator& actuator) {
  PamRig rig(rp, seed);
  rig.reset();
  IdentificationRun rec;
  std::size_t k = 0;
  rig.run(static_cast<double>(pressure.size()) * tc, tc, [&](const RigOutputs& o) {
    const double desired = std::clamp(pressure[std::min(k, pressure.size() - 1)], 0.0, kPressureMax);
    const RigInputs in = actuator(desired, o);
    rec.t.push_back(o.time);
    rec.pressure_command_mpa.push_back(desired);
    rec.pressure_mpa.push_back(o.pressure_measured * 1e-6);
    rec.contraction_mm.push_back(o.contraction_measured * 1e3);
    ++k;
    return in;
  });
  return rec;
}

IdentificationRun decimate(const IdentificationRun& r, std::size_t every) {
  IdentificationRun d;
  for (std::size_t i = 0; i < r.t.size(); i += every) {
    d.t.push_back(r.t[i]);
    d.pressure_command_mpa.push_back(r.pressure_command_mpa[i]);
    d.pressure_mpa.push_back(r.pressure_mpa[i]);
    d.contraction_mm.push_back(r.contraction_mm[i]);
  }
  return d;
}

// Straight line x = a p + b through the record (least squares): the baseline's
// "inverse without hysteresis".
ModelParams straight_line(const IdentificationRun& r) {
  const auto n = static_cast<double>(r.pressure_mpa.size());
  double sp = 0, sx = 0, spp = 0, spx = 0;
  for (std::size_t i = 0; i < r.pressure_mpa.size(); ++i) {
    sp += r.pressure_mpa[i];
    sx += r.contraction_mm[i];
    spp += r.pressure_mpa[i] * r.pressure_mpa[i];
    spx += r.pressure_mpa[i] * r.contraction_mm[i];
  }
  const double den = n * spp - sp * sp;
  const double a = (n * spx - sp * sx) / den;
  const double b = (sx - a * sp) / n;
  if (!(a > 0)) throw Error("experiment: the identification run shows no contraction increasing with pressure");
  GpiParams g;
  g.envelope = Envelope::affine(a, b);
  g.q = 1.0;
  g.n = 0;
  g.input_limits = {0.0, kPressureMax};
  return g;
}

FitReport fit_checked(const IdentificationRun& r, FitOptions fo, const std::string& what, FitStatus* status) {
  FitReport rep = fit(r.pressure_mpa, r.contraction_mm, fo);
  if (status) *status = rep.status;
  if (rep.status == FitStatus::invalid_input || rep.status == FitStatus::failed)
    throw Error(fmt::format("experiment: fit of the {} failed: {}", what, rep.message));
  std::visit([](auto& p) { p.input_limits = {0.0, kPressureMax}; }, rep.model);
  Inverse check(rep.model);  // throws if the fitted model is not invertible
  return rep;
}

TrackingErrors errors_of(const TrackingRun& run, std::size_t from, std::size_t to) {
  TrackingErrors e;
  double s2 = 0, s1 = 0;
  std::size_t n = 0;
  for (std::size_t k = from; k < std::min(to, run.t.size()); ++k) {
    const double d = run.reference_mm[k] - run.measured_mm[k];
    e.max_error_mm = std::max(e.max_error_mm, std::abs(d));
    s1 += std::abs(d);
    s2 += d * d;
    ++n;
  }
  if (n) {
    e.mae_mm = s1 / static_cast<double>(n);
    e.rms_error_mm = std::sqrt(s2 / static_cast<double>(n));
  }
  return e;
}

std::string guard_note(const TrackingRun& run, bool rig_changed) {
  const LoopDesign& c = run.controller;
  if (c.guard_cuts == 0 || !c.pid) return "";
  return fmt::format("{} ({}): the loop rang near its ultimate period (T_u = {:.0f} ms, the position relay's), and "
                     "the PID's limit-cycle guard cut its gains {} time(s), to x{:.2f} of the tuned ones "
                     "(docs/control.md, section 2); {}",
                     run.variant, run.reference, c.pid->guard.period * 1e3, c.guard_cuts, c.guard_final_scale,
                     rig_changed ? "the rig it tracked on (--tracking-plant) differs from the one it was tuned on: "
                                   "identify and tune on the rig as it is now"
                                 : "the gain trial's gains are too high for this reference on this rig");
}

std::string saturation_note(const TrackingRun& run, std::size_t from, std::size_t to) {
  to = std::min(to, run.t.size());
  if (from >= to) return {};
  std::size_t low = 0, high = 0;
  double in2 = 0.0, out2 = 0.0;
  for (std::size_t k = from; k < to; ++k) {
    const double d = run.reference_mm[k] - run.measured_mm[k], p = run.pressure_command_mpa[k];
    const bool at_low = p <= 0.0, at_high = p >= kPressureMax;
    low += at_low, high += at_high;
    (at_low || at_high ? in2 : out2) += d * d;
  }
  const std::size_t n = to - from, sat = low + high;
  if (100 * sat < n) return {};  // brief touches of a limit: no note
  const double rms_in = std::sqrt(in2 / static_cast<double>(sat));
  const double rms_out = sat < n ? std::sqrt(out2 / static_cast<double>(n - sat)) : 0.0;
  return fmt::format(
      "{} ({}): the pressure command was at a limit on {:.1f} % of the scored samples ({} at 0 MPa, {} at {} MPa); "
      "RMS error {:.3f} mm there, {:.3f} mm elsewhere: at a limit the loop has no authority left (e.g. the load "
      "cannot follow the reference's descent with the muscle vented, or the reference needs more pressure than the "
      "actuator has)",
      run.variant, run.reference, 100.0 * static_cast<double>(sat) / static_cast<double>(n), low, high, kPressureMax,
      rms_in, rms_out);
}

TrackingRun track(const ExperimentOptions& o, std::uint64_t seed, const std::vector<double>& ref_m,
                  std::size_t lead, bool periodic, const Law& law) {
  PamRig rig(o.tracking_rig ? *o.tracking_rig : o.rig, seed);
  rig.reset();
  TrackingRun run;
  const std::size_t n = ref_m.size();
  for (auto* v : {&run.t, &run.reference_mm, &run.measured_mm, &run.actual_mm, &run.pressure_command_mpa,
                  &run.pressure_mpa, &run.pressure_measured_mpa, &run.duty})
    v->reserve(n);
  std::size_t k = 0;
  rig.run(static_cast<double>(n) * o.control_period, o.control_period, [&](const RigOutputs& out) {
    const std::size_t i = std::min(k, n - 1);
    const std::size_t ahead = periodic ? (i + lead) % n : std::min(i + lead, n - 1);
    const Sample s{ref_m[i], ref_m[ahead], out.contraction_measured, out.pressure_measured * 1e-6, k};
    RigInputs in = law(s);
    run.t.push_back(out.time);
    run.reference_mm.push_back(s.reference_m * 1e3);
    run.measured_mm.push_back(out.contraction_measured * 1e3);
    run.actual_mm.push_back(out.contraction * 1e3);
    // With the valves, pressure_command carries the cascade's desired pressure (the rig ignores it).
    run.pressure_command_mpa.push_back(in.pressure_command);
    run.pressure_mpa.push_back(out.pressure * 1e-6);
    run.pressure_measured_mpa.push_back(s.pressure_mpa);
    run.duty.push_back(in.mode == Actuation::switching_valves ? in.pwm_duty : 0.0);
    if (in.pressure_command <= 0.0 || in.pressure_command >= kPressureMax) ++run.saturated;
    ++k;
    return in;
  });
  return run;
}

}  // namespace hysteron::experiment
