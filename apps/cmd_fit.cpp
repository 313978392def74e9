// hysteron fit: identify a model from measured input/output columns.
//
//   hysteron fit --model auto|gpi|pi|mpi-deadzone|mpi-asym|preisach|kp|bouc-wen|maxwell-slip|rate-pi --data D.csv --input COL --output COL
//                [--n N] [--dead-zones J] [--train A:B] [--validate C:D] [--validate-data V.csv ...]
//                [--time-column COL]  (ranges in seconds with a suffix s: --train 0s:20s; both sides
//                                      of a range in the same unit)
//                --out model.json|- [--report fit.json|fit.html] [--json] [--huber DELTA] [--seed S]
//                [--starts K] [--threads T] [--max-iterations M] [--min-slope S] [--relaxed]
//                [--free-weights] [--no-mirror] [--force] [--input-label "Pressure [kPa]"] [--output-label "..."]
//
// --out - prints only the model JSON on stdout (the summary goes to stderr); --json prints
// exactly one JSON document on stdout (the report, as --report FILE.json writes it). The
// report is HTML if its name ends in .html or .htm, else JSON.
//
// Exit codes: 0 converged (model written); 1 error: bad input, bad usage (CLI11 parse
// errors too), unreadable or unwritable files (hysteron::Error); 2 no_convergence or
// failed (model not written unless --force); 3 poor_fit (the model is useless or worse
// than the reference PI; not written unless --force); 4 internal error.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

