// Levenberg-Marquardt identification through Ceres (Eqs. 12-16): detail::fit_core, a
// dispatcher over one parametrization object per model kind (kinds.hpp, registry.cpp),
// and the names, options and reports of the fit. The pieces: residuals.cpp,
// layouts.cpp, starts.cpp, lm.cpp, kind_*.cpp (see fit_internal.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include "detail.hpp"
#include "fit_internal.hpp"
#include "hysteron/error.hpp"
#include "kinds.hpp"

namespace hysteron {

namespace {

using fitting::Clock;

FitReport invalid(std::string msg, FitModel kind, Clock::time_point t0) {
  return detail::invalid_report(std::move(msg), kind, t0);
}

}  // namespace

std::string_view fit_model_name(FitModel model) noexcept {
  switch (model) {
    case FitModel::gpi: return "gpi";
    case FitModel::pi: return "pi";
    case FitModel::mpi_deadzone: return "mpi-deadzone";
    case FitModel::mpi_asym: return "mpi-asym";
    case FitModel::preisach: return "preisach";
    case FitModel::kp: return "kp";
    case FitModel::bouc_wen: return "bouc-wen";
    case FitModel::maxwell_slip: return "maxwell-slip";
    case FitModel::rate_pi: return "rate-pi";
    case FitModel::automatic: return "auto";
  }
  return "gpi";
}

FitModel fit_model_from_name(std::string_view name) {
  std::string names;
  for (FitModel m : fit_model_kinds) {
    if (fit_model_name(m) == name) return m;
    names += fmt::format("{}, ", fit_model_name(m));
  }
  if (name == "auto") return FitModel::automatic;
  throw Error(fmt::format("unknown model '{}' (expected {}or auto)", name, names));
}

bool has_model(FitStatus s) noexcept {
  return s == FitStatus::converged || s == FitStatus::no_convergence || s == FitStatus::poor_fit;
}

std::string_view fit_status_name(FitStatus status) noexcept {
  switch (status) {
    case FitStatus::not_run: return "not_run";
    case FitStatus::converged: return "converged";
    case FitStatus::no_convergence: return "no_convergence";
    case FitStatus::failed: return "failed";
    case FitStatus::invalid_input: return "invalid_input";
    case FitStatus::poor_fit: return "poor_fit";
  }
  return "not_run";
}

bool FitOptions::is_valid(std::string* error) const {
  auto fail = [&](std::string msg) {
    if (error) *error = std::move(msg);
    return false;
  };
  if (num_operators < 1 || num_operators > 200) return fail(fmt::format("num_operators must be in 1..200, got {}", num_operators));
  if (num_dead_zones < 0 || num_dead_zones > 50) return fail(fmt::format("num_dead_zones must be in 0..50, got {}", num_dead_zones));
  if (!(huber_delta >= 0) || !std::isfinite(huber_delta)) return fail(fmt::format("huber_delta must be >= 0, got {}", huber_delta));
  if (num_starts < 1 || num_starts > 54) return fail(fmt::format("num_starts must be in 1..54, got {}", num_starts));
  if (max_iterations < 1) return fail(fmt::format("max_iterations must be >= 1, got {}", max_iterations));
  if (stall_iterations < 1 || stall_iterations > 100000)
    return fail(fmt::format("stall_iterations must be in 1..100000, got {}", stall_iterations));
  if (!(stall_tolerance >= 0) || !std::isfinite(stall_tolerance))
    return fail(fmt::format("stall_tolerance must be >= 0, got {}", stall_tolerance));
  if (num_threads < 0 || num_threads > 256) return fail(fmt::format("num_threads must be in 0..256, got {}", num_threads));
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0))
    return fail("tolerances must be >= 0");
  if (!(weight_regularization >= 0) || !std::isfinite(weight_regularization))
    return fail(fmt::format("weight_regularization must be >= 0, got {}", weight_regularization));
  if (!(positivity_margin >= 0 && positivity_margin < 0.1))
    return fail(fmt::format("positivity_margin must be in [0, 0.1), got {}", positivity_margin));
  if (!(min_slope > 0 && min_slope < 1)) return fail(fmt::format("min_slope must be in (0, 1), got {}", min_slope));
  if (!(holdout_fraction >= 0.05 && holdout_fraction <= 0.5))
    return fail(fmt::format("holdout_fraction must be in [0.05, 0.5], got {}", holdout_fraction));
  if (!(sample_time >= 0) || !std::isfinite(sample_time))
    return fail(fmt::format("sample_time must be >= 0 (0: unknown), got {}", sample_time));
  if (!(poor_fit_ratio == 0 || (poor_fit_ratio >= 1 && std::isfinite(poor_fit_ratio))))
    return fail(fmt::format("poor_fit_ratio must be 0 (off) or >= 1, got {}", poor_fit_ratio));
  if (censor_passes < 0 || censor_passes > 10)
    return fail(fmt::format("censor_passes must be within 0..10, got {}", censor_passes));
  return true;
}

