// The rig's reach read off its identification run, the references fitted to it, and the
// pressure range hysteron's model is identified over (docs/control.md, sections 0 and 5).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "detail.hpp"
#include "hysteron/identify.hpp"

namespace hysteron::experiment {

std::size_t smoothing_half_width(double tc) {
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(kSmoothingHalfWindow / tc)));
}

// Centred moving mean of 2 h + 1 samples of the measured contraction (the sensor's noise does not
// widen the reach) [mm].
std::vector<double> smoothed(const std::vector<double>& x, std::size_t h) {
  const std::size_t n = x.size();
  if (n <= 2 * h) return x;
  std::vector<double> m(n);
  double sum = 0.0;
  for (std::size_t k = 0; k < 2 * h + 1; ++k) sum += x[k];
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t c = std::clamp(k, h, n - h - 1);  // window [c - h, c + h]
    if (k > h && k < n - h) sum += x[c + h] - x[c - h - 1];
    m[k] = sum / static_cast<double>(2 * h + 1);
  }
  return m;
}

// The top pressure the loops can use [MPa]: p_max (the run's limit), or the highest the identification
// run's pressure reading reached (max of sm.p) where that stayed below (1 - kPressureHeadroom)
// of the run's highest command (at most p_max): the supply, regulator or valves cap the
// actuator. Unless the muscle went on contracting with the command while the reading stayed at
// its top: over the samples where the reading is within 1 % of its top and the command rises,
// the least-squares slope of the contraction on the command is at least kSensorTopSlope of the
// run's (on the commands below 0.9 of that top). An actuator held at its top holds the
// contraction (0.3-4.7 % of the run's slope there with a 4 or 4.5 bar supply, a lag of up to
// 300 ms, a 10 kg load; a sensor whose range ends at 0.45-0.55 MPa: 58-143 %), so a slope that
// steep is the pressure sensor's limit (its range ends there, or it reads low), not the
// actuator's. The top is the reading's either way: the models are fitted on the reading and the
// pressure loops close on it, so the loops are kept where it sees; only the note differs.
constexpr double kSensorTopSlope = 0.25;

ActuatorTop usable_top(const IdentificationRun& id, const SmoothedRun& sm, double p_max) {
  ActuatorTop t;
  t.mpa = p_max;
  t.reached_mpa = max_of(sm.p);
  const std::vector<double>& c = id.pressure_command_mpa;
  const double p_cmd_max = max_of(c);
  const bool short_of_commands = t.reached_mpa < (1.0 - kPressureHeadroom) * std::min(p_cmd_max, p_max);
  if (!short_of_commands || !(t.reached_mpa > 0.0)) return t;
  t.mpa = t.reached_mpa;
  {
    std::vector<double> gap;
    const std::size_t n = std::min(c.size(), id.pressure_mpa.size());
    for (std::size_t k = 0; k < n; ++k)
      if (c[k] >= 0.25 * t.reached_mpa && c[k] <= 0.75 * t.reached_mpa) gap.push_back(c[k] - id.pressure_mpa[k]);
    if (gap.size() >= 20) {
      std::nth_element(gap.begin(), gap.begin() + static_cast<std::ptrdiff_t>(gap.size() / 2), gap.end());
      t.offset_mpa = gap[gap.size() / 2];
      t.reads_low = t.offset_mpa >= 0.5 * (std::min(p_cmd_max, p_max) - t.reached_mpa);
    }
  }
  // least-squares slope of x on c over the samples `in` selects
  auto slope = [&](auto in) {
    double n = 0, sc = 0, sx = 0, scc = 0, scx = 0;
    for (std::size_t k = 1; k < c.size() && k < sm.x_mm.size(); ++k)
      if (in(k)) n += 1, sc += c[k], sx += sm.x_mm[k], scc += c[k] * c[k], scx += c[k] * sm.x_mm[k];
    const double var = n * scc - sc * sc;
    return std::pair{n, var > 0.0 ? (n * scx - sc * sx) / var : 0.0};
  };
  auto at_top = [&](std::size_t k) { return sm.p[k] >= 0.99 * t.reached_mpa && c[k] > c[k - 1]; };
  const auto [n_top, b_top] = slope(at_top);
  const auto [n_run, b_run] = slope([&](std::size_t k) { return c[k] <= 0.9 * t.reached_mpa; });
  if (n_top < 20.0 || n_run < 20.0 || !(b_run > 0.0)) return t;
  t.slope_ratio = b_top / b_run;
  t.x_lo_mm = t.cmd_lo_mpa = std::numeric_limits<double>::infinity();
  t.x_hi_mm = t.cmd_hi_mpa = -t.x_lo_mm;
  for (std::size_t k = 1; k < c.size() && k < sm.x_mm.size(); ++k)
    if (at_top(k)) {
      t.x_lo_mm = std::min(t.x_lo_mm, sm.x_mm[k]), t.x_hi_mm = std::max(t.x_hi_mm, sm.x_mm[k]);
      t.cmd_lo_mpa = std::min(t.cmd_lo_mpa, c[k]), t.cmd_hi_mpa = std::max(t.cmd_hi_mpa, c[k]);
    }
  const double sigma = first_difference_sigma(id.contraction_mm, 0, id.contraction_mm.size());
  t.sensor_limited = t.slope_ratio >= kSensorTopSlope && t.x_hi_mm - t.x_lo_mm > 5.0 * sigma;
  return t;
}

