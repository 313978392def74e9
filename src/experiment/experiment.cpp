#include "hysteron/experiment.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <utility>

#include "detail.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/results.hpp"

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
  // a run's loop names its pressure limits (the rig's): result.json must not leave them to the model
  if (!loop.feedforward.pressure_limits.bounded())
    throw Error(fmt::format("internal: the loop \"{}\" has no pressure limits of its own", loop.description));
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

// `law` with the position PID's limit-cycle guard restarted (Loop::restart_guard) at sample k,
// the end of a pre-roll (Reference::pre_roll): the muscle's fill from rest during it is no
// ringing of the loop, and gains cut then would stay cut over the scored part. `law` itself
// where k is 0 or the loop has no guard to restart.
Law guard_from(Law law, const Loop& loop, std::size_t k) {
  if (k == 0 || !loop.restart_guard || loop.position.guard.period <= 0.0) return law;
  return [inner = std::move(law), restart = loop.restart_guard, k](const Sample& s) {
    if (s.k == k) restart();
    return inner(s);
  };
}

// The learning variant on top of `base`: `periods` repetitions of the reference's
// first period, the ILC designed on the identified closed loop and `which` of its neighbours,
// among the Q-filters of `window`. A user's reference (Reference::user) is preceded by its
// pre-roll (add_pre_roll: its first value held, unscored, nothing learnt): the papers' start at
// the vented muscle's rest, a user's may start anywhere, and a first period that fills the
// muscle to it teaches the learning a transient no later period has (a sine from 30 mm:
// 6.7 mm RMS in its first period, 0.38 after ten, against 0.87 compensated).
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
  const std::size_t n0 = ref.user ? std::min(ref.periodic_from, ref.ref_m.size()) : 0;  // the pre-roll
  std::vector<double> r(ref.ref_m.begin(), ref.ref_m.begin() + static_cast<std::ptrdiff_t>(n0));
  r.reserve(n0 + ref.period * static_cast<std::size_t>(o.learning_periods));
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
  Law law = [ilc, inner = guard_from(base.law, base, ref.user ? n0 : 0), lead, applied, p_max, n0](const Sample& s) {
    if (s.k < n0) {  // the pre-roll: the loop alone
      applied->push_back(0.0);
      return inner(s);
    }
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
  TrackingRun run = track(o, seed, r, lead, true, law);
  for (int j = 0; j < o.learning_periods; ++j) {
    const std::size_t b = n0 + static_cast<std::size_t>(j) * ref.period;
    run.periods.push_back(errors_of(run, b, b + ref.period));
  }
  run.errors = run.periods.back();
  const std::size_t last = n0 + static_cast<std::size_t>(o.learning_periods - 1) * ref.period;
  run.scored_from_s = last < run.t.size() ? run.t[last] : 0.0;
  run.saturated = saturated_samples(run, last, last + ref.period, p_max);
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
      const TrackingRun run = track(on_identified_rig, o.seed + 86028121, trap, lead, false, law);
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


}  // namespace

