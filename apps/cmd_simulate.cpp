// hysteron simulate / invert: run a model file forwards or its exact inverse on
// a column of a CSV or .mat file.
//
//   hysteron simulate --model M.json --input X.csv [--column C] --output Y.csv [--relaxed] [--compress]
//   hysteron invert   --model M.json --input Y.csv [--column C] --output X.csv [--limits LO,HI] [--relaxed]
// --model - reads the model JSON from stdin (e.g. hysteron fit ... --out - | hysteron simulate --model - ...).
// A CSV output to a regular file (or a new path) is streamed: the input is read in chunks, run in
// blocks and written through a fixed buffer into the temporary file, so memory stays bounded
// whatever the record's length; an error on a later input line leaves no output behind.
#include <sys/stat.h>

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <cctype>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/models.hpp"

namespace hysteron::cli {

namespace {

struct Options {
  std::string model, input, column, output, limits;
  bool relaxed = false, compress = false;
};

// The chosen column; without --column: the file's only column, else the one named `preferred`.
io::ReadOptions input_options(const std::string& column, const std::string& preferred) {
  io::ReadOptions r;
  r.column_spec = column;
  r.preferred_column = preferred;
  return r;
}

bool is_mat(const std::string& path) {
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  return lower.ends_with(".mat");
}

// A CSV output written through a temporary file (a regular file or a new path): streamed.
// Devices, FIFOs and stdout get the whole result at once, after the input was read and checked.
bool streamed_output(const std::string& path) {
  if (path == "-" || is_mat(path) || path == "/dev/stdout" || path == "/dev/stderr" || path.starts_with("/dev/fd/") ||
      path.starts_with("/proc/self/fd/"))
    return false;
  struct stat st {};
  return ::stat(path.c_str(), &st) != 0 || S_ISREG(st.st_mode);
}

// Runs f on blocks of at most 8192 input samples of the chosen column (bounded memory).
// `unit_check` sees the column's name and unit before its first value.
template <class F>
void for_each_block(const std::string& path, const io::ReadOptions& ro, F&& f,
                    const std::function<void(const io::NamedColumn&)>& unit_check) {
  constexpr std::size_t kBlock = 8192;
  std::vector<double> block;
  block.reserve(kBlock);
  io::for_each_value(
      path, ro,
      [&](double v) {
        block.push_back(v);
        if (block.size() == kBlock) {
          f(std::span<const double>(block));
          block.clear();
        }
      },
      unit_check);
  if (!block.empty()) f(std::span<const double>(block));
}

// Output of a model started relaxed at x0 and driven by x0.
double relaxed_output(const ModelParams& params, double x0) {
  Model m(params);
  m.reset_relaxed(x0);
  return m.step(x0);
}

// The input x0 at which a model relaxed at rest outputs y0 (bisection on the
// increasing rest curve, inside the inverse's limits).
double relaxed_input_for(const ModelParams& params, const Limits& lim, double y0) {
  double lo = lim.lo, hi = lim.hi;
  if (!std::isfinite(lo) || !std::isfinite(hi)) {
    double w = 1.0;
    lo = std::isfinite(lo) ? lo : -w;
    hi = std::isfinite(hi) ? hi : w;
    while (w < 1e300) {
      const bool lo_ok = std::isfinite(lim.lo) || relaxed_output(params, lo) <= y0;
      const bool hi_ok = std::isfinite(lim.hi) || relaxed_output(params, hi) >= y0;
      if (lo_ok && hi_ok) break;
      w *= 2;
      if (!lo_ok) lo = -w;
      if (!hi_ok) hi = w;
    }
  }
  if (relaxed_output(params, lo) >= y0) return lo;
  if (relaxed_output(params, hi) <= y0) return hi;
  for (int it = 0; it < 2000; ++it) {
    const double mid = lo + (hi - lo) / 2;
    if (!(mid > lo && mid < hi)) break;
    if (relaxed_output(params, mid) < y0) lo = mid; else hi = mid;
  }
  return std::abs(relaxed_output(params, lo) - y0) <= std::abs(relaxed_output(params, hi) - y0) ? lo : hi;
}

// rate-pi run on a record without time stamps: its dt is assumed (said once the input was read
// and run: a read error is the only message then).
void warn_assumed_dt(const ModelParams& params, const std::string& input, const char* command) {
  for (const auto& w : rate_time_warnings(params, nullptr, 0.0, input, ""))  // no time column read here
    fmt::print(stderr, "{}: warning: {}\n", command, w);
}

int run_simulate(const Options& o) {
  io::check_output_files({{"--output", o.output}}, {{"--model", o.model}, {"--input", o.input}});
  const io::ModelDocument doc = io::read_model_document(o.model);
  const ModelParams& params = doc.params;
  const ModelUnits units = model_units(doc);
  const io::ReadOptions ro = input_options(o.column, "input");
  const auto unit_check = [&](const io::NamedColumn& c) { check_column_unit(c, o.input, ro, units.input, o.model, "input"); };
  Model model(params);
  InputCoverage coverage;  // summed over the blocks: inputs beyond the model's input_limits
  coverage.limits = input_limits(params);
  const auto cover = [&](std::span<const double> x) {
    const InputCoverage c = input_coverage(params, x);
    coverage.outside += c.outside, coverage.n += c.n, coverage.max_beyond = std::max(coverage.max_beyond, c.max_beyond);
  };
  const auto warn_after_run = [&] {  // the input read and run: rate-pi's assumed dt, the coverage
    warn_assumed_dt(params, o.input, "simulate");
    if (coverage.fraction() > 0.01)
      fmt::print(stderr,
                 "simulate: warning: {} of the {} samples ({:.1f} %) have an input outside the model's input_limits "
                 "[{:.6g}, {:.6g}] (fit() sets them to its training range), up to {:.6g} beyond: the output there is "
                 "extrapolated\n",
                 coverage.outside, coverage.n, 100.0 * coverage.fraction(), coverage.limits.lo, coverage.limits.hi,
                 coverage.max_beyond);
  };
  if (streamed_output(o.output)) {
    io::write_csv_rows(o.output, {"input", "output"}, [&](io::CsvRowWriter& w) {
      std::vector<double> y(8192);
      bool first = true;
      for_each_block(
          o.input, ro,
          [&](std::span<const double> x) {
            if (first && o.relaxed) model.reset_relaxed(x.front());
            first = false;
            model.simulate(x, std::span<double>(y.data(), x.size()));
            cover(x);
            for (std::size_t k = 0; k < x.size(); ++k) w.row(std::array<double, 2>{x[k], y[k]});
          },
          unit_check);
    });
    warn_after_run();
    return 0;
  }
  io::NamedColumn in = io::read_named_column(o.input, ro);
  unit_check(in);
  const std::vector<double> x = std::move(in.values);
  if (o.relaxed && !x.empty()) model.reset_relaxed(x.front());
  const std::vector<double> y = model.simulate(x);
  cover(x);
  io::WriteOptions wo;
  wo.compress_mat = o.compress;
  io::write_columns(o.output, {"input", "output"}, {x, y}, wo);
  warn_after_run();
  return 0;
}

int run_invert(const Options& o) {
  io::check_output_files({{"--output", o.output}}, {{"--model", o.model}, {"--input", o.input}});
  const io::ModelDocument doc = io::read_model_document(o.model);
  const ModelParams& params = doc.params;
  const ModelUnits units = model_units(doc);
  const io::ReadOptions ro = input_options(o.column, "output");
  const auto unit_check = [&](const io::NamedColumn& c) {
    check_column_unit(c, o.input, ro, units.output, o.model, "output");
  };
  InverseOptions opt;
  if (!o.limits.empty()) {
    opt.input_limits = parse_limits(o.limits);
    warn_limits_beyond_model(params, opt.input_limits, "invert", doc.unit("input"));
  }
  Inverse inv(params, opt);
  Model forward(params);  // the model driven by the inverse's inputs: what they produce
  std::size_t saturated = 0, samples = 0, missed = 0, miss_at = 0;
  double max_miss = 0.0, y_scale = 0.0;
  {  // the scale of a miss: the model's output span between the limits (at rest there); without
     // finite limits, the largest desired output
    Model m(params);
    const Limits& l = inv.limits();
    if (std::isfinite(l.lo) && std::isfinite(l.hi) && m.reset_relaxed(l.lo)) {
      const double y_lo = m.step(l.lo);
      if (m.reset_relaxed(l.hi)) y_scale = std::abs(m.step(l.hi) - y_lo);
    }
  }
  bool first = true;
  // x = inverse(y), sample by sample; the relaxed start needs the first desired output
  auto run = [&](std::span<const double> y, double* x) {
    if (first && o.relaxed && !y.empty()) {
      Model start(params);
      start.reset_relaxed(relaxed_input_for(params, inv.limits(), y.front()));
      inv.reset(start.state());
      forward = start;
    }
    first = false;
    if (!(y_scale > 0.0))  // no span from the limits (unbounded): the desired outputs' magnitude
      for (double v : y) y_scale = std::max(y_scale, std::abs(v));
    for (std::size_t k = 0; k < y.size(); ++k) {
      x[k] = inv.step(y[k]);
      const double got = forward.step(x[k]);
      if (inv.saturated()) {
        ++saturated;
      } else if (const double miss = std::abs(got - y[k]); miss > 1e-6 * y_scale) {
        // reachable inside the limits, yet not reached: a numerical inverse of a model whose
        // output jumps (preisach's relays) or is flat there
        if (++missed == 1 || miss > max_miss) miss_at = samples + k;
        max_miss = std::max(max_miss, miss);
      }
    }
    samples += y.size();
  };
  auto check_faults = [&] {
    if (inv.faults() != 0) throw Error(fmt::format("{}: {} samples could not be inverted", o.input, inv.faults()));
  };
  if (streamed_output(o.output)) {
    io::write_csv_rows(o.output, {"output", "input"}, [&](io::CsvRowWriter& w) {
      std::vector<double> x(8192);
      for_each_block(
          o.input, ro,
          [&](std::span<const double> y) {
            run(y, x.data());
            for (std::size_t k = 0; k < y.size(); ++k) w.row(std::array<double, 2>{y[k], x[k]});
          },
          unit_check);
      check_faults();
    });
  } else {
    io::NamedColumn out = io::read_named_column(o.input, ro);
    unit_check(out);
    const std::vector<double> y = std::move(out.values);
    std::vector<double> x(y.size());
    run(y, x.data());
    check_faults();
    io::WriteOptions wo;
    wo.compress_mat = o.compress;
    io::write_columns(o.output, {"output", "input"}, {y, x}, wo);
  }
  warn_assumed_dt(params, o.input, "invert");
  const Limits& l = inv.limits();
  fmt::print(stderr, "invert: {} of {} samples saturated at the input limits [{}, {}]\n", saturated, samples, l.lo + 0.0,
             l.hi + 0.0);
  if (missed > 0)
    fmt::print(stderr,
               "invert: warning: {} of the {} unsaturated samples miss the desired output by more than 1e-6 of the "
               "model's output span, by up to {:.6g} (sample {}): the model does not output those values anywhere "
               "inside the limits (its output jumps or is flat there; {} has a numerical inverse)\n",
               missed, samples - saturated, max_miss, miss_at, model_name(params));
  return 0;
}

void add_common(CLI::App* sub, Options& o, const char* input_help) {
  sub->add_option("--model,-m", o.model, "model file (JSON, see docs/model-files.md); - reads it from stdin")->required();
  sub->add_option("--input,-i", o.input, input_help)->required();
  sub->add_option("--column,-c", o.column, "column of the input file: header name or 0-based index; .mat: variable, or NAME:INDEX = column INDEX (0-based) of the matrix NAME");
  sub->add_option("--output,-o", o.output, "output file: .csv, .mat, or - for CSV on stdout")->required();
  sub->add_flag("--relaxed", o.relaxed, "start from rest at the first sample instead of the virgin state");
  sub->add_flag("--compress", o.compress, ".mat output: zlib-compressed variables (smaller, slower to write)");
}

}  // namespace

void add_simulate_invert(CLI::App& app, Action& action) {
  auto opts = std::make_shared<Options>();
  CLI::App* sim = app.add_subcommand("simulate", "run a model forwards: input samples -> output (columns input,output)");
  add_common(sim, *opts, "input samples (CSV or .mat); default column: the only one, or \"input\"");
  sim->callback([opts, &action] { action = [opts] { return run_simulate(*opts); }; });

  CLI::App* invs = app.add_subcommand("invert", "run the exact inverse: desired output -> input (columns output,input)");
  add_common(invs, *opts, "desired outputs (CSV or .mat); default column: the only one, or \"output\"");
  invs->add_option("--limits", opts->limits,
                   "input limits LO,HI to saturate at (default: the model's input_limits, a fitted model's training input "
                   "range; write --limits=LO,HI if LO < 0)");
  invs->callback([opts, &action] { action = [opts] { return run_invert(*opts); }; });
}

}  // namespace hysteron::cli