namespace {

// The note of a top below the commands (fit_to_reach): the actuator's cap, or the sensor's limit.
std::string top_note(const ActuatorTop& t, double p_cmd_max, double p_limit, double p_max) {
  if (t.reads_low)
    return fmt::format(
        "the pressure reading of the identification run reached at most {:.3f} MPa while the command went up to "
        "{:.3f} MPa, but it sat {:.3f} MPa below the command all along the run (the median over its middle commands, "
        "rising and falling, where the regulator's lag cancels), as much as it falls short at the top: a pressure "
        "sensor that reads low (an offset: zero it at atmospheric pressure), or an actuator short of its command "
        "everywhere, not a cap at the top; the models are fitted on the reading and the pressure loops close on it, "
        "so the rig's reach is measured up to {:.3f} MPa of the reading ({:.0f} % below its top as headroom)",
        t.reached_mpa, p_cmd_max, t.offset_mpa, p_limit, kPressureHeadroom * 100.0);
  if (!t.sensor_limited)
    return fmt::format(
        "the actuator's pressure reached at most {:.3f} MPa in the identification run, whose command went up to "
        "{:.3f} MPa: the supply, regulator or valves cap it below the {:.2f} MPa the loops may command; the "
        "rig's reach is measured up to {:.3f} MPa ({:.0f} % below that top as headroom)",
        t.reached_mpa, p_cmd_max, p_max, p_limit, kPressureHeadroom * 100.0);
  return fmt::format(
      "the pressure reading of the identification run stopped at {:.3f} MPa while the command went up to {:.3f} MPa, "
      "but the muscle went on contracting with the command ({:.1f} to {:.1f} mm while the command rose from {:.3f} to "
      "{:.3f} MPa with the reading at its top: {:.0f} % of the run's slope, where an actuator held at its top holds "
      "the contraction): the pressure sensor's range ends below the actuator's pressure, or it reads low (an "
      "offset), not the actuator; the models are fitted on the reading and the pressure loops close on it, so the "
      "rig's reach is measured up to {:.3f} MPa of the reading ({:.0f} % below its top as headroom); a sensor whose "
      "range covers the actuator's would let the loops use the rest (--paper-references tracks the published "
      "references regardless)",
      t.reached_mpa, p_cmd_max, t.x_lo_mm, t.x_hi_mm, t.cmd_lo_mpa, t.cmd_hi_mpa, 100.0 * t.slope_ratio, p_limit,
      kPressureHeadroom * 100.0);
}

}  // namespace

// The pressures of the identification run's stroke (StrokePressures, detail.hpp), on its
// 11-sample means. "Off its rest" is also at least 3 noise sigmas of the raw reading above its
// least (sigma from the record's first differences): on a short stroke with a noisy sensor 2 %
// of the span is within the noise, and a noise peak at the rest read as a lifted load (77 kg,
// 0.16 mm of noise: "lifted above 0.009 MPa").
StrokePressures stroke_pressures(const IdentificationRun& id, const SmoothedRun& sm) {
  StrokePressures s;
  if (sm.x_mm.empty() || id.contraction_mm.size() < 3) return s;
  const auto [lo, hi] = std::minmax_element(sm.x_mm.begin(), sm.x_mm.end());
  const double span = *hi - *lo, mid = 0.5 * (*lo + *hi);
  if (!(span > 0.0)) return s;
  const double sigma = first_difference_sigma(id.contraction_mm, 0, id.contraction_mm.size());
  const double lifted = *lo + std::max(0.02 * span, 3.0 * sigma);
  double sum = 0.0, floor = std::numeric_limits<double>::infinity();
  std::size_t n = 0;
  for (std::size_t k = 0; k < sm.x_mm.size(); ++k) {
    if (std::abs(sm.x_mm[k] - mid) <= 0.05 * span) sum += sm.p[k], ++n;
    if (sm.x_mm[k] > lifted) floor = std::min(floor, sm.p[k]);
  }
  if (n == 0 || !std::isfinite(floor)) return s;
  s.mid_mpa = sum / static_cast<double>(n);
  s.floor_mpa = floor;
  return s;
}