void check_control_period(double control_period, double dt, std::string_view where, std::string_view rig) {
  if (!(control_period >= dt) || !(control_period <= kMaxControlPeriod))
    throw Error(fmt::format("{}: control_period = {} s must be within [{} dt = {} s, {} s]", where, control_period, rig,
                            dt, kMaxControlPeriod));
  control_steps(control_period, dt, fmt::format("{}: {}", where, rig));  // a whole number of the rig's steps
}

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
  check_control_period(control_period, rig.simulation.dt, "experiment", "rig");
  if (learning_periods < 0 || learning_periods > 1000)
    throw Error(fmt::format("experiment: learning_periods = {} must be within 0..1000", learning_periods));
  if (tracking_rig) {
    hysteron::validate(*tracking_rig, "experiment: tracking rig");
    check_return_force(*tracking_rig, "tracking rig");
    check_control_period(control_period, tracking_rig->simulation.dt, "experiment", "tracking rig");
  }
  check_user_references(references, control_period);
  for (const UserReference& u : references) {  // the learning run: learning_periods of its period
    const bool file = u.kind == UserReference::Kind::file;
    const double period_s = !file ? 1.0 / u.frequency_hz : u.periodic ? u.t_s.back() : 0.0;
    if (const double s = learning_periods * period_s; s > kMaxLearningSeconds)
      throw Error(fmt::format("experiment: {}: its learning run of {} periods (--learning-periods) of {:g} s would "
                              "last {:g} s, more than the {:g} s a learning run may (fewer --learning-periods, or "
                              "--learning-periods 0: no learning run)",
                              u.origin, learning_periods, period_s, s, kMaxLearningSeconds));
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
  res.control_period_s = tc;
  res.published = spec.published;
  for (const UserReference& u : o.references) {
    if (u.kind == UserReference::Kind::file) res.input_files.push_back(u.path);
    if (!u.note.empty()) res.messages.push_back(u.note);
  }
  // no paper tracked them: no figures (NaN, printed "-"); the report (src/report/html.cpp) knows
  // them by this source (PublishedFigures::of_user_references)
  if (!o.references.empty()) {
    res.published = {std::string(kUserReferencesSource), {}};
    for (const UserReference& u : o.references) res.published.errors.push_back({u.name});
  }
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
  check_stop(o);
  const IdentificationRun id = identification_run(o.rig, o.seed, paper_input, tc, make_actuator(), p_max);
  check_stop(o);
  res.identification = id;
  res.id_train_end = static_cast<std::size_t>(std::lround(spec.train_seconds / tc));
  const auto every = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (kFitRate * tc))));
  const IdentificationRun idf = decimate(id, every);
  const std::size_t train_end = (res.id_train_end + every - 1) / every;
  FitOptions fo;
  fo.model = spec.model;
  fo.num_operators = spec.operators;
  // the plain orientation only: the mirror is kept by its training cost, which is no choice by
  // tracking error (a 0.2 m muscle: mpi-openloop's mirrored fit won, its compensated triangle's max
  // rose 1.168 -> 1.381 mm; docs/models.md); the experiments choose their kind by a second run
  fo.mpi_asym_mirror = false;
  fo.train = {0, train_end};
  fo.seed = static_cast<unsigned>(o.seed);
  fo.num_threads = o.fit_threads;
  fo.stop_requested = o.stop_requested;  // and so every fit of the run (candidate_fit_options copies fo)
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
  std::vector<Reference> refs = o.references.empty() ? spec.references(tc) : user_references(o.references, tc);
  std::optional<IdentificationRun> extended_run, extended_runf;
  {
    const SmoothedRun sm(id, tc);
    if (const double ext = extended_input_top(paper_input, sm, refs, usable_top(id, sm, p_max).mpa, p_max);
        ext > 0.0) {
      const double input_max = *std::max_element(paper_input.begin(), paper_input.end());
      const double reached_mm = *std::max_element(sm.x_mm.begin(), sm.x_mm.end());
      extended_run = identification_run(o.rig, o.seed, scaled_to(paper_input, ext, true), tc, make_actuator(), p_max);
      check_stop(o);
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
  const SmoothedRun smooth(id_run, tc);
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
    check_stop(o);
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
  check_stop(o);
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
  check_stop(o);
  position_relay_test(o.rig, o.seed + 32452843, tc, make_actuator, res.dynamics, p_max, top,
                      stroke_pressures(id_run, smooth));
  check_stop(o);
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
      TrackingRun run = track(o, track_seed, ref.ref_m, v.preview ? lead : 0, false,
                              guard_from(loop.law, loop, ref.pre_roll));
      run.variant = v.name;
      run.reference = ref.name;
      run.description = loop.description;
      run.controller = loop_design(loop, v.preview ? lead : 0, tc, v.preview ? &zv : nullptr);
      run.errors = errors_of(run, ref.score_from, run.t.size());
      run.scored_from_s = ref.score_from < run.t.size() ? run.t[ref.score_from] : 0.0;
      run.saturated = saturated_samples(run, ref.score_from, run.t.size(), p_max);
      run_notes(run, ref.score_from);
      res.runs.push_back(std::move(run));
      if (loop.note)
        if (std::string note = loop.note(); !note.empty()) res.messages.push_back(std::move(note));
      if (v.name == spec.learning_on && o.learning_periods > 0 && ref.period == 0)
        res.messages.push_back(fmt::format("learning ({}) not run: the reference is not periodic, and the learning "
                                           "variant repeats one period (a file reference is periodic where it says "
                                           "so: file:PATH,periodic)",
                                           ref.name));
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

namespace experiment {

bool set_learning_shaper(bool on) { return learning_shaper.exchange(on); }
}  // namespace experiment

}  // namespace hysteron
