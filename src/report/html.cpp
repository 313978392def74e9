// Self-contained HTML reports of experiments and fits (plots as inline SVG).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

namespace hysteron::report {

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

namespace {

using nlohmann::json;

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

std::string num(double v, int digits = 4) {
  if (!std::isfinite(v)) return "&ndash;";
  return fmt::format("{:.{}g}", v, digits);
}

// One HTML document under construction.
class Page {
 public:
  Page(const std::string& title, const std::string& command_line) {
    html_ = fmt::format(R"(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="generator" content="hysteron {ver}">
<title>{title}</title>
<style>
body {{ font-family: Helvetica, Arial, sans-serif; margin: 2em auto; max-width: 1000px; color: #222; background: #fff; }}
h1 {{ font-size: 1.6em; margin-bottom: 0.2em; }}
h2 {{ font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }}
.meta {{ color: #555; font-size: 0.9em; }}
code, pre {{ background: #f4f4f4; padding: 0.1em 0.3em; border-radius: 3px; font-size: 0.9em; }}
pre {{ padding: 0.6em; overflow-x: auto; white-space: pre-wrap; }}
table {{ border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }}
th, td {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }}
th {{ background: #eef2f7; }}
td.l, th.l {{ text-align: left; }}
tr.published td {{ background: #fff7e0; font-style: italic; }}
figure.plot {{ margin: 1.2em 0; }}
figure.plot svg {{ max-width: 100%; height: auto; border: 1px solid #e4e4e4; }}
figcaption {{ font-size: 0.9em; color: #444; margin-top: 0.3em; }}
.warn {{ color: #a40000; }}
</style>
</head>
<body>
<h1>{title}</h1>
<p class="meta">hysteron {ver} &middot; generated {date}<br>command: <code>{cmd}</code></p>
)",
                        fmt::arg("ver", hysteron_version), fmt::arg("title", html_escape(title)),
                        fmt::arg("date", now_utc()), fmt::arg("cmd", html_escape(command_line)));
  }
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

std::vector<double> difference(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> d(std::min(a.size(), b.size()));
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = a[i] - b[i];
  return d;
}

const char* variant_color(const std::string& v) {
  if (v == "compensated") return "#d62728";
  if (v == "faithful") return "#1f77b4";
  if (v == "baseline") return "#7f7f7f";
  return "#2ca02c";
}

json parse_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the file", path));
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return json::parse(ss.str());
  } catch (const json::parse_error& e) {
    throw Error(fmt::format("{}: malformed JSON: {}", path, e.what()));
  }
}

// j[key] with a clear error naming the file and the key path.
const json& need(const json& j, const std::string& key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw Error(fmt::format("{}: missing key \"{}\"", where, key));
  return j.at(key);
}
template <class T>
T get(const json& j, const std::string& key, const std::string& where) {
  const json& v = need(j, key, where);
  try {
    return v.get<T>();
  } catch (const json::exception&) {
    throw Error(fmt::format("{}: key \"{}\" has the wrong type ({})", where, key, v.type_name()));
  }
}

FitMetrics metrics_from(const json& j, const std::string& where) {
  FitMetrics m;
  m.rms = get<double>(j, "rms", where);
  m.max = get<double>(j, "max", where);
  m.mae = get<double>(j, "mae", where);
  m.rms_percent_span = get<double>(j, "rms_percent_span", where);
  m.r2 = get<double>(j, "r2", where);
  m.n = get<std::size_t>(j, "n", where);
  return m;
}

json metrics_to(const FitMetrics& m) {
  return {{"rms", m.rms}, {"max", m.max}, {"mae", m.mae}, {"rms_percent_span", m.rms_percent_span}, {"r2", m.r2},
          {"n", m.n}};
}

FitStatus status_from(const std::string& name, const std::string& where) {
  for (FitStatus s : {FitStatus::not_run, FitStatus::converged, FitStatus::no_convergence, FitStatus::failed,
                      FitStatus::invalid_input})
    if (fit_status_name(s) == name) return s;
  throw Error(fmt::format("{}: unknown fit status \"{}\"", where, name));
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
  page.para(fmt::format("Simulated rig, noise seed {}; the experiment took {:.1f} s of wall time. Positions are "
                        "muscle contractions in mm, pressures gauge pressures in MPa.",
                        r.seed, r.wall_time_s));

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
  const json& pub = r.published;
  if (pub.is_object()) {
    auto val = [](const json& o, const char* k) {
      return o.contains(k) && o[k].is_number() ? num(o[k].get<double>()) : std::string("&ndash;");
    };
    if (pub.contains("max_error_mm")) {
      rows.push_back({"paper", "published", val(pub, "max_error_mm"), val(pub, "mae_mm"), val(pub, "rms_error_mm"),
                      "&ndash;", html_escape(pub.value("source", std::string("published")))});
      classes.emplace_back("published");
    }
    for (const auto& [key, o] : pub.items())
      if (o.is_object() && o.contains("max_error_mm")) {
        rows.push_back({html_escape(key), "published", val(o, "max_error_mm"), val(o, "mae_mm"),
                        val(o, "rms_error_mm"), "&ndash;", html_escape(pub.value("source", std::string("published")))});
        classes.emplace_back("published");
      }
  }
  page.table({"reference", "variant", "max [mm]", "MAE [mm]", "RMS [mm]", "saturated samples", "description"}, rows,
             classes);
  if (pub.is_null()) page.para("The paper's text ends before its results: there are no published figures to compare.");

  // identification
  page.heading("Identification");
  page.para(fmt::format("The paper's model ({}) fitted on the major loop ({}): status {}{}{}.",
                        fit_model_name(r.fit.model_kind),
                        r.id_train_end > 0 ? fmt::format("samples 0..{} of {}", r.id_train_end, r.id_t.size())
                                           : std::string("training range not recorded"),
                        fit_status_name(r.fit.status), r.fit.message.empty() ? "" : ", ", r.fit.message));
  page.table(metric_header, {metric_cells("major loop (training) [mm]", r.fit.train),
                             metric_cells("minor loops (validation) [mm]", r.validation),
                             metric_cells(fmt::format("best model ({}), second run [mm]",
                                                      fit_model_name(r.best_fit.model_kind)),
                                          r.best_validation)});
  parameter_table(page, r.fit);
  page.raw("<h3>Fitted model (model.json)</h3>\n");
  page.table({"key", "value"}, model_rows(r.fit.model));
  page.raw(fmt::format("<h3>Best model ({}, best_model.json)</h3>\n", fit_model_name(r.best_fit.model_kind)));
  page.table({"key", "value"}, model_rows(r.best_fit.model));

  // figures of the identification run
  page.heading("Figures");
  const Axis time{"Time", "s"}, pressure{"Pressure", "MPa"}, contraction{"Contraction", "mm"};
  if (!r.id_t.empty()) {
    page.figure({{"Identification input", time, pressure},
                 {{"pressure command", r.id_t, r.id_pressure_command_mpa, "lines", "#1f77b4", false},
                  {"measured pressure", r.id_t, r.id_pressure_mpa, "lines", "#d62728", false}}},
                "Identification input: the pressure command and the measured pressure (paper Fig. 4).");
    std::vector<double> model;
    try {
      model = simulate_record(r.fit.model, r.id_pressure_mpa);
    } catch (const Error& e) {
      page.para(fmt::format("The model cannot be simulated on the identification run: {}", e.what()), "warn");
    }
    const std::size_t n = r.id_t.size();
    const std::size_t split = r.id_train_end > 0 && r.id_train_end < n ? r.id_train_end : n;
    auto sub = [](const std::vector<double>& v, std::size_t b, std::size_t e) {
      return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(b), v.begin() + static_cast<std::ptrdiff_t>(e));
    };
    PlotSpec loops{{"Length/pressure hysteresis: measured and model", pressure, contraction}, {}};
    loops.series.push_back({split < n ? "measured, major loop" : "measured", sub(r.id_pressure_mpa, 0, split),
                            sub(r.id_contraction_mm, 0, split), "lines", "#d62728", false});
    if (split < n)
      loops.series.push_back({"measured, minor loops", sub(r.id_pressure_mpa, split, n),
                              sub(r.id_contraction_mm, split, n), "lines", "#ff9896", false});
    if (model.size() == n)
      loops.series.push_back({fmt::format("{} model", fit_model_name(r.fit.model_kind)), r.id_pressure_mpa, model,
                              "lines", "#1f77b4", true});
    page.figure(loops, "Measured contraction against pressure, major and minor loops, with the identified model "
                       "(paper Figs. 5 and 9).");
    if (model.size() == n)
      page.figure({{"Model residuals on the identification run", time, {"Residual (measured - model)", "mm"}},
                   {{"residual", r.id_t, difference(r.id_contraction_mm, model), "lines", "#2ca02c", false}}},
                  fmt::format("Fit residuals over the identification run; the model was trained on t < {:.3g} s.",
                              split < n ? r.id_t[split] : r.id_t.back()));
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
    page.figure(track, fmt::format("Desired and measured contraction, {} reference (paper Fig. 11).", ref));
    page.figure(err, fmt::format("Tracking errors, {} reference (paper Fig. 12).", ref));
    page.figure(dva, fmt::format("Measured against desired contraction, {} reference: a straight line means the "
                                 "hysteresis is compensated (paper Fig. 13).", ref));
  }
  io::write_text_file(html_path, page.finish());
}

ExperimentResult read_experiment_dir(const std::string& dir) {
  if (!fs::is_directory(dir)) throw Error(fmt::format("{}: not an experiment output directory", dir));
  const fs::path d(dir);
  const std::string rj = (d / "result.json").string();
  if (!fs::exists(rj)) throw Error(fmt::format("{}: missing file (is {} the output of `hysteron experiment "
                                               "NAME --out DIR`?)", rj, dir));
  const json j = parse_json_file(rj);
  if (!j.is_object()) throw Error(fmt::format("{}: expected a JSON object", rj));
  if (j.contains("schema") && j["schema"] != 1)
    throw Error(fmt::format("{}: unsupported schema {} (this hysteron reads schema 1)", rj, j["schema"].dump()));
  if (!j.contains("experiment") || !j.contains("identification"))
    throw Error(fmt::format("{}: not an experiment result (no \"experiment\"/\"identification\" keys)", rj));
  ExperimentResult r;
  r.name = get<std::string>(j, "experiment", rj);
  r.title = get<std::string>(j, "title", rj);
  r.seed = get<std::uint64_t>(j, "seed", rj);
  r.published = j.value("published", json());
  r.wall_time_s = j.value("wall_time_s", 0.0);
  const json& id = need(j, "identification", rj);
  const std::string idw = rj + ": identification";
  r.fit.model_kind = fit_model_from_name(get<std::string>(id, "model", idw));
  r.fit.status = status_from(get<std::string>(id, "status", idw), idw);
  r.fit.train = metrics_from(need(id, "train", idw), idw + ".train");
  r.validation = metrics_from(need(id, "validate", idw), idw + ".validate");
  r.fit.time_s = id.value("fit_time_s", 0.0);
  r.id_train_end = id.value("train_end", std::size_t{0});
  if (j.contains("best_model")) {
    const json& b = j["best_model"];
    r.best_fit.model_kind = fit_model_from_name(get<std::string>(b, "model", rj + ": best_model"));
    if (b.contains("validate_second_run"))
      r.best_validation = metrics_from(b["validate_second_run"], rj + ": best_model.validate_second_run");
  }
  auto need_file = [&](const char* name) {
    const std::string p = (d / name).string();
    if (!fs::exists(p)) throw Error(fmt::format("{}: missing file in the experiment directory", p));
    return p;
  };
  r.fit.model = io::read_model_file(need_file("model.json"));
  r.best_fit.model = fs::exists(d / "best_model.json") ? io::read_model_file((d / "best_model.json").string())
                                                       : r.fit.model;
  const std::string idc = need_file("identification.csv");
  const io::Table t = io::read_table(idc);
  r.id_t = column(t, "t_s", idc);
  r.id_pressure_command_mpa = column(t, "pressure_command_mpa", idc);
  r.id_pressure_mpa = column(t, "pressure_mpa", idc);
  r.id_contraction_mm = column(t, "contraction_mm", idc);

  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(d)) {
    const std::string f = e.path().filename().string();
    if (f.starts_with("tracking_") && f.ends_with(".csv")) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const char* variant : {"compensated", "faithful", "baseline"}) {
    const json v = j.value(variant, json::object());
    for (const auto& p : files) {
      const std::string f = p.filename().string();
      const std::string prefix = fmt::format("tracking_{}_", variant);
      if (!f.starts_with(prefix)) continue;
      TrackingRun run;
      run.variant = variant;
      run.reference = f.substr(prefix.size(), f.size() - prefix.size() - 4);
      const json& e = v.contains("max_error_mm") ? v : v.value(run.reference, json::object());
      run.description = e.value("description", std::string());
      run.saturated = e.value("saturated_samples", std::size_t{0});
      const std::string ps = p.string();
      const io::Table tt = io::read_table(ps);
      run.t = column(tt, "t_s", ps);
      run.reference_mm = column(tt, "reference_mm", ps);
      run.measured_mm = column(tt, "measured_mm", ps);
      run.actual_mm = column(tt, "actual_mm", ps);
      run.pressure_command_mpa = column(tt, "pressure_command_mpa", ps);
      run.pressure_mpa = column(tt, "pressure_mpa", ps);
      run.duty = column(tt, "pwm_duty", ps);
      if (e.contains("max_error_mm")) {
        run.errors.max_error_mm = e["max_error_mm"].get<double>();
        run.errors.mae_mm = e.value("mae_mm", 0.0);
        run.errors.rms_error_mm = e.value("rms_error_mm", 0.0);
      } else {  // recompute from the series
        double sa = 0, s2 = 0, mx = 0;
        for (std::size_t i = 0; i < run.t.size(); ++i) {
          const double er = std::abs(run.reference_mm[i] - run.measured_mm[i]);
          sa += er, s2 += er * er, mx = std::max(mx, er);
        }
        const double n = std::max<double>(1.0, static_cast<double>(run.t.size()));
        run.errors = {mx, sa / n, std::sqrt(s2 / n)};
      }
      r.runs.push_back(std::move(run));
    }
    // the summary names a run whose series is missing
    for (const auto& [key, e] : v.items()) {
      const bool single = v.contains("max_error_mm");
      if (!single && !e.is_object()) continue;
      const std::string ref = single ? std::string() : key;
      const bool found = std::any_of(r.runs.begin(), r.runs.end(), [&](const TrackingRun& x) {
        return x.variant == variant && (single || x.reference == ref);
      });
      if (!found)
        throw Error(fmt::format("{}: missing file (result.json lists a {} run{})",
                                (d / fmt::format("tracking_{}_{}.csv", variant, single ? "*" : ref)).string(),
                                variant, single ? "" : " for the " + ref + " reference"));
      if (single) break;
    }
  }
  if (r.runs.empty())
    throw Error(fmt::format("{}: no tracking_<variant>_<reference>.csv file in the experiment directory", dir));
  return r;
}

// ---- fit -------------------------------------------------------------------------

void write_fit_report(const FitReport& fit, const FitData& data, const std::string& html_path,
                      const std::string& command_line) {
  Page page(fmt::format("hysteron fit: {} model", fit_model_name(fit.model_kind)), command_line);
  if (!data.source.empty()) page.para("Data: " + data.source);
  page.heading("Result");
  page.table({"status", "message", "iterations (all starts)", "starts", "initial cost", "final cost", "time [s]"},
             {{html_escape(fit_status_name(fit.status)), html_escape(fit.message),
               fmt::format("{} ({})", fit.iterations, fit.total_iterations), fmt::format("{}", fit.num_starts),
               num(fit.initial_cost, 6), num(fit.final_cost, 6), num(fit.time_s, 3)}});
  if (!fit.ok()) page.para(fmt::format("The fit did not converge ({}).", fit_status_name(fit.status)), "warn");
  parameter_table(page, fit);
  page.raw("<h3>Model file</h3>\n");
  page.table({"key", "value"}, model_rows(fit.model));

  const std::size_t n = std::min(data.x.size(), data.y.size());
  std::vector<double> model;
  if (fit.status != FitStatus::invalid_input && n > 0) {
    try {
      model = simulate_record(fit.model, data.x, data.initial_state);
    } catch (const Error& e) {
      page.para(fmt::format("The model cannot be simulated on the data: {}", e.what()), "warn");
    }
  }
  const IndexRange tr = data.train.resolved(n);
  page.heading("Errors");
  std::vector<std::vector<std::string>> rows;
  const std::string unit = data.output.unit.empty() ? "" : fmt::format(" [{}]", data.output.unit);
  if (model.size() == n && n > 0) {
    auto metrics = [&](std::size_t b, std::size_t e) {
      return compute_metrics(std::span(data.y).subspan(b, e - b), std::span(model).subspan(b, e - b));
    };
    if (tr.end > tr.begin && tr.end <= n) rows.push_back(metric_cells("training" + unit, metrics(tr.begin, tr.end)));
    if (tr.begin > 0 || tr.end < n) {
      if (tr.end < n) rows.push_back(metric_cells("after training (validation)" + unit, metrics(tr.end, n)));
      if (tr.begin > 0) rows.push_back(metric_cells("before training" + unit, metrics(0, tr.begin)));
      rows.push_back(metric_cells("whole record" + unit, metrics(0, n)));
    }
  } else {
    rows.push_back(metric_cells("training (from the fit)" + unit, fit.train));
  }
  page.table(metric_header, rows);

  page.heading("Figures");
  if (n == 0) {
    page.para("No data were given: no figures.", "warn");
  } else {
    std::vector<double> xs(data.x.begin(), data.x.begin() + static_cast<std::ptrdiff_t>(n));
    std::vector<double> ys(data.y.begin(), data.y.begin() + static_cast<std::ptrdiff_t>(n));
    PlotSpec loops{{"Hysteresis loops: measured and model", data.input, data.output},
                   {{"measured", xs, ys, "lines", "#d62728", false}}};
    if (model.size() == n)
      loops.series.push_back({fmt::format("{} model", fit_model_name(fit.model_kind)), xs, model, "lines", "#1f77b4",
                              true});
    page.figure(loops, "Output against input: measured and fitted model.");
    const bool has_t = data.t.size() == n;
    std::vector<double> t = has_t ? data.t : std::vector<double>(n);
    if (!has_t)
      for (std::size_t i = 0; i < n; ++i) t[i] = static_cast<double>(i);
    const Axis ta = has_t ? Axis{"Time", "s"} : Axis{"Sample", ""};
    PlotSpec ts{{"Output over the record", ta, data.output}, {{"measured", t, ys, "lines", "#d62728", false}}};
    if (model.size() == n) ts.series.push_back({"model", t, model, "lines", "#1f77b4", true});
    page.figure(ts, "Measured and model output over the record.");
    if (model.size() == n)
      page.figure({{"Fit residuals", ta, {"Residual (measured - model)", data.output.unit}},
                   {{"residual", t, difference(ys, model), "lines", "#2ca02c", false}}},
                  fmt::format("Residuals; training samples {}..{} of {}.", tr.begin, tr.end, n));
  }
  io::write_text_file(html_path, page.finish());
}

json fit_report_to_json(const FitReport& fit, const FitData& data, const FitDataSource& source) {
  json params = json::array();
  for (const auto& p : fit.parameters)
    params.push_back({{"name", p.name}, {"value", p.value},
                      {"std_error", std::isfinite(p.std_error) ? json(p.std_error) : json()}, {"held", p.held},
                      {"at_bound", p.at_bound}});
  json train_range = json::array({data.train.begin, data.train.end == IndexRange::npos ? json() : json(data.train.end)});
  return {{"format", "hysteron-fit-report"},
          {"schema", fit_report_schema},
          {"status", std::string(fit_status_name(fit.status))},
          {"message", fit.message},
          {"model_kind", std::string(fit_model_name(fit.model_kind))},
          {"initial_cost", fit.initial_cost},
          {"final_cost", fit.final_cost},
          {"iterations", fit.iterations},
          {"total_iterations", fit.total_iterations},
          {"num_starts", fit.num_starts},
          {"time_s", fit.time_s},
          {"covariance_note", fit.covariance_note},
          {"model", io::model_to_json(fit.model)},
          {"parameters", params},
          {"train", metrics_to(fit.train)},
          {"data",
           {{"input", {{"file", source.input_file}, {"column", source.input_column}}},
            {"output", {{"file", source.output_file}, {"column", source.output_column}}},
            {"input_axis", {{"label", data.input.label}, {"unit", data.input.unit}}},
            {"output_axis", {{"label", data.output.label}, {"unit", data.output.unit}}},
            {"initial_state", data.initial_state == InitialState::virgin ? "virgin" : "relaxed"},
            {"train", train_range}}}};
}

LoadedFit read_fit_report_json(const std::string& path, const FitDataSource& data_override) {
  const json j = parse_json_file(path);
  // two dialects: this file's ("format": "hysteron-fit-report", with "data"), and the
  // report of `hysteron fit --report` (no "format"; the data come from data_override)
  const bool ours = j.is_object() && j.value("format", std::string()) == "hysteron-fit-report";
  const bool cli = j.is_object() && !j.contains("format") && j.contains("status") && j.contains("model_kind") &&
                   j.contains("parameters") && j.contains("model");
  if (!ours && !cli)
    throw Error(fmt::format("{}: not a hysteron fit report (expected the output of `hysteron fit ... --report "
                            "FILE.json`)", path));
  if ((ours || j.contains("schema")) && (!j.contains("schema") || j["schema"] != fit_report_schema))
    throw Error(fmt::format("{}: unsupported fit report schema {} (this hysteron reads schema {})", path,
                            j.value("schema", json()).dump(), fit_report_schema));
  if (j["model"].is_null())
    throw Error(fmt::format("{}: the fit produced no model (status {})", path, j.value("status", std::string("?"))));
  LoadedFit out;
  FitReport& f = out.fit;
  f.status = status_from(get<std::string>(j, "status", path), path);
  f.message = j.value("message", std::string());
  f.model_kind = fit_model_from_name(get<std::string>(j, "model_kind", path));
  f.initial_cost = j.value("initial_cost", 0.0);
  f.final_cost = j.value("final_cost", 0.0);
  f.iterations = j.value("iterations", 0);
  f.total_iterations = j.value("total_iterations", 0);
  f.num_starts = j.value("num_starts", j.value("starts", 0));
  f.time_s = j.value("time_s", 0.0);
  f.covariance_note = j.value("covariance_note", std::string());
  f.model = io::model_from_json(need(j, "model", path), path + ": model");
  for (const auto& p : j.value("parameters", json::array())) {
    FitParameter fp;
    fp.name = get<std::string>(p, "name", path + ": parameters");
    fp.value = get<double>(p, "value", path + ": parameters");
    fp.std_error = p.contains("std_error") && p["std_error"].is_number() ? p["std_error"].get<double>()
                                                                        : std::numeric_limits<double>::quiet_NaN();
    fp.held = p.value("held", false);
    fp.at_bound = p.value("at_bound", false);
    f.parameters.push_back(fp);
  }
  if (j.contains("train")) f.train = metrics_from(j["train"], path + ": train");

  json d = j.value("data", json::object());
  if (!data_override.input_file.empty()) {
    d["input"] = {{"file", data_override.input_file}, {"column", data_override.input_column}};
    d["output"] = {{"file", data_override.output_file.empty() ? data_override.input_file : data_override.output_file},
                   {"column", data_override.output_column}};
  }
  if (!d.contains("input") || !d.contains("output"))
    throw Error(fmt::format("{}: the report does not name its data: pass them (hysteron report {} --data FILE "
                            "--input COLUMN --output COLUMN)", path, path));
  if (!d.contains("train") && j.contains("train") && j["train"].contains("range")) d["train"] = j["train"]["range"];
  const std::string dw = path + ": data";
  auto resolve = [&](const std::string& file) {
    if (file.empty()) throw Error(fmt::format("{}: empty data file name", dw));
    const fs::path p(file);
    if (p.is_relative()) {
      const fs::path beside = fs::path(path).parent_path() / p;
      if (fs::exists(beside)) return beside.string();
    }
    if (!fs::exists(p)) throw Error(fmt::format("{}: data file {} not found (looked beside {} and in the current "
                                                "directory)", dw, file, path));
    return file;
  };
  auto load = [&](const char* key) {
    const json& s = need(d, key, dw);
    const std::string file = resolve(get<std::string>(s, "file", dw + "." + key));
    const std::string col = s.value("column", std::string());
    return std::make_pair(io::read_column(file, col), fmt::format("{} (column {})", file, col.empty() ? "-" : col));
  };
  auto [x, xs] = load("input");
  auto [y, ys] = load("output");
  if (x.size() != y.size())
    throw Error(fmt::format("{}: input and output have different lengths ({} and {})", dw, x.size(), y.size()));
  out.data.x = std::move(x);
  out.data.y = std::move(y);
  out.data.source = fmt::format("input {}, output {}", xs, ys);
  auto axis = [&](const char* key, Axis def) {
    if (!d.contains(key)) return def;
    return Axis{d[key].value("label", def.label), d[key].value("unit", def.unit)};
  };
  out.data.input = axis("input_axis", {"Input", ""});
  out.data.output = axis("output_axis", {"Output", ""});
  if (out.data.input.label.empty()) out.data.input.label = "Input";
  if (out.data.output.label.empty()) out.data.output.label = "Output";
  out.data.initial_state = d.value("initial_state", std::string("virgin")) == "relaxed" ? InitialState::relaxed
                                                                                        : InitialState::virgin;
  if (d.contains("train") && d["train"].is_array() && d["train"].size() == 2) {
    out.data.train.begin = d["train"][0].is_number() ? d["train"][0].get<std::size_t>() : 0;
    out.data.train.end = d["train"][1].is_number() ? d["train"][1].get<std::size_t>() : IndexRange::npos;
  }
  return out;
}

void write_report_from(const std::string& input, const std::string& html_path, const std::string& command_line,
                       const FitDataSource& data_override) {
  if (fs::is_directory(input)) {
    write_experiment_report(read_experiment_dir(input), html_path, command_line);
  } else if (fs::is_regular_file(input)) {
    const LoadedFit f = read_fit_report_json(input, data_override);
    write_fit_report(f.fit, f.data, html_path, command_line);
  } else {
    throw Error(fmt::format("{}: no such file or directory (expected an experiment output directory or a fit "
                            "report JSON file)", input));
  }
}

}  // namespace hysteron::report