FitReport detail::fit_core(std::span<const double> x, std::span<const double> y, const FitOptions& options,
                           bool free_offset) {
  const auto t0 = Clock::now();
  // The starts may run on several threads: the caller's progress callback is called
  // one call at a time (a mutex per fit).
  std::mutex progress_mutex;
  FitOptions o = options;
  if (options.progress)
    o.progress = [&progress_mutex, &f = options.progress](int start, int iteration, double cost) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      f(start, iteration, cost);
    };
  std::string why;
  if (!o.is_valid(&why)) return invalid("invalid options: " + why, o.model, t0);
  IndexRange tr;
  try {
    detail::check_record(x, y, "fit");
    tr = detail::check_range(o.train, x.size(), "fit: train");
  } catch (const Error& e) {
    return invalid(e.what(), o.model, t0);
  }
  const fitting::Parametrization* kind = fitting::find_parametrization(o);
  if (!kind) return invalid(fmt::format("fit: no parametrization for the model {}", fit_model_name(o.model)), o.model, t0);
  const int np = kind->num_parameters(o);
  const std::size_t m = tr.end - tr.begin;
  if (m < 10 * static_cast<std::size_t>(np)) {
    // the largest operator count whose parameters these samples support, if the kind has one
    std::string hint;
    for (int n = o.num_operators - 1; n >= 1 && hint.empty(); --n) {
      FitOptions fewer = o;
      fewer.num_operators = n;
      if (fewer.is_valid(nullptr) && m >= 10 * static_cast<std::size_t>(kind->num_parameters(fewer)))
        hint = fmt::format("; with num_operators = {} (hysteron fit --n {}) it has {} parameters", n, n,
                           kind->num_parameters(fewer));
    }
    return invalid(fmt::format("fit: {} training samples are too few for {} parameters (need at least {}, 10 per "
                               "parameter){}",
                               m, np, 10 * np, hint),
                   o.model, t0);
  }
  fitting::Data d{x, y, tr, o.initial_state, o.huber_delta};
  d.free_offset = free_offset && o.huber_delta == 0.0;
  const fitting::Ranges rg = fitting::ranges_of(d);
  d.xc = 0.5 * (rg.xlo + rg.xhi);
  d.xs = std::max(0.5 * rg.xspan(), std::numeric_limits<double>::min());
  if (!(rg.xspan() > 0)) return invalid("fit: the input is constant over the training range", o.model, t0);
  if (!(rg.yspan() > 0)) return invalid("fit: the output is constant over the training range", o.model, t0);

  FitReport rep;
  rep.model_kind = o.model;
  try {
    kind->fit(d, rg, o, rep);
  } catch (const Error& e) {
    return invalid(e.what(), o.model, t0);
  }
  if (rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence) {
    // The model is identified on the training input range: the inverse saturates there.
    std::visit([&](auto& fitted) { fitted.input_limits = Limits{rg.xlo, rg.xhi}; }, rep.model);
  }
  if (rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence)
    rep.train = evaluate(rep.model, x, y, tr, o.initial_state);
  rep.time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return rep;
}

std::string FitReport::brief_report() const {
  return fmt::format("{} fit: {} after {} iterations ({} starts), cost {:.6g} -> {:.6g}, train rms {:.6g} ({:.3g}% of span), {:.3f} s",
                     fit_model_name(model_kind), fit_status_name(status), iterations, num_starts, initial_cost,
                     final_cost, train.rms, train.rms_percent_span, time_s);
}

std::string FitReport::full_report() const {
  std::string out = brief_report() + "\n";
  if (!message.empty()) out += fmt::format("message: {}\n", message);
  out += fmt::format("{:<10} {:>16} {:>14}\n", "parameter", "value", "std error");
  for (const auto& p : parameters)
    out += fmt::format("{:<10} {:>16.8g} {:>14}\n", p.name, p.value,
                       p.held ? std::string("held") : p.at_bound ? std::string("at bound") : (std::isnan(p.std_error) ? std::string("-") : fmt::format("{:.4g}", p.std_error)));
  if (!covariance_note.empty()) out += fmt::format("note: {}\n", covariance_note);
  out += fmt::format("train: rms {:.6g}  max {:.6g}  mae {:.6g}  rms {:.4g}% of span  r2 {:.6f}  n {}\n", train.rms,
                     train.max, train.mae, train.rms_percent_span, train.r2, train.n);
  return out;
}

}  // namespace hysteron
