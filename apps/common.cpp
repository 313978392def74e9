// Helpers shared by the subcommands (see commands.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <iostream>
#include <iterator>
#include <string>
#include <tuple>

#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/names.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/io/numbers.hpp"

namespace hysteron::cli {

namespace {

double parse_number(std::string_view s, std::string_view what) {
  const std::optional<double> v = io::finite_number(s);
  if (!v) throw Error(fmt::format("{}: \"{}\" is not a number", what, s));
  return *v;
}

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

}  // namespace

ModelUnits model_units(const io::ModelDocument& doc) { return {doc.unit("input"), doc.unit("output")}; }

namespace {
// A record's column and a model (or the training record) naming two different units of one kind.
// Two unit texts that name different known units (free text, or the same unit, does not).
bool units_differ(std::string_view a, std::string_view b) {
  const std::string ca = io::canonical_unit(a), cb = io::canonical_unit(b);
  return !ca.empty() && !cb.empty() && ca != cb;
}

void refuse_other_units(const std::string& file, std::string_view column_what, const std::string& column,
                        const std::string& in_file, const std::string& source, std::string_view what,
                        const std::string& in_source) {
  if (!units_differ(in_file, in_source)) return;
  throw Error(fmt::format("{}: the {}column {} is in {}, but {}'s {} is in {}: every value would be off by the ratio "
                          "of the two units; convert one of them",
                          file, column_what, column, in_file, source, what, in_source));
}
}  // namespace

void check_units_agree(const ModelUnits& units, const std::string& source, const DataColumns& rec,
                       const DataSelection& sel, const std::string& file) {
  refuse_other_units(file, "input ", sel.input, rec.input_unit, source, "input", units.input);
  refuse_other_units(file, "output ", sel.output, rec.output_unit, source, "output", units.output);
}

void check_column_unit(const io::NamedColumn& c, const std::string& file, const io::ReadOptions& options,
                       const std::string& model_unit, const std::string& model_file, std::string_view what) {
  refuse_other_units(file, "", c.name.empty() ? options.column_spec : c.name, c.unit,
                     fmt::format("the model {}", model_file == "-" ? std::string("<stdin>") : model_file), what,
                     model_unit);
}

namespace {
double parse_limit(std::string_view s, std::string_view what) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  const std::optional<double> v = io::finite_number(s);
  if (!v)
    throw Error(fmt::format("--limits: {} \"{}\" is not a finite number (expected LO,HI, e.g. --limits=0,0.6)", what, s));
  return *v;
}

}  // namespace

Limits parse_limits(const std::string& text) {
  const auto comma = text.find(',');
  if (comma == std::string::npos)
    throw Error(fmt::format("--limits: expected LO,HI (e.g. --limits=0,0.6), got \"{}\"", text));
  Limits l;
  l.lo = parse_limit(std::string_view(text).substr(0, comma), "LO");
  l.hi = parse_limit(std::string_view(text).substr(comma + 1), "HI");
  if (!(l.lo < l.hi)) throw Error(fmt::format("--limits: LO = {} must be < HI = {}", l.lo, l.hi));
  return l;
}

void warn_limits_beyond_model(const ModelParams& params, const Limits& limits, std::string_view command,
                              std::string_view input_unit) {
  const Limits& m = input_limits(params);
  if (!m.bounded()) return;
  const std::string in = input_unit.empty() ? std::string() : fmt::format(" (the model's input is in {})", input_unit);
  // the part of --limits inside the model's range; none (limits in another unit, e.g. 0,0.6 MPa on a
  // model in kPa fitted on 8..626) is refused by the library's Inverse itself (InverseOptions)
  const double lo = std::max(limits.lo, m.lo), hi = std::min(limits.hi, m.hi);
  if (!(lo < hi)) return;
  const double tol = kInputCoverageTolerance * (m.hi - m.lo);
  const double below = m.lo - limits.lo, above = limits.hi - m.hi;
  if (!(below > tol) && !(above > tol)) return;
  if (hi - lo < 0.5 * (limits.hi - limits.lo)) {
    fmt::print(stderr,
               "{}: warning: most of --limits [{:.6g}, {:.6g}] lie outside the model's input_limits [{:.6g}, {:.6g}]{} "
               "(fit() sets them to its training range): only [{:.6g}, {:.6g}] is within them, and the inverse may "
               "command inputs beyond, where the model extrapolates; are --limits in the model's input unit?\n",
               command, limits.lo, limits.hi, m.lo, m.hi, in, lo, hi);
    return;
  }
  fmt::print(stderr,
             "{}: warning: --limits [{:.6g}, {:.6g}] reach beyond the model's input_limits [{:.6g}, {:.6g}] (fit() sets "
             "them to its training range) by up to {:.6g}: the inverse may command inputs there, where the model "
             "extrapolates; fit on a record that covers them, or keep --limits within them\n",
             command, limits.lo, limits.hi, m.lo, m.hi, std::max(below, above));
}

