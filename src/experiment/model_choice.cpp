// hysteron's model for the compensated variants: the candidate kinds fitted on the
// identification record and the one chosen on a second run (docs/control.md, section 0).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "detail.hpp"
#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"

namespace hysteron::experiment {

namespace {

// The kinds a run tries for hysteron's model: the one asked for, or (auto) the paper's
// kind first, then every other kind in the order of fit_model_kinds.
std::vector<FitModel> candidate_kinds(const ExperimentOptions& o, const Spec& spec) {
  if (o.model != FitModel::automatic) return {o.model};
  std::vector<FitModel> kinds{spec.model};
  for (FitModel k : fit_model_kinds)
    if (k != spec.model) kinds.push_back(k);
  return kinds;
}

}  // namespace

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

namespace {

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

}  // namespace

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

}  // namespace hysteron::experiment