namespace {

// The note of a clipped displacement record (fit_to_reach).
std::string clipping_note(const Clipping& clip) {
  std::string where;
  if (clip.low)
    where = fmt::format("{:.1f} % of its samples within 3 noise widths of its least reading, {:.3f} mm, are exactly "
                        "that reading",
                        100.0 * clip.low_share, clip.lo);
  if (clip.high)
    where += fmt::format("{}{:.1f} % of those near its largest, {:.3f} mm, are exactly it", clip.low ? "; " : "",
                         100.0 * clip.high_share, clip.hi);
  return fmt::format(
      "the displacement sensor clips in the identification run: {} (noise {:.4f} mm from the record); the rig cannot "
      "be seen beyond, so the reach keeps 3 times the noise from {}: {}; the errors are measured by that sensor and "
      "miss the muscle's excursions beyond its limit (at the start, from rest, and wherever the loop overshoots); the "
      "models are fitted on it as censored data (FitOptions::censor_passes)",
      where, clip.sigma, clip.low && clip.high ? "either limit" : "the limit",
      clip.low ? "a sensor zeroed above the muscle's rest (a negative offset) reads its limit while the muscle is "
                 "below it"
               : "a sensor whose range ends inside the stroke reads its limit beyond it");
}

}  // namespace

namespace {

// Where the contraction stops growing on the ascent while the pressure still rises: the muscle's
// stroke end, a hard stop, or a load come to rest on a support. Over the samples of the
// identification run whose command rises, p_mpa is the least (11-sample mean) pressure at which
// the (11-sample mean) contraction lies within a band of its largest, x_mm: 3 noise widths of
// that mean (detect_clipping's sigma of the displacement record / sqrt of the mean's window) or
// 0.1 % of the reached span, whichever is larger. A stop where that pressure lies below the headroom line, (1 - kPressureHeadroom) of
// the usable top: the contraction stayed put while the pressure rose by more than the headroom
// (without a stop the largest contraction is reached at the top pressure, and within the band
// only just below it). The reach then ends where the ascent reached (1 - kPressureHeadroom) of
// p_mpa, so that the position loop keeps that headroom below the stop as it does below the
// actuator's top; a reference mapped onto the stop itself is tracked where the contraction no
// longer answers the pressure (a 15 % stroke: compensated max 1.86 mm against 0.93 nominal).
struct StrokeEnd {
  double x_mm = 0.0, p_mpa = 0.0;  // the stop's contraction, the least pressure that reaches it
  bool found = false;
};

StrokeEnd stroke_end(const IdentificationRun& id, const SmoothedRun& sm, double p_top) {
  StrokeEnd s;
  const std::vector<double>& c = id.pressure_command_mpa;
  const std::size_t n = std::min({c.size(), sm.x_mm.size(), sm.p.size()});
  if (n < 100) return s;
  const auto [lo_it, hi_it] = std::minmax_element(sm.x_mm.begin(), sm.x_mm.begin() + static_cast<std::ptrdiff_t>(n));
  s.x_mm = *hi_it;
  // 3 noise widths of the 11-sample mean the band is compared with: the record's noise (from its
  // second differences) / sqrt(window); 3 widths of the raw reading were 3.3x too wide, and with 2 mm
  // of sensor noise the band reached 48 kPa below the top, where the slope is small: a false stop
  const double sigma_mean = detect_clipping(id.contraction_mm).sigma / std::sqrt(static_cast<double>(sm.window));
  const double band = std::max(3.0 * sigma_mean, 1e-3 * (*hi_it - *lo_it));
  double p_at = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < n; ++k)
    if (c[k] > c[k - 1] && sm.x_mm[k] >= s.x_mm - band) p_at = std::min(p_at, sm.p[k]);
  s.p_mpa = p_at;
  s.found = std::isfinite(p_at) && p_at > 0.0 && p_at < (1.0 - kPressureHeadroom) * p_top;
  return s;
}

}  // namespace

