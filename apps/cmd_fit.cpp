// hysteron fit: identify a model from measured input/output columns.
//
//   hysteron fit --model gpi|pi|mpi-deadzone|mpi-asym --data D.csv --input COL --output COL
//                [--n N] [--dead-zones J] [--train A:B] [--validate C:D] [--validate-data V.csv ...]
//                [--time-column COL]  (ranges in seconds with a suffix s: --train 0s:20s)
//                --out model.json [--report fit.json] [--json] [--huber DELTA] [--seed S]
//                [--starts K] [--threads T] [--relaxed] [--free-weights] [--force]
//
// Exit codes: 0 converged (model written); 1 bad input (hysteron::Error);
// 2 not converged (model not written unless --force).
#include <fmt/format.h>
#include <unistd.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"

namespace hysteron::cli {

namespace {

struct FitCliOptions {
  std::string model = "gpi", data, input, output, train, validate, time_column, out, report;
  std::vector<std::string> validate_data;
  int n = 10, dead_zones = 4, starts = 2, threads = 0;
  double huber = 0.0;
  unsigned seed = 0;
  bool json = false, relaxed = false, force = false, free_weights = false;
};

double parse_number(std::string_view s, std::string_view what) {
  double v = 0.0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || res.ec != std::errc() || res.ptr != s.data() + s.size() || !std::isfinite(v))
    throw Error(fmt::format("{}: \"{}\" is not a number", what, s));
  return v;
}

// "A:B" (sample indices, half-open; either side may be empty) or "As:Bs" (seconds, needs the time column).
IndexRange parse_range(const std::string& text, std::string_view opt, const std::vector<double>* time, std::size_t n) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw Error(fmt::format("{}: expected A:B (sample indices) or As:Bs (seconds), got \"{}\"", opt, text));
  IndexRange r{0, n};
  auto side = [&](std::string_view s, bool is_end) {
    if (s.empty()) return;
    std::size_t idx = 0;
    if (s.back() == 's') {
      if (!time) throw Error(fmt::format("{}: a range in seconds (\"{}\") needs --time-column", opt, text));
      const double t = parse_number(s.substr(0, s.size() - 1), opt);
      if (t < time->front() || t > time->back())
        throw Error(fmt::format("{}: time {} s is outside the record ({} s .. {} s)", opt, t, time->front(), time->back()));
      idx = static_cast<std::size_t>(std::lower_bound(time->begin(), time->end(), t) - time->begin());
    } else {
      const double v = parse_number(s, opt);
      if (v < 0 || v != std::floor(v)) throw Error(fmt::format("{}: \"{}\" is not a sample index", opt, s));
      idx = static_cast<std::size_t>(v);
    }
    (is_end ? r.end : r.begin) = idx;
  };
  side(std::string_view(text).substr(0, colon), false);
  side(std::string_view(text).substr(colon + 1), true);
  if (r.end > n || r.begin >= r.end)
    throw Error(fmt::format("{}: range [{}, {}) is empty or outside the data ({} samples)", opt, r.begin, r.end, n));
  return r;
}

nlohmann::json metrics_json(const FitMetrics& m) {
  return {{"rms", m.rms}, {"max", m.max}, {"mae", m.mae}, {"rms_percent_span", m.rms_percent_span}, {"r2", m.r2}, {"n", m.n}};
}

std::string metrics_text(std::string_view name, const FitMetrics& m) {
  return fmt::format("{:<9} rms {:.6g}  max {:.6g}  mae {:.6g}  rms {:.4g}% of span  r2 {:.6f}  ({} samples)\n", name, m.rms,
                     m.max, m.mae, m.rms_percent_span, m.r2, m.n);
}

