// The HTML page of a plant-variant sweep (sweep.hpp): the errors of every variant
// and variant kind, the misses of issue 11's targets, and the RMS error against
// each parameter varied one at a time (inline SVG through gnuplot, as html.cpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>
#include <map>

#include "hysteron/error.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/report.hpp"
#include "hysteron/sweep.hpp"

#include "common.hpp"

namespace hysteron::report {

using detail::num;
using detail::variant_color;

namespace {

// The unit of a rig parameter in its JSON form (SI), for the plots' axes: the rig's parameter
// table's (rig_parameters); none for a dimensionless one or a path that is no parameter.
std::string unit_of(const std::string& path) {
  static const std::map<std::string, std::string> units = [] {
    std::map<std::string, std::string> m;
    for (const RigParameter& p : rig_parameters(PamRigParams{}))
      if (p.unit != "-") m.emplace(p.path, p.unit);
    return m;
  }();
  const auto it = units.find(path);
  return it == units.end() ? std::string() : it->second;
}

template <class T>
void add_unique(std::vector<T>& v, const T& x) {
  if (std::find(v.begin(), v.end(), x) == v.end()) v.push_back(x);
}

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

}  // namespace

std::string sweep_report_html(const SweepResult& r, const std::string& command_line) {
  std::string names;
  for (const auto& e : r.experiments) { names += (names.empty() ? "" : ", "); names += e; }
  const std::string title = fmt::format("hysteron sweep: {} over {} rigs", names, r.variants.size());
  // a wider page and narrower cells for the 12-column table; misses and the nominal rig marked
  std::string h = detail::page_head(title, command_line, 1200,
                                    "table { font-size: 0.88em; }\n"
                                    "th, td { padding: 0.25em 0.5em; }\n"
                                    "td.miss { background: #fde0e0; color: #a40000; font-weight: bold; }\n"
                                    "tr.nominal td { background: #f3f8ee; }\n"
                                    "tr.failed td { background: #fde0e0; }\n");
  h += fmt::format(
      "<p>Each experiment ran end to end (identification, fits, tracking) on every rig, rig noise seed {}, every loop "
      "at a control period of {:g} ms, {} at a "
      "time: {:.1f} s of wall time for {} runs. Errors are contraction tracking errors in mm (reference against the "
      "displacement sensor); the command range is the minimum and maximum pressure command in MPa over every variant "
      "kind. <i>comp/nom</i>: the compensated RMS over its value on the nominal rig; <i>comp/base</i>: over the "
      "baseline's RMS on the same rig. <i>model</i>: the kind of hysteron's model the compensated variants invert; "
      "<i>reference scale</i>: the reference as tracked over the published one (below 1: mapped into the rig's "
      "reach, docs/control.md section 5). Cells in red miss issue 11's targets: compensated RMS at most the variant's "
      "limit times nominal (1.5, 2 for the worst combination) and below the baseline's, commands inside 0 MPa "
      "to the rig's actuator limit (muscle.max_pressure, and regulator.max_command for the regulator experiments: 0.6 "
      "MPa on the nominal rig), the reference within the rig's reach.</p>\n",
      r.seed, r.control_period * 1e3, r.jobs, r.wall_time_s, r.runs.size());
  if (const std::string note = r.identification_note(); !note.empty())
    h += fmt::format("<p class=\"warn\">{}.</p>\n", html_escape(note));

  // the variants
  h += "<h2>Rigs</h2>\n<table>\n<tr><th class=\"l\">variant</th><th class=\"l\">overrides (values on the rig)</th>"
       "<th class=\"l\">varied parameter</th><th>RMS limit [x nominal]</th></tr>\n";
  for (const auto& v : r.variants) {
    std::string ov;
    for (std::size_t i = 0; i < v.variant.overrides.size(); ++i) {
      const auto& o = v.variant.overrides[i];
      { ov += (ov.empty() ? "" : "<br>"); ov += html_escape(to_string(o)); }
      if (o.percent && i < v.values.size()) ov += fmt::format(" ({})", num(v.values[i], 6));
    }
    h += fmt::format("<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td></tr>\n",
                     html_escape(v.variant.name), ov.empty() ? "&ndash; (base rig)" : ov,
                     html_escape(v.variant.group), v.variant.overrides.empty() ? "&ndash;" : num(v.variant.rms_ratio_limit));
  }
  h += "</table>\n";
  for (const auto& n : r.notes) h += fmt::format("<p>Note: {}</p>\n", html_escape(n));

  // target misses
  const auto misses = r.target_misses();
  h += "<h2>Issue 11's targets</h2>\n";
  if (misses.empty()) {
    h += "<p>Every run met the targets.</p>\n";
  } else {
    h += fmt::format("<p class=\"warn\">{} miss(es):</p>\n<ul>\n", misses.size());
    for (const auto& m : misses) h += fmt::format("<li>{}</li>\n", html_escape(m));
    h += "</ul>\n";
  }
  if (const auto above = r.learning_not_below_compensated(); !above.empty()) {
    h += fmt::format("<p class=\"warn\">{} learning run(s) not below their compensated loop:</p>\n<ul>\n",
                     above.size());
    for (const auto& m : above) h += fmt::format("<li>{}</li>\n", html_escape(m));
    h += "</ul>\n";
  }
  if (const auto useless = r.not_below_baseline(); !useless.empty()) {
    h += fmt::format("<p class=\"warn\">{} run(s) of hysteron's loops not below their baseline (<code>hysteron "
                     "experiment</code> exits 3 on such a rig; the sweep does not):</p>\n<ul>\n",
                     useless.size());
    for (const auto& m : useless) h += fmt::format("<li>{}</li>\n", html_escape(m));
    h += "</ul>\n";
  }
  if (const auto cut = r.guard_acted(); !cut.empty()) {
    h += fmt::format("<p>{} run(s) whose limit-cycle guard cut the PID's gains (they rang near the relay's period; "
                     "docs/control.md, section 2):</p>\n<ul>\n",
                     cut.size());
    for (const auto& m : cut) h += fmt::format("<li>{}</li>\n", html_escape(m));
    h += "</ul>\n";
  }

  // the kinds present
  std::vector<std::string> kinds;
  for (const auto& run : r.runs)
    for (const auto& e : run.runs) add_unique(kinds, e.kind);

  for (std::size_t e = 0; e < r.experiments.size(); ++e) {
    std::vector<std::string> refs;
    for (std::size_t v = 0; v < r.variants.size(); ++v)
      for (const auto& x : r.run(e, v).runs) add_unique(refs, x.reference);
    h += fmt::format("<h2>{}</h2>\n<table>\n<tr><th class=\"l\">variant</th><th class=\"l\">reference</th>",
                     html_escape(r.experiments[e]));
    for (const auto& k : kinds) h += fmt::format("<th>{0} RMS</th><th>{0} max</th>", html_escape(k));
    h += "<th>comp/nom</th><th>comp/base</th><th>command [MPa]</th><th class=\"l\">model</th>"
         "<th>reference scale</th><th>wall [s]</th></tr>\n";
    const std::size_t ncols = 2 + 2 * kinds.size() + 6;
    for (std::size_t v = 0; v < r.variants.size(); ++v) {
      const SweepRun& run = r.run(e, v);
      const std::string& vn = r.variants[v].variant.name;
      if (!run.ok) {
        h += fmt::format("<tr class=\"failed\"><td class=\"l\">{}</td><td class=\"l\" colspan=\"{}\">failed: {}</td></tr>\n",
                         html_escape(vn), ncols - 1, html_escape(run.error));
        continue;
      }
      for (const auto& ref : refs) {
        h += fmt::format("<tr{}><td class=\"l\">{}</td><td class=\"l\">{}</td>", v == 0 ? " class=\"nominal\"" : "",
                         html_escape(vn), html_escape(ref));
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (const auto& k : kinds) {
          const SweepRunErrors* x = r.find(e, v, ref, k);
          bool miss = false;
          if (x && k == "compensated") {
            const SweepRunErrors* n = r.find(e, 0, ref, k);
            const SweepRunErrors* b = r.find(e, v, ref, "baseline");
            miss = (v > 0 && n && x->errors.rms_error_mm > r.variants[v].variant.rms_ratio_limit * n->errors.rms_error_mm) ||
                   (b && !(x->errors.rms_error_mm < b->errors.rms_error_mm));
          }
          h += x ? fmt::format("<td{}>{}</td><td>{}</td>", miss ? " class=\"miss\"" : "", num(x->errors.rms_error_mm),
                               num(x->errors.max_error_mm))
                 : std::string("<td>&ndash;</td><td>&ndash;</td>");
          if (x && std::isfinite(x->min_command_mpa)) lo = std::min(lo, x->min_command_mpa), hi = std::max(hi, x->max_command_mpa);
        }
        const SweepRunErrors* c = r.find(e, v, ref, "compensated");
        const SweepRunErrors* n = r.find(e, 0, ref, "compensated");
        const SweepRunErrors* b = r.find(e, v, ref, "baseline");
        const double rn = c && n && n->errors.rms_error_mm > 0 ? c->errors.rms_error_mm / n->errors.rms_error_mm : nan;
        const double rb = c && b && b->errors.rms_error_mm > 0 ? c->errors.rms_error_mm / b->errors.rms_error_mm : nan;
        const bool cmd_miss = std::isfinite(lo) && (lo < 0.0 || !(hi <= run.command_limit_mpa));
        const std::string scale = !c                    ? std::string("&ndash;")
                                  : !c->reachable         ? std::string("out of reach")
                                                          : num(c->reference_scale, 3);
        h += fmt::format("<td>{}</td><td>{}</td><td{}>{}</td><td class=\"l\">{}</td><td{}>{}</td><td>{:.1f}</td></tr>\n",
                         num(rn, 3), num(rb, 3), cmd_miss ? " class=\"miss\"" : "",
                         std::isfinite(lo) ? fmt::format("{:.3f}..{:.3f}", lo, hi) : std::string("&ndash;"),
                         html_escape(run.model), c && !c->reachable ? " class=\"miss\"" : "", scale,
                         run.wall_time_s);
      }
    }
    h += "</table>\n";
  }

  // RMS against each parameter varied one at a time (the nominal rig at the base value)
  std::vector<std::string> groups;
  for (const auto& v : r.variants)
    if (!v.variant.group.empty()) add_unique(groups, v.variant.group);
  if (!groups.empty()) h += "<h2>RMS error against each varied parameter</h2>\n";
  int figure = 0;
  for (const auto& g : groups) {
    // the x value of each variant of the group: its first override's value on the rig
    std::vector<std::pair<double, std::size_t>> points;
    std::string first_path;
    for (std::size_t v = 1; v < r.variants.size(); ++v) {
      const auto& sv = r.variants[v];
      if (sv.variant.group != g || sv.values.empty()) continue;
      if (first_path.empty()) first_path = sv.variant.overrides[0].path;
      if (sv.variant.overrides[0].path != first_path) continue;
      points.emplace_back(sv.values[0], v);
    }
    if (points.empty()) continue;
    std::string pointer = "/" + first_path;
    std::replace(pointer.begin(), pointer.end(), '.', '/');
    const double nominal_x = rig_params_to_json(r.variants[0].rig).at(nlohmann::json::json_pointer(pointer)).get<double>();
    points.emplace_back(nominal_x, 0);
    std::sort(points.begin(), points.end());
    for (std::size_t e = 0; e < r.experiments.size(); ++e) {
      std::vector<std::string> refs;
      for (const auto& [x, v] : points)
        for (const auto& t : r.run(e, v).runs) add_unique(refs, t.reference);
      PlotSpec spec{{fmt::format("{}: RMS error against {}", r.experiments[e], g), {first_path, unit_of(first_path)},
                     {"RMS tracking error", "mm"}},
                    {}};
      spec.height = 420;
      std::size_t failed = 0;
      for (const auto& [x, v] : points) failed += r.run(e, v).ok ? 0 : 1;
      for (const auto& k : kinds)
        for (std::size_t ri = 0; ri < refs.size(); ++ri) {
          Series s;
          s.label = refs.size() > 1 ? fmt::format("{}, {}", k, refs[ri]) : k;
          s.style = "linespoints";
          s.color = variant_color(k);
          s.dashed = ri > 0;
          for (const auto& [x, v] : points)
            if (const SweepRunErrors* t = r.find(e, v, refs[ri], k)) {
              s.x.push_back(x);
              s.y.push_back(t->errors.rms_error_mm);
            }
          if (!s.x.empty()) spec.series.push_back(std::move(s));
        }
      if (spec.series.empty()) {
        h += fmt::format("<p class=\"warn\">{}: every run varying {} failed; no plot.</p>\n",
                         html_escape(r.experiments[e]), html_escape(g));
        continue;
      }
      const std::string svg = render(spec, "svg");
      const auto start = svg.find("<svg");
      if (start == std::string::npos) throw Error(fmt::format("plot '{}': gnuplot wrote no SVG", spec.labels.title));
      std::string caption = fmt::format("{}: RMS error of every variant kind against {} (the nominal rig at {}{}{})",
                                        r.experiments[e], first_path, num(nominal_x, 6),
                                        unit_of(first_path).empty() ? "" : " ", unit_of(first_path));
      if (g != first_path) caption += fmt::format("; varied together: {}", g);
      if (failed) caption += fmt::format("; {} failed run(s) left out", failed);
      h += fmt::format("<figure class=\"plot\" id=\"fig-{}\">\n{}\n<figcaption>{}.</figcaption>\n</figure>\n", ++figure,
                       svg.substr(start), html_escape(caption));
    }
  }
  return h + "</body>\n</html>\n";
}

void write_sweep_report(const SweepResult& result, const std::string& html_path, const std::string& command_line) {
  const std::string html = sweep_report_html(result, command_line);
  io::write_text_file(html_path, html);
}

}  // namespace hysteron::report