CLI::Validator non_negative_integer(std::uint64_t max, std::uint64_t min) {
  return CLI::Validator(
      [max, min](std::string& text) -> std::string {
        std::uint64_t v = 0;
        const bool digits = !text.empty() &&
                            std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
        const bool ok = digits && ec == std::errc() && end == text.data() + text.size() && v >= min && v <= max;
        return ok ? std::string() : fmt::format("{} is not an integer in {}..{}", text, min, max);
      },
      "");
}

CLI::Validator one_of(std::vector<std::string> names) {
  std::string set;
  for (const auto& n : names) set += (set.empty() ? "" : ",") + n;
  set = "{" + set + "}";
  return CLI::Validator(
      [names = std::move(names), set](std::string& text) -> std::string {
        if (std::find(names.begin(), names.end(), text) != names.end()) return std::string();
        const std::string_view hint = io::closest_name(text, names);
        return fmt::format("{} not in {}{}", text, set, hint.empty() ? "" : fmt::format(" (did you mean {}?)", hint));
      },
      set);
}

void check_float_options(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) check_float_options(*sub);
  for (CLI::Option* opt : app.get_options([](const CLI::Option* o) { return o->get_type_name() == "FLOAT"; }))
    opt->check(CLI::Validator(
        [](std::string& text) -> std::string {
          return io::finite_number(text) ? std::string() : fmt::format("{} is not a finite decimal number", text);
        },
        ""));
}

void add_control_period_option(CLI::App* cmd, double& period) {
  cmd->add_option("--control-period", period,
                  "The controller's sample time [s], also the logging period (default 0.001): within "
                  "[rig dt, 0.01] and a whole number of the rig's time steps (dt 1e-4 s by default); every "
                  "gain, lead and filter is derived at this period (an experiment's result.json \"controller\" "
                  "and a sweep's JSON record it; docs/control.md)");
}

IndexRange parse_range(const std::string& text, std::string_view opt, const std::vector<double>* time, std::size_t n) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw Error(fmt::format("{}: expected A:B (sample indices) or As:Bs (seconds), got \"{}\"", opt, text));
  const std::string_view a = std::string_view(text).substr(0, colon), b = std::string_view(text).substr(colon + 1);
  const bool a_s = !a.empty() && a.back() == 's', b_s = !b.empty() && b.back() == 's';
  if (!a.empty() && !b.empty() && a_s != b_s)
    throw Error(fmt::format("{}: \"{}\" mixes seconds and sample indices; write both sides in seconds (As:Bs) or "
                            "both as sample indices (A:B)", opt, text));
  IndexRange r{0, n};
  auto side = [&](std::string_view s, bool is_end) {
    if (s.empty()) return;
    std::size_t idx = 0;
    if (s.back() == 's') {
      if (!time) throw Error(fmt::format("{}: a range in seconds (\"{}\") needs --time-column", opt, text));
      if (time->empty()) throw Error(fmt::format("{}: the time column is empty", opt));
      const double t = parse_number(s.substr(0, s.size() - 1), opt);
      // the range is half-open: its end may lie up to one sample step past the last stamp (a
      // record of 20 s at 1 kHz ends at 19.999 s, and 12s:20s takes it to its end)
      const std::size_t m = time->size();
      const double step = m >= 2 ? time->back() - (*time)[m - 2] : 0.0;
      const double last = is_end && step > 0 ? time->back() + step : time->back();
      if (t < time->front() || t > last)
        throw Error(fmt::format("{}: time {} s is outside the record ({} s .. {} s)", opt, t, time->front(),
                                time->back()));
      idx = static_cast<std::size_t>(std::lower_bound(time->begin(), time->end(), t) - time->begin());
    } else {
      const double v = parse_number(s, opt);
      if (v < 0 || v != std::floor(v)) throw Error(fmt::format("{}: \"{}\" is not a sample index", opt, s));
      idx = static_cast<std::size_t>(v);
    }
    (is_end ? r.end : r.begin) = idx;
  };
  side(a, false);
  side(b, true);
  if (r.end > n || r.begin >= r.end)
    throw Error(fmt::format("{}: range [{}, {}) is empty or outside the data ({} samples)", opt, r.begin, r.end, n));
  return r;
}

