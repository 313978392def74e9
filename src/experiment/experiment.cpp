#include "hysteron/experiment.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <utility>

#include "detail.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"

namespace hysteron {

using namespace experiment;

namespace {

// The fits use the record at 100 Hz (every 10th sample at a 1 kHz control
// period): the loops are slow (0.2 Hz), so nothing is lost and fitting is 10x faster.
constexpr double kFitRate = 100.0;  // [Hz]

std::atomic<bool> learning_shaper{true};  // set_learning_shaper (tests)

// `inner` with the feedforward's preview taken from `preview` (e.g. the shaped reference):
// sample k gets preview[k + lead] (clamped to its last sample); the PID's reference is kept.
Law with_preview(Law inner, std::shared_ptr<const std::vector<double>> preview, std::size_t lead) {
  return [inner = std::move(inner), preview = std::move(preview), lead](const Sample& s) {
    Sample m = s;
    if (!preview->empty()) m.preview_m = (*preview)[std::min(s.k + lead, preview->size() - 1)];
    return inner(m);
  };
}

// The shaper's impulses for the loops' descriptions: "(0.955 now, 0.045 after 172 ms)".
std::string shaper_timing(const ZvShaper& z, double tc) {
  return fmt::format("({:.3f} now, {:.3f} after {:.0f} ms)", z.a1, z.a2, static_cast<double>(z.delay) * tc * 1e3);
}

// The numbers of a loop (result.json "controller"): its PID if it has one, the feedforward's
// preview and the shaper on it (nullptr or inactive: none).
LoopDesign loop_design(const Loop& loop, std::size_t lead, double tc, const ZvShaper* zv) {
  LoopDesign d;
  d.kind = loop.kind;
  d.feedforward = {loop.feedforward.pressure_limits, loop.feedforward.model_scale, loop.feedforward.lag_time_constant};
  d.pwm = loop.pwm;
  const PidParams& pid = loop.position;
  if (pid.kp != 0.0 || pid.ki != 0.0 || pid.kd != 0.0) d.pid = pid;
  d.pressure_pid = loop.pressure;
  d.pressure_gain = loop.pressure_gain;
  d.adaptation = loop.adaptation;
  d.feedforward_lead = lead;
  d.sample_time = tc;
  if (loop.position_state) {
    const PidState s = loop.position_state();
    d.guard_final_scale = s.gain_scale;
    d.guard_cuts = s.guard_cuts;
  }
  if (zv && zv->active()) d.shaper = LoopDesign::Shaper{zv->a1, zv->a2, zv->delay, zv->advance};
  return d;
}

// The learning variant on top of `base`: `periods` repetitions of the reference's
// first period, the ILC designed on the identified closed loop and `which` of its neighbours,
// among the Q-filters of `window`.
TrackingRun learning_run(const ExperimentOptions& o, const Context& ctx, const Reference& ref, const Loop& base,
                         std::uint64_t seed, std::vector<std::string>& messages, Neighbours which = Neighbours::all,
                         FilterWindow window = FilterWindow::whole) {
  double rho = 0.0;
  LearningParams lp = design_learning(ctx.dynamics, base.position, ctx.lead, ref.period, ctx.tc, rho, which, window);
  lp.rise_tolerance = kLearningRiseTolerance;
  lp.hold_after_cuts = kLearningHoldAfterCuts;
  lp.max_gain = learning_growth_limit(ctx.dynamics, base.position, ctx.lead, lp, ctx.tc);
  auto ilc = std::make_shared<IterativeLearning>(lp);
  const std::size_t lead = ctx.lead;
  std::vector<double> r;
  r.reserve(ref.period * static_cast<std::size_t>(o.learning_periods));
  for (int j = 0; j < o.learning_periods; ++j)
    r.insert(r.end(), ref.ref_m.begin() + static_cast<std::ptrdiff_t>(ref.periodic_from),
             ref.ref_m.begin() + static_cast<std::ptrdiff_t>(ref.periodic_from + ref.period));
  // The feedforward's preview of the reference through the shaper the gain trial chose for the
  // compensated loop (none if it chose none); the correction is added unshaped, so the loop
  // from the correction to the contraction, which the design's T models, is unchanged.
  std::shared_ptr<const std::vector<double>> preview;
  if (ctx.shaper.active() && learning_shaper.load())
    preview = std::make_shared<const std::vector<double>>(shaped(r, ctx.shaper));
  // the correction applied at every sample, for the run's correction_mm (reserved: no
  // reallocation while the rig runs)
  auto applied = std::make_shared<std::vector<double>>();
  applied->reserve(r.size());
  const double p_max = ctx.pressure_max;
  Law law = [ilc, inner = base.law, lead, applied, p_max](const Sample& s) {
    Sample m = s;
    const double c = ilc->correction(0);
    applied->push_back(c * 1e3);
    m.reference_m += c;
    m.preview_m += ilc->correction(lead);
    const RigInputs in = inner(m);
    // anti-windup: no learning where the pressure command is at a limit (the error there
    // cannot be reduced, and the Q-filter would spread its integral to the neighbours)
    const bool saturated = in.pressure_command <= 0.0 || in.pressure_command >= p_max;
    ilc->step(saturated ? 0.0 : s.reference_m - s.measured_m);
    return in;
  };
  if (preview) law = with_preview(std::move(law), preview, lead);  // shaped first, the correction added to it
  TrackingRun run = track(o, seed, r, lead, true, law, p_max);
  for (int j = 0; j < o.learning_periods; ++j) {
    const std::size_t b = static_cast<std::size_t>(j) * ref.period;
    run.periods.push_back(errors_of(run, b, b + ref.period));
  }
  run.errors = run.periods.back();
  const std::size_t last = static_cast<std::size_t>(o.learning_periods - 1) * ref.period;
  run.scored_from_s = last < run.t.size() ? run.t[last] : 0.0;
  run.description = fmt::format("{}; + iterative learning over {} periods (L = {}, phase lead {} samples, "
                                "binomial Q-filter half-width {}, contraction bound {:.3f} on the identified loop; L "
                                "may grow to {}, the largest gain whose bound holds on the identified loop itself)",
                                base.description, o.learning_periods, lp.gain, lp.lead, lp.half_width, rho,
                                lp.max_gain);
  if (preview)
    run.description += fmt::format("; feedforward through the gain trial's zero-vibration shaper {}, the correction "
                                   "unshaped",
                                   shaper_timing(ctx.shaper, ctx.tc));
  // in the order the supervisor acts: the doublings come before the first halving
  if (ilc->gain_raises() > 0)
    run.description += fmt::format("; L doubled {} time(s) after periods that were the best so far", ilc->gain_raises());
  if (ilc->gain_cuts() > 0)
    run.description += fmt::format("; L halved {} time(s) to {:.3g}, after periods whose RMS error rose above the "
                                   "least before them",
                                   ilc->gain_cuts(), ilc->gain());
  if (ilc->held()) run.description += fmt::format("; best correction held after {} halvings", lp.hold_after_cuts);
  run.controller = loop_design(base, lead, ctx.tc, preview ? &ctx.shaper : nullptr);
  run.controller.learning = LoopDesign::Learning{lp, rho, ilc->gain(), ilc->gain_raises(), ilc->gain_cuts(), ilc->held()};
  if (applied->size() == run.t.size()) run.correction_mm = std::move(*applied);
  if (ilc->faults() > 0)
    messages.push_back(fmt::format("learning ({}): {} non-finite errors ignored", ref.name, ilc->faults()));
  return run;
}

// learning_run on `lc` (the loop built for learning); where no design contracts on the
// identified loop and its neighbours, once more on models that agree with the position relay's
// point (docs/control.md, section 3): with a load mode, the neighbours that keep it; without
// one, where the FOPDT has more gain at the relay's frequency than the relay measured, the
// FOPDT through the point. Where neither contracts, both again with the narrower Q-filters
// whose summed taps fit in the period (FilterWindow::summed_taps). Where nothing contracts:
// nothing, and the first reason in `messages`.
std::optional<TrackingRun> learning_with_fallback(const ExperimentOptions& o, const Context& lc, const Reference& ref,
                                                  const Variant& v, std::uint64_t seed,
                                                  std::vector<std::string>& messages) {
  std::string first;
  try {
    return learning_run(o, lc, ref, v.make(lc), seed, messages);
  } catch (const Error& e) {
    first = e.what();
  }
  const RigDynamics& identified = lc.dynamics;
  RigDynamics through = identified;
  const bool with_mode = identified.mode_frequency_hz > 0.0;
  const bool relay_models = with_mode || fit_fopdt_through_relay_point(through);
  const Context lt{lc.options,       lc.result, with_mode ? identified : through, lc.tc,     lc.lead,
                   lc.pressure_loop, true,      lc.gain_scale,                    lc.shaper, lc.reference,
                   lc.guard_amplitude_m, lc.pressure_max};
  // the attempts after the first, in order, and what the result says of the one that runs
  struct Attempt {
    bool on_relay_models;  // on lt (the models through the relay's point), else on lc again
    Neighbours which;
    FilterWindow window;
  };
  std::vector<Attempt> attempts;
  if (relay_models) attempts.push_back({true, Neighbours::with_mode, FilterWindow::whole});
  attempts.push_back({false, Neighbours::all, FilterWindow::summed_taps});
  if (relay_models) attempts.push_back({true, Neighbours::with_mode, FilterWindow::summed_taps});
  const auto why = [&](const Attempt& a) {
    if (!a.on_relay_models)
      return fmt::format("learning ({}): {}; so on the same models with a narrower Q-filter, one whose summed taps, "
                         "not its whole window, fit in the period: its band ends further below the loop's resonance "
                         "(docs/control.md, section 3)",
                         ref.name, first);
    const std::string how = a.window == FilterWindow::whole ? ""
                                                            : ", with a narrower Q-filter, one whose summed taps, not "
                                                              "its whole window, fit in the period";
    return with_mode ? fmt::format("learning ({}): {}; so the learning filter is designed on the neighbours that keep "
                                   "the load mode, which pass through the position relay's point, without their "
                                   "twins without it{} (docs/control.md, section 3)",
                                   ref.name, first, how)
                     : fmt::format("learning ({}): {}; so the learning loop is designed on the FOPDT put through the "
                                   "position relay's point, gain and phase, instead: dead time {:.0f} ms and lag "
                                   "{:.0f} ms for the identified {:.0f} ms and {:.0f} ms{} (docs/control.md, section 3)",
                                   ref.name, first, through.dead_time_s * 1e3, through.lag_s * 1e3,
                                   identified.dead_time_s * 1e3, identified.lag_s * 1e3, how);
  };
  for (const Attempt& a : attempts) {
    try {
      std::vector<std::string> notes;
      const Context& ctx = a.on_relay_models ? lt : lc;
      TrackingRun lr = learning_run(o, ctx, ref, v.make(ctx), seed, notes, a.which, a.window);
      messages.push_back(why(a));
      messages.insert(messages.end(), notes.begin(), notes.end());
      return lr;
    } catch (const Error&) {  // not on these models or filters: the next attempt; the first reason is the one given
    }
  }
  messages.push_back(fmt::format("learning ({}) not run: {}", ref.name, first));
  return std::nullopt;
}

// The gain trial (docs/control.md, section 2). The relay's ultimate gain is measured with the
// muscle reversing twice per period, where the rig's hysteresis sticks; tracking runs mostly
// along the branches, where the loop gain is higher (on the worst rig of docs/plant.md the
// classic gains oscillated at 2.9 Hz). So the compensated loop is tried on the rig: a
// trapezoid over the reference's range [r_min, r_max] at its largest speed v (hold r_min
// 1.5 s, ramp up, hold 0.5 s, ramp down, hold 0.5 s), once per gain scale s = 2^(k/3),
// k = -4..2 (0.40..1.59: K_p stays below the relay's K_u, 0.6 x 1.59 = 0.95), scored by the RMS
// of reference - measured contraction from the first ramp on. The least wins (ties: the
// smaller s). A trial whose rig diverges scores +inf. It runs on the identified rig (o.rig), as
// the relay tests do, not on a --tracking-plant rig. Where a load mode was identified, every
// scale is tried again with the feedforward's preview through the zero-vibration shaper at that
// mode (zv_shaper: the mode rings after the corners of a ramp); the least RMS of all wins (ties:
// unshaped first).
GainTrial gain_trial(const ExperimentOptions& o, const Variant& compensated, Context c, const Reference& ref,
                     std::size_t lead) {
  GainTrial g;
  g.reference = ref.name;
  const std::size_t k0 = std::min(ref.periodic_from, ref.ref_m.size());  // after a pre-roll
  const std::size_t n = ref.period > 0 ? std::min(k0 + ref.period, ref.ref_m.size()) : ref.ref_m.size();
  double lo = k0 < ref.ref_m.size() ? ref.ref_m[k0] : 0.0, hi = lo, v = 0.0;
  for (std::size_t k = k0; k < n; ++k) {
    lo = std::min(lo, ref.ref_m[k]);
    hi = std::max(hi, ref.ref_m[k]);
    if (k > k0) v = std::max(v, std::abs(ref.ref_m[k] - ref.ref_m[k - 1]) / c.tc);
  }
  if (!(v > 0.0) || !(hi > lo)) return g;  // a constant reference: nothing to try
  std::vector<double> trap;
  auto segment = [&](double seconds, double from, double to) {
    const auto m = static_cast<std::size_t>(std::lround(seconds / c.tc));
    for (std::size_t k = 0; k < m; ++k)
      trap.push_back(from + (to - from) * static_cast<double>(k) / static_cast<double>(m));
  };
  const double ramp = (hi - lo) / v;
  segment(1.5, lo, lo);
  const std::size_t scored_from = trap.size();
  segment(ramp, lo, hi);
  segment(0.5, hi, hi);
  segment(ramp, hi, lo);
  segment(0.5, lo, lo);
  // on the rig the relay tests ran on (a --tracking-plant rig changed after them)
  ExperimentOptions on_identified_rig = o;
  on_identified_rig.tracking_rig.reset();
  const ZvShaper zv = zv_shaper(c.dynamics, c.tc);
  const auto trap_shaped = std::make_shared<const std::vector<double>>(shaped(trap, zv));
  // The candidates (shaped?, scale 2^(k/3)), k = kLo..kHi, in the order the result lists them.
  constexpr int kLo = -4, kHi = 2;
  constexpr auto per_kind = static_cast<std::size_t>(kHi - kLo + 1);
  struct Candidate {
    bool shape;
    int k;
    std::size_t at() const { return static_cast<std::size_t>(k - kLo); }  // index in the lists
  };
  std::vector<Candidate> order;
  for (bool shape : {false, true}) {
    if (shape && !zv.active()) break;
    for (int k = kLo; k <= kHi; ++k) order.push_back({shape, k});
  }
  for (const Candidate& x : order)
    if (!x.shape) g.scales.push_back(std::exp2(x.k / 3.0));
  const double inf = std::numeric_limits<double>::infinity();
  g.rms_mm.assign(per_kind, inf);
  if (zv.active()) g.rms_shaped_mm.assign(per_kind, inf);
  // Early stop (ExperimentOptions::complete_gain_trials = false): the likeliest best first
  // (the shaped loop, scales x1.26, x1.59, x1.00, then down; then the same unshaped: the
  // choices of the documented sweep; the order only changes how soon the others stop: x1.59
  // before x1.00 runs one whole trial less where x1.59 wins, as on most valve rigs, and the
  // same number where x1.00 wins, since x1.59 then stops against x1.26), and a
  // candidate stops once the sum of its squared errors exceeds the best's by more than
  // rounding. A stopped candidate's RMS only exceeds the best's, so it is never chosen, and
  // ties go to the earlier candidate of `order`, as in a complete trial: the choice is the same.
  const bool early = !o.complete_gain_trials;
  std::vector<std::size_t> visit(order.size());
  for (std::size_t i = 0; i < visit.size(); ++i) visit[i] = i;
  if (early) {
    auto rank = [](const Candidate& x) {
      static constexpr int by_k[per_kind] = {6, 5, 4, 3, 2, 0, 1};  // k = -4..2
      return (x.shape ? 0 : 10) + by_k[x.at()];
    };
    std::stable_sort(visit.begin(), visit.end(),
                     [&](std::size_t a, std::size_t b) { return rank(order[a]) < rank(order[b]); });
  }
  struct Stopped {};  // thrown by the law to end a candidate early
  const double n_scored = static_cast<double>(trap.size() - scored_from);
  double best = inf;  // the least RMS so far
  std::size_t best_at = order.size();
  for (std::size_t at : visit) {
    const Candidate& cand = order[at];
    c.gain_scale = std::exp2(cand.k / 3.0);
    double rms = inf, sse = 0.0;
    try {
      const Loop loop = compensated.make(c);
      Law law = cand.shape ? with_preview(loop.law, trap_shaped, lead) : loop.law;
      if (early && std::isfinite(best)) {
        const double stop_above = best * best * n_scored * (1.0 + 1e-9);  // the best's sum of squares
        law = [inner = std::move(law), &sse, stop_above, scored_from](const Sample& s) {
          if (s.k >= scored_from) {
            const double d = s.reference_m * 1e3 - s.measured_m * 1e3;  // as errors_of
            sse += d * d;
            if (sse > stop_above) throw Stopped{};
          }
          return inner(s);
        };
      }
      const TrackingRun run = track(on_identified_rig, o.seed + 86028121, trap, lead, false, law, c.pressure_max);
      rms = errors_of(run, scored_from, run.t.size()).rms_error_mm;
      if (!std::isfinite(rms)) rms = inf;
    } catch (const Stopped&) {  // above the best: a lower bound of its RMS
      rms = std::sqrt(sse / n_scored);
      g.early_stop = true;
    } catch (const Error&) {  // the rig diverged with this gain
    }
    (cand.shape ? g.rms_shaped_mm : g.rms_mm)[cand.at()] = rms;
    if (rms < best || (rms == best && std::isfinite(rms) && at < best_at)) {
      best = rms;
      best_at = at;
      g.scale = c.gain_scale;
      g.shaped = cand.shape;
    }
  }
  return g;
}

// Pressure headroom kept below the actuator's limit at a reference's top [fraction of
// the run's limit]: the position loop needs pressure above the feedforward's to correct an error
// there. The papers' references keep more on the nominal rig (gpi-pid's 95 mm top is reached
// at about 0.56 MPa, docs/control.md section 5).
constexpr double kPressureHeadroom = 0.05;

// Centred 11-sample moving mean of the measured contraction (the sensor's noise does not
// widen the reach) [mm].
std::vector<double> smoothed(const std::vector<double>& x) {
  const std::size_t n = x.size(), h = 5;
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

// The largest element of v; 0 where v is empty.
double max_of(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

// The identification run's contraction [mm] and measured pressure [MPa], each as its
// centred 11-sample mean: what the reach and the model's identification range are read from.
struct SmoothedRun {
  std::vector<double> x_mm, p;
  explicit SmoothedRun(const IdentificationRun& id) : x_mm(smoothed(id.contraction_mm)), p(smoothed(id.pressure_mpa)) {}
};

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

struct ActuatorTop {
  double mpa = 0.0;             // the usable top
  double reached_mpa = 0.0;     // the reading's top
  bool sensor_limited = false;  // the reading stopped short of the commands, the muscle did not
  double slope_ratio = 0.0;     // the contraction's slope on the command at the reading's top / the run's
  double x_lo_mm = 0.0, x_hi_mm = 0.0, cmd_lo_mpa = 0.0, cmd_hi_mpa = 0.0;  // over those samples
  // the reading's median shortfall below the command over the run's middle commands (rising
  // and falling alike, so that the regulator's lag cancels) [MPa]: a sensor that reads low
  // (or an actuator short everywhere) shows it all along, a cap only at the top
  double offset_mpa = 0.0;
  bool reads_low = false;  // offset_mpa is at least half the shortfall at the top
};

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

// Where the contraction stops growing on the ascent while the pressure still rises: the muscle's
// stroke end, a hard stop, or a load come to rest on a support. Over the samples of the
// identification run whose command rises, p_mpa is the least (11-sample mean) pressure at which
// the (11-sample mean) contraction lies within a band of its largest, x_mm: 3 noise widths of
// the displacement record (detect_clipping's sigma) or 0.1 % of the reached span, whichever is
// larger. A stop where that pressure lies below the headroom line, (1 - kPressureHeadroom) of
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
  const double band = std::max(3.0 * detect_clipping(id.contraction_mm).sigma, 1e-3 * (*hi_it - *lo_it));
  double p_at = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < n; ++k)
    if (c[k] > c[k - 1] && sm.x_mm[k] >= s.x_mm - band) p_at = std::min(p_at, sm.p[k]);
  s.p_mpa = p_at;
  s.found = std::isfinite(p_at) && p_at > 0.0 && p_at < (1.0 - kPressureHeadroom) * p_top;
  return s;
}

// ExperimentOptions::fit_references. The reach measured on the identification run: from the
// contraction at rest (the least, vented) to the contraction on the ascent when the
// measured pressure first reached (1 - kPressureHeadroom) of the actuator's top pressure
// (the least contraction at or above that pressure). The top pressure p_top is usable_top's
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
    if (id.pressure_mpa[k] >= p_limit) top = std::min(top, x[k]);
  }
  // the rest position, with the sensor's resolution as tolerance: 0.1 % of the reached span
  double floor_mm = res.reach_min_mm;  // where a reference below the reach is mapped to
  double bottom = res.reach_min_mm - 1e-3 * (res.reach_max_mm - res.reach_min_mm);
  // A displacement sensor that clips (detect_clipping; docs/control.md section 5): the rig
  // cannot be seen beyond its limit, so the reach keeps 3 noise widths from it.
  if (const Clipping clip = detect_clipping(id.contraction_mm); clip.any()) {
    const double band = 3.0 * clip.sigma;
    if (clip.low && clip.lo + band > floor_mm) floor_mm = bottom = clip.lo + band;
    if (clip.high) top = std::min(top, clip.hi - band);
    res.messages.push_back(clipping_note(clip));
  }
  const bool known_top = std::isfinite(top);  // else the identification never reached p_limit
  res.reach_top_mm = known_top ? top : std::numeric_limits<double>::quiet_NaN();
  res.reach_top_pressure_mpa = p_limit;
  for (Reference& ref : refs) {
    const auto [lo_it, hi_it] = std::minmax_element(ref.ref_m.begin(), ref.ref_m.end());
    ReferenceRange rr;
    rr.reference = ref.name;
    rr.paper_min_mm = rr.min_mm = *lo_it * 1e3;
    rr.paper_max_mm = rr.max_mm = *hi_it * 1e3;
    const bool above = known_top && rr.paper_max_mm > top, below = rr.paper_min_mm < bottom;
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
                                           "published {:.1f}..{:.1f} mm (scale {:.3f}): {}; errors are against the "
                                           "mapped reference (--paper-references keeps the published one)",
                                           ref.name, rr.min_mm, rr.max_mm, rr.paper_min_mm, rr.paper_max_mm, s, why));
      } else {
        rr.reachable = false;
        res.messages.push_back(fmt::format("reference {} ({:.1f}..{:.1f} mm) is out of this rig's reach: {}; the "
                                           "errors beyond it are the actuator's limit, not the controller's",
                                           ref.name, rr.paper_min_mm, rr.paper_max_mm, why));
      }
    } else if (!known_top && rr.paper_max_mm > res.reach_max_mm) {
      res.messages.push_back(fmt::format("reference {}: its top, {:.1f} mm, lies above the {:.1f} mm the "
                                         "identification run reached, whose pressure stayed below {:.2f} MPa; the "
                                         "rig's reach above it is not known, and the reference is kept",
                                         ref.name, rr.paper_max_mm, res.reach_max_mm, p_limit));
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
    r.score_from = r.periodic_from = n;
  }
}

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
  const RigStatics s = rig_statics(rig);
  const std::string why = rig_weak_return_reason(rig, s, which);
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
struct IdentificationRange {
  double top_mm = 0.0, p_need_mpa = 0.0, p_id_mpa = 0.0, input_max_mpa = 0.0;
  std::string note() const {
    return fmt::format("hysteron's model is identified on the paper's pressure inputs scaled to 0..{:.3f} MPa (from "
                       "{:.3f}): the references reach {:.1f} mm, which the rig's ascent reached at {:.3f} MPa in the "
                       "identification run, and the model is not fitted where the loops do not go (docs/control.md, "
                       "section 0)",
                       p_id_mpa, input_max_mpa, top_mm, p_need_mpa);
  }
};

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
std::vector<double> scaled_to(std::vector<double> input, double top_mpa, bool up_too = false) {
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

// The kinds a run tries for hysteron's model: the one asked for, or (auto) the paper's
// kind first, then every other kind in the order of fit_model_kinds.
std::vector<FitModel> candidate_kinds(const ExperimentOptions& o, const Spec& spec) {
  if (o.model != FitModel::automatic) return {o.model};
  std::vector<FitModel> kinds{spec.model};
  for (FitModel k : fit_model_kinds)
    if (k != spec.model) kinds.push_back(k);
  return kinds;
}

// The fit options of a candidate kind for hysteron's model: the paper's options with the
// kind, its number of operators (20 for mpi-asym, max(10, the paper's n) for the others),
// the decimated record's sample time (rate-pi's rates are per second) and the whole record.
FitOptions candidate_fit_options(const FitOptions& paper, FitModel kind, const Spec& spec, double fit_dt) {
  FitOptions f = paper;
  f.model = kind;
  f.num_operators = kind == FitModel::mpi_asym ? 20 : std::max(10, spec.operators);
  f.sample_time = fit_dt;
  f.train = {};
  return f;
}

// A rate-pi fitted at the decimated record's sample period, run at the control period: its
// rate is per second, so only dt changes (the filter of the rate keeps its time constant).
// The bound c max(r) <= (tau + dt) / 2 tightens with a shorter dt; c is lowered onto it if
// needed (said in the messages).
void to_control_rate(ModelParams& m, double tc, std::vector<std::string>& messages) {
  auto* r = std::get_if<RatePiParams>(&m);
  if (!r) return;
  const double fit_dt = r->dt;
  r->dt = tc;
  const double rmax = max_of(r->r);
  std::string lowered;
  if (rmax > 0.0 && r->c * rmax > 0.5 * (r->tau + r->dt)) {
    const double c = 0.5 * (r->tau + r->dt) / rmax * (1.0 - 1e-12);
    lowered = fmt::format("; c lowered from {:.6g} to {:.6g} s per input unit to keep c max(r) <= (tau + dt) / 2", r->c, c);
    r->c = c;
  }
  validate_model(m);
  messages.push_back(fmt::format("rate-pi: fitted at the decimated record's sample time dt = {:g} s, run by the "
                                 "loops at the control period dt = {:g} s{}",
                                 fit_dt, tc, lowered));
}

// The kinds whose fitted model has the PI family's play structure (has_pi_structure, which
// choose_model checks on every fitted model): the ones the adaptive variant re-identifies.
bool pi_family(FitModel k) {
  switch (k) {
    case FitModel::pi:
    case FitModel::gpi:
    case FitModel::mpi_deadzone:
    case FitModel::mpi_asym:
    case FitModel::maxwell_slip:
      return true;
    default:
      return false;
  }
}

// Fits the candidates of hysteron's model on `idf` and keeps (res.best_fit) the one with the
// least RMS on `id2`; fills res.candidates, res.model_choice and res.model_reason.
void choose_model(const ExperimentOptions& o, const Spec& spec, const IdentificationRun& idf,
                  const IdentificationRun& id2, const FitOptions& fo, double fit_dt, double p_max,
                  ExperimentResult& res) {
  const bool automatic = o.model == FitModel::automatic;
  res.model_choice = o.model;
  double best_rms = std::numeric_limits<double>::infinity();
  std::size_t best = 0;
  // auto chooses a kind every variant of the run can use: the adaptive variant re-identifies
  // the weights of a PI-family model, so while it runs only those are eligible (the others
  // are still fitted and listed, for comparison).
  const bool pi_only = automatic && o.adaptive &&
                       std::any_of(spec.variants.begin(), spec.variants.end(),
                                   [](const Variant& v) { return v.name == "adaptive"; });
  std::size_t eligible = 0;
  for (FitModel kind : candidate_kinds(o, spec)) {
    const FitOptions f2 = candidate_fit_options(fo, kind, spec, fit_dt);
    ModelCandidate c;
    c.kind = kind;
    if (pi_only && !o.fit_ineligible_candidates && !pi_family(kind)) {
      c.message = "not fitted: not eligible for auto while the adaptive variant runs, and the run lists only the "
                  "eligible ones (ExperimentOptions::fit_ineligible_candidates = false, as in hysteron sweep)";
      res.candidates.push_back(std::move(c));
      continue;
    }
    FitReport rep;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      rep = fit_checked(idf, f2, fmt::format("{} model", fit_model_name(kind)), p_max, &c.status);
      c.validation = evaluate_censored(rep.model, id2.pressure_mpa, id2.contraction_mm);
      if (!std::isfinite(c.validation.rms))
        throw Error(fmt::format("experiment: the {} model's output on the second identification run is not finite",
                                fit_model_name(kind)));
      c.ok = true;
      c.message = rep.message;
    } catch (const Error& e) {
      c.message = e.what();
      if (!automatic)
        throw Error(fmt::format("experiment {}: the model kind {} (--model) cannot be used for the compensated "
                                "variants: {}",
                                spec.name, fit_model_name(kind), e.what()));
      res.messages.push_back(fmt::format("candidate {} skipped: {}", fit_model_name(kind), e.what()));
    }
    c.fit_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const bool can_choose = c.ok && (!pi_only || has_pi_structure(rep.model));
    if (c.ok && !can_choose)
      c.message = fmt::format("not eligible for auto while the adaptive variant runs (it needs a PI-family model; "
                              "--no-adaptive or --model {} to use it); {}",
                              fit_model_name(kind), c.message);
    eligible += can_choose;
    if (can_choose && c.validation.rms < best_rms) {
      best_rms = c.validation.rms;
      best = res.candidates.size();
      res.best_fit = std::move(rep);
      res.best_validation = c.validation;
    }
    res.candidates.push_back(std::move(c));
  }
  if (!std::isfinite(best_rms))
    throw Error(fmt::format("experiment {}: no model kind could be fitted and inverted for the compensated variants "
                            "(see the candidates' messages: {})",
                            spec.name, fmt::join(res.messages, "; ")));
  res.candidates[best].chosen = true;
  const ModelCandidate& c = res.candidates[best];
  if (automatic) {
    std::size_t ok = 0;
    double second = std::numeric_limits<double>::infinity(), best_any = c.validation.rms;
    FitModel best_any_kind = c.kind;
    for (const auto& x : res.candidates)
      if (x.ok) {
        ++ok;
        if (x.validation.rms < best_any) {
          best_any = x.validation.rms;
          best_any_kind = x.kind;
        }
        if (!x.chosen) second = std::min(second, x.validation.rms);
      }
    res.model_reason = fmt::format(
        "auto: {} has the least RMS on the second identification run, {:.3f} mm, of the {} of {} kinds that could "
        "be fitted and inverted{}{}",
        fit_model_name(c.kind), c.validation.rms, pi_only ? eligible : ok, res.candidates.size(),
        pi_only ? " and the adaptive variant can use (PI family)" : "",
        pi_only && best_any_kind != c.kind
            ? fmt::format(" (of all {}: {} at {:.3f} mm, used with --no-adaptive or --model {})", ok,
                          fit_model_name(best_any_kind), best_any, fit_model_name(best_any_kind))
        : std::isfinite(second) ? fmt::format(" (next best {:.3f} mm)", second)
                                : std::string());
  } else {
    res.model_reason = fmt::format("{} asked for (--model {}); {:.3f} mm RMS on the second identification run",
                                   fit_model_name(c.kind), fit_model_name(c.kind), c.validation.rms);
  }
  if (res.best_fit.status == FitStatus::poor_fit)
    res.messages.push_back(fmt::format("hysteron's model {}: the fit is poor ({})", fit_model_name(c.kind),
                                       res.best_fit.message));
  to_control_rate(res.best_fit.model, o.control_period, res.messages);
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

}  // namespace