namespace hysteron::cli {

namespace {

struct FitCliOptions {
  std::string model = "gpi", train, validate, out, report;
  DataSelection sel;
  std::vector<std::string> validate_data;
  int n = 10, dead_zones = 4, starts = 2, threads = 0, max_iterations = 200, censor_passes = FitOptions{}.censor_passes;
  double huber = 0.0, min_slope = FitOptions{}.min_slope, sample_time = 0.0;
  unsigned seed = 0;
  bool json = false, relaxed = false, force = false, free_weights = false, no_mirror = false;
};

std::vector<std::string> model_names() {
  std::vector<std::string> names;
  names.emplace_back(fit_model_name(FitModel::automatic));
  for (FitModel m : fit_model_kinds) names.emplace_back(fit_model_name(m));
  return names;
}

std::string join(const std::vector<std::string>& v, std::string_view sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? std::string(sep) : "") + v[i];
  return s;
}

std::string metrics_text(std::string_view name, const FitMetrics& m) {
  return fmt::format("{:<9} rms {:.6g}  max {:.6g}  mae {:.6g}  rms {:.4g}% of span  r2 {:.6f}  ({} samples)", name,
                     m.rms, m.max, m.mae, m.rms_percent_span, m.r2, m.n);
}

std::string rms_cell(const std::optional<FitMetrics>& m) {
  return m && std::isfinite(m->rms) ? fmt::format("{:.6g}", m->rms) : "-";
}

// One validation set: its record (a range of the fit's record when x is empty).
struct ValidationSet {
  std::string file;  // "" = the fit's record
  std::vector<double> x, y, t;
  IndexRange range;
};

int run_fit(const FitCliOptions& c) {
  // an output naming stdout (-, /dev/stdout, the file stdout is redirected to) is handled as - is
  const bool out_stdout = names_stdout(c.out), report_stdout = names_stdout(c.report);
  if (out_stdout && c.json)
    throw Error(fmt::format("--out {} and --json both write to standard output: choose one (e.g. --json with --out "
                            "FILE, or --out - with --report FILE.json)",
                            c.out));
  if (report_stdout && (out_stdout || c.json))
    throw Error(fmt::format("--report {} and --out {} / --json would both write to standard output: choose one",
                            c.report, c.out.empty() ? std::string("FILE") : c.out));
  {
    std::vector<io::NamedPath> inputs{{"--data", c.sel.file}};
    for (const auto& f : c.validate_data) inputs.push_back({"--validate-data", f});
    io::check_output_files({{"--out", c.out}, {"--report", c.report}}, inputs);
  }
  const DataSelection& sel = c.sel;
  const DataColumns rec = read_data_columns(c.sel.file, sel);
  const std::vector<double>& x = rec.x;
  const std::vector<double>& y = rec.y;
  const std::optional<std::vector<double>>& time = rec.t;
  FitOptions o;
  o.model = fit_model_from_name(c.model);
  o.num_operators = c.n;
  o.num_dead_zones = c.dead_zones;
  o.num_starts = c.starts;
  o.num_threads = c.threads;
  o.max_iterations = c.max_iterations;
  o.min_slope = c.min_slope;
  o.huber_delta = c.huber;
  o.seed = c.seed;
  o.initial_state = c.relaxed ? InitialState::relaxed : InitialState::virgin;
  o.gpi_free_weights = c.free_weights;
  o.mpi_asym_mirror = !c.no_mirror;
  o.sample_time = c.sample_time;
  o.censor_passes = c.censor_passes;
  std::vector<std::string> time_warnings;
  const bool rate = o.model == FitModel::rate_pi || o.model == FitModel::automatic;
  // both given: they must agree (--sample-time silently overrode a column of another step)
  check_sample_time_agrees(o.sample_time, time ? &*time : nullptr, c.sel.file, c.sel.time_column);
  if (rate && time && time->size() > 1) {
    // rate-pi: the mean step of the time column, which must increase and should be uniform.
    // auto: only its rate-pi candidate needs it; a column that cannot give it leaves that
    // candidate unfitted (no sample time), with the reason as a warning, instead of refusing the fit.
    // With --sample-time (which agrees with the column's mean step) the column's faults are warnings.
    const bool given = o.sample_time > 0.0;
    try {
      if (std::string w = require_increasing_time(*time, c.sel.file, c.sel.time_column,
                                                  "rate-pi's sample time (or give --sample-time)");
          !w.empty())
        time_warnings.push_back(std::move(w));
      if (std::string w = uniform_time_warning(*time, c.sel.file, c.sel.time_column); !w.empty())
        time_warnings.push_back(std::move(w));
      if (!given) o.sample_time = mean_time_step(*time);
    } catch (const Error& e) {
      if (given)
        time_warnings.push_back(fmt::format("{}: --sample-time {} s is used", e.what(), o.sample_time));
      else if (o.model != FitModel::automatic)
        throw;
      else
        time_warnings.push_back(fmt::format("{}: auto's rate-pi candidate is not fitted", e.what()));
    }
  }
  // Another kind does not run on the time column, but the document records it (hysteron report draws
  // the time axis from it, and `report --data` refuses one that goes backwards): a stamp that goes
  // backwards (concatenated runs, a logger's glitch) is said here, naming the row (review of 2026-12-01)
  std::string axis_warning;
  if (!rate && time && time->size() > 1) try {
      (void)require_increasing_time(*time, c.sel.file, c.sel.time_column, "a time axis", true);
    } catch (const Error& e) {
      axis_warning = fmt::format("{}: the fit does not use it, but its report's time axis does (where the column "
                                 "is no time, leave out --time-column; hysteron report --no-time draws a report "
                                 "without it)",
                                 e.what());
    }
  // rate-pi's dt is in seconds: a record sampled slower than 10 Hz or at 1 MHz or faster is rare for it, a time
  // column in another unit (or a wrong --time-unit) common; 1 us within the 1 % tolerance: a 1 kHz column in s read
  // as ms gives 1 us give or take the stamps' rounding
  if (rate && o.sample_time > 0.0 && (o.sample_time > 0.1 || o.sample_time <= 1e-6 * (1 + kSampleTimeTolerance)))
    time_warnings.push_back(fmt::format(
        "{}: rate-pi's sample time is {:.6g} s ({}), {}: is the time column in {}? {} (--sample-time and the model's "
        "dt are in seconds)",
        c.sel.file, o.sample_time,
        c.sample_time > 0 ? std::string("--sample-time")
                          : fmt::format("the mean step of the time column {} in {}", c.sel.time_column,
                                        rec.time_unit),
        o.sample_time > 0.1 ? "above 0.1 s" : "1 us or below",
        o.sample_time > 0.1 ? (rec.time_unit == "s" ? "ms" : "another unit") : "s or another unit",
        c.sample_time == 0 && rec.time_unit_from_file
            ? fmt::format("the file gives it the unit {}: correct its header or units row if that is wrong",
                          rec.time_unit)
            : std::string("see --time-unit")));
  // a range in seconds looks its ends up in the time column: it must not go backwards
  const auto in_seconds = [](const std::string& r) { return r.find('s') != std::string::npos; };
  if (time && (in_seconds(c.train) || (c.validate_data.empty() && in_seconds(c.validate))))
    (void)require_increasing_time(*time, c.sel.file, c.sel.time_column, "a range in seconds", true);
  const IndexRange train =
      c.train.empty() ? IndexRange{0, x.size()} : parse_range(c.train, "--train", time ? &*time : nullptr, x.size());
  o.train = train;
  std::string why;
  if (!o.is_valid(&why)) throw Error(fmt::format("fit options: {}", why));

  // validation sets: each --validate-data file (range --validate of each), or a range of this record
  std::vector<ValidationSet> sets;
  for (const auto& file : c.validate_data) {
    ValidationSet v;
    v.file = file;
    DataColumns d = read_data_columns(file, sel);
    check_units_agree({rec.input_unit, rec.output_unit}, fmt::format("the training record {}", c.sel.file), d, sel,
                      file);
    v.x = std::move(d.x);
    v.y = std::move(d.y);
    if (d.t) v.t = std::move(*d.t);
    if (d.t && in_seconds(c.validate))
      (void)require_increasing_time(v.t, file, c.sel.time_column, "a range in seconds", true);
    v.range = c.validate.empty() ? IndexRange{0, v.x.size()}
                                 : parse_range(c.validate, fmt::format("--validate (on {})", file),
                                               time ? &v.t : nullptr, v.x.size());
    sets.push_back(std::move(v));
  }
  if (c.validate_data.empty()) {
    if (!c.validate.empty())
      sets.push_back({"", {}, {}, {}, parse_range(c.validate, "--validate", time ? &*time : nullptr, x.size())});
    else if (train.end < x.size())
      sets.push_back({"", {}, {}, {}, IndexRange{train.end, x.size()}});
  }

  // auto's candidates fit silently (a minute on 1e5 samples): say how many have ended, on a terminal in one line
  // rewritten, off one (a log, a pipe) one line as each ends, so that a long auto fit is seen to move
  const bool terminal = isatty(fileno(stderr));
  if (terminal)
    o.progress = [](int start, int it, double cost) {
      fmt::print(stderr, "\rstart {} iteration {:3d} cost {:.6g}   ", start, it, cost);
    };
  if (o.model == FitModel::automatic) {
    fmt::print(stderr, "auto: fitting every kind on two hold-out folds\n");
    o.candidate_done = [terminal](std::size_t done, std::size_t total, FitModel kind) {
      fmt::print(stderr, "{}auto: {} of {} candidate fits done (the last: {}){}", terminal ? "\r" : "", done, total,
                 fit_model_name(kind), terminal ? "        " : "\n");
      std::fflush(stderr);
    };
  }
  FitReport rep = fit(x, y, o);
  // the time column's warnings concern rate-pi only: where it is the kind fitted (or auto chose it),
  // or where auto's rate-pi candidate could not be fitted because of them
  if (has_model(rep.status) && (rep.model_kind == FitModel::rate_pi || (o.model == FitModel::automatic &&
                                                                        o.sample_time == 0.0)))
    rep.warnings.insert(rep.warnings.end(), time_warnings.begin(), time_warnings.end());
  if (!axis_warning.empty()) rep.warnings.push_back(std::move(axis_warning));
  // the stretch the sensor-fault advice names in samples, in seconds where --train was (the time column increases)
  if (rep.fault_free_train && time && in_seconds(c.train)) {
    const IndexRange f = *rep.fault_free_train;
    const std::optional<std::string> s = seconds_range(*time, f);
    rep.warnings.push_back(s ? fmt::format("the sensor faults' --train {}:{} above, in seconds: --train {}", f.begin,
                                           f.end, *s)
                             : fmt::format("the sensor faults' --train {}:{} above has no range in seconds (the "
                                           "time column repeats a stamp at one of its ends): give it in samples",
                                           f.begin, f.end));
  }
  if (o.progress) fmt::print(stderr, "\r{:80}\r", "");
  if (rep.status == FitStatus::invalid_input) throw Error(fmt::format("{}: {}", c.sel.file, rep.message));

  // A validation record that clips is scored as censored, as the fit treats its own record
  // (--censor-passes 0: as recorded); `censored` receives the count. The documents and the
  // HTML report say and do the same (data.censored, FitData::censor_clipped).
  const bool censor = o.censor_passes > 0;
  // a validation set's record: its file's, or (a range of) the fit's
  const auto input_of = [&](const ValidationSet& v) { return std::span<const double>(v.file.empty() ? x : v.x); };
  const auto output_of = [&](const ValidationSet& v) { return std::span<const double>(v.file.empty() ? y : v.y); };
  // nullopt where the model cannot be run on the set (an input beyond its bound): *error says why
  auto evaluate_on = [&](const ModelParams& m, const ValidationSet& v, std::size_t* censored = nullptr,
                         std::string* error = nullptr) -> std::optional<FitMetrics> {
    try {
      return evaluate_scored(m, input_of(v), output_of(v), v.range, o.initial_state, censor, censored);
    } catch (const Error& e) {
      if (error) *error = e.what();
      return std::nullopt;
    }
  };

  io::FitDocument doc;
  doc.fit = rep;
  doc.data = describe_data(sel, rec, o.initial_state, train);
  doc.data.censored = censor;
  const bool fitted = has_model(rep.status);
  // validation sets the model does not describe (validation_useless: worse than their mean, R^2 <= 0,
  // and more than twice the training RMS error): the fit exits exit_poor_fit
  // Sets the model cannot be run on (an input sample beyond its bound) count as useless too: a
  // validation asked for is never left out (listed with its error, exit_poor_fit).
  std::vector<std::string> useless, unrun;
  // a training input that reverses fewer than twice (fit() warns: validate on a record with loops): whether each
  // validation record has them
  const std::size_t train_turns = input_reversals(x, train);
  const auto turns_text = [](std::size_t n) { return n == 0 ? "never reverses" : "reverses once"; };
  if (fitted)
    for (const auto& v : sets) {
      std::size_t censored = 0;
      std::string error;
      const auto m = evaluate_on(rep.model, v, &censored, &error);
      const InputCoverage cov = input_coverage(rep.model, input_of(v), v.range);
      const std::string what = v.file.empty() ? "validation range" : v.file;
      if (!m) {
        io::Evaluation e{v.file, v.range, {}, 0, cov.outside, {}};
        e.metrics.rms = e.metrics.max = e.metrics.mae = e.metrics.rms_percent_span = e.metrics.r2 = std::nan("");
        e.error = error;
        doc.validation.push_back(std::move(e));
        unrun.push_back(fmt::format("{} (samples {}..{})", v.file.empty() ? c.sel.file : v.file, v.range.begin,
                                    v.range.end));
        std::string w = fmt::format("{}: the model cannot be run on this validation record ({}): it is not scored "
                                    "and counts as a useless validation",
                                    what, error);
        rep.warnings.push_back(w);
        doc.fit.warnings.push_back(std::move(w));
        continue;
      }
      const OutputMap map = output_map(rep.model, input_of(v), output_of(v), v.range, o.initial_state, censor);
      doc.validation.push_back({v.file, v.range, *m, censored, cov.outside, map});
      // a validation record beyond the training range scores the model's extrapolation; one whose output
      // differs by a sign, a unit or a zero scores that, one the model does not describe is said so
      // (against the training R^2); another file sampled otherwise runs rate-pi's rates wrong (as
      // evaluate says)
      // (an input in another zero or unit is named as such; a narrow stretch is useless only where a
      // sign, unit or zero explains it: diagnose_record)
      RecordDiagnosis dg = diagnose_record(rep.model, input_of(v), output_of(v), v.range, o.initial_state, censor, map,
                                           rep.train, cov.span_share, what);
      if (validation_useless(*m, rep.train, cov.span_share, dg.map_named))
        useless.push_back(fmt::format("{} (samples {}..{}: R^2 {:.4g}, RMS {:.4g}, {:.4g} % of span)",
                                      v.file.empty() ? c.sel.file : v.file, v.range.begin, v.range.end, m->r2,
                                      m->rms, m->rms_percent_span));
      std::vector<std::string> ws = {input_coverage_warning(cov, what), std::move(dg.warning),
                                     std::move(dg.sensor_warning), std::move(dg.input_sensor_warning),
                                     std::move(dg.outlier_warning)};
      if (train_turns < 2) {
        const std::size_t turns = input_reversals(input_of(v), v.range);
        ws.push_back(turns < 2 ? fmt::format("{}: its input {} (by more than 10 % of its span there), as the training "
                                             "input {}: it does not score the inner loops the fit extrapolates; "
                                             "validate on a record with loops",
                                             what, turns_text(turns), turns_text(train_turns))
                               : fmt::format("{}: its input reverses {} times (by more than 10 % of its span there): "
                                             "it scores the loops the training input did not hold",
                                             what, turns));
      }
      if (!v.file.empty()) {
        auto rw = rate_time_warnings(rep.model, v.t.empty() ? nullptr : &v.t, v.t.empty() ? o.sample_time : 0.0,
                                     v.file, c.sel.time_column);
        ws.insert(ws.end(), rw.begin(), rw.end());
      }
      for (std::string& w : ws)
        if (!w.empty()) {
          rep.warnings.push_back(w);
          doc.fit.warnings.push_back(std::move(w));
        }
    }
  // A converged fit whose validation is useless (R^2 <= 0: worse than the validation output's mean)
  // must not exit as a success: exit_poor_fit, as poor_fit, naming the sets; the status stays
  // converged and the model is written as for any converged fit (its training fit is good).
  const auto named = [](const std::vector<std::string>& list) {
    std::string out;
    for (const auto& u : list) out += (out.empty() ? "" : " and ") + u;
    return out;
  };
  if (!useless.empty() || !unrun.empty()) {
    std::string because;
    if (!useless.empty())
      because = fmt::format("the model predicts {} worse than its mean (R^2 <= 0) and with more than {:g} times its "
                        "training RMS error ({:.4g}; training R^2 {:.4g})",
                        named(useless), kValidationRmsFactor, rep.train.rms, rep.train.r2);
    if (!unrun.empty())
      because += fmt::format("{}the model cannot be run on {}", because.empty() ? "" : "; ", named(unrun));
    std::string w = fmt::format("the validation is useless: {}{}", because,
                                rep.status == FitStatus::converged
                                    ? fmt::format(": the fit exits {} (the model is written: its training fit converged)",
                                                  exit_poor_fit)
                                    : std::string());
    rep.warnings.push_back(w);
    doc.fit.warnings.push_back(std::move(w));
  }
  if (!sets.empty())
    for (const auto& cand : rep.candidates) {
      std::vector<FitMetrics> row;
      for (const auto& v : sets) {
        const auto m = has_model(cand.status) ? evaluate_on(cand.model, v) : std::nullopt;
        FitMetrics none;
        none.rms = none.max = none.mae = none.rms_percent_span = none.r2 = std::nan("");
        row.push_back(m.value_or(none));
      }
      doc.candidate_validation.push_back(std::move(row));
    }

  const bool write = rep.status == FitStatus::converged || (fitted && c.force);
  // the model and the report replaced together, once both are complete: a Ctrl-C or a gnuplot
  // failure while the report is made leaves the old pair, never a new model beside an old report
  io::FileBatch batch;
  if (write) {
    const std::string note = o.model == FitModel::automatic
                                 ? fmt::format("hysteron fit --model auto (chose {}) on {}",
                                               fit_model_name(rep.model_kind), c.sel.file)
                                 : fmt::format("hysteron fit --model {} on {}", c.model, c.sel.file);
    nlohmann::json extra{{"note", note}};
    // the units the record's columns or --input-label / --output-label name: evaluate checks a record against them
    if (!doc.data.input_unit.empty()) extra["units"]["input"] = doc.data.input_unit;
    if (!doc.data.output_unit.empty()) extra["units"]["output"] = doc.data.output_unit;
    // the training error in the output's units: evaluate compares a record's with it
    if (nlohmann::json t = io::training_json(rep.train); !t.is_null()) extra["training"] = std::move(t);
    io::write_model_file(c.out, rep.model, extra);
  }
  doc.model_written = write;
  doc.model_file = write ? c.out : std::string();

  if (!c.report.empty()) {
    if (is_html_path(c.report)) {
      report::FitData data = plot_data(sel, rec, o.initial_state, train);
      for (const auto& v : sets) data.validation.push_back({v.file, v.x, v.y, v.t, v.range});
      data.censor_clipped = censor;
      report::write_fit_report(rep, data, c.report, command_line());
    } else {
      io::write_text_file(c.report, io::to_json(doc).dump(2) + "\n");
    }
  }
  batch.commit();

  int code = rep.status == FitStatus::converged  ? exit_ok
             : rep.status == FitStatus::poor_fit ? exit_poor_fit
                                                 : exit_not_converged;
  if ((!useless.empty() || !unrun.empty()) && code == exit_ok) code = exit_poor_fit;
  if (c.json) {
    fmt::print("{}\n", io::to_json(doc).dump(2));
    return code;
  }
  // the text report: on stdout, or on stderr when stdout carries the model (--out -)
  std::string text = rep.full_report();
  if (!text.empty() && text.back() != '\n') text += '\n';
  const std::string xu = doc.data.input_unit.empty() ? "input units" : doc.data.input_unit;
  const std::string yu = doc.data.output_unit.empty() ? "output unit" : doc.data.output_unit;
  if (fitted) {
    text += fmt::format("reference PI: rms {:.6g}  ({:.4g}% of span) on the training range; the fit's rms {:.6g}\n",
                        rep.reference.rms, rep.reference.rms_percent_span, rep.train.rms);
    if (std::isfinite(rep.inverse.max_slope))
      text += fmt::format("inverse: max slope {:.6g} {} per {}; max jump per sample {:.6g} (measured input: max step "
                          "{:.6g}){}\n",
                          rep.inverse.max_slope, xu, yu, rep.inverse.max_jump, rep.inverse.max_input_step,
                          rep.inverse.increasing ? "" : "; the model is decreasing");
    else  // no inverse: no slope or jump of it to give (they were printed as inf)
      text += fmt::format("inverse: none ({}){}\n", rep.inverse.no_inverse,
                          rep.inverse.increasing ? "" : "; the model is decreasing");
  }
  for (const auto& w : rep.warnings) text += fmt::format("warning: {}\n", w);
  if (!rep.candidates.empty()) {
    // a row's status, params, train and validate RMS are its fold-0 fit's (on the training range without its last
    // part), not the chosen kind's refit on the whole range: the table says so, and where the refit's figures are
    const IndexRange f0 = rep.candidates.front().fit_range, tr = train.resolved(x.size());
    const bool chosen = std::any_of(rep.candidates.begin(), rep.candidates.end(), [](const auto& k) { return k.chosen; });
    text += fmt::format(
        "candidates (chosen by the hold-out score: over the first and the last {:.0f} % of the training range, the "
        "geometric mean of the RMS over the best kind's; within 2 % of the least score, the fewest parameters).\n"
        "  Each row is the kind's fold-0 fit, trained on samples {}..{} (the training range without its last part): "
        "its \"(fold 0)\" columns are that fit's{}.\n",
        100 * o.holdout_fraction, f0.begin, f0.end,
        chosen ? fmt::format(", not the chosen kind's refit on the whole training range (samples {}..{}), whose "
                             "figures are the train line above and the validate lines below",
                             tr.begin, tr.end)
               : std::string());
    std::string head = fmt::format("  {:<13} {:<15} {:>6} {:>18} {:>12} {:>9}", "kind", "status (fold 0)", "params",
                                   "train RMS (fold 0)", "hold-out RMS", "score");
    for (std::size_t k = 0; k < sets.size(); ++k) head += fmt::format(" {:>21}", "validate RMS (fold 0)");
    text += head + fmt::format(" {:>9}\n", "time [s]");
    for (std::size_t i = 0; i < rep.candidates.size(); ++i) {
      const auto& cand = rep.candidates[i];
      const auto cell = [](double v, const char* f) { return std::isfinite(v) ? fmt::format(fmt::runtime(f), v) : "-"; };
      std::string line = fmt::format("  {:<13} {:<15} {:>6} {:>18} {:>12} {:>9}", fit_model_name(cand.kind),
                                     fit_status_name(cand.status),
                                     cand.num_parameters ? std::to_string(cand.num_parameters) : "-",
                                     cell(cand.train.rms, "{:.6g}"),
                                     cell(cand.holdout.rms, "{:.6g}"), cell(cand.holdout_score, "{:.4g}"));
      for (std::size_t k = 0; k < sets.size(); ++k) {
        const bool ok = i < doc.candidate_validation.size() && k < doc.candidate_validation[i].size();
        line += fmt::format(" {:>21}", ok ? rms_cell(doc.candidate_validation[i][k]) : "-");
      }
      text += line + fmt::format(" {:>9.3f}{}\n", cand.time_s, cand.chosen ? "  <- chosen" : "");
    }
    if (sets.size() > 1) {
      text += "  validate RMS columns:";
      for (const auto& v : sets) text += " " + (v.file.empty() ? std::string("this record") : v.file);
      text += "\n";
    }
  }
  for (const auto& e : doc.validation)
    text += (e.error.empty() ? metrics_text("validate:", e.metrics) : fmt::format("validate: not scored: {}", e.error)) +
            fmt::format("  [{}, samples {}..{}{}]\n", e.file.empty() ? c.sel.file : e.file, e.range.begin, e.range.end,
                        e.censored > 0 ? fmt::format("; the output clips: {} samples at its limit where the model "
                                                     "predicts beyond it scored as censored, no error "
                                                     "(--censor-passes 0: as recorded)",
                                                     e.censored)
                                       : std::string());
  if (write && !out_stdout)
    text += fmt::format("model written to {}\n", c.out);
  else if (!write)
    text += fmt::format("model NOT written ({}{})\n", fit_status_name(rep.status),
                        fitted ? "; use --force to write it anyway" : "");
  if (!c.report.empty() && !report_stdout) text += fmt::format("report written to {}\n", c.report);
  std::fputs(text.c_str(), out_stdout || report_stdout ? stderr : stdout);
  return code;
}

}  // namespace