std::optional<std::string> seconds_range(const std::vector<double>& time, IndexRange r) {
  const std::size_t m = time.size();
  if (r.begin >= r.end || r.end > m) return std::nullopt;
  // the fewest digits (6 or more) that parse_range reads back as r: 1.3s, not 1.3000000000000003s; a range to the
  // record's end is left open ("As:"), which no rounding of a stamp past the last one can move
  for (int digits = 6; digits <= 17; ++digits) {
    std::string text = fmt::format("{:.{}g}s:", time[r.begin], digits);
    if (r.end < m) text += fmt::format("{:.{}g}s", time[r.end], digits);
    try {
      const IndexRange back = parse_range(text, "seconds_range", &time, m);
      if (back.begin == r.begin && back.end == r.end) return text;
    } catch (const Error&) {
    }
  }
  return std::nullopt;  // a stamp repeated at an end: the first sample at or after it is another one
}

report::Axis parse_axis(const std::string& text, const std::string& fallback) {
  const std::string t = trim(text);
  if (t.empty()) return {fallback.empty() ? std::string("value") : fallback, ""};
  // "Pressure [kPa]", "Pressure (kPa)"; a label the user gives may also write "Pressure[kPa]"
  std::string unit = io::trailing_unit(t), label = io::without_unit(t);
  if (const auto open = t.rfind('['); unit.empty() && open != std::string::npos && t.back() == ']') {
    unit = trim(std::string_view(t).substr(open + 1, t.size() - open - 2));
    label = trim(std::string_view(t).substr(0, open));
  }
  if (unit.empty()) return {t, ""};
  if (label.empty() || label == t) label = fallback.empty() ? std::string("value") : fallback;
  return {label, unit};
}

bool names_stdout(const std::string& path) {
  if (path == "-") return true;
  if (path.empty()) return false;
  struct stat out {}, named {};
  if (::fstat(STDOUT_FILENO, &out) != 0 || ::stat(path.c_str(), &named) != 0) return false;
  if (out.st_dev != named.st_dev || out.st_ino != named.st_ino) return false;
  // the null device discards both documents: nobody reads two of them (--out /dev/null > /dev/null)
  struct stat null {};
  return !(S_ISCHR(named.st_mode) && ::stat("/dev/null", &null) == 0 && null.st_rdev == named.st_rdev);
}

void add_data_options(CLI::App* sub, DataSelection& sel) {
  sub->add_option("--data,-d", sel.file, "data file (.csv or .mat)")->required();
  sub->add_option("--input,-i", sel.input,
                  "input column: header name or 0-based index; .mat: variable, or NAME:INDEX = column INDEX (0-based) "
                  "of the matrix NAME")
      ->required();
  sub->add_option("--output,-y", sel.output,
                  "output column: header name or 0-based index; .mat: variable or NAME:INDEX (0-based column of a "
                  "matrix)")
      ->required();
  CLI::Option* time = sub->add_option("--time-column", sel.time_column,
                                      "time column: ranges in seconds, time axis of the HTML report");
  sub->add_option("--time-unit", sel.time_unit,
                  "unit of the time column: s, ms or us (default: the unit its header or units row gives, as in "
                  "\"t [ms]\", else s); read as seconds")
      ->check(one_of({"s", "ms", "us"}))
      ->needs(time);
  sub->add_option("--input-label", sel.input_label, "input axis label with unit, e.g. \"Pressure [kPa]\"");
  sub->add_option("--output-label", sel.output_label, "output axis label with unit, e.g. \"Force [N]\"");
}

namespace {
// " (column 3 \"voltage\")": a column as read_named_column found it, for a message
std::string column_named(const io::NamedColumn& c) {
  if (c.index == io::NamedColumn::npos) return std::string();
  return c.name.empty() ? fmt::format(" (column {})", c.index) : fmt::format(" (column {} \"{}\")", c.index, c.name);
}

io::ReadOptions column_options(const std::string& spec) {
  io::ReadOptions o;
  o.column_spec = spec;
  return o;
}
}  // namespace