void ExperimentOptions::validate() const {
  if (model != FitModel::automatic &&
      std::find(std::begin(fit_model_kinds), std::end(fit_model_kinds), model) == std::end(fit_model_kinds))
  {
    std::string list;
    for (FitModel k : fit_model_kinds) list += ", " + std::string(fit_model_name(k));
    throw Error(fmt::format("experiment: model = {} is not a model kind (expected auto{})", static_cast<int>(model),
                            list));
  }
  hysteron::validate(rig, "experiment: rig");
  check_return_force(rig, "rig");
  if (!(control_period >= rig.simulation.dt) || !(control_period <= 0.02))
    throw Error(fmt::format("experiment: control_period = {} s must be within [rig dt = {} s, 0.02 s]",
                            control_period, rig.simulation.dt));
  if (learning_periods < 0 || learning_periods > 1000)
    throw Error(fmt::format("experiment: learning_periods = {} must be within 0..1000", learning_periods));
  if (tracking_rig) {
    hysteron::validate(*tracking_rig, "experiment: tracking rig");
    check_return_force(*tracking_rig, "tracking rig");
    if (!(control_period >= tracking_rig->simulation.dt))
      throw Error(fmt::format("experiment: control_period = {} s is shorter than the tracking rig's dt = {} s",
                              control_period, tracking_rig->simulation.dt));
  }
  if (!find_spec(name)) {
    std::string list;
    for (const auto& n : experiment_names()) list += (list.empty() ? "" : ", ") + n;
    throw Error(fmt::format("experiment: unknown experiment \"{}\" (expected one of {})", name, list));
  }
}

