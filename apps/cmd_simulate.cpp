// hysteron simulate / invert: run a model file forwards or its exact inverse on
// a column of a CSV or .mat file.
//
//   hysteron simulate --model M.json --input X.csv [--column C] --output Y.csv [--relaxed]
//   hysteron invert   --model M.json --input Y.csv [--column C] --output X.csv [--limits LO,HI] [--relaxed]
// --model - reads the model JSON from stdin (e.g. hysteron fit ... --out - | hysteron simulate --model - ...).
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/models.hpp"

namespace hysteron::cli {

namespace {

struct Options {
  std::string model, input, column, output, limits;
  bool relaxed = false;
};

// The chosen column; without --column: the file's only column, else the one named `preferred`.
std::vector<double> read_input(const std::string& path, const std::string& column, const std::string& preferred) {
  if (!column.empty()) return io::read_column(path, column);
  const io::Table t = io::read_table(path);
  std::size_t nonempty = 0;
  for (const auto& c : t.columns) nonempty += c.empty() ? 0 : 1;
  if (nonempty != 1)
    for (const auto& n : t.names)
      if (n == preferred) return t.column(preferred);
  return t.column("");  // the only non-empty column, or an error listing the columns
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

int run_simulate(const Options& o) {
  io::check_outputs_distinct({{"--output", o.output}}, {{"--model", o.model}, {"--input", o.input}});
  const ModelParams params = read_model_source(o.model);
  const std::vector<double> x = read_input(o.input, o.column, "input");
  Model model(params);
  if (o.relaxed && !x.empty()) model.reset_relaxed(x.front());
  const std::vector<double> y = model.simulate(x);
  io::write_columns(o.output, {"input", "output"}, {x, y});
  return 0;
}

int run_invert(const Options& o) {
  io::check_outputs_distinct({{"--output", o.output}}, {{"--model", o.model}, {"--input", o.input}});
  const ModelParams params = read_model_source(o.model);
  const std::vector<double> y = read_input(o.input, o.column, "output");
  InverseOptions opt;
  if (!o.limits.empty()) opt.input_limits = parse_limits(o.limits);
  Inverse inv(params, opt);
  if (o.relaxed && !y.empty()) {
    Model start(params);
    start.reset_relaxed(relaxed_input_for(params, inv.limits(), y.front()));
    inv.reset(start.state());
  }
  std::vector<double> x(y.size());
  std::size_t saturated = 0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    x[k] = inv.step(y[k]);
    if (inv.saturated()) ++saturated;
  }
  if (inv.faults() != 0) throw Error(fmt::format("{}: {} samples could not be inverted", o.input, inv.faults()));
  io::write_columns(o.output, {"output", "input"}, {y, x});
  const Limits& l = inv.limits();
  fmt::print(stderr, "invert: {} of {} samples saturated at the input limits [{}, {}]\n", saturated, y.size(), l.lo,
             l.hi);
  return 0;
}

void add_common(CLI::App* sub, Options& o, const char* input_help) {
  sub->add_option("--model,-m", o.model, "model file (JSON, see docs/model-files.md); - reads it from stdin")->required();
  sub->add_option("--input,-i", o.input, input_help)->required();
  sub->add_option("--column,-c", o.column, "column of the input file: header name or 0-based index; .mat: variable, or NAME:INDEX = column INDEX (0-based) of the matrix NAME");
  sub->add_option("--output,-o", o.output, "output file: .csv, .mat, or - for CSV on stdout")->required();
  sub->add_flag("--relaxed", o.relaxed, "start from rest at the first sample instead of the virgin state");
}

}  // namespace

void add_simulate_invert(CLI::App& app, Action& action) {
  auto opts = std::make_shared<Options>();
  CLI::App* sim = app.add_subcommand("simulate", "run a model forwards: input samples -> output (columns input,output)");
  add_common(sim, *opts, "input samples (CSV or .mat); default column: the only one, or \"input\"");
  sim->callback([opts, &action] { action = [opts] { return run_simulate(*opts); }; });

  CLI::App* invs = app.add_subcommand("invert", "run the exact inverse: desired output -> input (columns output,input)");
  add_common(invs, *opts, "desired outputs (CSV or .mat); default column: the only one, or \"output\"");
  invs->add_option("--limits", opts->limits, "input limits LO,HI to saturate at (write --limits=LO,HI if LO < 0)");
  invs->callback([opts, &action] { action = [opts] { return run_invert(*opts); }; });
}

}  // namespace hysteron::cli