// ExperimentOptions::fit_references. The reach measured on the identification run: from the
// contraction at rest (the least, vented) to the contraction on the ascent when the
// measured pressure (its 11-sample mean, as the contraction's: a raw reading's noise peak
// reached the line early, 90.8 mm instead of 96.5 with 20 kPa of sensor noise) first reached
// (1 - kPressureHeadroom) of the actuator's top pressure (the least contraction at or above
// that pressure). The top pressure p_top is usable_top's
// (p_max, the run's limit, or the most the measured pressure reached where the supply, the regulator
// or the valves cap the actuator, or the pressure sensor's range ends; its note says which). A
// reference that leaves the reach is mapped affinely onto its intersection with it (only
// the end that leaves it moves; a reference whose bottom is the rest position keeps it).
// The ranges and a note per reference out of reach go into the result.
std::vector<Reference> fit_to_reach(const ExperimentOptions& o, const IdentificationRun& id, const SmoothedRun& sm,
                                    const ActuatorTop& actuator_top, std::vector<Reference> refs,
                                    ExperimentResult& res, double p_max) {
  const std::vector<double>& x = sm.x_mm;
  const double p_top = actuator_top.mpa;
  double p_limit = (1.0 - kPressureHeadroom) * p_top;
  if (p_top < p_max) res.messages.push_back(top_note(actuator_top, max_of(id.pressure_command_mpa), p_limit, p_max));
  const StrokeEnd stop = stroke_end(id, sm, p_top);
  if (stop.found) {
    p_limit = (1.0 - kPressureHeadroom) * stop.p_mpa;
    res.messages.push_back(fmt::format(
        "the contraction stops growing at {:.1f} mm in the identification run, reached at {:.3f} MPa on the ascent "
        "while the pressure rose on to {:.3f} MPa: the muscle's stroke end or a hard stop; the reach ends where the "
        "ascent reached {:.3f} MPa ({:.0f} % below the stop's pressure as headroom for the position loop), as below "
        "the actuator's top",
        stop.x_mm, stop.p_mpa, max_of(sm.p), p_limit, kPressureHeadroom * 100.0));
  }
  double top = std::numeric_limits<double>::infinity();
  res.reach_min_mm = std::numeric_limits<double>::infinity();
  res.reach_max_mm = -res.reach_min_mm;
  for (std::size_t k = 0; k < x.size(); ++k) {
    res.reach_min_mm = std::min(res.reach_min_mm, x[k]);
    res.reach_max_mm = std::max(res.reach_max_mm, x[k]);
    if (k < sm.p.size() && sm.p[k] >= p_limit) top = std::min(top, x[k]);  // the mean: a noise peak is no top
  }
  // the rest position, with the sensor's resolution as tolerance: 0.1 % of the reached span
  double floor_mm = res.reach_min_mm;  // where a reference below the reach is mapped to
  double bottom = res.reach_min_mm - 1e-3 * (res.reach_max_mm - res.reach_min_mm);
  // A displacement sensor that clips (detect_clipping; docs/control.md section 5): the rig
  // cannot be seen beyond its limit, so the reach keeps 3 noise widths from it.
  const Clipping clip = detect_clipping(id.contraction_mm);
  if (clip.any()) {
    const double band = 3.0 * clip.sigma;
    if (clip.low && clip.lo + band > floor_mm) floor_mm = bottom = clip.lo + band;
    if (clip.high) top = std::min(top, clip.hi - band);
    res.messages.push_back(clipping_note(clip));
  }
  const bool known_top = std::isfinite(top);  // else the identification never reached p_limit
  res.reach_top_mm = known_top ? top : std::numeric_limits<double>::quiet_NaN();
  res.reach_top_pressure_mpa = p_limit;
  // What the record resolves of the reach's ends, read off the 11-sample mean: 3 noise widths of
  // that mean (the record's noise / sqrt of its window), and no finer than the sensor's step (the
  // least change between two readings); a reference that leaves the reach by less is kept (a
  // 1 um sensor clipped at the muscle's rest moved the bottom 0.004 mm: "mapped ... 0.0..40.0 mm
  // instead of the published 0.0..40.0 mm (scale 1.000)")
  double step_mm = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < id.contraction_mm.size(); ++k)
    if (const double d = std::abs(id.contraction_mm[k] - id.contraction_mm[k - 1]); d > 0.0) step_mm = std::min(step_mm, d);
  if (!std::isfinite(step_mm)) step_mm = 0.0;
  const double resolved_mm = 3.0 * std::max(step_mm, clip.sigma / std::sqrt(static_cast<double>(sm.window)));
  // a given reference's ends in mm: "{:.1f}", or 4 digits with an exponent where a unit mistake
  // made them huge (amplitude=1e300)
  const auto mm = [](double v) { return std::abs(v) < 1e6 ? fmt::format("{:.1f}", v) : fmt::format("{:.4g}", v); };
  for (Reference& ref : refs) {
    const auto [lo_it, hi_it] = std::minmax_element(ref.ref_m.begin(), ref.ref_m.end());
    ReferenceRange rr;
    rr.reference = ref.name;
    rr.paper_min_mm = rr.min_mm = *lo_it * 1e3;
    rr.paper_max_mm = rr.max_mm = *hi_it * 1e3;
    const bool above = known_top && rr.paper_max_mm > top + resolved_mm, below = rr.paper_min_mm < bottom - resolved_mm;
    if (above || below) {
      const std::string why = fmt::format(
          "the rig's reach in its identification run is {:.1f} mm at rest to {} on its ascent at {:.2f} MPa "
          "({:.0f} % of the {} {:.2f} MPa kept as headroom for the position loop; {:.1f} mm at most)",
          res.reach_min_mm, known_top ? fmt::format("{:.1f} mm", top) : std::string("an unknown contraction (never reached)"),
          p_limit, kPressureHeadroom * 100.0, stop.found ? "stroke end's" : "actuator's",
          stop.found ? stop.p_mpa : p_top, res.reach_max_mm);
      const double new_lo = below ? floor_mm : rr.paper_min_mm, new_hi = above ? top : rr.paper_max_mm;
      if (o.fit_references && new_hi > new_lo && rr.paper_max_mm > rr.paper_min_mm) {
        const double s = (new_hi - new_lo) / (rr.paper_max_mm - rr.paper_min_mm);
        const double old_lo = *lo_it;
        for (double& r : ref.ref_m) r = new_lo * 1e-3 + s * (r - old_lo);
        rr.min_mm = new_lo;
        rr.max_mm = new_hi;
        rr.scaled = true;
        res.messages.push_back(fmt::format("reference {} mapped onto the rig's reach: {:.1f}..{:.1f} mm instead of the "
                                           "{} {}..{} mm (scale {}): {}; errors are against the "
                                           "mapped reference (--paper-references keeps the {} one)",
                                           ref.name, rr.min_mm, rr.max_mm, ref.user ? "given" : "published",
                                           mm(rr.paper_min_mm), mm(rr.paper_max_mm),
                                           s >= 1e-3 ? fmt::format("{:.3f}", s) : fmt::format("{:.3g}", s), why,
                                           ref.user ? "given" : "published"));
      } else {
        rr.reachable = false;
        res.messages.push_back(fmt::format("reference {} ({}..{} mm) is out of this rig's reach: {}; the "
                                           "errors beyond it are the actuator's limit, not the controller's",
                                           ref.name, mm(rr.paper_min_mm), mm(rr.paper_max_mm), why));
      }
    } else if (!known_top && rr.paper_max_mm > res.reach_max_mm) {
      res.messages.push_back(fmt::format("reference {}: its top, {} mm, lies above the {:.1f} mm the "
                                         "identification run reached, whose pressure stayed below {:.2f} MPa; the "
                                         "rig's reach above it is not known, and the reference is kept",
                                         ref.name, mm(rr.paper_max_mm), res.reach_max_mm, p_limit));
    }
    res.reference_ranges.push_back(rr);
  }
  return refs;
}