ExperimentResult run_experiment(const ExperimentOptions& o) {
  o.validate();
  const auto t0 = std::chrono::steady_clock::now();
  const Spec& spec = *find_spec(o.name);
  const double tc = o.control_period;
  ExperimentResult res;
  res.name = spec.name;
  res.title = spec.title;
  res.seed = o.seed;
  res.published = spec.published;
  // the actuator's limit: no run commands more (the rig's rating and the regulator's range)
  const double p_max = run_pressure_limit(o, spec.valves);
  res.pressure_limit_mpa = p_max;
  if (p_max != kPaperPressureMax) res.messages.push_back(limit_note(o, spec, p_max));

  // 0. the actuator of every run: the regulator, or the valves behind a pressure PI tuned
  //    by a relay test of the valves (first: the identification runs through it too)
  RigDynamics valves_relay;
  PidParams pressure_loop;
  if (spec.valves) {
    relay_test(o.rig, o.seed + 15485863, tc, valves_relay, p_max);
    pressure_loop = tyreus_luyben_pi(valves_relay, tc);
  }
  auto make_actuator = [&]() -> Actuator {
    if (!spec.valves)
      return [k = spec.pressure_loop_gain, p_max](double p, const RigOutputs& out) {
        return regulator(pressure_loop_command(p, out.pressure_measured * 1e-6, k), p_max);
      };
    auto inner = std::make_shared<Pid>(pressure_loop);
    return [inner](double p, const RigOutputs& out) { return valves(inner->step(p, out.pressure_measured * 1e-6), p); };
  };

  // 1. identification run and the paper's fit on the major loop (the papers' inputs scaled to a
  //    limit below their 0..0.6 MPa: paper_pressure_input)
  const std::vector<double> paper_input = paper_pressure_input(spec.id_pressure(tc), p_max);
  const IdentificationRun id = identification_run(o.rig, o.seed, paper_input, tc, make_actuator(), p_max);
  res.identification = id;
  res.id_train_end = static_cast<std::size_t>(std::lround(spec.train_seconds / tc));
  const auto every = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (kFitRate * tc))));
  const IdentificationRun idf = decimate(id, every);
  const std::size_t train_end = (res.id_train_end + every - 1) / every;
  FitOptions fo;
  fo.model = spec.model;
  fo.num_operators = spec.operators;
  fo.train = {0, train_end};
  fo.seed = static_cast<unsigned>(o.seed);
  res.fit = fit_checked(idf, fo, "paper's model", p_max);
  res.validation =
      evaluate_censored(res.fit.model, idf.pressure_mpa, idf.contraction_mm, {train_end, IndexRange::npos});

  // 2. hysteron's model: candidates fitted on the whole record, chosen on a second
  //    identification run (other seed, other pressure sequence); both inputs scaled to the
  //    pressure range the references need where that is below the paper's input's maximum
  //    (model_identification_range; the references kept within the rig's reach first).
  // Where the paper's input stops short of the actuator's top and its run never reached the
  // references' top, the reach and hysteron's model come from a run of that input extended to
  // the top (extended_input_top); the paper's model stays fitted on the paper's run.
  std::vector<Reference> refs = spec.references(tc);
  std::optional<IdentificationRun> extended_run, extended_runf;
  {
    const SmoothedRun sm(id);
    if (const double ext = extended_input_top(paper_input, sm, refs, usable_top(id, sm, p_max).mpa, p_max);
        ext > 0.0) {
      const double input_max = *std::max_element(paper_input.begin(), paper_input.end());
      const double reached_mm = *std::max_element(sm.x_mm.begin(), sm.x_mm.end());
      extended_run = identification_run(o.rig, o.seed, scaled_to(paper_input, ext, true), tc, make_actuator(), p_max);
      extended_runf = decimate(*extended_run, every);
      res.messages.push_back(fmt::format(
          "the paper's identification input goes up to {:.3f} MPa, where this rig's contraction stayed at or below "
          "{:.1f} mm, short of the references' top: the rig's reach and hysteron's model are measured on that input "
          "scaled to {:.3f} MPa, the actuator's top (the paper's model stays fitted on the paper's run; "
          "docs/control.md, section 0)",
          input_max, reached_mm, ext));
    }
  }
  const IdentificationRun& id_run = extended_run ? *extended_run : id;  // the run the reach and the model come from
  const IdentificationRun& id_runf = extended_run ? *extended_runf : idf;
  const std::vector<double> id_input = extended_run ? scaled_to(paper_input, p_max, true) : paper_input;
  const SmoothedRun smooth(id_run);
  res.reach_pressure_max_mpa = max_of(smooth.p);
  // the actuator's usable top: the reach, the position relay's level and the FOPDT's clip
  const ActuatorTop actuator_top = usable_top(id_run, smooth, p_max);
  const double top = actuator_top.mpa;
  refs = fit_to_reach(o, id_run, smooth, actuator_top, std::move(refs), res, p_max);
  add_pre_roll(refs, tc);
  if (std::string note = descent_note(o.tracking_rig ? *o.tracking_rig : o.rig, refs, tc); !note.empty())
    res.messages.push_back(std::move(note));
  if (std::string note = weak_return_note(o.rig, "rig", refs); !note.empty()) res.messages.push_back(std::move(note));
  if (o.tracking_rig)
    if (std::string note = weak_return_note(*o.tracking_rig, "tracking rig", refs); !note.empty())
      res.messages.push_back(std::move(note));
  const IdentificationRange range = model_identification_range(smooth, refs, id_input, p_max);
  const bool rescaled = range.p_id_mpa > 0.0;
  res.model_id_top_mpa = rescaled ? range.p_id_mpa : extended_run ? p_max : 0.0;
  std::optional<IdentificationRun> scaled_run, scaled_runf;  // the model's identification run, if not the paper's
  if (rescaled) {
    res.messages.push_back(range.note());
    scaled_run = identification_run(o.rig, o.seed, scaled_to(id_input, range.p_id_mpa), tc, make_actuator(), p_max);
    scaled_runf = decimate(*scaled_run, every);
  }
  const IdentificationRun& ids = rescaled ? *scaled_run : id_run;
  const IdentificationRun& idsf = rescaled ? *scaled_runf : id_runf;
  if (rescaled || extended_run) res.model_identification = ids;  // the model's run, where not the paper's
  const IdentificationRun id2 = decimate(
      identification_run(o.rig, o.seed + 7919,
                         scaled_to(paper_pressure_input(spec.id2_pressure(tc), p_max), range.p_id_mpa), tc,
                         make_actuator(), p_max),
      every);
  choose_model(o, spec, idsf, id2, fo, static_cast<double>(every) * tc, p_max, res);
  res.baseline_model = straight_line(id_run, p_max);

  // 3. the rig's dynamics through its actuator, from the paper's identification run (or its
  //    extension, above), around hysteron's kind fitted on it (where the model was identified
  //    on scaled inputs, its kind is fitted once more on that run: the FOPDT, the lead and the
  //    loops tuned from them are those of the rig over the whole run, as without the scaling)
  std::size_t lead = 0;
  ModelParams dynamics_model = res.best_fit.model;
  bool on_paper_run = !rescaled;
  if (rescaled) {
    const FitModel kind = res.best_fit.model_kind;
    try {
      FitReport full = fit_checked(id_runf, candidate_fit_options(fo, kind, spec, static_cast<double>(every) * tc),
                                   fmt::format("{} model", fit_model_name(kind)), p_max);
      std::vector<std::string> said_already;  // to_control_rate's note was given for the chosen model
      to_control_rate(full.model, o.control_period, said_already);
      dynamics_model = std::move(full.model);
      on_paper_run = true;
    } catch (const Error& e) {
      res.messages.push_back(fmt::format("the dead time, lag and lead are identified on the scaled identification "
                                         "run: {} could not be fitted on the paper's run ({})",
                                         fit_model_name(kind), e.what()));
    }
  }
  // Where the supply caps the actuator well below the commands (the run's highest command more
  // than twice kPressureHeadroom above the top it reached; a regulator's lag at the input's
  // peaks falls short by less, 5.5 % with a 200 ms lag), the model is run on the commands
  // clipped at that top: what the actuator could deliver, so the FOPDT does not take the
  // saturation for a lag (a 4 bar supply: 300 ms, the grid's bound, on mpi-pwm).
  const IdentificationRun& dyn_run = on_paper_run ? id_run : ids;
  const double cmd_max = max_of(dyn_run.pressure_command_mpa);
  IdentificationRun capped_run;
  const bool clip = top < (1.0 - 2.0 * kPressureHeadroom) * std::min(cmd_max, p_max);
  if (clip) {
    capped_run = dyn_run;
    for (double& v : capped_run.pressure_command_mpa) v = std::min(v, top);
  }
  res.dynamics = identify_dynamics(dynamics_model, clip ? capped_run : dyn_run, tc, lead);
  res.lead_s = static_cast<double>(lead) * tc;
  if (std::string note = dynamics_bound_note(res.dynamics, res.lead_s, tc); !note.empty())
    res.messages.push_back(std::move(note));
  res.dynamics.relay_gain = valves_relay.relay_gain;
  res.dynamics.relay_period_s = valves_relay.relay_period_s;
  res.dynamics.relay_level_mpa = valves_relay.relay_level_mpa;
  res.dynamics.relay_duty = valves_relay.relay_duty;
  position_relay_test(o.rig, o.seed + 32452843, tc, make_actuator, res.dynamics, p_max, top,
                      stroke_pressures(id_run, smooth));
  fit_load_mode(res.dynamics);
  if (const RigDynamics fitted = res.dynamics; fit_fopdt_to_relay_phase(res.dynamics))
    res.messages.push_back(fmt::format(
        "the FOPDT fitted on the identification run (dead time {:.0f} ms, lag {:.0f} ms) has more phase lag at the "
        "position relay's frequency ({:.2f} Hz) than the relay measured, -180 degrees, and no load mode explains "
        "that; its dead time and lag, whose sum the run's least squares fixes better than their split, are split "
        "again, their sum kept, so that it reaches -180 degrees there: dead time {:.0f} ms, lag {:.0f} ms (the "
        "learning design and the learning loop's PID use them; docs/control.md, section 1)",
        fitted.dead_time_s * 1e3, fitted.lag_s * 1e3, 1.0 / res.dynamics.position_relay_period_s,
        res.dynamics.dead_time_s * 1e3, res.dynamics.lag_s * 1e3));
  Context ctx{o, res, res.dynamics, tc, lead, pressure_loop};
  ctx.pressure_max = p_max;

  // 4. tracking
  const std::uint64_t track_seed = o.seed + 104729;
  // the tracking rig is not the one identified (--tracking-plant): the notes name that first.
  // Parameters this experiment's actuation never reads (the regulator's under the valves, and
  // the reverse) do not change the rig it tracks on (with_unread_parameters_of; the sweep too).
  const Actuation mode = spec.valves ? Actuation::switching_valves : Actuation::regulator;
  const std::optional<PamRigParams> read_tracking =
      o.tracking_rig ? std::optional(with_unread_parameters_of(*o.tracking_rig, mode, o.rig)) : std::nullopt;
  const bool rig_changed = read_tracking && rig_params_to_json(*read_tracking) != rig_params_to_json(o.rig);
  if (rig_changed) res.messages.push_back(changed_rig_note(o.rig, *read_tracking));
  if (o.tracking_rig && !rig_changed && rig_params_to_json(*o.tracking_rig) != rig_params_to_json(o.rig))
    res.messages.push_back(fmt::format(
        "the rig of --tracking-plant differs from the identified one (--plant) only in parameters this experiment "
        "does not drive ({}); it tracks on the identified rig as driven {}",
        changed_rig_list(o.rig, *o.tracking_rig), spec.valves ? "through its switching valves" : "through its regulator"));
  std::vector<std::string> sensor_gaps;  // runs whose sensor hides part of the error (sensor_gap)
  const double frame_mm = o.rig.sensors.displacement_offset * 1e3;
  // the notes of a run scored on [from, end): its saturation and guard, and its sensor's gap
  const auto run_notes = [&](const TrackingRun& run, std::size_t from) {
    const auto say = [&](std::string note) {
      if (!note.empty()) res.messages.push_back(std::move(note));
    };
    say(saturation_note(run, from, run.t.size(), res.reach_pressure_max_mpa, rig_changed, p_max));
    say(guard_note(run, rig_changed));
    if (std::string gap = sensor_gap(run, from, run.t.size(), frame_mm); !gap.empty())
      sensor_gaps.push_back(std::move(gap));
  };
  for (const Reference& ref : refs) {
    Context rc = ctx;
    rc.reference = &ref;
    // the gain trial's choice for the compensated and adaptive loops: the PID's scale, and
    // their feedforward through the shaper (zv inactive: not shaped)
    ZvShaper zv;
    for (const Variant& v : spec.variants)
      if (v.name == "compensated") {
        GainTrial g = gain_trial(o, v, rc, ref, lead);
        rc.gain_scale = g.scale;
        rc.guard_amplitude_m = guard_amplitude(g);
        if (g.shaped) zv = zv_shaper(res.dynamics, tc);
        rc.shaper = zv;
        res.gain_trials.push_back(std::move(g));
      }
    const auto shaped_ref = std::make_shared<const std::vector<double>>(shaped(ref.ref_m, zv));
    for (const Variant& v : spec.variants) {
      if (v.name == "adaptive" && !o.adaptive) continue;
      if (v.name == "adaptive" && !has_pi_structure(res.best_fit.model)) {
        res.messages.push_back(fmt::format("adaptive ({}) not run: it re-identifies the weights of a PI-family model "
                                           "(pi, gpi, mpi-deadzone, mpi-asym, maxwell-slip), and hysteron's model is "
                                           "{}",
                                           ref.name, fit_model_name(res.best_fit.model_kind)));
        continue;
      }
      Loop loop;
      try {
        loop = v.make(rc);
      } catch (const Error& e) {
        if (v.name != "adaptive") throw;
        res.messages.push_back(fmt::format("adaptive ({}) not run: {}", ref.name, e.what()));
        continue;
      }
      if (zv.active() && v.preview) {
        loop.law = with_preview(loop.law, shaped_ref, lead);
        loop.description += fmt::format("; feedforward through a zero-vibration shaper at the identified mode {}",
                                        shaper_timing(zv, tc));
      }
      TrackingRun run = track(o, track_seed, ref.ref_m, v.preview ? lead : 0, false, loop.law, p_max);
      run.variant = v.name;
      run.reference = ref.name;
      run.description = loop.description;
      run.controller = loop_design(loop, v.preview ? lead : 0, tc, v.preview ? &zv : nullptr);
      run.errors = errors_of(run, ref.score_from, run.t.size());
      run.scored_from_s = ref.score_from < run.t.size() ? run.t[ref.score_from] : 0.0;
      run_notes(run, ref.score_from);
      res.runs.push_back(std::move(run));
      if (loop.note)
        if (std::string note = loop.note(); !note.empty()) res.messages.push_back(std::move(note));
      if (v.name == spec.learning_on && o.learning_periods > 0 && ref.period > 0) {
        Context lc = rc;
        lc.learning = true;
        if (std::optional<TrackingRun> lr = learning_with_fallback(o, lc, ref, v, track_seed, res.messages)) {
          lr->variant = "learning";
          lr->reference = ref.name;
          const std::size_t last = lr->t.size() - std::min(lr->t.size(), ref.period);  // the scored last period
          run_notes(*lr, last);
          // a learning run that ends above the loop it learns on must not look like an improvement
          for (const TrackingRun& base : res.runs)
            if (base.variant == v.name && base.reference == ref.name &&
                lr->errors.rms_error_mm > base.errors.rms_error_mm && lr->periods.size() >= 2)
              res.messages.push_back(learning_above_note(*lr, base));
          res.runs.push_back(std::move(*lr));
        }
      }
    }
    // a loop tuned from the rig's identification that does no better than the baseline must not
    // look like compensation (a relay cycle cut at the load's rest gave gains 6x too high once),
    // nor an adaptive run that ends above the compensated one it adapts
    const auto of_ref = [&](std::string_view variant) -> const TrackingRun* {
      for (const TrackingRun& run : res.runs)
        if (run.reference == ref.name && run.variant == variant) return &run;
      return nullptr;
    };
    const TrackingRun* base = of_ref("baseline");
    const TrackingRun* comp = of_ref("compensated");
    const TrackingRun* faithful = of_ref("faithful");
    const auto say = [&](std::string note) {
      if (!note.empty()) res.messages.push_back(std::move(note));
    };
    for (const TrackingRun& run : res.runs) {
      if (run.reference != ref.name) continue;
      if (base && (run.variant == "compensated" || run.variant == "adaptive" || run.variant == "learning"))
        say(above_baseline_note(run, *base, rig_changed));
      if (comp && run.variant == "adaptive") say(adaptive_above_note(run, *comp, rig_changed));
      if (faithful && run.variant == "compensated") say(faithful_below_note(run, *faithful, rig_changed));
    }
  }
  if (std::string note = sensor_gap_note(sensor_gaps, o.rig, o.tracking_rig ? *o.tracking_rig : o.rig); !note.empty())
    res.messages.push_back(std::move(note));
  if (std::string note = noise_floor_note(res, id); !note.empty()) res.messages.push_back(std::move(note));
  res.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