int run_fit(const FitCliOptions& c) {
  const std::vector<double> x = io::read_column(c.data, c.input);
  const std::vector<double> y = io::read_column(c.data, c.output);
  if (x.size() != y.size())
    throw Error(fmt::format("{}: input column has {} values, output column {}", c.data, x.size(), y.size()));
  std::optional<std::vector<double>> time;
  if (!c.time_column.empty()) time = io::read_column(c.data, c.time_column);
  FitOptions o;
  o.model = fit_model_from_name(c.model);
  o.num_operators = c.n;
  o.num_dead_zones = c.dead_zones;
  o.num_starts = c.starts;
  o.num_threads = c.threads;
  o.huber_delta = c.huber;
  o.seed = c.seed;
  o.initial_state = c.relaxed ? InitialState::relaxed : InitialState::virgin;
  o.gpi_free_weights = c.free_weights;
  const IndexRange train = c.train.empty() ? IndexRange{0, x.size()} : parse_range(c.train, "--train", time ? &*time : nullptr, x.size());
  o.train = train;
  std::optional<IndexRange> validate;
  if (!c.validate.empty()) {
    const std::size_t nv = c.validate_data.empty() ? x.size() : io::read_column(c.validate_data.front(), c.input).size();
    std::optional<std::vector<double>> vtime;
    if (!c.validate_data.empty() && time) vtime = io::read_column(c.validate_data.front(), c.time_column);
    validate = parse_range(c.validate, "--validate", c.validate_data.empty() ? (time ? &*time : nullptr) : (vtime ? &*vtime : nullptr), nv);
  }
  if (isatty(fileno(stderr)))
    o.progress = [](int start, int it, double cost) { fmt::print(stderr, "\rstart {} iteration {:3d} cost {:.6g}   ", start, it, cost); };
  const FitReport rep = fit(x, y, o);
  if (o.progress) fmt::print(stderr, "\n");
  if (rep.status == FitStatus::invalid_input) throw Error(rep.message);

  // validation: a range of the same record (simulated from its start), or another record
  std::optional<FitMetrics> val;
  std::vector<std::pair<std::string, FitMetrics>> vals;
  const bool fitted = rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence;
  if (fitted) {
    if (!c.validate_data.empty()) {
      for (const auto& file : c.validate_data) {
        const std::vector<double> xv = io::read_column(file, c.input);
        const std::vector<double> yv = io::read_column(file, c.output);
        vals.emplace_back(file, evaluate(rep.model, xv, yv, validate.value_or(IndexRange{}), o.initial_state));
      }
      val = vals.front().second;
    } else if (validate) {
      val = evaluate(rep.model, x, y, *validate, o.initial_state);
    } else if (train.end < x.size()) {
      val = evaluate(rep.model, x, y, IndexRange{train.end, x.size()}, o.initial_state);
    }
  }
  nlohmann::json j;
  j["status"] = std::string(fit_status_name(rep.status));
  j["message"] = rep.message;
  j["model_kind"] = std::string(fit_model_name(rep.model_kind));
  j["iterations"] = rep.iterations;
  j["total_iterations"] = rep.total_iterations;
  j["starts"] = rep.num_starts;
  j["time_s"] = rep.time_s;
  j["initial_cost"] = rep.initial_cost;
  j["final_cost"] = rep.final_cost;
  j["train"] = metrics_json(rep.train);
  j["train"]["range"] = {train.begin, train.end};
  j["validate"] = val ? metrics_json(*val) : nlohmann::json(nullptr);
  if (!vals.empty()) {
    j["validate_files"] = nlohmann::json::array();
    for (const auto& [file, m] : vals) {
      auto e = metrics_json(m);
      e["file"] = file;
      j["validate_files"].push_back(e);
    }
  }
  nlohmann::json params = nlohmann::json::array();
  for (const auto& p : rep.parameters)
    params.push_back({{"name", p.name},
                      {"value", p.value},
                      {"std_error", std::isfinite(p.std_error) ? nlohmann::json(p.std_error) : nlohmann::json(nullptr)},
                      {"held", p.held},
                      {"at_bound", p.at_bound}});
  j["parameters"] = params;
  j["covariance_note"] = rep.covariance_note;
  j["model"] = fitted ? io::model_to_json(rep.model) : nlohmann::json(nullptr);

  const bool write = rep.status == FitStatus::converged || (fitted && c.force);
  if (write) io::write_model_file(c.out, rep.model, {{"note", fmt::format("hysteron fit --model {} on {}", c.model, c.data)}});
  j["model_written"] = write;
  if (!c.report.empty()) io::write_text_file(c.report, j.dump(2) + "\n");
  if (c.json) {
    fmt::print("{}\n", j.dump(2));
  } else {
    std::string text = rep.full_report();
    if (vals.size() > 1) {
      for (const auto& [file, m] : vals) text += metrics_text("validate:", m) + fmt::format("          ({})\n", file);
    } else if (val) {
      text += metrics_text("validate:", *val);
    }
    text += write ? fmt::format("model written to {}\n", c.out)
                  : fmt::format("model NOT written ({}; use --force to write it anyway)\n", fit_status_name(rep.status));
    fmt::print("{}", text);
  }
  return rep.status == FitStatus::converged ? 0 : 2;
}

}  // namespace

void add_fit(CLI::App& app, Action& action) {
  auto c = std::make_shared<FitCliOptions>();
  CLI::App* sub = app.add_subcommand("fit", "identify a hysteresis model from measured input/output data");
  sub->add_option("--model,-m", c->model, "gpi | pi | mpi-deadzone | mpi-asym")->check(CLI::IsMember({"gpi", "pi", "mpi-deadzone", "mpi-asym"}));
  sub->add_option("--data,-d", c->data, "data file (.csv or .mat)")->required();
  sub->add_option("--input,-i", c->input, "input column (header name or 0-based index)")->required();
  sub->add_option("--output,-y", c->output, "output column (header name or 0-based index)")->required();
  sub->add_option("--n", c->n, "number of operators (default 10)");
  sub->add_option("--dead-zones", c->dead_zones, "mpi-deadzone: number of dead zones (default 4)");
  sub->add_option("--train", c->train, "training range A:B (sample indices, half-open) or As:Bs (seconds)");
  sub->add_option("--validate", c->validate, "validation range C:D (of --validate-data if given)");
  sub->add_option("--validate-data", c->validate_data, "other records (same columns) to validate on (repeatable)");
  sub->add_option("--time-column", c->time_column, "time column, for ranges in seconds");
  sub->add_option("--out,-o", c->out, "model file to write (JSON)")->required();
  sub->add_option("--report", c->report, "also write the JSON report to this file");
  sub->add_flag("--json", c->json, "print the report as JSON");
  sub->add_option("--huber", c->huber, "Huber loss threshold in output units (default: least squares)");
  sub->add_option("--seed", c->seed, "seed of the jitter of the initial guesses (0: none)");
  sub->add_option("--starts", c->starts, "number of initial guesses refined by LM (default 2)");
  sub->add_option("--threads", c->threads,
                  "threads refining the starts concurrently (default 0: one per hardware thread; 1: sequential; "
                  "the result does not depend on it)");
  sub->add_flag("--relaxed", c->relaxed, "start from rest at the first sample instead of the virgin state");
  sub->add_flag("--free-weights", c->free_weights,
                "gpi: the free-weight variant (tanh envelope, q and n free weights) instead of Eq. 8's exponential law");
  sub->add_flag("--force", c->force, "write the model even if the fit did not converge");
  sub->callback([c, &action] { action = [c] { return run_fit(*c); }; });
}

}  // namespace hysteron::cli
