// What the experiments share: rig runs, fits, the tracking loop (detail.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron::experiment {

double run_pressure_limit(const ExperimentOptions& o, bool valves) {
  const Actuation mode = valves ? Actuation::switching_valves : Actuation::regulator;
  double pa = pressure_command_limit(o.rig, mode);
  if (o.tracking_rig) pa = std::min(pa, pressure_command_limit(*o.tracking_rig, mode));
  return pa / 1e6;  // [MPa], correctly rounded (600e3 Pa: exactly the double 0.6)
}

std::vector<double> paper_pressure_input(std::vector<double> input, double p_max) {
  if (p_max < kPaperPressureMax)
    for (double& v : input) v *= p_max / kPaperPressureMax;
  return input;
}

RigInputs regulator(double p, double p_max) {
  RigInputs in;
  in.mode = Actuation::regulator;
  in.pressure_command = std::clamp(p, 0.0, p_max);
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
                                     double tc, const Actuator& actuator, double p_max) {
  PamRig rig(rp, seed);
  rig.reset();
  IdentificationRun rec;
  std::size_t k = 0;
  rig.run(static_cast<double>(pressure.size()) * tc, tc, [&](const RigOutputs& o) {
    const double desired = std::clamp(pressure[std::min(k, pressure.size() - 1)], 0.0, p_max);
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
ModelParams straight_line(const IdentificationRun& r, double p_max) {
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
  g.input_limits = {0.0, p_max};
  return g;
}

FitReport fit_checked(const IdentificationRun& r, FitOptions fo, const std::string& what, double p_max,
                      FitStatus* status) {
  FitReport rep = fit(r.pressure_mpa, r.contraction_mm, fo);
  if (status) *status = rep.status;
  if (rep.status == FitStatus::invalid_input || rep.status == FitStatus::failed)
    throw Error(fmt::format("experiment: fit of the {} failed: {}", what, rep.message));
  std::visit([p_max](auto& p) { p.input_limits = {0.0, p_max}; }, rep.model);
  Inverse check(rep.model);  // throws if the fitted model is not invertible
  return rep;
}

std::size_t saturated_samples(const TrackingRun& run, std::size_t from, std::size_t to, double p_max) {
  std::size_t n = 0;
  for (std::size_t k = from; k < std::min(to, run.pressure_command_mpa.size()); ++k)
    if (run.pressure_command_mpa[k] <= 0.0 || run.pressure_command_mpa[k] >= p_max) ++n;
  return n;
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

std::string sensor_gap(const TrackingRun& run, std::size_t from, std::size_t to, double frame_mm) {
  to = std::min({to, run.t.size(), run.actual_mm.size()});
  if (from >= to) return {};
  double s2 = 0.0, t2 = 0.0, bias = 0.0;
  for (std::size_t k = from; k < to; ++k) {
    const double truth = run.actual_mm[k] + frame_mm;
    const double ds = run.reference_mm[k] - run.measured_mm[k], dt = run.reference_mm[k] - truth;
    s2 += ds * ds, t2 += dt * dt, bias += run.measured_mm[k] - truth;
  }
  const double n = static_cast<double>(to - from);
  const double sensor = std::sqrt(s2 / n), truth = std::sqrt(t2 / n);
  if (!(truth > kSensorGapRatio * sensor && truth - sensor > kSensorGapFloorMm)) return {};
  return fmt::format("{} ({}) RMS {:.3f} mm by the sensor, {:.3f} mm against the true contraction (the reading {:.3f} "
                     "mm {} it on average)",
                     run.variant, run.reference, sensor, truth, std::abs(bias / n), bias >= 0.0 ? "above" : "below");
}

std::string sensor_gap_note(const std::vector<std::string>& gaps, const PamRigParams& identified,
                            const PamRigParams& tracked) {
  if (gaps.empty()) return {};
  const SensorParams &a = identified.sensors, &b = tracked.sensors;
  std::string s = fmt::format("the displacement sensor's reading hides part of the tracking error (the true "
                              "contraction taken in the identified sensor's frame, its offset {:.3f} mm added): ",
                              a.displacement_offset * 1e3);
  for (std::size_t i = 0; i < gaps.size(); ++i) s += (i ? "; " : "") + gaps[i];
  s += ". The errors in this result are the sensor's, as on a real rig, where only the sensor is seen";
  if (b.displacement_offset != a.displacement_offset)
    s += fmt::format(": its offset changed after the identification, {:.3f} -> {:.3f} mm (--tracking-plant), and "
                     "the loops track the reading; re-zero the sensor or identify again",
                     a.displacement_offset * 1e3, b.displacement_offset * 1e3);
  else
    s += fmt::format(": its resolution and range bound what they show ({} bits over {:.0f} mm)", b.displacement_bits,
                     b.displacement_range * 1e3);
  return s;
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

// Where the command sat at the top for long enough that the pressure reading levelled off (its
// mean over the last third of the longest stretch within 1 % of p_max of the middle
// third's) and it levelled off more than kCapMargin below the top, something caps the pressure
// on the rig tracked on: the supply, regulator or valves, or the pressure sensor's range. A
// stretch too short to level off (the regulator's lag) says nothing.
std::optional<CappedTop> capped_top(const TrackingRun& run, std::size_t from, std::size_t to, double p_max) {
  const std::vector<double>& p = run.pressure_measured_mpa.size() == run.t.size() ? run.pressure_measured_mpa
                                                                                   : run.pressure_mpa;
  std::size_t best_from = 0, best_n = 0;
  for (std::size_t k = from; k < to;) {
    if (run.pressure_command_mpa[k] < p_max) {
      ++k;
      continue;
    }
    std::size_t e = k;
    while (e < to && run.pressure_command_mpa[e] >= p_max) ++e;
    if (e - k > best_n) best_from = k, best_n = e - k;
    k = e;
  }
  if (best_n < 30 || p.size() < best_from + best_n) return std::nullopt;
  const auto mean = [&](std::size_t a, std::size_t b) {
    double s = 0.0;
    for (std::size_t k = a; k < b; ++k) s += p[k];
    return s / static_cast<double>(b - a);
  };
  const std::size_t third = best_n / 3;
  const double middle = mean(best_from + third, best_from + 2 * third);
  const double last = mean(best_from + best_n - third, best_from + best_n);
  if (!(std::abs(last - middle) <= 0.01 * p_max) || !(last < (1.0 - kCapMargin) * p_max))
    return std::nullopt;
  return CappedTop{last, run.t[best_from + best_n - 1] - run.t[best_from]};
}

std::string saturation_note(const TrackingRun& run, std::size_t from, std::size_t to, double reach_mpa,
                            bool rig_changed, double p_max) {
  to = std::min(to, run.t.size());
  if (from >= to) return {};
  std::size_t low = 0, high = 0;
  double in2 = 0.0, out2 = 0.0;
  for (std::size_t k = from; k < to; ++k) {
    const double d = run.reference_mm[k] - run.measured_mm[k], p = run.pressure_command_mpa[k];
    const bool at_low = p <= 0.0, at_high = p >= p_max;
    low += at_low, high += at_high;
    (at_low || at_high ? in2 : out2) += d * d;
  }
  const std::size_t n = to - from, sat = low + high;
  if (100 * sat < n) return {};  // brief touches of a limit: no note
  const double rms_in = std::sqrt(in2 / static_cast<double>(sat));
  const double rms_out = sat < n ? std::sqrt(out2 / static_cast<double>(n - sat)) : 0.0;
  std::string why =
      "at a limit the loop has no authority left (e.g. the load cannot follow the reference's descent with the "
      "muscle vented, or the reference needs more pressure than the actuator has)";
  if (const std::optional<CappedTop> top = capped_top(run, from, to, p_max)) {
    // the cap explains the samples at the top; where those at 0 MPa are more, the generic words stay first
    why = (high >= low ? std::string() : why + "; and ") +
          fmt::format("while the command sat at {} MPa (over its longest stretch, {:.2f} s) the pressure reading "
                      "levelled off at {:.3f} MPa",
                      p_max, top->stretch_s, top->level_mpa);
    if (reach_mpa > (1.0 + kCapMargin) * top->level_mpa)
      why += fmt::format(", where the identification run reached {:.3f} MPa", reach_mpa);
    why += ": the supply, regulator or valves cap the pressure on this rig, or the pressure sensor's range ends "
           "there, so the reference needs more than the actuator gives";
    if (rig_changed && reach_mpa > (1.0 + kCapMargin) * top->level_mpa)
      why += "; the references were fitted to the reach of the identified rig (--plant), not of the rig tracked on "
             "(--tracking-plant): identify on the rig as it is now";
  }
  return fmt::format(
      "{} ({}): the pressure command was at a limit on {:.1f} % of the scored samples ({} at 0 MPa, {} at {} MPa); "
      "RMS error {:.3f} mm there, {:.3f} mm elsewhere: {}",
      run.variant, run.reference, 100.0 * static_cast<double>(sat) / static_cast<double>(n), low, high, p_max,
      rms_in, rms_out, why);
}

void check_stop(const ExperimentOptions& o) {
  if (o.stop_requested && o.stop_requested()) throw Stopped("experiment stopped (stop requested)");
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
    if (k % 4096 == 0) check_stop(o);  // a learning run lasts minutes of the rig's time
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
    ++k;
    return in;
  });
  return run;
}

}  // namespace hysteron::experiment