// Tracking starts with the rig vented: the muscle at rest, the regulator or valves at 0. A
// reference without an unscored warm-up (score_from == 0: mpi-openloop's two, mpi-pwm's
// triangle; gpi-pid's and mpi-pwm's sines have a warm-up period) is preceded by a hold of its
// first value for kPreRollS, unscored, with the loop running, which fills the muscle to where
// the reference starts, as an experimenter does before a run (docs/control.md, section 5).
// Scored from a cold start, the first 0.1 s (filling the muscle to lift-off through the
// regulator's dead time and lag while the triangle already rose at 16 mm/s) was mpi-openloop's
// largest error, 1.367 mm at 0.093 s, 0.872 mm after 0.5 s.
void add_pre_roll(std::vector<Reference>& refs, double tc) {
  const auto n = static_cast<std::size_t>(std::lround(kPreRollS / tc));
  for (Reference& r : refs) {
    if (r.score_from > 0 || r.ref_m.empty()) continue;
    r.ref_m.insert(r.ref_m.begin(), n, r.ref_m.front());
    r.score_from = r.periodic_from = r.pre_roll = n;
  }
}

// The pressure hysteron's model is identified up to (docs/control.md, section 0): the
// papers' identification inputs span the actuator's range for *their* muscle and load; on
// another rig the references may need much less (a longer muscle, mpi-openloop's 40 mm
// references: about 0.3 MPa of the input's 0.5), and a model fitted over the whole range
// spends its operators and its least squares where the loops never go. So: the pressure
// the ascent needs to reach the highest reference top, p_need = max{ p(k) : x(k) <= top }
// on the identification run (11-sample means), plus twice the reach's headroom (one for the
// position loop, as in fit_to_reach, one so that the model covers the descending branch
// from above the top): p_id. p_id = 0 (keep the paper's inputs) where that is at or above
// the input's maximum, or the run never went above the reference top.