DataColumns read_data_columns(const std::string& file, const DataSelection& sel) {
  DataColumns d;
  io::NamedColumn in_id, out_id;  // the columns read (without their values), for the time column's check
  {
    io::NamedColumn in = io::read_named_column(file, column_options(sel.input));
    io::NamedColumn out = io::read_named_column(file, column_options(sel.output));
    // one column read as both: a "fit" of the identity (converged at 1e-12 % of span, exit 0)
    if (io::NamedColumn::same(in, out))
      throw Error(fmt::format("{}: the input ({}) and the output ({}) are the same column{}: give two different "
                              "columns",
                              file, sel.input, sel.output, column_named(in)));
    in_id = {{}, in.name, in.unit, in.index};
    out_id = {{}, out.name, out.unit, out.index};
    d.x = std::move(in.values);
    d.y = std::move(out.values);
    d.input_name = std::move(in.name);
    d.input_unit = std::move(in.unit);
    d.output_name = std::move(out.name);
    d.output_unit = std::move(out.unit);
  }
  if (d.x.size() != d.y.size())
    throw Error(fmt::format("{}: input column has {} values, output column {}", file, d.x.size(), d.y.size()));
  // a label's unit is the axis's and the model's: one the column's own contradicts is refused
  const auto label_agrees = [&](std::string_view what, const std::string& column, const std::string& unit,
                                const std::string& label) {
    if (units_differ(unit, parse_axis(label, column).unit))
      throw Error(fmt::format("{}: the {} column {} is in {}, but --{}-label \"{}\" says {}: give the label the "
                              "column's unit (or none)",
                              file, what, column, unit, what, label, parse_axis(label, column).unit));
  };
  label_agrees("input", sel.input, d.input_unit, sel.input_label);
  label_agrees("output", sel.output, d.output_unit, sel.output_label);
  if (!sel.time_column.empty()) {
    io::NamedColumn t = io::read_named_column(file, column_options(sel.time_column));
    for (const auto& [what, spec, id] : {std::tuple{"input", &sel.input, &in_id}, std::tuple{"output", &sel.output, &out_id}})
      if (io::NamedColumn::same(t, *id))
        throw Error(fmt::format("{}: the time column ({}) is the {} column ({}){}: give the time stamps' own column "
                                "(or none)",
                                file, sel.time_column, what, *spec, column_named(t)));
    d.t = std::move(t.values);
    if (d.t->size() != d.x.size())
      throw Error(fmt::format("{}: time column has {} values, input column {}", file, d.t->size(), d.x.size()));
    // the unit the file gives the time column ("t [ms]", a units row): a record in ms read as
    // seconds would run rate-pi 1000 times slow and put ranges in seconds 1000 times off
    const std::string named = io::time_unit_named(t.unit, fmt::format("{}: the time column {}", file, sel.time_column));
    if (!sel.time_unit.empty() && !named.empty() && named != sel.time_unit)
      throw Error(fmt::format("{}: --time-unit {} but the file gives the time column {} the unit \"{}\": one of "
                              "them is wrong (drop --time-unit if the file is right)",
                              file, sel.time_unit, sel.time_column, t.unit));
    d.time_unit = !sel.time_unit.empty() ? sel.time_unit : !named.empty() ? named : std::string("s");
    d.time_unit_from_file = !named.empty();
    const double to_s = io::time_unit_seconds(d.time_unit, file + ": --time-unit");
    if (to_s != 1.0)
      for (double& v : *d.t) v *= to_s;
  }
  return d;
}

void check_sample_time_agrees(double sample_time, const std::vector<double>* t, const std::string& file,
                              const std::string& column) {
  if (!(sample_time > 0.0) || !t || t->size() < 2) return;
  const double step = mean_time_step(*t);  // s
  if (!(step > 0.0) || std::abs(sample_time - step) <= kSampleTimeTolerance * step) return;
  // or the overall mean step, lost samples counted as steps: stamps on a tick coarser than half
  // the step (1.4 ms stamped to 1 ms) look like lost samples to mean_time_step
  const double overall = (t->back() - t->front()) / static_cast<double>(t->size() - 1);  // s
  if (std::abs(sample_time - overall) <= kSampleTimeTolerance * overall) return;
  throw Error(fmt::format("{}: --sample-time {:.6g} s disagrees with the mean step {:.6g} s of the time column {} "
                          "(by {:.3g} %, more than the {:g} % allowed): one of them is wrong (a rate, or a unit: see "
                          "--time-unit); give the right one alone",
                          file, sample_time, step, column, 100.0 * std::abs(sample_time - step) / step,
                          100.0 * kSampleTimeTolerance));
}

