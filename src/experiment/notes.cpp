// The notes the experiments add to a result: what the rig, its sensors and the runs' errors
// say about the loops (the rig's limits, a run above another, a changed rig).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "detail.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/plant.hpp"

namespace hysteron::experiment {

// The note of references that descend faster than the vented load's terminal speed (empty if
// none does). With the muscle vented it pulls at most what its hysteresis band leaves (P1-P2),
// and its return force, weight plus spring, drives the load down against the damping at the
// terminal speed v_t(x) = (m g + F_s0 + k_s x) / c (P5). It is no strict bound: the creep
// element's pull (up to k_c x after a quick rise, P4) and the momentum of a load whose spring
// force drops as it falls add to it for a while (a 20 N load fell at 84.9 mm/s after a 0.5 s
// rise where v_t was 50). So the note says where the reference asks for more than v_t: there
// the loop has the command at 0 MPa and little authority left. On the rig the references are
// tracked on (a --tracking-plant rig, or the identified one); a load without damping has none.
std::string descent_note(const PamRigParams& rig, const std::vector<Reference>& refs, double tc) {
  const LoadParams& l = rig.load;
  if (!(l.damping > 0.0)) return {};
  std::vector<std::string> parts;
  for (const Reference& ref : refs) {
    double worst = 1.0, v_at = 0.0, x_at = 0.0, faster_s = 0.0;
    for (std::size_t k = std::max<std::size_t>(ref.score_from, 1); k < ref.ref_m.size(); ++k) {
      const double v = (ref.ref_m[k - 1] - ref.ref_m[k]) / tc;  // descent speed [m/s]
      const double v_t = return_force(l, std::max(0.0, ref.ref_m[k])) / l.damping;
      if (!(v > v_t)) continue;
      faster_s += tc;
      if (v / v_t > worst) {
        worst = v / v_t;
        v_at = v;
        x_at = ref.ref_m[k];
      }
    }
    if (faster_s > 0.0)
      parts.push_back(fmt::format("{} descends at {:.1f} mm/s at {:.1f} mm, where the terminal speed is {:.1f} mm/s "
                                  "({:.1f} s of the scored reference faster than it)",
                                  ref.name, v_at * 1e3, x_at * 1e3, v_at / worst * 1e3, faster_s));
  }
  if (parts.empty()) return {};
  return fmt::format(
      "the references descend faster than the vented load's terminal speed under its return force, (load.mass x "
      "load.gravity + load.spring_preload + load.spring_rate x contraction) / load.damping = ({:g} + {:g} + {:g} x) "
      "N / {:g} N s/m: {}; there the command sits at 0 MPa and the loop has little authority left (only the creep "
      "element's pull and the load's momentum add to that speed for a while), so the error is mostly the rig's (a "
      "heavier load, a stiffer return spring, less damping or a slower reference; docs/plant.md, P5)",
      l.mass * l.gravity, l.spring_preload, l.spring_rate, l.damping, fmt::join(parts, "; "));
}

// The note of a rig whose vented muscle, held at the top of its reach longer than the creep time,
// stalls in the upper half of its reach where the creep element's pull meets the return force
// (rig_weak_return_reason, the warning of `hysteron rig`; docs/plant.md, "A weak return force"),
// naming the references whose scored part goes below the stall; empty if the rig's return is not
// weak. Not a refusal: the vented muscle does get below the stall, only at the creep's pace, and a
// reference the rig cannot follow is noted, as where it leaves the reach (fit_to_reach).
std::string weak_return_note(const PamRigParams& rig, std::string_view which, const std::vector<Reference>& refs) {
  const RigStatics s = rig_statics(rig, which);  // its weak_return is the reason, keys named after `which`
  const std::string& why = s.weak_return;
  if (why.empty()) return {};
  std::vector<std::string> below;
  for (const Reference& ref : refs) {
    if (ref.score_from >= ref.ref_m.size()) continue;
    const auto scored = ref.ref_m.begin() + static_cast<std::ptrdiff_t>(ref.score_from);
    const double lo = *std::min_element(scored, ref.ref_m.end());
    if (lo < s.vented_stall_m) below.push_back(fmt::format("{} down to {:.1f} mm", ref.name, lo * 1e3));
  }
  return fmt::format("{}: {}: {}; the results below {:.1f} mm are the rig's, not the controller's", which, why,
                     below.empty() ? std::string("no reference goes below the stall")
                                   : fmt::format("the references go below the stall ({})", fmt::join(below, ", ")),
                     s.vented_stall_m * 1e3);
}

// The displacement sensor's noise is in every RMS error the sensor measures: with noise of
// width sigma independent of the loop's true error e, the reading's RMS is about
// sqrt(e^2 + sigma^2), so no loop reads below sigma, and learning cannot learn what is noise.
// Where sigma is at least half the least RMS of the compensating runs (their true error then at
// most 0.87 of what the reading shows), a note says so. sigma is estimated as the fit does
// (detect_clipping: the MAD of the second differences) on the identification run's contraction,
// the user's own record; empty where the floor is below that.
std::string noise_floor_note(const ExperimentResult& res, const IdentificationRun& id) {
  const double sigma = detect_clipping(id.contraction_mm).sigma;
  if (!(sigma > 0.0)) return {};
  const TrackingRun* least = nullptr;
  for (const TrackingRun& run : res.runs)
    if ((run.variant == "compensated" || run.variant == "learning" || run.variant == "adaptive") &&
        (!least || run.errors.rms_error_mm < least->errors.rms_error_mm))
      least = &run;
  if (!least || !(sigma >= 0.5 * least->errors.rms_error_mm)) return {};
  return fmt::format(
      "the displacement sensor's noise, about {:.3f} mm wide (estimated on the identification run: the median "
      "absolute second difference of its contraction), is in every RMS error of this result, which that sensor "
      "measures: a loop without error would read about {:.3f} mm RMS, and the least here is {:.3f} mm ({}, {}), so "
      "the runs' true errors are smaller than they read and differences between them of the order of the noise are "
      "not the loops'; nor can learning learn it away (a finer sensor, docs/control.md section 5)",
      sigma, sigma, least->errors.rms_error_mm, least->variant, least->reference);
}

// The note of a run whose actuator limit is not the papers' 0..0.6 MPa: where it comes from,
// and what changes (the papers' identification inputs scaled, or kept).
std::string limit_note(const ExperimentOptions& o, const Spec& spec, double p_max) {
  const auto of = [&](const PamRigParams& rp, const char* which) {
    std::string s = fmt::format("{}muscle.max_pressure = {:g} kPa", which, rp.muscle.max_pressure * 1e-3);
    if (!spec.valves) s += fmt::format(", regulator.max_command = {:g} kPa", rp.regulator.max_command * 1e-3);
    return s;
  };
  std::string from = of(o.rig, "");
  if (o.tracking_rig) from += "; " + of(*o.tracking_rig, "the tracking rig's ");
  return fmt::format(
      "the actuator's limit is 0..{:.3f} MPa, the least of {} ({}), not the papers' 0..{} MPa: no run commands more{}",
      p_max, from,
      spec.valves ? "the muscle's rated maximum; the switching valves have no command range"
                  : "the muscle's rated maximum and the regulator's command range",
      kPaperPressureMax,
      p_max < kPaperPressureMax
          ? fmt::format(", and the papers' identification inputs are scaled by {:.3f} (docs/control.md, section 0)",
                        p_max / kPaperPressureMax)
          : std::string("; the papers' identification inputs are kept (docs/control.md, section 0)"));
}

// An experiment needs a force that extends the vented muscle (the load's weight or the return
// spring's, P5) and a muscle that can lift its load: without the first (load.gravity = 0, a
// horizontal rig, and no spring) every variant sat near the top, 45 mm RMS "ok" (a sweep
// outside the documented set, 2026-11-30); without the second the position relay failed with
// a message that did not name the load (rig_unusable_reason).
void check_return_force(const PamRigParams& rig, const char* which) {
  if (std::string why = rig_unusable_reason(rig, which); !why.empty())
    throw Error(fmt::format("experiment: {}", why));
}

std::string learning_above_note(const TrackingRun& learning, const TrackingRun& base) {
  const std::size_t n = learning.periods.size();
  const double last = learning.errors.rms_error_mm, target = base.errors.rms_error_mm;
  // why, from the periods: below the base run in some period (the rig did not repeat what the
  // update assumed, or the supervisor's restores cost more), or never (its loop starts higher)
  std::size_t best = 0;
  for (std::size_t j = 1; j < n; ++j)
    if (learning.periods[j].rms_error_mm < learning.periods[best].rms_error_mm) best = j;
  const double least = n > 0 ? learning.periods[best].rms_error_mm : last;
  const std::string why =
      least < target
          ? fmt::format("it was below in period {}, {:.3f} mm, and rose after it", best + 1, least)
          : fmt::format("it learns on a more robust, slower loop: its first period, before any correction, was "
                        "{:.3f} mm, and no period came below",
                        n > 0 ? learning.periods[0].rms_error_mm : last);
  std::string head = fmt::format("learning ({}): after {} periods its RMS error, {:.3f} mm, is above the {} run's "
                                 "{:.3f} mm ({}); ",
                                 learning.reference, n, last, base.variant, target, why);
  const double before = n >= 2 ? learning.periods[n - 2].rms_error_mm : last;
  if (!(last < before) || !(last > 0.0)) return head + "it was no longer falling";
  // an earlier period was lower: the last two periods' fall is not a convergence to extrapolate
  // (1.054 -> 2.857 -> 2.835 mm on a 2 kg load), more periods would not bring it below
  if (least < last)
    return head + fmt::format("its last period fell a little ({:.3f} mm the period before), but period {} was lower, "
                              "{:.3f} mm: it is not converging, and more periods would not bring it below",
                              before, best + 1, least);
  // periods to reach the base run's error at the last period's rate, q = last / before per period
  const double q = last / before;
  const double more = std::log(target / last) / std::log(q);
  constexpr double kHorizon = 100.0;  // periods: beyond this the run has stalled for any user
  if (more <= kHorizon)
    return head + fmt::format("it was still falling ({:.3f} mm the period before; at that rate about {:.0f} more "
                              "period(s) would bring it below: --learning-periods)",
                              before, std::ceil(more));
  return head + fmt::format("it was still falling, but by only {:.2g} % per period ({:.3f} mm the period before): at "
                            "that rate it would not come below within {:.0f} more periods",
                            100.0 * (1.0 - q), before, kHorizon);
}

std::string above_baseline_note(const TrackingRun& run, const TrackingRun& base, bool rig_changed) {
  if (run.errors.rms_error_mm < base.errors.rms_error_mm) return {};
  return fmt::format(
      "{} ({}): its RMS error, {:.3f} mm, is not below the baseline's {:.3f} mm (a straight line for the "
      "hysteresis): {}",
      run.variant, run.reference, run.errors.rms_error_mm, base.errors.rms_error_mm,
      rig_changed ? fmt::format("the loop was identified and tuned on the rig of --plant (default: the nominal one), "
                                "and the rig it tracked on (--tracking-plant) differs from it: its gains and model may "
                                "not suit the changed rig (a loop tuned on a well-damped load can ring on a less "
                                "damped one, docs/plant.md); identify and tune on the rig as it is now{}",
                                run.variant == "learning" ? "" : ", or use the learning variant")
                  : std::string("the loop tuned from this rig's identification does no better than no compensation; "
                                "the identified dynamics and relay tests above are suspect"));
}

std::string adaptive_above_note(const TrackingRun& adaptive, const TrackingRun& compensated, bool rig_changed) {
  if (!(adaptive.errors.rms_error_mm > compensated.errors.rms_error_mm)) return {};
  return fmt::format(
      "{} ({}): its RMS error, {:.3f} mm, is above the compensated run's {:.3f} mm ({:+.1f} %), the same loop with "
      "the fitted inverse: the weights it adapted online predicted the contraction from the pressure reading at "
      "least as well as the fitted ones (its guard) but tracked worse (docs/control.md section 4){}",
      adaptive.variant, adaptive.reference, adaptive.errors.rms_error_mm, compensated.errors.rms_error_mm,
      100.0 * (adaptive.errors.rms_error_mm / compensated.errors.rms_error_mm - 1.0),
      rig_changed ? "; the rig it tracked on (--tracking-plant) differs from the identified one: a change the "
                    "weights cannot represent (a pressure sensor's offset, a load that shifts the pressure at "
                    "which the muscle starts to contract) is fitted into them as a wrong shape"
                  : "");
}

std::string faithful_below_note(const TrackingRun& compensated, const TrackingRun& faithful, bool rig_changed) {
  if (!(compensated.errors.rms_error_mm > faithful.errors.rms_error_mm)) return {};
  return fmt::format(
      "{} ({}): its RMS error, {:.3f} mm (max {:.3f}), is above the faithful run's {:.3f} mm (max {:.3f}; {:+.1f} %), "
      "the paper's loop with its published gains: on this rig the loop tuned from the identification run (its "
      "relay tests and gain trial, docs/control.md sections 1-2) does worse than the paper's own; compare the two "
      "rows before deploying the compensated loop{}",
      compensated.variant, compensated.reference, compensated.errors.rms_error_mm, compensated.errors.max_error_mm,
      faithful.errors.rms_error_mm, faithful.errors.max_error_mm,
      100.0 * (compensated.errors.rms_error_mm / faithful.errors.rms_error_mm - 1.0),
      rig_changed ? "; the rig it tracked on (--tracking-plant) differs from the identified one, on which it was tuned"
                  : "");
}

// The leaves of two rigs' JSON forms (rig_params_to_json) that differ, as "section.key: a -> b".
std::string changed_rig_list(const PamRigParams& identified, const PamRigParams& tracking, std::size_t* count) {
  const nlohmann::json a = rig_params_to_json(identified), b = rig_params_to_json(tracking);
  std::string list;
  std::size_t n = 0;
  for (const auto& [section, keys] : a.items())
    for (const auto& [key, value] : keys.items()) {
      const nlohmann::json& other = b.at(section).at(key);
      if (other == value) continue;
      list += fmt::format("{}{}.{}: {} -> {}", list.empty() ? "" : "; ", section, key, value.dump(), other.dump());
      ++n;
    }
  if (count) *count = n;
  return list;
}

std::string changed_rig_note(const PamRigParams& identified, const PamRigParams& tracking) {
  std::size_t n = 0;
  const std::string list = changed_rig_list(identified, tracking, &n);
  return fmt::format(
      "the tracking runs are on the rig of --tracking-plant, which differs from the identified one (--plant) in "
      "{} parameter(s): {}; every loop was identified and tuned on the identified rig, not re-tuned (its reach, "
      "model, gains and learning design are that rig's)",
      n, list);
}

}  // namespace hysteron::experiment