void add_fit(CLI::App& app, Action& action) {
  auto c = std::make_shared<FitCliOptions>();
  CLI::App* sub = app.add_subcommand("fit", "identify a hysteresis model from measured input/output data");
  const std::vector<std::string> names = model_names();
  sub->add_option("--model,-m", c->model,
                  fmt::format("{} (auto: fit every kind, choose by the hold-out score; default gpi)", join(names, " | ")))
      ->check(one_of(names));
  add_data_options(sub, c->sel);
  // the ranges FitOptions::is_valid checks, said before the fit (10.5: CLI11's "Could not convert" otherwise)
  sub->add_option("--n", c->n, "number of operators, an integer in 1..200 (default 10)")
      ->check(non_negative_integer(200, 1));
  sub->add_option("--dead-zones", c->dead_zones, "mpi-deadzone: number of dead zones, an integer in 0..50 (default 4)")
      ->check(non_negative_integer(50));
  sub->add_option("--train", c->train, "training range A:B (sample indices, half-open) or As:Bs (seconds)");
  sub->add_option("--validate", c->validate,
                  "validation range C:D (sample indices, half-open) or Cs:Ds (seconds), of each --validate-data file "
                  "if given (default: the whole file; without --validate-data, the samples after --train, if any)");
  sub->add_option("--validate-data", c->validate_data, "other records (same columns) to validate on (repeatable)");
  sub->add_option("--out,-o", c->out, "model file to write (JSON); - prints the model JSON on stdout")->required();
  sub->add_option("--report", c->report, "also write the report: HTML if the name ends in .html/.htm, else JSON");
  sub->add_flag("--json", c->json, "print the report as one JSON document");
  sub->add_option("--huber", c->huber, "Huber loss threshold in output units (default: least squares)");
  sub->add_option("--seed", c->seed, "seed of the jitter of the initial guesses, an integer in 0..4294967295 (default 0: none)")
      ->check(non_negative_integer(std::numeric_limits<unsigned>::max()));
  sub->add_option("--starts", c->starts, "number of initial guesses refined by LM, an integer in 1..54 (default 2)")
      ->check(non_negative_integer(54, 1));
  sub->add_option("--threads", c->threads,
                  "threads refining the starts concurrently (default 0: one per usable CPU: the affinity mask "
                  "within the cgroups' CPU quota; fewer on a long record so that the concurrent starts hold at "
                  "most about 512 MB; 1: sequential; the result does not depend on it)");
  sub->add_option("--max-iterations", c->max_iterations, "LM iterations per start (default 200)");
  sub->add_option("--min-slope", c->min_slope,
                  fmt::format("minimum slope of the model relative to span(y)/span(x), bounds the inverse's slope "
                              "(default {})", FitOptions{}.min_slope));
  sub->add_option("--sample-time", c->sample_time,
                  "rate-pi: sample time of the record in s (default: the mean step of --time-column)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--censor-passes", c->censor_passes,
                  fmt::format("an output that clips (a sensor's limit, detected from the record) is fitted as censored "
                              "data: the samples at the limit where the model predicts beyond it count as no error, "
                              "over this many refits (default {}; 0: fitted to the limit as recorded)",
                              FitOptions{}.censor_passes))
      ->check(CLI::Range(0, 10));
  sub->add_flag("--relaxed", c->relaxed, "start from rest at the first sample instead of the virgin state");
  sub->add_flag("--free-weights", c->free_weights,
                "gpi: the free-weight variant (tanh envelope, q and n free weights) instead of Eq. 8's exponential law");
  sub->add_flag("--no-mirror", c->no_mirror,
                "mpi-asym: fit the input as recorded only (by default the mirrored input is fitted too and the "
                "orientation with the lower training cost kept)");
  sub->add_flag("--force", c->force, "write the model even if the fit did not converge or is a poor fit");
  sub->callback([c, &action] { action = [c] { return run_fit(*c); }; });
}

}  // namespace hysteron::cli