std::string IdentificationRange::note() const {
  return fmt::format("hysteron's model is identified on the paper's pressure inputs scaled to 0..{:.3f} MPa (from "
                     "{:.3f}): the references reach {:.1f} mm, which the rig's ascent reached at {:.3f} MPa in the "
                     "identification run, and the model is not fitted where the loops do not go (docs/control.md, "
                     "section 0)",
                     p_id_mpa, input_max_mpa, top_mm, p_need_mpa);
}

IdentificationRange model_identification_range(const SmoothedRun& sm, const std::vector<Reference>& refs,
                                               const std::vector<double>& input, double p_max) {
  IdentificationRange r;
  if (refs.empty() || input.empty() || sm.x_mm.empty()) return r;
  r.input_max_mpa = *std::max_element(input.begin(), input.end());
  r.top_mm = -std::numeric_limits<double>::infinity();
  for (const Reference& ref : refs)
    r.top_mm = std::max(r.top_mm, 1e3 * *std::max_element(ref.ref_m.begin(), ref.ref_m.end()));
  const std::vector<double>& x = sm.x_mm;
  const std::vector<double>& p = sm.p;
  double p_need = -1.0;
  bool above = false;
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (x[k] <= r.top_mm) p_need = std::max(p_need, p[k]);
    else above = true;
  }
  if (!above || p_need < 0.0) return r;
  r.p_need_mpa = p_need;
  const double p_id = p_need + 2.0 * kPressureHeadroom * p_max;
  if (p_id < r.input_max_mpa) r.p_id_mpa = p_id;
  return r;
}

// `input` scaled so that its maximum is top_mpa: down only (unchanged where it is already
// below), or with `up_too` by the factor either way.
std::vector<double> scaled_to(std::vector<double> input, double top_mpa, bool up_too) {
  const double m = max_of(input);
  if (top_mpa > 0.0 && m > 0.0 && (up_too || m > top_mpa))
    for (double& v : input) v *= top_mpa / m;
  return input;
}

// Where the paper's identification input stops short of the actuator's top (mpi-openloop's
// 0.5 MPa of 0.6) and its run never reached the highest reference top, the rig's reach at
// that top is not known and a model fitted on the run would be extrapolated there (a 0.2 m
// muscle, a heavy load or a weak muscle): the pressure the input is extended to, p_max (the
// run's limit), else 0 (the paper's input is kept). Not where the supply caps the actuator
// below the input's maximum already (p_top < p_max): a larger command would not be delivered.
double extended_input_top(const std::vector<double>& input, const SmoothedRun& sm, const std::vector<Reference>& refs,
                          double p_top, double p_max) {
  if (input.empty() || refs.empty() || sm.x_mm.empty() || p_top < p_max) return 0.0;
  const double input_max = *std::max_element(input.begin(), input.end());
  if (!(input_max < (1.0 - kPressureHeadroom) * p_max)) return 0.0;
  double ref_top = -std::numeric_limits<double>::infinity();
  for (const Reference& ref : refs) ref_top = std::max(ref_top, 1e3 * *std::max_element(ref.ref_m.begin(), ref.ref_m.end()));
  const double reached = *std::max_element(sm.x_mm.begin(), sm.x_mm.end());
  return reached > ref_top ? 0.0 : p_max;
}

}  // namespace hysteron::experiment