std::vector<std::string> rate_time_warnings(const ModelParams& model, const std::vector<double>* t,
                                            double sample_time, const std::string& file, const std::string& column) {
  std::vector<std::string> warnings;
  const auto* rp = std::get_if<RatePiParams>(&model);
  if (!rp) return warnings;
  if (!(sample_time > 0.0) && (!t || t->size() < 2)) {
    warnings.push_back(fmt::format("{}: the record's sample time is unknown (no time column): the rate-pi model's "
                                   "dt {:.6g} s is assumed (its rates are per second through it)",
                                   file, rp->dt));
    return warnings;
  }
  double dt = sample_time;  // s
  std::string from = "--sample-time";
  // The time column's faults are warnings here (the model's dt is what runs it), also where
  // --sample-time gives the step: a gap or a backwards stamp is still the record's
  if (t && t->size() > 1) {
    try {
      if (std::string w = require_increasing_time(*t, file, column, "rate-pi's sample time"); !w.empty())
        warnings.push_back(std::move(w));
    } catch (const Error& e) {
      warnings.push_back(fmt::format("{}: the record's sample time is uncertain", e.what()));
    }
  }
  if (!(dt > 0.0)) {
    dt = mean_time_step(*t);
    from = fmt::format("mean step of the time column {}", column);
  }
  if (!(dt > 0.0))
    warnings.push_back(fmt::format("{}: the time column {} has no positive step: the record's sample time "
                                   "is unknown",
                                   file, column));
  else if (std::abs(dt - rp->dt) > 0.1 * rp->dt)
    warnings.push_back(fmt::format("{}: the record's sample time {:.6g} s ({}) differs from the rate-pi model's dt "
                                   "{:.6g} s: the model runs its rates {:.3g}x too {}",
                                   file, dt, from, rp->dt, std::max(dt, rp->dt) / std::min(dt, rp->dt),
                                   dt > rp->dt ? "slow" : "fast"));
  if (warnings.empty() && t && t->size() > 1)
    if (std::string w = uniform_time_warning(*t, file, column); !w.empty()) warnings.push_back(std::move(w));
  return warnings;
}

std::string require_increasing_time(const std::vector<double>& t, const std::string& file, const std::string& column,
                                    std::string_view why, bool repeats_ok) {
  std::size_t repeats = 0, first_repeat = 0;
  for (std::size_t k = 0; k < t.size(); ++k)
    if (std::isnan(t[k]))
      throw Error(fmt::format("{}: the time column {} is not a number at sample {} (data row {}); {} needs time "
                              "stamps",
                              file, column, k, k + 1, why));
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (t[k] == t[k - 1]) {
      if (repeats++ == 0) first_repeat = k;
      continue;
    }
    if (!(t[k] > t[k - 1]))
      throw Error(fmt::format("{}: the time column {} goes backwards at sample {} (data row {}: {} s after {} s); {} "
                              "needs increasing time stamps",
                              file, column, k, k + 1, t[k], t[k - 1], why));
  }
  if (repeats == 0) return {};
  const std::string where = fmt::format("{}: the time column {} repeats a stamp at {} of its {} steps (the first at "
                                        "sample {}, data row {}: {} s)",
                                        file, column, repeats, t.size() - 1, first_repeat, first_repeat + 1,
                                        t[first_repeat]);
  if (!repeats_ok && 100 * repeats > t.size() - 1)
    throw Error(fmt::format("{}; {} needs increasing time stamps", where, why));
  return where + "; the mean step is used";
}

namespace {
// Steps of a uniformly sampled column: within these multiples of the median step (a step of 2
// sample times or more has lost a sample; stamps rounded to a clock's tick vary by up to 1/2).
constexpr double kMaxStep = 1.9, kMinStep = 0.4;
// The steps the record's time step is the mean of: within these multiples of the median step,
// both ends included (to 1e-6). Symmetric, so jitter averages out; stamps rounded to a tick of at
// most half the step differ from the median by at most one tick, so by at most half a median
// (Festo test8: 1, 2 and 3 ms around 2 ms); a lost sample (2 medians), a gap, a repeated stamp
// and the double step after it, a backward step do not count. A coarser tick (1.4 ms stamped to
// 1 ms: steps of 1 and 2 ms) cannot be told from lost samples by the steps: the median's step
// is taken, the column is warned as non-uniform, and --sample-time may give the rate (it is
// checked against the column's overall mean step too, check_sample_time_agrees).
constexpr double kMeanStepLo = 0.5, kMeanStepHi = 1.5;

double median_step(const std::vector<double>& t) {
  if (t.size() < 2) return 0.0;
  std::vector<double> dts(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) dts[k - 1] = t[k] - t[k - 1];
  std::nth_element(dts.begin(), dts.begin() + static_cast<std::ptrdiff_t>(dts.size() / 2), dts.end());
  return dts[dts.size() / 2];
}
}  // namespace

