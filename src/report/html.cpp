// Self-contained HTML reports of experiments and fits (plots as inline SVG).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <span>
#include <utility>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

#include "common.hpp"

namespace hysteron::report {

using detail::now_utc;
using detail::num;
using detail::variant_color;

namespace fs = std::filesystem;

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace detail {

std::string page_head(std::string_view title, std::string_view command_line, int max_width_px,
                      std::string_view extra_css) {
  return fmt::format(R"(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="generator" content="hysteron {ver}">
<title>{title}</title>
<style>
body {{ font-family: Helvetica, Arial, sans-serif; margin: 2em auto; max-width: {width}px; color: #222; background: #fff; }}
h1 {{ font-size: 1.6em; margin-bottom: 0.2em; }}
h2 {{ font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }}
.meta {{ color: #555; font-size: 0.9em; }}
code, pre {{ background: #f4f4f4; padding: 0.1em 0.3em; border-radius: 3px; font-size: 0.9em; }}
pre {{ padding: 0.6em; overflow-x: auto; white-space: pre-wrap; }}
table {{ border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }}
th, td {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }}
th {{ background: #eef2f7; }}
td.l, th.l {{ text-align: left; }}
figure.plot {{ margin: 1.2em 0; }}
figure.plot svg {{ max-width: 100%; height: auto; border: 1px solid #e4e4e4; }}
figcaption {{ font-size: 0.9em; color: #444; margin-top: 0.3em; }}
.warn {{ color: #a40000; }}
{extra}</style>
</head>
<body>
<h1>{title}</h1>
<p class="meta">hysteron {ver} &middot; generated {date}<br>command: <code>{cmd}</code></p>
)",
                     fmt::arg("ver", hysteron_version), fmt::arg("title", html_escape(title)),
                     fmt::arg("width", max_width_px), fmt::arg("extra", extra_css), fmt::arg("date", now_utc()),
                     fmt::arg("cmd", html_escape(command_line)));
}

}  // namespace detail

namespace {

using nlohmann::json;

// One HTML document under construction.
class Page {
 public:
  Page(const std::string& title, const std::string& command_line)
      : html_(detail::page_head(title, command_line, 1000, "tr.published td { background: #fff7e0; font-style: italic; }\n")) {}
  void raw(std::string_view s) { html_ += s; }
  void heading(std::string_view s) { html_ += fmt::format("<h2>{}</h2>\n", html_escape(s)); }
  void para(std::string_view s, std::string_view cls = "") {
    html_ += cls.empty() ? fmt::format("<p>{}</p>\n", html_escape(s))
                         : fmt::format("<p class=\"{}\">{}</p>\n", cls, html_escape(s));
  }
  // A figure: the plot rendered as inline SVG (the XML prolog removed).
  void figure(const PlotSpec& spec, std::string_view caption) {
    const std::string svg = render(spec, "svg");
    const auto start = svg.find("<svg");
    if (start == std::string::npos) throw Error(fmt::format("plot '{}': gnuplot wrote no SVG", spec.labels.title));
    html_ += fmt::format("<figure class=\"plot\" id=\"fig-{}\">\n{}\n<figcaption>{}</figcaption>\n</figure>\n",
                         ++figures_, svg.substr(start), html_escape(caption));
  }
  // A table: header row, then rows of already-escaped cells; the first column left-aligned.
  void table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
             const std::vector<std::string>& row_classes = {}) {
    html_ += "<table>\n<tr>";
    for (std::size_t i = 0; i < header.size(); ++i)
      html_ += fmt::format("<th{}>{}</th>", i == 0 ? " class=\"l\"" : "", html_escape(header[i]));
    html_ += "</tr>\n";
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const std::string cls = r < row_classes.size() && !row_classes[r].empty()
                                  ? fmt::format(" class=\"{}\"", row_classes[r]) : "";
      html_ += fmt::format("<tr{}>", cls);
      for (std::size_t i = 0; i < rows[r].size(); ++i)
        html_ += fmt::format("<td{}>{}</td>", i == 0 ? " class=\"l\"" : "", rows[r][i]);
      html_ += "</tr>\n";
    }
    html_ += "</table>\n";
  }
  int figures() const { return figures_; }
  std::string finish() { return html_ + "</body>\n</html>\n"; }

 private:
  std::string html_;
  int figures_ = 0;
};

// Model parameters (the model-file keys) as table rows.
std::vector<std::vector<std::string>> model_rows(const ModelParams& model) {
  std::vector<std::vector<std::string>> rows;
  const json j = io::model_to_json(model);
  for (const auto& [key, value] : j.items()) {
    if (key == "schema") continue;
    std::string v;
    if (value.is_number()) v = num(value.get<double>(), 6);
    else if (value.is_string()) v = html_escape(value.get<std::string>());
    else if (value.is_array() && std::all_of(value.begin(), value.end(), [](const json& e) { return e.is_number(); })) {
      for (std::size_t i = 0; i < value.size(); ++i) v += (i ? ", " : "") + num(value[i].get<double>(), 6);
    } else {
      v = "<code>" + html_escape(value.dump()) + "</code>";
    }
    rows.push_back({html_escape(key), v});
  }
  return rows;
}

std::vector<std::string> metric_cells(const std::string& what, const FitMetrics& m) {
  return {html_escape(what), num(m.rms), num(m.max), num(m.mae), num(m.rms_percent_span, 3), num(m.r2, 5),
          fmt::format("{}", m.n)};
}
const std::vector<std::string> metric_header = {"range", "RMS", "max |e|", "MAE", "RMS [% of span]", "R²", "samples"};

// A record scored as `hysteron fit` / `evaluate` scored it: a clipped output as censored data
// where FitData::censor_clipped (`censored` receives the count), else as recorded.
FitMetrics score(const FitData& data, const ModelParams& m, std::span<const double> x, std::span<const double> y,
                 IndexRange range, std::size_t* censored = nullptr) {
  return evaluate_scored(m, x, y, range, data.initial_state, data.censor_clipped, censored);
}

void parameter_table(Page& page, const FitReport& fit) {
  if (fit.parameters.empty()) return;
  std::vector<std::vector<std::string>> rows;
  for (const auto& p : fit.parameters)
    rows.push_back({html_escape(p.name), num(p.value, 7), p.held ? "held" : p.at_bound ? "at bound" : num(p.std_error, 3),
                    std::isfinite(p.std_error) && p.value != 0 && !p.held && !p.at_bound
                        ? num(100.0 * p.std_error / std::abs(p.value), 3) : "&ndash;"});
  page.table({"parameter", "value", "std. error", "rel. error [%]"}, rows);
  if (!fit.covariance_note.empty()) page.para("Standard errors: " + fit.covariance_note);
}

std::vector<double> difference(std::span<const double> a, std::span<const double> b) {
  std::vector<double> d(std::min(a.size(), b.size()));
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = a[i] - b[i];
  return d;
}

json parse_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the file", path));
  std::stringstream ss;
  ss << in.rdbuf();
  return io::parse_json(ss.str(), path);
}

std::vector<double> column(const io::Table& t, const std::string& name, const std::string& where) {
  try {
    return t.column(name);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", where, e.what()));
  }
}

}  // namespace

// ---- experiment ------------------------------------------------------------------

void write_experiment_report(const ExperimentResult& r, const std::string& html_path,
                             const std::string& command_line) {
  Page page(fmt::format("hysteron experiment {}: {}", r.name, r.title), command_line);
  page.para(fmt::format("Simulated rig, noise seed {}; every loop ran at a control period of {:g} ms; the experiment "
                        "took {:.1f} s of wall time. Positions are muscle contractions in mm, pressures gauge pressures "
                        "in MPa.",
                        r.seed, r.control_period_s * 1e3, r.wall_time_s));
  // the run's actuator limit and reach (docs/control.md, sections 0 and 5)
  std::string limits;
  if (std::isfinite(r.pressure_limit_mpa) && r.pressure_limit_mpa > 0.0)
    limits = fmt::format("Every pressure command lies within 0..{:.3f} MPa, this rig's actuator limit.",
                         r.pressure_limit_mpa);
  if (std::isfinite(r.reach_min_mm) && std::isfinite(r.reach_max_mm))
    limits += fmt::format("{}The identification run reached {:.1f}..{:.1f} mm{}.", limits.empty() ? "" : " ",
                          r.reach_min_mm, r.reach_max_mm,
                          std::isfinite(r.reach_top_mm)
                              ? fmt::format("; the references are kept below {:.1f} mm, where its ascent reached "
                                            "{:.3f} MPa",
                                            r.reach_top_mm, r.reach_top_pressure_mpa)
                              : std::string());
  if (!limits.empty()) page.para(limits);

  // tracking errors beside the published figures
  page.heading("Tracking errors");
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> classes;
  for (const auto& run : r.runs) {
    rows.push_back({html_escape(run.reference), html_escape(run.variant), num(run.errors.max_error_mm),
                    num(run.errors.mae_mm), num(run.errors.rms_error_mm), fmt::format("{}", run.saturated),
                    "<span style=\"text-align:left\">" + html_escape(run.description) + "</span>"});
    classes.emplace_back();
  }
  for (const auto& e : r.published.errors) {
    rows.push_back({html_escape(e.reference.empty() ? std::string("paper") : e.reference), "published",
                    num(e.max_error_mm), num(e.mae_mm), num(e.rms_error_mm), "&ndash;",
                    html_escape(r.published.source.empty() ? std::string("published") : r.published.source)});
    classes.emplace_back("published");
  }
  page.table({"reference", "variant", "max [mm]", "MAE [mm]", "RMS [mm]", "saturated samples", "description"}, rows,
             classes);
  if (r.published.empty())
    page.para("The paper's text ends before its results: there are no published figures to compare.");
  if (const auto useless = r.not_below_baseline(); !useless.empty())
    page.raw(fmt::format("<p><strong>Not below the baseline:</strong> {}. On this rig the compensation does no better "
                         "than a straight line for the hysteresis; the notes below say why.</p>\n",
                         html_escape(fmt::format("{}", fmt::join(useless, ", ")))));
  if (!r.messages.empty()) {
    // e.g. a reference mapped into the rig's reach (docs/control.md, section 5), a skipped variant
    page.raw("<h3>Notes of the run</h3>\n<ul>\n");
    for (const auto& m : r.messages) page.raw(fmt::format("<li>{}</li>\n", html_escape(m)));
    page.raw("</ul>\n");
  }

  // identification
  page.heading("Identification");
  page.para(fmt::format("The paper's model ({}) fitted on the major loop ({}): status {}{}{}.",
                        fit_model_name(r.fit.model_kind),
                        r.id_train_end > 0 ? fmt::format("samples 0..{} of {}", r.id_train_end, r.identification.size())
                                           : std::string("training range not recorded"),
                        fit_status_name(r.fit.status), r.fit.message.empty() ? "" : ", ", r.fit.message));
  page.table(metric_header, {metric_cells("major loop (training) [mm]", r.fit.train),
                             metric_cells("minor loops (validation) [mm]", r.validation),
                             metric_cells(fmt::format("best model ({}), second run [mm]",
                                                      fit_model_name(r.best_fit.model_kind)),
                                          r.best_validation)});
  if (!r.model_reason.empty()) page.para(fmt::format("Model of the compensated variants: {}.", r.model_reason));
  if (!r.candidates.empty()) {
    std::vector<std::vector<std::string>> cand;
    for (const auto& c : r.candidates) {
      cand.push_back({html_escape(std::string(fit_model_name(c.kind))) + (c.chosen ? " (chosen)" : ""),
                      c.ok ? num(c.validation.rms) : std::string("&ndash;"),
                      c.ok ? num(c.validation.rms_percent_span, 3) : std::string("&ndash;"), num(c.fit_time_s, 3),
                      html_escape(std::string(fit_status_name(c.status))), html_escape(c.message)});
    }
    page.raw("<h3>Candidates for the compensated variants' model</h3>\n");
    page.table({"kind", "RMS, second run [mm]", "RMS [% of span]", "fit time [s]", "fit status", "note"}, cand);
  }
  parameter_table(page, r.fit);
  page.raw("<h3>Fitted model (model.json)</h3>\n");
  page.table({"key", "value"}, model_rows(r.fit.model));
  page.raw(fmt::format("<h3>Best model ({}, best_model.json)</h3>\n", fit_model_name(r.best_fit.model_kind)));
  page.table({"key", "value"}, model_rows(r.best_fit.model));

  // figures of the identification run
  page.heading("Figures");
  const Axis time{"Time", "s"}, pressure{"Pressure", "MPa"}, contraction{"Contraction", "mm"};
  if (const IdentificationRun& id = r.identification; !id.empty()) {
    page.figure({{"Identification input", time, pressure},
                 {{"pressure command", id.t, id.pressure_command_mpa, "lines", "#1f77b4", false},
                  {"measured pressure", id.t, id.pressure_mpa, "lines", "#d62728", false}}},
                "Identification input: the pressure command and the measured pressure (paper Fig. 4).");
    std::vector<double> model;
    try {
      model = simulate_record(r.fit.model, id.pressure_mpa);
    } catch (const Error& e) {
      page.para(fmt::format("The model cannot be simulated on the identification run: {}", e.what()), "warn");
    }
    const std::size_t n = id.t.size();
    const std::size_t split = r.id_train_end > 0 && r.id_train_end < n ? r.id_train_end : n;
    auto sub = [](const std::vector<double>& v, std::size_t b, std::size_t e) {
      return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(b), v.begin() + static_cast<std::ptrdiff_t>(e));
    };
    PlotSpec loops{{"Length/pressure hysteresis: measured and model", pressure, contraction}, {}};
    loops.series.push_back({split < n ? "measured, major loop" : "measured", sub(id.pressure_mpa, 0, split),
                            sub(id.contraction_mm, 0, split), "lines", "#d62728", false});
    if (split < n)
      loops.series.push_back({"measured, minor loops", sub(id.pressure_mpa, split, n),
                              sub(id.contraction_mm, split, n), "lines", "#ff9896", false});
    if (model.size() == n)
      loops.series.push_back({fmt::format("{} model", fit_model_name(r.fit.model_kind)), id.pressure_mpa, model,
                              "lines", "#1f77b4", true});
    page.figure(loops, "Measured contraction against pressure, major and minor loops, with the identified model "
                       "(paper Figs. 5 and 9).");
    if (model.size() == n)
      page.figure({{"Model residuals on the identification run", time, {"Residual (measured - model)", "mm"}},
                   {{"residual", id.t, difference(id.contraction_mm, model), "lines", "#2ca02c", false}}},
                  fmt::format("Fit residuals over the identification run; the model was trained on t < {:.3g} s.",
                              split < n ? id.t[split] : id.t.back()));
  }
  // the run hysteron's model was fitted on, where it is not the paper's
  if (const IdentificationRun& mid = r.model_identification; !mid.empty()) {
    std::vector<double> best;
    try {
      best = simulate_record(r.best_fit.model, mid.pressure_mpa);
    } catch (const Error& e) {
      page.para(fmt::format("The best model cannot be simulated on its identification run: {}", e.what()), "warn");
    }
    PlotSpec loops{{"hysteron's model on the run it was fitted on (model_identification.csv)", pressure, contraction},
                   {{"measured", mid.pressure_mpa, mid.contraction_mm, "lines", "#d62728", false}}};
    if (best.size() == mid.t.size())
      loops.series.push_back({fmt::format("{} model", fit_model_name(r.best_fit.model_kind)), mid.pressure_mpa,
                              best, "lines", "#1f77b4", true});
    page.figure(loops, fmt::format("hysteron's model ({}, best_model.json) was fitted on a run of the paper's input "
                                   "scaled to a top of {:.3f} MPa, not on the run above (docs/control.md, section 0).",
                                   fit_model_name(r.best_fit.model_kind), r.model_id_top_mpa));
    if (best.size() == mid.t.size())
      page.figure({{"hysteron's model's residuals on the run it was fitted on", time, {"Residual (measured - model)", "mm"}},
                   {{"residual", mid.t, difference(mid.contraction_mm, best), "lines", "#2ca02c", false}}},
                  fmt::format("Residuals of hysteron's model ({}) over the run it was fitted on (the whole run): RMS "
                              "{:.3f} mm.",
                              fit_model_name(r.best_fit.model_kind), compute_metrics(mid.contraction_mm, best).rms));
  }

  // tracking figures, one group per reference
  std::vector<std::string> refs;
  for (const auto& run : r.runs)
    if (std::find(refs.begin(), refs.end(), run.reference) == refs.end()) refs.push_back(run.reference);
  for (const auto& ref : refs) {
    PlotSpec track{{fmt::format("Trajectory tracking: {} reference", ref), time, contraction}, {}};
    PlotSpec err{{fmt::format("Tracking errors: {} reference", ref), time, {"Error (desired - measured)", "mm"}}, {}};
    PlotSpec dva{{fmt::format("Desired vs actual contraction: {} reference", ref), {"Desired contraction", "mm"},
                  {"Actual (measured) contraction", "mm"}},
                 {}};
    dva.equal_axes = true;
    dva.width = 700;
    dva.height = 640;
    bool first = true;
    double lo = INFINITY, hi = -INFINITY;
    for (const auto& run : r.runs) {
      if (run.reference != ref) continue;
      if (first) track.series.push_back({"desired", run.t, run.reference_mm, "lines", "#222222", true});
      first = false;
      track.series.push_back({run.variant, run.t, run.measured_mm, "lines", variant_color(run.variant), false});
      err.series.push_back({run.variant, run.t, difference(run.reference_mm, run.measured_mm), "lines",
                            variant_color(run.variant), false});
      dva.series.push_back({run.variant, run.reference_mm, run.measured_mm, "points", variant_color(run.variant),
                            false});
      for (double v : run.reference_mm)
        if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
    if (hi >= lo) dva.series.push_back({"ideal", {lo, hi}, {lo, hi}, "lines", "#222222", true});
    // the paper's figures beside a paper's reference; a user's (--reference) was in no paper
    const bool user = r.published.of_user_references();
    const auto paper_fig = [user](int n) { return user ? std::string() : fmt::format(" (paper Fig. {})", n); };
    page.figure(track, fmt::format("Desired and measured contraction, {} reference{}.", ref, paper_fig(11)));
    page.figure(err, fmt::format("Tracking errors, {} reference{}.", ref, paper_fig(12)));
    page.figure(dva, fmt::format("Measured against desired contraction, {} reference: a straight line means the "
                                 "hysteresis is compensated{}.", ref, paper_fig(13)));
    for (const auto& run : r.runs) {
      if (run.reference != ref || run.periods.empty()) continue;
      PlotSpec per{{fmt::format("Learning: error of each period, {} reference", ref), {"Period", ""},
                    {"Error", "mm"}},
                   {}};
      std::vector<double> k, rms, mx;
      for (std::size_t i = 0; i < run.periods.size(); ++i) {
        k.push_back(static_cast<double>(i + 1));
        rms.push_back(run.periods[i].rms_error_mm);
        mx.push_back(run.periods[i].max_error_mm);
      }
      per.series.push_back({"RMS", k, rms, "linespoints", variant_color(run.variant), false});
      per.series.push_back({"max", k, mx, "linespoints", "#7f7f7f", true});
      page.figure(per, fmt::format("Iterative learning on the {} reference: RMS and maximum error of each period "
                                   "(the tracking plots above show all {} periods).", ref, run.periods.size()));
    }
  }
  io::write_text_file(html_path, page.finish());
}

ExperimentResult read_experiment_dir(const std::string& dir) {
  if (!fs::is_directory(dir)) throw Error(fmt::format("{}: not an experiment output directory", dir));
  const fs::path d(dir);
  const std::string rj = (d / "result.json").string();
  if (!fs::exists(rj)) throw Error(fmt::format("{}: missing file (is {} the output of `hysteron experiment "
                                               "NAME --out DIR`?)", rj, dir));
  // the summary (io::from_json), then the models and series from their files
  ExperimentResult r = io::from_json<ExperimentResult>(parse_json_file(rj), rj);
  auto need_file = [&](const char* name) {
    const std::string p = (d / name).string();
    if (!fs::exists(p)) throw Error(fmt::format("{}: missing file in the experiment directory", p));
    return p;
  };
  r.fit.model = io::read_model_file(need_file("model.json"));
  r.best_fit.model = fs::exists(d / "best_model.json") ? io::read_model_file((d / "best_model.json").string())
                                                       : r.fit.model;
  // an identification run's CSV (identification.csv, model_identification.csv)
  auto read_id_run = [](const std::string& path) {
    const io::Table t = io::read_table(path);
    return IdentificationRun{column(t, "t_s", path), column(t, "pressure_command_mpa", path),
                             column(t, "pressure_mpa", path), column(t, "contraction_mm", path)};
  };
  r.identification = read_id_run(need_file("identification.csv"));
  if (const fs::path mic = d / "model_identification.csv"; fs::exists(mic))  // absent: the paper's run
    r.model_identification = read_id_run(mic.string());

  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(d)) {
    const std::string f = e.path().filename().string();
    if (f.starts_with("tracking_") && f.ends_with(".csv")) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  std::vector<bool> used(files.size(), false);
  auto load_series = [&](TrackingRun& run, const fs::path& p) {
    const std::string ps = p.string();
    const io::Table tt = io::read_table(ps);
    run.t = column(tt, "t_s", ps);
    run.reference_mm = column(tt, "reference_mm", ps);
    run.measured_mm = column(tt, "measured_mm", ps);
    run.actual_mm = column(tt, "actual_mm", ps);
    run.pressure_command_mpa = column(tt, "pressure_command_mpa", ps);
    run.pressure_mpa = column(tt, "pressure_mpa", ps);
    run.duty = column(tt, "pwm_duty", ps);
    // the pressure sensor's reading (written since 2026-11-26)
    if (std::find(tt.names.begin(), tt.names.end(), "pressure_measured_mpa") != tt.names.end())
      run.pressure_measured_mpa = column(tt, "pressure_measured_mpa", ps);
    // learning runs: the correction they applied (ExperimentResult::write)
    if (std::find(tt.names.begin(), tt.names.end(), "correction_mm") != tt.names.end())
      run.correction_mm = column(tt, "correction_mm", ps);
  };
  // the runs the summary lists: each needs its series (a summary without the reference
  // name, from an older hysteron, takes the variant's only file)
  for (auto& run : r.runs) {
    const std::string prefix = fmt::format("tracking_{}_", run.variant);
    std::size_t found = files.size();
    for (std::size_t i = 0; i < files.size(); ++i) {
      const std::string f = files[i].filename().string();
      if (!f.starts_with(prefix)) continue;
      const std::string ref = f.substr(prefix.size(), f.size() - prefix.size() - 4);
      if (run.reference.empty() ? !used[i] : ref == run.reference) {
        found = i;
        if (run.reference.empty()) run.reference = ref;
        break;
      }
    }
    if (found == files.size())
      throw Error(fmt::format("{}: missing file (result.json lists a {} run{})",
                              (d / fmt::format("tracking_{}_{}.csv", run.variant,
                                               run.reference.empty() ? "*" : run.reference)).string(),
                              run.variant, run.reference.empty() ? "" : " for the " + run.reference + " reference"));
    used[found] = true;
    load_series(run, files[found]);
  }
  // series the summary does not list: errors recomputed from the series
  for (std::size_t i = 0; i < files.size(); ++i) {
    if (used[i]) continue;
    const std::string f = files[i].filename().string();
    {
      // tracking_<variant>_<reference>.csv (neither name has an underscore)
      const std::size_t us = f.find('_', 9);
      if (!f.starts_with("tracking_") || us == std::string::npos) continue;
      const std::string variant = f.substr(9, us - 9);
      const std::string prefix = fmt::format("tracking_{}_", variant);
      TrackingRun run;
      run.variant = variant;
      run.reference = f.substr(prefix.size(), f.size() - prefix.size() - 4);
      load_series(run, files[i]);
      double sa = 0, s2 = 0, mx = 0;
      for (std::size_t k = 0; k < run.t.size(); ++k) {
        const double er = std::abs(run.reference_mm[k] - run.measured_mm[k]);
        sa += er, s2 += er * er, mx = std::max(mx, er);
      }
      const double n = std::max<double>(1.0, static_cast<double>(run.t.size()));
      run.errors = {mx, sa / n, std::sqrt(s2 / n)};
      r.runs.push_back(std::move(run));
    }
  }
  if (r.runs.empty())
    throw Error(fmt::format("{}: no tracking_<variant>_<reference>.csv file in the experiment directory", dir));
  return r;
}

// ---- fit -------------------------------------------------------------------------

namespace {

// Errors, loops, output over the record and residuals of `model` on one record.
struct RecordView {
  std::string name;  // caption suffix, e.g. "validation: b.csv"; "" for the main record
  std::span<const double> x, y, t;
};

std::vector<double> sample_axis(std::size_t n) {
  std::vector<double> t(n);
  for (std::size_t i = 0; i < n; ++i) t[i] = static_cast<double>(i);
  return t;
}

// Simulates `model` on the record; empty (and a warning on the page) if it cannot.
std::vector<double> try_simulate(Page& page, const ModelParams& model, std::span<const double> x,
                                 InitialState initial, const std::string& what) {
  try {
    return simulate_record(model, x, initial);
  } catch (const Error& e) {
    page.para(fmt::format("The model cannot be simulated on {}: {}", what, e.what()), "warn");
    return {};
  }
}

// Figures of one record: loops (output against input), output over the record, residuals, each series
// thinned to the points a plot draws (thinned_series: a long record is not copied whole).
// The samples of the runs of one column (input or output) of `faults` within [0, n), as points of (a, b): the
// sensor-fault rows a fit's warnings name, drawn over its record's figures.
std::optional<Series> fault_points(std::span<const SensorFaultRun> faults, bool input, std::span<const double> a,
                                   std::span<const double> b) {
  std::vector<double> pa, pb;
  for (const SensorFaultRun& f : faults)
    if (f.input == input)
      for (std::size_t k = f.rows.begin; k < std::min(f.rows.end, a.size()); ++k) pa.push_back(a[k]), pb.push_back(b[k]);
  if (pa.empty()) return std::nullopt;
  return thinned_series(input ? "input sensor fault (see the warnings)" : "output sensor fault (see the warnings)",
                        pa, pb, input ? "#ff7f0e" : "#9467bd", false, "points");
}

void record_figures(Page& page, const RecordView& v, std::span<const double> model, const std::string& kind,
                    const FitData& data, const std::string& range_note, bool with_series = true,
                    std::span<const SensorFaultRun> faults = {}) {
  const std::size_t n = std::min(v.x.size(), v.y.size());
  const std::string suffix = v.name.empty() ? "" : fmt::format(" ({})", v.name);
  const std::span<const double> xs = v.x.first(n), ys = v.y.first(n);
  const bool has_model = model.size() == n;
  const std::string faulty = faults.empty() ? "" : "; the rows the sensor-fault warnings name are marked";
  PlotSpec loops{{"Hysteresis loops: measured and model" + suffix, data.input, data.output},
                 {thinned_series("measured", xs, ys, "#d62728", false)}};
  if (has_model) loops.series.push_back(thinned_series(fmt::format("{} model", kind), xs, model, "#1f77b4", true));
  for (const bool input : {true, false})
    if (auto p = fault_points(faults, input, xs, ys)) loops.series.push_back(std::move(*p));
  page.figure(loops, fmt::format("{} against {}: measured and model{}{}.", data.output.label, data.input.label, suffix,
                                 faulty));
  const bool has_t = v.t.size() == n;
  const std::vector<double> index = has_t ? std::vector<double>{} : sample_axis(n);
  const std::span<const double> t = has_t ? v.t : std::span<const double>(index);
  const Axis ta = has_t ? Axis{"Time", "s"} : Axis{"Sample", ""};
  if (with_series) {
    PlotSpec ts{{"Output over the record" + suffix, ta, data.output},
                {thinned_series("measured", t, ys, "#d62728", false)}};
    if (has_model) ts.series.push_back(thinned_series("model", t, model, "#1f77b4", true));
    for (const bool input : {true, false})
      if (auto p = fault_points(faults, input, t, ys)) ts.series.push_back(std::move(*p));
    page.figure(ts, "Measured and model output over the record" + suffix + faulty + ".");
  }
  if (has_model) {
    const std::vector<double> residual = difference(ys, model);
    page.figure({{"Residuals" + suffix, ta, {"Residual (measured - model)", data.output.unit}},
                 {thinned_series("residual", t, residual, "#2ca02c", false)}},
                fmt::format("Residuals{}; {}.", suffix, range_note));
  }
}

std::string validation_name(const ValidationData& v) { return v.name.empty() ? std::string("this record") : v.name; }

}  // namespace

void write_fit_report(const FitReport& fit, const FitData& data, const std::string& html_path,
                      const std::string& command_line) {
  Page page(fmt::format("hysteron fit: {} model", fit_model_name(fit.model_kind)), command_line);
  if (!data.source.empty()) page.para("Data: " + data.source);
  page.heading("Result");
  page.table({"status", "message", "iterations (all starts)", "starts", "initial cost", "final cost", "time [s]"},
             {{html_escape(fit_status_name(fit.status)), html_escape(fit.message),
               fmt::format("{} ({})", fit.iterations, fit.total_iterations), fmt::format("{}", fit.num_starts),
               num(fit.initial_cost, 6), num(fit.final_cost, 6), num(fit.time_s, 3)}});
  if (fit.status == FitStatus::poor_fit)
    page.para(fmt::format("Poor fit: {}", fit.message), "warn");
  else if (!fit.ok())
    page.para(fmt::format("The fit did not converge ({}).", fit_status_name(fit.status)), "warn");
  if (!fit.warnings.empty()) {
    std::string list = "<ul class=\"warn\" id=\"warnings\">\n";
    for (const auto& w : fit.warnings) list += fmt::format("<li>{}</li>\n", html_escape(w));
    page.raw(list + "</ul>\n");
  }
  const std::string yu = data.output.unit.empty() ? "" : fmt::format(" [{}]", data.output.unit);
  const std::string xu = data.input.unit.empty() ? "" : fmt::format(" [{}]", data.input.unit);

  // reference PI and the inverse's slope and jumps
  if (fit.status != FitStatus::invalid_input && fit.status != FitStatus::not_run) {
    page.raw("<h3>Reference PI and inverse</h3>\n");
    page.table({"quantity", "value"},
               {{"reference PI, training RMS" + html_escape(yu), num(fit.reference.rms, 6)},
                {"reference PI, training RMS [% of span]", num(fit.reference.rms_percent_span, 4)},
                {html_escape(fmt::format("inverse: max slope [{} per {}]",
                                         data.input.unit.empty() ? "input unit" : data.input.unit,
                                         data.output.unit.empty() ? "output unit" : data.output.unit)),
                 num(fit.inverse.max_slope, 6)},
                {"inverse: max jump per sample" + html_escape(xu), num(fit.inverse.max_jump, 6)},
                {"measured input: max step per sample" + html_escape(xu), num(fit.inverse.max_input_step, 6)},
                {"model increasing", fit.inverse.increasing ? "yes" : "no (decreasing)"}});
  }

  const std::size_t n = std::min(data.x.size(), data.y.size());
  const bool can_simulate = fit.status != FitStatus::invalid_input && fit.status != FitStatus::not_run &&
                            fit.status != FitStatus::failed;
  // validation sets: their records and the fitted model on them
  struct Val {
    const ValidationData* v;
    std::span<const double> x, y, t;
    IndexRange range;
  };
  std::vector<Val> vals;
  for (const auto& v : data.validation) {
    const bool own = v.x.empty();
    Val e{&v, own ? std::span<const double>(data.x) : std::span<const double>(v.x),
          own ? std::span<const double>(data.y) : std::span<const double>(v.y),
          own ? std::span<const double>(data.t) : std::span<const double>(v.t), {}};
    e.range = v.range.resolved(std::min(e.x.size(), e.y.size()));
    vals.push_back(e);
  }
  auto metrics_on = [&](const ModelParams& m, const Val& v, std::size_t* censored = nullptr) -> std::optional<FitMetrics> {
    try {
      return score(data, m, v.x, v.y, v.range, censored);
    } catch (const Error&) {
      return std::nullopt;
    }
  };

  if (!fit.candidates.empty()) {
    page.raw("<h3>Candidates (--model auto)</h3>\n");
    // a row's status, parameters, train and validation RMS are its fold-0 fit's, not the chosen kind's refit
    const IndexRange f0 = fit.candidates.front().fit_range, whole = data.train.resolved(n);
    const bool chosen = std::any_of(fit.candidates.begin(), fit.candidates.end(), [](const auto& c) { return c.chosen; });
    page.para(fmt::format("Each row is the kind's fold-0 fit, trained on {}the training range without its last part"
                          "{}: its \"(fold 0)\" columns are that fit's{}.",
                          f0.end == IndexRange::npos ? "" : fmt::format("samples {}..{} (", f0.begin, f0.end),
                          f0.end == IndexRange::npos ? "" : ")",
                          chosen ? fmt::format(", not the chosen kind's refit on the whole training range (samples "
                                               "{}..{}), whose figures are those of the result above and of the "
                                               "errors below",
                                               whole.begin, whole.end)
                                 : std::string()));
    std::vector<std::string> header = {"kind", "status (fold 0)", "parameters", "train RMS (fold 0)" + yu,
                                       "hold-out RMS" + yu, "hold-out RMS [% of span]", "hold-out score"};
    for (const auto& v : vals)
      header.push_back(fmt::format("validation RMS (fold 0){} ({})", yu, validation_name(*v.v)));
    header.insert(header.end(), {"time [s]", "chosen"});
    std::vector<std::vector<std::string>> rows;
    std::vector<std::string> classes;
    for (const auto& c : fit.candidates) {
      std::vector<std::string> row = {html_escape(fit_model_name(c.kind)), html_escape(fit_status_name(c.status)),
                                      c.num_parameters ? std::to_string(c.num_parameters) : "-",
                                      num(c.train.rms, 5), num(c.holdout.rms, 5), num(c.holdout.rms_percent_span, 4),
                                      num(c.holdout_score, 4)};
      const bool usable = c.status != FitStatus::failed && c.status != FitStatus::invalid_input &&
                          c.status != FitStatus::not_run;
      for (const auto& v : vals) {
        const auto m = usable ? metrics_on(c.model, v) : std::nullopt;
        row.push_back(m ? num(m->rms, 5) : "&ndash;");
      }
      row.push_back(num(c.time_s, 3));
      row.push_back(c.chosen ? "<b>chosen</b>" : "");
      rows.push_back(std::move(row));
      classes.emplace_back(c.chosen ? "chosen" : "");
    }
    page.table(header, rows, classes);
    page.para("The kind with the lowest hold-out score (over the first and the last part of the training range, each "
              "predicted by a fit on the rest: the geometric mean of its RMS over the best kind's; within 2 % of the "
              "least score, the one with the fewest parameters) is chosen and refitted on the whole training range; "
              "the hold-out RMS is pooled over both parts; validation data never enter the choice.");
  }

  parameter_table(page, fit);
  if (can_simulate) {
    page.raw("<h3>Model file</h3>\n");
    page.table({"key", "value"}, model_rows(fit.model));
  }

  std::vector<double> model;
  if (can_simulate && n > 0) model = try_simulate(page, fit.model, std::span(data.x).first(n), data.initial_state, "the data");
  const IndexRange tr = data.train.resolved(n);
  page.heading("Errors");
  std::vector<std::vector<std::string>> rows;
  std::size_t own_censored = 0;  // the record's clipped samples scored as censored, as fit() fitted them
  if (model.size() == n && n > 0) {
    const std::span<const double> y = std::span(data.y).first(n);
    const std::vector<double> measured = data.censor_clipped && tr.end > tr.begin && tr.end <= n
                                             ? censor_clipped(y, model, tr, &own_censored)
                                             : std::vector<double>(y.begin(), y.end());
    auto metrics = [&](std::size_t b, std::size_t e) {
      return compute_metrics(std::span(measured).subspan(b, e - b), std::span(model).subspan(b, e - b));
    };
    if (tr.end > tr.begin && tr.end <= n) rows.push_back(metric_cells("training" + yu, metrics(tr.begin, tr.end)));
    if (tr.begin > 0 || tr.end < n) {
      if (tr.end < n) rows.push_back(metric_cells("after training (validation)" + yu, metrics(tr.end, n)));
      if (tr.begin > 0) rows.push_back(metric_cells("before training" + yu, metrics(0, tr.begin)));
      rows.push_back(metric_cells("whole record" + yu, metrics(0, n)));
    }
  } else {
    rows.push_back(metric_cells("training (from the fit)" + yu, fit.train));
  }
  if (can_simulate)
    for (const auto& v : vals) {
      std::size_t censored = 0;
      const auto m = metrics_on(fit.model, v, &censored);
      if (m)
        rows.push_back(metric_cells(fmt::format("validation: {}, samples {}..{}{}{}", validation_name(*v.v),
                                                v.range.begin, v.range.end,
                                                censored > 0 ? fmt::format(" ({} clipped samples censored)", censored)
                                                             : std::string(),
                                                yu),
                                    *m));
      else
        page.para(fmt::format("The model cannot be evaluated on {}: a useless validation (hysteron fit exits 3).",
                              validation_name(*v.v)),
                  "warn");
    }
  page.table(metric_header, rows);
  if (own_censored > 0)
    page.para(fmt::format("The output clips (a sensor's limit): {} samples of the record at the limit where the model "
                          "predicts beyond it are scored as censored, no error, as the fit treated them "
                          "(--censor-passes 0: as recorded).",
                          own_censored));

  page.heading("Figures");
  if (n == 0) {
    page.para("No data were given: no figures.", "warn");
  } else {
    record_figures(page, {"", std::span(data.x).first(n), std::span(data.y).first(n), data.t}, model,
                   std::string(fit_model_name(fit.model_kind)), data,
                   fmt::format("training samples {}..{} of {}", tr.begin, tr.end, n), true, fit.fault_runs);
    for (const auto& v : vals) {
      if (v.v->x.empty() || !can_simulate) continue;  // a range of the record above: already shown
      const std::vector<double> vm = try_simulate(page, fit.model, v.x, data.initial_state, v.v->name);
      record_figures(page, {"validation: " + v.v->name, v.x, v.y, v.t}, vm, std::string(fit_model_name(fit.model_kind)),
                     data, fmt::format("scored samples {}..{}", v.range.begin, v.range.end), false);
    }
  }
  io::write_text_file(html_path, page.finish());
}

// What the evaluation page shows for a count its document does not record.
constexpr std::string_view kNotRecorded = "not recorded in this document";

// The evaluation page: the evaluated range's metrics are the document's (doc.result), and it
// shows what the document records besides (censored samples, samples outside the model's input
// limits, the output map).
void write_evaluation_report(const io::EvaluationDocument& doc, const FitData& data, const std::string& html_path,
                             const std::string& command_line) {
  const ModelParams& model = doc.model;
  const io::Evaluation& recorded = doc.result;
  Page page(fmt::format("hysteron evaluate: {} model", model_name(model)), command_line);
  page.para(fmt::format("Model: {}", doc.model_file));
  if (!data.source.empty()) page.para("Data: " + data.source);
  const std::size_t n = std::min(data.x.size(), data.y.size());
  const IndexRange range = data.train.resolved(n);
  const std::vector<double> y = try_simulate(page, model, std::span(data.x).first(n), data.initial_state, "the data");
  const std::string yu = data.output.unit.empty() ? "" : fmt::format(" [{}]", data.output.unit);
  if (doc.useless)
    page.para("The evaluation is useless: the model predicts the record worse than its mean (R² <= 0) with more "
              "than twice its training RMS error (evaluate exits 3).",
              "warn");
  if (!doc.warnings.empty()) {
    std::string list = "<ul class=\"warn\" id=\"warnings\">\n";
    for (const auto& w : doc.warnings) list += fmt::format("<li>{}</li>\n", html_escape(w));
    page.raw(list + "</ul>\n");
  }
  page.heading("Errors");
  if (y.size() == n && range.end <= n && range.begin < range.end) {
    // a record whose output clips: scored as censored, as `hysteron evaluate` scores it
    const std::span<const double> recorded_y = std::span(data.y).first(n);
    const std::vector<double> measured = data.censor_clipped ? censor_clipped(recorded_y, y, {}, nullptr)
                                                             : std::vector<double>(recorded_y.begin(), recorded_y.end());
    std::vector<std::vector<std::string>> rows = {
        metric_cells(fmt::format("samples {}..{}{}", range.begin, range.end, yu), recorded.metrics)};
    if (range.begin > 0 || range.end < n) rows.push_back(metric_cells("whole record" + yu, compute_metrics(measured, y)));
    page.table(metric_header, rows);
    if (!doc.data.censored && !recorded.censored_recorded)
      page.para("This document was written before hysteron scored a record whose output clips as censored data "
                "(it records neither data.censored nor metrics.censored_samples): its metrics, and this page's, "
                "score the record as recorded.");
    if (recorded.censored > 0)
      page.para(fmt::format("The output clips (a sensor's limit): {} samples of the evaluated range at the limit where "
                            "the model predicts beyond it are scored as censored, no error (--uncensored: as "
                            "recorded).",
                            recorded.censored));
  }
  {
    // the rest of what `hysteron evaluate` recorded (io::Evaluation); a count a document from
    // before it was recorded lacks is unknown, not 0
    auto count_cell = [](bool was_recorded, std::size_t count) {
      return was_recorded ? fmt::format("{}", count) : std::string(kNotRecorded);
    };
    const OutputMap& m = recorded.output_map;
    page.raw("<h3>Recorded by the evaluation</h3>\n");
    const std::vector<std::pair<std::string, std::string>> recorded_rows = {
        {"censored samples (output at its clip limit, no error)", count_cell(recorded.censored_recorded, recorded.censored)},
        {"samples outside the model's input limits",
         count_cell(recorded.outside_input_limits_recorded, recorded.outside_input_limits)},
        {"output map: gain (record's output against the prediction)", num(m.gain, 6)},
        {"output map: offset" + yu, num(m.offset, 6)},
        {"output map: R² as recorded", num(m.r2, 5)},
        {"output map: R² mapped", num(m.r2_mapped, 5)},
        {"output map: RMS as recorded" + yu, num(m.rms, 6)},
        {"output map: RMS mapped" + yu, num(m.rms_mapped, 6)},
        {"output span on the range" + yu, num(m.span, 6)}};
    std::vector<std::vector<std::string>> rows;
    for (const auto& [what, value] : recorded_rows) rows.push_back({html_escape(what), value});
    page.table({"quantity", "value"}, rows);
  }
  page.raw("<h3>Model file</h3>\n");
  page.table({"key", "value"}, model_rows(model));
  page.heading("Figures");
  if (n == 0) {
    page.para("No data were given: no figures.", "warn");
  } else {
    record_figures(page, {"", std::span(data.x).first(n), std::span(data.y).first(n), data.t}, y,
                   std::string(model_name(model)), data,
                   fmt::format("scored samples {}..{} of {}", range.begin, range.end, n));
  }
  io::write_text_file(html_path, page.finish());
}

json fit_report_to_json(const FitReport& fit, const FitData& data, const FitDataSource& source) {
  io::FitDocument d;
  d.fit = fit;
  d.data.input_file = source.input_file;
  d.data.input_column = source.input_column;
  d.data.output_file = source.output_file;
  d.data.output_column = source.output_column;
  d.data.input_label = data.input.label;
  d.data.input_unit = data.input.unit;
  d.data.output_label = data.output.label;
  d.data.output_unit = data.output.unit;
  d.data.initial_state = data.initial_state;
  d.data.train = data.train;
  d.data.censored = data.censor_clipped;
  for (const auto& v : data.validation) {
    io::Evaluation e;
    e.file = v.name;
    e.range = v.range;
    if (fit.status != FitStatus::invalid_input) {
      try {
        e.metrics = score(data, fit.model, v.x.empty() ? data.x : v.x, v.x.empty() ? data.y : v.y, v.range, &e.censored);
      } catch (const Error& err) {  // listed unscored, with why (as hysteron fit does)
        e.metrics.rms = e.metrics.max = e.metrics.mae = e.metrics.rms_percent_span = e.metrics.r2 = std::nan("");
        e.error = err.what();
      }
    }
    d.validation.push_back(e);
  }
  return io::to_json(d);
}

namespace {

// ---- the data a fit or evaluation document names ---------------------------------

// data_override (hysteron report --data/--input/--output/--time-column/--time-unit/--no-time):
// each given field replaces the document's own, the others are kept (FitDataSource). A --time-unit
// where no time column is left would be ignored: an error naming the document.
void apply_data_override(io::DataDescription& d, const FitDataSource& o, const std::string& doc_path) {
  if (!o.input_file.empty()) {
    d.input_file = o.input_file;
    d.output_file = o.output_file.empty() ? o.input_file : o.output_file;
  }
  if (!o.input_column.empty()) d.input_column = o.input_column;
  if (!o.output_column.empty()) d.output_column = o.output_column;
  if (o.no_time) {
    d.time_column.clear();
    d.time_unit = "s";
  } else if (!o.time_column.empty()) {
    d.time_column = o.time_column;
    d.time_unit = o.time_unit;  // empty: the unit the file gives the column, else s (read_time_seconds)
  } else if (!o.time_unit.empty()) {
    d.time_unit = o.time_unit;  // the document's column, in another unit than it records (or s)
  }
  if (!o.time_unit.empty() && d.time_column.empty())
    throw Error(fmt::format("{}: data: --time-unit {} but {}", doc_path, o.time_unit,
                            o.no_time ? "--no-time draws against the sample index: drop one of them"
                                      : "the document names no time column: give the time column with --time-column "
                                        "NAME, or drop --time-unit"));
}

// A data file a document names: a relative path beside the document first, then from the
// current directory. Throws naming the document and the file.
std::string resolve_data_file(const std::string& doc_path, const std::string& file) {
  const std::string dw = doc_path + ": data";
  if (file.empty()) throw Error(fmt::format("{}: empty data file name", dw));
  const fs::path p(file);
  if (p.is_relative()) {
    const fs::path beside = fs::path(doc_path).parent_path() / p;
    if (fs::exists(beside)) return beside.string();
  }
  if (!fs::exists(p))
    throw Error(fmt::format("{}: data file {} not found (looked beside {} and in the current directory)", dw, file,
                            doc_path));
  return file;
}

// One column of a data file a document names (with its header's name and unit); a read error
// names the document, the column and (through the reader's message) the file.
io::NamedColumn read_named_document_column(const std::string& doc_path, const std::string& file,
                                           const std::string& column, std::string_view what,
                                           std::string_view remedy = {}) {
  try {
    io::ReadOptions o;
    o.column_spec = column;
    return io::read_named_column(file, o);
  } catch (const Error& e) {
    const std::string msg = e.what();
    // the readers' messages start with the file; where one does not, name it
    const std::string named = msg.starts_with(file) ? msg : fmt::format("{}: {}", file, msg);
    throw Error(fmt::format("{}: data: {} column {}: {}{}", doc_path, what, column.empty() ? "(none given)" : column,
                            named, remedy));
  }
}

// The time column of `file` in seconds: the column in its unit (data.time_unit; "s" in documents
// without it; empty, a --time-column without --time-unit: the unit the file gives the column
// ("t [ms]", a units row), else s; `unit` receives it) times its seconds; n values (the input's).
// `data`: the record's input and output columns where they were read from `file` (the time column
// must be neither). `reused`: the document's time column read from another file (--data without
// --time-column), whose stamps must then not go backwards: a column of another meaning is refused
// rather than drawn as time.
std::vector<double> read_time_seconds(const std::string& doc_path, const io::DataDescription& d,
                                      const std::string& file, std::size_t n, bool unit_given,
                                      std::string* unit = nullptr,
                                      std::span<const std::pair<std::string_view, const io::NamedColumn*>> data = {},
                                      bool reused = false) {
  const std::string_view remedy =
      "; give the file's time column (hysteron report --time-column NAME [--time-unit s|ms|us]) or draw against the "
      "sample index (--no-time)";
  io::NamedColumn c = read_named_document_column(doc_path, file, d.time_column, "time", remedy);
  const std::string whose = reused ? " (the document's, read from the file --data gives)" : "";
  for (const auto& [what, col] : data)
    if (col && io::NamedColumn::same(c, *col))
      throw Error(fmt::format("{}: data: the time column {}{} is the {} column of {}{}", doc_path, d.time_column, whose,
                              what, file, remedy));
  if (reused)
    for (std::size_t k = 1; k < c.values.size(); ++k)
      if (!(c.values[k] >= c.values[k - 1]))  // NaN too
        throw Error(fmt::format("{}: data: the time column {}{} goes backwards in {} at sample {} ({} after {}): it "
                                "is no time column there{}",
                                doc_path, d.time_column, whose, file, k, c.values[k], c.values[k - 1], remedy));
  // as fit and evaluate read it: the unit the file gives the column (io::time_unit_named) wherever it
  // gives one (each --validate-data file in its own), else the document's, else s; a --time-unit
  // given here that disagrees with the file is refused, as fit's and evaluate's is
  const std::string named =
      io::time_unit_named(c.unit, fmt::format("{}: data: the time column {} of {}", doc_path, d.time_column, file));
  if (unit_given && !named.empty() && named != d.time_unit)
    throw Error(fmt::format("{}: data: --time-unit {} but {} gives the time column {} the unit \"{}\": one of them "
                            "is wrong (drop --time-unit if the file is right)",
                            doc_path, d.time_unit, file, d.time_column, c.unit));
  // a file that names no unit: the user's --time-unit (fit's or this report's), else s, as fit read it
  const bool given = unit_given || d.time_unit_given;
  std::string u = !named.empty() ? named : given && !d.time_unit.empty() ? d.time_unit : std::string("s");
  const double to_s = io::time_unit_seconds(u, doc_path + ": data.time_unit");
  if (unit) *unit = u;
  std::vector<double> t = std::move(c.values);
  if (t.size() != n)
    throw Error(fmt::format("{}: data: time column {}: {} has {} values and {} input samples{}", doc_path,
                            d.time_column, file, t.size(), n, remedy));
  if (to_s != 1.0)
    for (double& v : t) v *= to_s;
  return t;
}

}  // namespace

std::string data_source_line(const io::DataDescription& d) {
  const std::string& yf = d.output_file.empty() ? d.input_file : d.output_file;
  auto col = [](const std::string& c) { return c.empty() ? std::string("-") : c; };
  const std::string time = d.time_column.empty()
                               ? std::string()
                               : fmt::format(", time column {} in {}", d.time_column, d.time_unit);
  if (yf == d.input_file)
    return fmt::format("{} (input column {}, output column {}{})", d.input_file, col(d.input_column),
                       col(d.output_column), time);
  return fmt::format("input {} (column {}{}), output {} (column {})", d.input_file, col(d.input_column), time, yf,
                     col(d.output_column));
}

namespace {

// The record a document's "data" object names (input, output, time in s), its axes, initial state,
// range (data.train) and censoring, read again. Throws naming the document and the file.
// --data without --time-column (or --no-time): the document's time column is read from the file given.
bool time_reused(const FitDataSource& o) { return !o.input_file.empty() && o.time_column.empty() && !o.no_time; }

// time_reused: the document's time column is read from a file given by --data (read_time_seconds).
FitData load_document_record(const std::string& doc_path, const io::DataDescription& d, bool time_unit_given,
                             bool time_reused) {
  if (d.input_file.empty())
    throw Error(fmt::format("{}: the report does not name its data: pass them (hysteron report {} --data FILE "
                            "--input COLUMN --output COLUMN)", doc_path, doc_path));
  const std::string dw = doc_path + ": data";
  const std::string xf = resolve_data_file(doc_path, d.input_file);
  const std::string yf = resolve_data_file(doc_path, d.output_file.empty() ? d.input_file : d.output_file);
  FitData out;
  io::NamedColumn in = read_named_document_column(doc_path, xf, d.input_column, "input");
  io::NamedColumn outc = read_named_document_column(doc_path, yf, d.output_column, "output");
  if (xf == yf && io::NamedColumn::same(in, outc))
    throw Error(fmt::format("{}: the input ({}) and the output ({}) are the same column of {}: give two different "
                            "columns (--input, --output)",
                            dw, d.input_column, d.output_column, xf));
  out.x = std::move(in.values);
  out.y = std::move(outc.values);
  if (out.x.size() != out.y.size())
    throw Error(fmt::format("{}: input and output have different lengths ({} in {}, {} in {})", dw, out.x.size(), xf,
                            out.y.size(), yf));
  io::DataDescription as_read = d;  // the time column's unit as read (--time-column without --time-unit)
  if (!d.time_column.empty()) {
    const std::pair<std::string_view, const io::NamedColumn*> cols[] = {{"input", &in},
                                                                       {"output", xf == yf ? &outc : nullptr}};
    out.t = read_time_seconds(doc_path, d, xf, out.x.size(), time_unit_given, &as_read.time_unit, cols, time_reused);
  }
  out.files = {xf, yf};
  out.source = data_source_line(as_read);
  out.input = {d.input_label, d.input_unit};
  out.output = {d.output_label, d.output_unit};
  out.initial_state = d.initial_state;
  out.train = d.train;
  out.censor_clipped = d.censored;
  return out;
}

// ---- the documents hysteron report reads -------------------------------------------

enum class DocumentKind { fit, evaluation };

// A document's kind by its "format" key (a fit report of an older hysteron has none). Throws
// naming the file and an unknown format.
DocumentKind document_kind(const json& j, const std::string& path) {
  if (j.is_object() && j.contains("format")) {
    const json& f = j["format"];
    if (f == std::string(io::fit_document_format)) return DocumentKind::fit;
    if (f == std::string(io::evaluation_document_format)) return DocumentKind::evaluation;
    throw Error(fmt::format("{}: unknown document format {} (hysteron report reads \"{}\", written by `hysteron fit "
                            "... --report FILE.json`, and \"{}\", written by `hysteron evaluate ... --report "
                            "FILE.json`)",
                            path, f.dump(), io::fit_document_format, io::evaluation_document_format));
  }
  const bool old_cli = j.is_object() && j.contains("status") && j.contains("model_kind") &&
                       j.contains("parameters") && j.contains("model");
  if (!old_cli)
    throw Error(fmt::format("{}: not a hysteron fit report or evaluation document (expected the output of `hysteron "
                            "fit ... --report FILE.json` or `hysteron evaluate ... --report FILE.json`)", path));
  return DocumentKind::fit;
}

LoadedFit read_fit_document(const json& j, const std::string& path, const FitDataSource& data_override) {
  // the document of `hysteron fit --report` ("format": "hysteron-fit-report"), or the
  // report of older versions (no "format"; the data then come from data_override)
  const bool ours = j.is_object() && j.contains("format");
  if (ours && (!j.contains("schema") || j["schema"] != fit_report_schema))
    throw Error(fmt::format("{}: unsupported fit report schema {} (this hysteron reads schema {})", path,
                            j.value("schema", json()).dump(), fit_report_schema));
  if (j["model"].is_null())
    throw Error(fmt::format("{}: the fit produced no model (status {})", path, j.value("status", std::string("?"))));
  io::FitDocument doc = io::from_json<io::FitDocument>(j, path);
  LoadedFit out;
  out.fit = doc.fit;
  io::DataDescription& d = doc.data;
  apply_data_override(d, data_override, path);
  if (!d.input_file.empty() && !j.contains("data") && j.contains("train") && j["train"].contains("range"))
    io::from_json(j["train"]["range"], d.train, path + ": train.range");
  const std::string dw = path + ": data";
  out.data = load_document_record(path, d, !data_override.time_unit.empty(), time_reused(data_override));
  // The data must be the record the fit used (-d names a file and columns by hand): another
  // record, or swapped columns, gave a report of the fit against data it never saw, silently.
  if (const FitMetrics& t = out.fit.train; t.n > 0) {
    const IndexRange tr = d.train.end > d.train.begin ? d.train : IndexRange{0, out.data.x.size()};
    if (tr.end > out.data.x.size())
      throw Error(fmt::format("{}: the fit's training range [{}, {}) lies beyond the {} samples of {}: not the record "
                              "the fit used",
                              dw, tr.begin, tr.end, out.data.x.size(), out.data.source));
    const FitMetrics again =
        evaluate_scored(out.fit.model, out.data.x, out.data.y, tr, d.initial_state, d.censored, nullptr);
    // a censored fit's metrics are those of the record censored by its last pass's input model,
    // the report censors with the final model: close, not equal
    const double tol = d.censored ? 0.1 : 1e-6;
    if (!(std::abs(again.rms - t.rms) <= tol * std::max(t.rms, again.rms) + 1e-300) || again.n != t.n)
      throw Error(fmt::format("{}: {} does not reproduce the fit's training RMS ({:.6g} over {} samples; the fit "
                              "reported {:.6g} over {}): not the record the fit used; give the data file and columns "
                              "the fit read (--data, --input, --output)",
                              dw, out.data.source, again.rms, again.n, t.rms, t.n));
  }
  for (const auto& e : doc.validation) {
    ValidationData v;
    v.name = e.file;
    v.range = e.range;
    if (!e.file.empty()) {
      const std::string vf = resolve_data_file(path, e.file);
      out.data.files.push_back(vf);
      io::NamedColumn vin = read_named_document_column(path, vf, d.input_column, "validation input");
      io::NamedColumn vout = read_named_document_column(path, vf, d.output_column, "validation output");
      v.x = std::move(vin.values);
      v.y = std::move(vout.values);
      if (!d.time_column.empty()) {
        const std::pair<std::string_view, const io::NamedColumn*> cols[] = {{"input", &vin}, {"output", &vout}};
        v.t = read_time_seconds(path, d, vf, v.x.size(), !data_override.time_unit.empty(), nullptr, cols);
      }
    }
    out.data.validation.push_back(std::move(v));
  }
  return out;
}

LoadedEvaluation read_evaluation_document(const json& j, const std::string& path, const FitDataSource& data_override) {
  LoadedEvaluation out;
  out.document = io::from_json<io::EvaluationDocument>(j, path);
  io::DataDescription& d = out.document.data;
  apply_data_override(d, data_override, path);
  out.data = load_document_record(path, d, !data_override.time_unit.empty(), time_reused(data_override));
  // The data must be the record evaluated (as for a fit: -d by hand, or a file changed since):
  // the model scored on it again gives the document's metrics. (from_json refuses a missing or
  // empty metrics.range; an end of null is the record's end.)
  io::Evaluation& r = out.document.result;
  const std::string dw = path + ": data";
  const std::size_t n = out.data.x.size();
  if (r.range.end == IndexRange::npos) r.range.end = n;
  if (r.range.end > n || r.range.begin >= r.range.end)
    throw Error(fmt::format("{}: the evaluated range [{}, {}) (metrics.range) lies beyond the {} samples of {}: not "
                            "the record the evaluation used",
                            dw, r.range.begin, r.range.end, n, out.data.source));
  const FitMetrics again =
      evaluate_scored(out.document.model, out.data.x, out.data.y, r.range, d.initial_state, d.censored, nullptr);
  const double tol = 1e-6;
  if (!(std::abs(again.rms - r.metrics.rms) <= tol * std::max(r.metrics.rms, again.rms) + 1e-300) ||
      again.n != r.metrics.n)
    throw Error(fmt::format("{}: {} does not reproduce the evaluation's RMS ({:.6g} over {} samples, scored {}; the "
                            "document records {:.6g} over {}): not the record the evaluation used; give the data "
                            "file and columns it read (--data, --input, --output)",
                            dw, out.data.source, again.rms, again.n,
                            d.censored ? "censored where the output clips" : "as recorded", r.metrics.rms,
                            r.metrics.n));
  out.data.train = r.range;  // the page's range label: the range the metrics are of
  return out;
}

// The page must not replace a data file the document named (`report ev.json --out track.csv`
// wrote HTML over the record). Throws naming both.
void refuse_data_file_as_output(const std::string& html_path, const std::string& input,
                                const std::vector<std::string>& files) {
  std::error_code ec;
  for (const std::string& f : files)
    if (fs::equivalent(html_path, f, ec))
      throw Error(fmt::format("{}: --out {} is the data file {} names ({}): nothing was written", html_path,
                              html_path, input, f));
}

}  // namespace

LoadedFit read_fit_report_json(const std::string& path, const FitDataSource& data_override) {
  const json j = parse_json_file(path);
  if (document_kind(j, path) != DocumentKind::fit)
    throw Error(fmt::format("{}: not a hysteron fit report (an evaluation document: `hysteron report` reads it)", path));
  return read_fit_document(j, path, data_override);
}

LoadedEvaluation read_evaluation_json(const std::string& path, const FitDataSource& data_override) {
  const json j = parse_json_file(path);
  if (document_kind(j, path) != DocumentKind::evaluation)
    throw Error(fmt::format("{}: not a hysteron evaluation document (a fit report: `hysteron report` reads it)", path));
  return read_evaluation_document(j, path, data_override);
}

void write_report_from(const std::string& input, const std::string& html_path, const std::string& command_line,
                       const FitDataSource& data_override) {
  if (fs::is_directory(input)) {
    const FitDataSource& o = data_override;
    if (!o.input_file.empty() || !o.input_column.empty() || !o.output_column.empty() || !o.time_column.empty() ||
        !o.time_unit.empty() || o.no_time)
      throw Error(fmt::format("{}: an experiment directory: --data, --input, --output, --time-column, --time-unit and "
                              "--no-time apply to fit and evaluation documents only (the experiment's records are "
                              "its own)",
                              input));
    write_experiment_report(read_experiment_dir(input), html_path, command_line);
  } else if (fs::is_regular_file(input)) {
    const json j = parse_json_file(input);
    if (document_kind(j, input) == DocumentKind::evaluation) {
      const LoadedEvaluation e = read_evaluation_document(j, input, data_override);
      refuse_data_file_as_output(html_path, input, e.data.files);
      write_evaluation_report(e.document, e.data, html_path, command_line);
    } else {
      const LoadedFit f = read_fit_document(j, input, data_override);
      refuse_data_file_as_output(html_path, input, f.data.files);
      write_fit_report(f.fit, f.data, html_path, command_line);
    }
  } else {
    throw Error(fmt::format("{}: no such file or directory (expected an experiment output directory, a fit report "
                            "or an evaluation JSON file)", input));
  }
}

}  // namespace hysteron::report