bool ExperimentResult::is_output_file(const std::string& f) {
  for (const char* name : {"identification.csv", "model_identification.csv", "model.json", "best_model.json",
                           "result.json", "report.html"})
    if (f == name) return true;
  return f.starts_with("tracking_") && f.ends_with(".csv");
}

namespace {

// Writes the run's files into `d`; returns their names.
std::vector<std::string> write_files(const ExperimentResult& r, const std::filesystem::path& d) {
  std::vector<std::string> written = {"model.json", "best_model.json", "result.json"};
  // an identification run's columns (read back by report::read_experiment_dir)
  auto write_id_run = [&](const char* name, const IdentificationRun& run) {
    written.push_back(name);
    io::write_columns((d / name).string(), {"t_s", "pressure_command_mpa", "pressure_mpa", "contraction_mm"},
                      {run.t, run.pressure_command_mpa, run.pressure_mpa, run.contraction_mm});
  };
  write_id_run("identification.csv", r.identification);
  if (!r.model_identification.empty()) write_id_run("model_identification.csv", r.model_identification);
  for (const auto& run : r.runs) {
    std::vector<std::string> names = {"t_s",      "reference_mm", "measured_mm", "actual_mm", "pressure_command_mpa",
                                      "pressure_mpa", "pwm_duty"};
    std::vector<std::vector<double>> columns = {run.t, run.reference_mm, run.measured_mm, run.actual_mm,
                                                run.pressure_command_mpa, run.pressure_mpa, run.duty};
    if (!run.pressure_measured_mpa.empty()) {  // the pressure sensor's reading the loop was given
      names.push_back("pressure_measured_mpa");
      columns.push_back(run.pressure_measured_mpa);
    }
    if (!run.correction_mm.empty()) {  // learning runs: the correction added to the reference
      names.push_back("correction_mm");
      columns.push_back(run.correction_mm);
    }
    written.push_back(fmt::format("tracking_{}_{}.csv", run.variant, run.reference));
    io::write_columns((d / written.back()).string(), names, columns);
  }
  io::write_model_file((d / "model.json").string(), r.fit.model);
  io::write_model_file((d / "best_model.json").string(), r.best_fit.model,
                       r.model_reason.empty()
                           ? nlohmann::json{}
                           : nlohmann::json{{"note", fmt::format("hysteron experiment {}: the model of the "
                                                                 "compensated variants; {}",
                                                                 r.name, r.model_reason)}});
  io::write_text_file((d / "result.json").string(), io::to_json(r).dump(2) + "\n");
  return written;
}

}  // namespace