double mean_time_step(const std::vector<double>& t) {
  const double median = median_step(t);  // s
  if (!(median > 0.0)) return median;
  // the mean of the steps from kMeanStepLo to kMeanStepHi medians, so stamps rounded to a tick or
  // jittered average out to the record's rate
  const double lo = kMeanStepLo * median * (1.0 - 1e-6), hi = kMeanStepHi * median * (1.0 + 1e-6);
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 1; k < t.size(); ++k)
    if (const double step = t[k] - t[k - 1]; step >= lo && step <= hi) sum += step, ++n;
  return sum / static_cast<double>(n);  // n > 0: the median step itself counts
}

std::string uniform_time_warning(const std::vector<double>& t, const std::string& file, const std::string& column) {
  const double dt = median_step(t);  // s
  if (t.size() < 3 || !(dt > 0)) return {};
  // repeated stamps (require_increasing_time's warning) are not steps: the smallest positive one
  std::size_t widest = 0, narrowest = 0;
  double hi = -std::numeric_limits<double>::infinity(), lo = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < t.size(); ++k) {
    // a step right after a repeated stamp spans the repeat: half the two steps (0.099, 0.099,
    // 0.101 is one sample stamped late, not a gap)
    const double step = k >= 2 && t[k - 1] == t[k - 2] ? 0.5 * (t[k] - t[k - 2]) : t[k] - t[k - 1];
    if (step > hi) hi = step, widest = k;
    if (step > 0.0 && step < lo) lo = step, narrowest = k;
  }
  if (narrowest == 0) return {};
  if (hi <= kMaxStep * dt && lo >= kMinStep * dt) return {};
  const bool gap = hi > kMaxStep * dt;
  const std::size_t k = gap ? widest : narrowest;
  return fmt::format("{}: the time column {} is not uniformly sampled: the step to sample {} (data row {}) is {:.6g} s, "
                     "{:.3g} times the median step {:.6g} s ({}); rate-pi's rates assume one sample time",
                     file, column, k, k + 1, gap ? hi : lo, (gap ? hi : lo) / dt, dt,
                     gap ? "a gap, or lost samples" : "jittered sampling");
}

namespace {
// --input-label if given, else the column's header name and unit ("pressure", "kPa"), else its spec.
report::Axis data_axis(const std::string& label, const std::string& spec, const std::string& name,
                       const std::string& unit) {
  if (!trim(label).empty()) return parse_axis(label, spec);
  return {name.empty() ? (spec.empty() ? std::string("value") : spec) : name, unit};
}
}  // namespace

io::DataDescription describe_data(const DataSelection& sel, const DataColumns& rec, InitialState initial,
                                  IndexRange range) {
  const report::Axis in = data_axis(sel.input_label, sel.input, rec.input_name, rec.input_unit),
                     out = data_axis(sel.output_label, sel.output, rec.output_name, rec.output_unit);
  io::DataDescription d;
  d.input_file = d.output_file = sel.file;
  d.input_column = sel.input;
  d.output_column = sel.output;
  d.time_column = sel.time_column;
  d.time_unit = rec.time_unit;
  d.time_unit_given = !sel.time_unit.empty();  // else the file's header gave it, or none (s)
  d.input_label = in.label;
  d.input_unit = in.unit;
  d.output_label = out.label;
  d.output_unit = out.unit;
  d.initial_state = initial;
  d.train = range;
  return d;
}

report::FitData plot_data(const DataSelection& sel, const DataColumns& d, InitialState initial, IndexRange range) {
  report::FitData data;
  data.x = d.x;
  data.y = d.y;
  if (d.t) data.t = *d.t;
  data.input = data_axis(sel.input_label, sel.input, d.input_name, d.input_unit);
  data.output = data_axis(sel.output_label, sel.output, d.output_name, d.output_unit);
  data.source = report::data_source_line(describe_data(sel, d, initial, range));  // as `hysteron report` words it
  data.initial_state = initial;
  data.train = range;
  return data;
}

}  // namespace hysteron::cli