void ExperimentResult::write(const std::string& dir) const {
  namespace fs = std::filesystem;
  const fs::path d(dir);
  std::error_code ec;
  const bool existed = fs::is_directory(d, ec);
  fs::create_directories(d, ec);
  if (ec) throw Error(fmt::format("experiment: cannot create output directory {}: {}", dir, ec.message()));
  const bool earlier_run = fs::exists(d / "result.json", ec);
  std::vector<std::string> written;
  try {
    io::FileBatch batch;  // every file complete before any is replaced
    written = write_files(*this, d);
    batch.commit();
  } catch (...) {
    if (!existed) fs::remove(d, ec);  // the directory it created, if still empty
    throw;
  }
  if (!earlier_run) return;
  // The earlier run's files this one does not have (a variant it did not run, its report).
  std::vector<fs::path> stale;
  for (const auto& e : fs::directory_iterator(d, ec)) {
    const std::string f = e.path().filename().string();
    if (is_output_file(f) && std::find(written.begin(), written.end(), f) == written.end()) stale.push_back(e.path());
  }
  for (const fs::path& p : stale) fs::remove(p, ec);
}

std::string ExperimentResult::table() const {
  std::string s = fmt::format("{}: {}\n", name, title);
  s += fmt::format("  identification: {} fitted on the major loop, RMS {:.3f} mm train, {:.3f} mm ({:.2f} % of span) "
                   "on the minor loops; best model {} ({:.3f} mm RMS on a second run)\n",
                   fit_model_name(fit.model_kind), fit.train.rms, validation.rms, validation.rms_percent_span,
                   fit_model_name(best_fit.model_kind), best_validation.rms);
  if (!model_reason.empty()) s += fmt::format("  model of the compensated variants: {}\n", model_reason);
  if (candidates.size() > 1) {
    s += "  candidates (RMS on the second run [mm], fit time [s]):";
    for (const auto& c : candidates)
      s += c.ok ? fmt::format(" {}{} {:.3f} ({:.2f} s);", fit_model_name(c.kind), c.chosen ? "*" : "", c.validation.rms,
                              c.fit_time_s)
                : fmt::format(" {} skipped;", fit_model_name(c.kind));
    s.back() = '\n';
  }
  s += fmt::format("  {:<10} {:<12} {:>9} {:>9} {:>9}\n", "reference", "variant", "max [mm]", "MAE [mm]", "RMS [mm]");
  for (const auto& r : runs)
    s += fmt::format("  {:<10} {:<12} {:>9.3f} {:>9.4f} {:>9.4f}{}\n", r.reference, r.variant, r.errors.max_error_mm,
                     r.errors.mae_mm, r.errors.rms_error_mm,
                     r.periods.empty() ? "" : fmt::format("   (period {})", r.periods.size()));
  if (!published.empty()) {
    auto cell = [](double v, int digits) {
      return std::isfinite(v) ? fmt::format("{:>9.{}f}", v, digits) : fmt::format("{:>9}", "-");
    };
    for (const auto& e : published.errors)
      s += fmt::format("  {:<10} {:<12} {} {} {}\n", e.reference.empty() ? "paper" : e.reference, "published",
                       cell(e.max_error_mm, 3), cell(e.mae_mm, 4), cell(e.rms_error_mm, 4));
  } else {
    s += "  (the paper's text ends before its results: no published figures)\n";
  }
  for (const auto& r : runs) {
    if (r.periods.empty()) continue;
    s += fmt::format("  learning, {}: RMS [mm] of each period:", r.reference);
    for (const auto& e : r.periods) s += fmt::format(" {:.3f}", e.rms_error_mm);
    s += "\n";
  }
  // the relay's amplitude only where it had to be raised (a wide hysteresis band)
  const double h = dynamics.position_relay_amplitude_mpa;
  // ... and its level (and the pressure relay's) only where a capped supply moved it off 0.3 MPa
  auto moved = [&](double level) { return level > 0.0 && std::abs(level - relay_level(pressure_limit_mpa)) > 1e-9; };
  std::string amplitude;
  if (moved(dynamics.position_relay_level_mpa))
    amplitude = fmt::format(" (at {:.3f} +-{:g} MPa)", dynamics.position_relay_level_mpa, h);
  else if (h > kPositionRelayAmplitude * (1.0 + 1e-9))
    amplitude = fmt::format(" (+-{:g} MPa)", h);
  s += fmt::format("  identified: dead time {:.0f} ms, lag {:.0f} ms, slope {:.3f} mm/kPa; position relay{} K_u = {:.3g} "
                   "MPa/m, T_u = {:.0f} ms, mode {:.2f} Hz (damping {:.2f}){}\n",
                   dynamics.dead_time_s * 1e3, dynamics.lag_s * 1e3, dynamics.gain_m_per_mpa, amplitude,
                   dynamics.position_relay_gain, dynamics.position_relay_period_s * 1e3,
                   dynamics.mode_frequency_hz, dynamics.mode_damping,
                   dynamics.relay_gain > 0
                       ? fmt::format(", pressure relay{}{} K_u = {:.3g}/MPa, T_u = {:.1f} ms",
                                     moved(dynamics.relay_level_mpa)
                                         ? fmt::format(" (at {:.3f} MPa)", dynamics.relay_level_mpa)
                                         : std::string(),
                                     dynamics.relay_duty > 0.5 ? fmt::format(" (duty +-{:g}: the valves did not "
                                                                             "open at +-0.5)", dynamics.relay_duty)
                                                               : std::string(),
                                     dynamics.relay_gain, dynamics.relay_period_s * 1e3)
                       : std::string());
  for (const auto& g : gain_trials) {
    s += fmt::format("  gain trial, {}: PID gains x{:.2f}{}; RMS [mm] on the trapezoid per scale:", g.reference, g.scale,
                     g.shaped ? ", shaped feedforward" : "");
    for (std::size_t i = 0; i < g.scales.size(); ++i)
      s += fmt::format(" x{:.2f}{} {:.3f}", g.scales[i], !g.shaped && g.scales[i] == g.scale ? "*" : "", g.rms_mm[i]);
    if (!g.rms_shaped_mm.empty()) {
      s += "; shaped:";
      for (std::size_t i = 0; i < g.scales.size(); ++i)
        s += fmt::format(" x{:.2f}{} {:.3f}", g.scales[i], g.shaped && g.scales[i] == g.scale ? "*" : "",
                         g.rms_shaped_mm[i]);
    }
    if (g.early_stop) s += " (stopped early above the best: those RMS are lower bounds)";
    s += "\n";
  }
  for (const auto& m : messages) s += fmt::format("  note: {}\n", m);
  return s;
}

namespace experiment {
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

bool set_learning_shaper(bool on) { return learning_shaper.exchange(on); }
}  // namespace experiment

}  // namespace hysteron
