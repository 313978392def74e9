// Plots (gnuplot) and HTML reports.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <random>
#include <sstream>

#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;
using namespace hysteron;
using namespace hysteron::report;

namespace {

struct Tmp {
  fs::path dir;
  Tmp() {
    std::string t = (fs::temp_directory_path() / "hysteron-report-test-XXXXXX").string();
    if (!::mkdtemp(t.data())) throw std::runtime_error("mkdtemp");
    dir = t;
  }
  ~Tmp() { fs::remove_all(dir); }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
};

// Sets an environment variable for a scope, restoring its value (or its absence) at the end.
struct EnvGuard {
  std::string name;
  std::optional<std::string> old;
  EnvGuard(std::string n, const std::string& value) : name(std::move(n)) {
    if (const char* v = std::getenv(name.c_str())) old = v;
    ::setenv(name.c_str(), value.c_str(), 1);
  }
  ~EnvGuard() {
    if (old) ::setenv(name.c_str(), old->c_str(), 1);
    else ::unsetenv(name.c_str());
  }
  EnvGuard(const EnvGuard&) = delete;
  EnvGuard& operator=(const EnvGuard&) = delete;
};

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// gnuplot replaced by a script that keeps the generated gnuplot script in `path` and writes an
// empty SVG where the plot was to go, for the life of the object.
struct KeptScript {
  std::string path;
  std::optional<EnvGuard> gnuplot, keep;
  explicit KeptScript(const Tmp& tmp) : path(tmp / "script.gp") {
    const std::string fake = tmp / "gnuplot.sh";
    {
      std::ofstream f(fake);  // (the output path as plot.cpp's quote() writes it: '' for ')
      f << "#!/bin/sh\ncp \"$1\" \"$HYSTERON_TEST_KEEP\"\n"
        << "out=$(sed -n \"s/^set output '\\(.*\\)'$/\\1/p\" \"$1\" | sed \"s/''/'/g\")\n"
        << "printf '<svg></svg>' > \"$out\"\n";
    }
    fs::permissions(fake, fs::perms::owner_all);
    gnuplot.emplace("HYSTERON_GNUPLOT", fake);
    keep.emplace("HYSTERON_TEST_KEEP", path);
  }
  // The last script's lines but the output file's.
  std::vector<std::string> script_lines() const {
    std::istringstream script(slurp(path));
    std::vector<std::string> lines;
    for (std::string line; std::getline(script, line);)
      if (!line.starts_with("set output ")) lines.push_back(line);
    return lines;
  }
  // The data blocks of the last script: "$d0 << EOD" to "EOD", each line as written.
  std::vector<std::vector<std::string>> data_blocks() const {
    std::istringstream script(slurp(path));
    std::vector<std::vector<std::string>> blocks;
    std::string line;
    bool in_block = false;
    while (std::getline(script, line)) {
      if (!in_block && line.starts_with("$d") && line.ends_with("<< EOD")) {
        blocks.emplace_back();
        in_block = true;
      } else if (in_block && line == "EOD") {
        in_block = false;
      } else if (in_block) {
        blocks.back().push_back(line);
      }
    }
    return blocks;
  }
};

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

// Counts the plotter's temporary directories in `where`. Tests point TMPDIR at a private
// directory first: the shared /tmp also holds those of plot tests running in parallel.
std::size_t plot_temp_dirs(const fs::path& where) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(where))
    if (e.path().filename().string().starts_with("hysteron-plot-")) ++n;
  return n;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

GpiParams test_gpi() {
  GpiParams g;
  g.envelope = Envelope::tanh(40.0, 3.0, 0.0, 0.0);
  g.q = 1.0;
  g.n = 5;
  g.rho = 0.4;
  g.tau = 2.0;
  g.alpha = 3.0;
  return g;
}

std::vector<double> test_input(std::size_t n) {
  std::vector<double> x(n);
  for (std::size_t i = 0; i < n; ++i)
    x[i] = 0.3 + 0.3 * std::sin(0.02 * static_cast<double>(i)) * std::exp(-static_cast<double>(i) / 1500.0);
  return x;
}

// The model's output for x with a small deterministic "noise" (a record the model does not fit exactly).
std::vector<double> measured_output(const ModelParams& model, const std::vector<double>& x) {
  std::vector<double> y = simulate_record(model, x);
  for (std::size_t i = 0; i < y.size(); ++i) y[i] += 0.01 * std::sin(1.7 * static_cast<double>(i));
  return y;
}

const Labels kLabels{"Tracking", {"Time", "s"}, {"Contraction", "mm"}};

// A data file and its columns (hysteron report --data FILE --input IN --output OUT).
FitDataSource by_hand(const std::string& file, const std::string& in, const std::string& out) {
  FitDataSource s;
  s.input_file = file;
  s.input_column = in;
  s.output_column = out;
  return s;
}

}  // namespace

TEST(Plot, SvgAndPngWithLabelsAndNoTempFilesLeft) {
  Tmp tmp;
  Tmp private_tmp;
  const char* old_tmpdir = std::getenv("TMPDIR");
  const std::string saved = old_tmpdir ? old_tmpdir : "";
  ::setenv("TMPDIR", private_tmp.dir.c_str(), 1);
  ASSERT_EQ(fs::temp_directory_path(), private_tmp.dir);
  std::vector<double> t(20000), d(20000), a(20000);
  for (std::size_t i = 0; i < t.size(); ++i) {
    t[i] = 1e-3 * static_cast<double>(i);
    d[i] = 45 * std::sin(t[i]);
    a[i] = d[i] + (i == 12345 ? 7.5 : 0.1);
  }
  plot_tracking(t, d, a, kLabels, tmp / "a.svg");
  const std::string svg = slurp(tmp / "a.svg");
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("Contraction [mm]"), std::string::npos);
  EXPECT_NE(svg.find("Time [s]"), std::string::npos);
  EXPECT_NE(svg.find("Tracking"), std::string::npos);
  EXPECT_NE(svg.find("desired"), std::string::npos);
  EXPECT_LT(svg.size(), 800'000u);  // decimated
  plot_tracking_error(t, d, a, {"Error", {"Time", "s"}, {"Error", "mm"}}, tmp / "e.png");
  EXPECT_EQ(slurp(tmp / "e.png").substr(0, 4), "\x89PNG");
  plot_desired_vs_actual(d, a, {"DvA", {"Desired", "mm"}, {"Actual", "mm"}}, tmp / "d.svg");
  plot_fit_residuals({}, d, a, {"Res", {"Sample", ""}, {"Residual", "mm"}}, tmp / "r.svg");
  plot_identification_input(t, d, a, {"Input", {"Time", "s"}, {"Pressure", "MPa"}}, tmp / "i.svg");
  plot_hysteresis_loops(d, a, d, {"Loops", {"Pressure", "MPa"}, {"Contraction", "mm"}}, tmp / "l.svg", 5000);
  EXPECT_NE(slurp(tmp / "l.svg").find("minor loops"), std::string::npos);
  EXPECT_EQ(plot_temp_dirs(private_tmp.dir), 0u);
  if (old_tmpdir) ::setenv("TMPDIR", saved.c_str(), 1);
  else ::unsetenv("TMPDIR");
}

// A signal riding on a large offset (a sensor reading 1e6 +- 0.001) is plotted relative to a
// round reference named in the axis label: with the values written to 9 digits it was a flat
// line, and gnuplot's tick labels all read 1e+06.
TEST(Plot, ASignalOnALargeOffsetIsPlottedRelativeToAReference) {
  Tmp tmp;
  std::vector<double> t(2000), y(2000);
  for (std::size_t i = 0; i < t.size(); ++i) {
    t[i] = 1e-3 * static_cast<double>(i);
    y[i] = 1e6 + 1e-3 * std::sin(6 * t[i]);
  }
  plot_tracking(t, y, y, kLabels, tmp / "o.svg");
  const std::string svg = slurp(tmp / "o.svg");
  EXPECT_NE(svg.find("Contraction [mm] - 1000000"), std::string::npos);
  EXPECT_NE(svg.find("Time [s]<"), std::string::npos);  // the time axis is not shifted
  // the y tick labels: distinct values around 0 (before: "1e+06" on every tick)
  EXPECT_EQ(svg.find(">1e+06<"), std::string::npos);
  EXPECT_NE(svg.find(">-0.001<"), std::string::npos);
  EXPECT_NE(svg.find("> 0.001<"), std::string::npos);
}

TEST(Plot, NoDataIsAClearError) {
  Tmp tmp;
  const std::vector<double> none;
  EXPECT_NE(error_of([&] { plot_tracking(none, none, none, kLabels, tmp / "x.svg"); }).find("no finite data"),
            std::string::npos);
  const std::vector<double> nan(10, std::nan(""));
  EXPECT_NE(error_of([&] { plot_tracking(nan, nan, nan, kLabels, tmp / "x.svg"); }).find("no finite data"),
            std::string::npos);
  const std::vector<double> one{1.0, 2.0};
  EXPECT_NE(error_of([&] { plot_tracking(one, one, one, {"T", {"", ""}, {"y", ""}}, tmp / "x.svg"); }).find("label"),
            std::string::npos);
  EXPECT_NE(error_of([&] { plot_tracking(one, one, one, kLabels, tmp / "x.pdf"); }).find("unknown plot format"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "x.svg"));
}

TEST(Plot, MissingGnuplotIsAClearError) {
  Tmp tmp;
  const EnvGuard gnuplot("HYSTERON_GNUPLOT", "/nonexistent/gnuplot");
  const std::vector<double> one{1.0, 2.0};
  const std::string e = error_of([&] { plot_tracking(one, one, one, kLabels, tmp / "x.svg"); });
  EXPECT_NE(e.find("gnuplot"), std::string::npos) << e;
  EXPECT_NE(e.find("/nonexistent/gnuplot"), std::string::npos) << e;
}

// A long periodic record's loop (output against input, 1e6 samples, 400 periods that go round
// three nested loops in turn, all through the origin): gnuplot is replaced by a script that keeps
// the generated data. The drawn path must follow the loops: no segment longer than 3 % of the
// box's diagonal (the record moves 0.1 % per sample; bucketing by y over the sample order drew
// chords across the loops), every 101st sample within 1 % of a drawn point, at most max_points.
TEST(Plot, ALongLoopIsThinnedAlongItsPath) {
  Tmp tmp;
  const KeptScript kept(tmp);
  const std::size_t n = 1'000'000, period = 2500;
  const double pi = std::acos(-1.0), phase = 0.5;
  std::vector<double> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double a = std::array{1.0, 0.6, 0.3}[(i / period) % 3];
    const double th = 2 * pi * static_cast<double>(i % period) / static_cast<double>(period);
    x[i] = a * std::sin(th);
    y[i] = a * (std::sin(th - phase) + std::sin(phase));
  }
  PlotSpec spec;
  spec.labels = {"Loops", {"Pressure", "MPa"}, {"Force", "N"}};
  spec.series.push_back({"measured", x, y, "lines", "", false});
  plot(spec, tmp / "loops.svg");

  std::istringstream script(slurp(kept.path));
  std::string line;
  while (std::getline(script, line) && line != "$d0 << EOD") {
  }
  std::vector<std::array<double, 2>> drawn;
  double longest = 0;
  bool joined = false;  // the previous line was a point (not a break)
  while (std::getline(script, line) && line != "EOD") {
    if (line.empty()) {
      joined = false;
      continue;
    }
    std::array<double, 2> p{};
    std::istringstream(line) >> p[0] >> p[1];
    if (joined) longest = std::max(longest, std::hypot(p[0] - drawn.back()[0], p[1] - drawn.back()[1]));
    drawn.push_back(p);
    joined = true;
  }
  const double diagonal = std::hypot(2.0, *std::max_element(y.begin(), y.end()) - *std::min_element(y.begin(), y.end()));
  ASSERT_GT(drawn.size(), 100u);
  EXPECT_LE(drawn.size(), spec.max_points);
  EXPECT_LT(longest, 0.03 * diagonal) << drawn.size() << " points drawn";
  double farthest = 0;
  for (std::size_t i = 0; i < n; i += 101) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& p : drawn) nearest = std::min(nearest, std::hypot(p[0] - x[i], p[1] - y[i]));
    farthest = std::max(farthest, nearest);
  }
  EXPECT_LT(farthest, 0.01 * diagonal);
}

// thin_for_plot gives the points render() draws: a plot of them writes the same data as a plot
// of the whole series (so that reports build a long record's series from them instead of copying
// it whole: 160 -> 74 bytes per sample for `evaluate --report` on 2e6 samples, history part 23),
// over time with a gap, along a loop with a gap, and as points (actual against desired).
TEST(Plot, ThinnedPointsDrawWhatTheWholeSeriesDraws) {
  Tmp tmp;
  const KeptScript kept(tmp);
  const std::size_t n = 300'000;
  const double pi = std::acos(-1.0);
  std::vector<double> t(n), big_t(n), x(n), y(n);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> nd(0.0, 0.01);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = 1e-3 * static_cast<double>(i);
    // a Unix time axis whose midpoint, 1.7e9 + 50, is where its offset's reference rounds to 1.7e9 + 100
    big_t[i] = 1.7e9 + 25.0 + 50.0 * static_cast<double>(i) / static_cast<double>(n - 1);
    const double a = std::array{1.0, 0.5}[(i / 3000) % 2];
    x[i] = a * std::sin(2 * pi * static_cast<double>(i % 3000) / 3000.0);
    y[i] = x[i] + 0.2 * a * std::cos(2 * pi * static_cast<double>(i % 3000) / 3000.0) + nd(rng);
  }
  for (std::size_t i = 120'000; i < 120'050; ++i) y[i] = std::nan("");
  struct Case {
    std::span<const double> x, y;
    std::string style;
    bool equal_axes;
    const char* what;
  };
  for (const Case& c : {Case{t, y, "lines", false, "over time"}, Case{big_t, y, "lines", false, "a Unix time axis"},
                        Case{x, y, "lines", false, "a loop"}, Case{x, y, "points", true, "actual against desired"}}) {
    PlotSpec whole;
    whole.labels = {"Thinned", {"In", ""}, {"Out", ""}};
    whole.equal_axes = c.equal_axes;
    whole.series.push_back({"s", {c.x.begin(), c.x.end()}, {c.y.begin(), c.y.end()}, c.style, "", false});
    const ThinnedPoints p = thin_for_plot(c.x, c.y, whole.max_points);
    ASSERT_EQ(p.x.size(), p.y.size());
    EXPECT_LE(p.x.size(), whole.max_points);
    EXPECT_GT(p.x.size(), whole.max_points / 4);
    EXPECT_TRUE(std::any_of(p.y.begin(), p.y.end(), [](double v) { return std::isnan(v); })) << "the gap is kept";
    // the series' extremes are drawn (the axes' ranges and an offset's reference are computed from them)
    const auto finite_range = [](std::span<const double> v) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (double u : v)
        if (std::isfinite(u)) lo = std::min(lo, u), hi = std::max(hi, u);
      return std::pair{lo, hi};
    };
    EXPECT_EQ(finite_range(p.x), finite_range(c.x)) << c.what;
    EXPECT_EQ(finite_range(p.y), finite_range(c.y)) << c.what;
    PlotSpec thin = whole;
    thin.series[0].x = p.x, thin.series[0].y = p.y;
    plot(whole, tmp / "p.svg");
    const auto a = kept.script_lines();
    const auto blocks = kept.data_blocks();
    plot(thin, tmp / "p.svg");
    ASSERT_EQ(blocks.size(), 1u);
    EXPECT_GT(blocks[0].size(), 100u);
    EXPECT_EQ(a, kept.script_lines()) << c.what;  // the same labels, ranges and data
  }
  // a short series is its own points
  const std::vector<double> few{1.0, 3.0, 2.0};
  EXPECT_EQ(thin_for_plot(few, few).y, few);
  EXPECT_NE(error_of([&] { thin_for_plot(few, std::span(few).first(2)); }).find("3 x and 2 y"), std::string::npos);
  EXPECT_NE(error_of([&] { thin_for_plot(few, few, 8); }).find("max_points"), std::string::npos);
}

// An evaluation document (`hysteron evaluate --report ev.json`): read back with its record (the
// time column in ms as data.time_unit says), drawn by write_report_from; a document whose record
// does not give its RMS, or whose data file is missing, is refused before anything is written.
TEST(Report, EvaluationJsonAndHtml) {
  Tmp tmp;
  const std::vector<double> x = test_input(1500);
  const ModelParams model = test_gpi();
  const std::vector<double> y = measured_output(model, x);
  std::vector<double> t_ms(x.size());
  for (std::size_t i = 0; i < t_ms.size(); ++i) t_ms[i] = 2.0 * static_cast<double>(i);  // 2 ms samples
  io::write_columns(tmp / "track.csv", {"t_ms", "pressure", "length"}, {t_ms, x, y});
  io::EvaluationDocument doc;
  doc.model_file = "m.json";
  doc.model = model;
  doc.data.input_file = doc.data.output_file = "track.csv";  // beside the document
  doc.data.input_column = "pressure";
  doc.data.output_column = "length";
  doc.data.time_column = "t_ms";
  doc.data.time_unit = "ms";
  doc.data.output_unit = "mm";
  doc.data.train = {300, 1200};
  doc.result.file = "track.csv";
  doc.result.range = {300, 1200};
  doc.result.metrics = evaluate_scored(model, x, y, doc.result.range, InitialState::virgin, true, &doc.result.censored);
  io::write_text_file(tmp / "ev.json", io::to_json(doc).dump(2));
  const LoadedEvaluation le = read_evaluation_json(tmp / "ev.json");
  EXPECT_EQ(le.data.x, x);
  EXPECT_EQ(le.data.y, y);
  ASSERT_EQ(le.data.t.size(), x.size());
  EXPECT_DOUBLE_EQ(le.data.t.back(), 0.002 * static_cast<double>(x.size() - 1));  // s
  EXPECT_EQ(le.document.result.metrics.n, 900u);
  EXPECT_EQ(le.data.train.begin, 300u);
  write_report_from(tmp / "ev.json", tmp / "ev.html", "hysteron report ev.json --out ev.html");
  const std::string html = slurp(tmp / "ev.html");
  EXPECT_EQ(count(html, "<svg"), 3u);
  EXPECT_NE(html.find("samples 300..1200 [mm]"), std::string::npos);
  EXPECT_NE(html.find("Recorded by the evaluation"), std::string::npos);
  EXPECT_NE(html.find("Model: m.json"), std::string::npos);
  // the fit reader refuses it, and the page reader refuses another format by name
  EXPECT_NE(error_of([&] { (void)read_fit_report_json(tmp / "ev.json"); }).find("not a hysteron fit report"),
            std::string::npos);
  nlohmann::json j = io::to_json(doc);
  j["format"] = "hysteron-other";
  io::write_text_file(tmp / "other.json", j.dump());
  EXPECT_NE(error_of([&] { write_report_from(tmp / "other.json", tmp / "x.html", ""); })
                .find("other.json: unknown document format \"hysteron-other\""),
            std::string::npos);
  // a missing data file is named; another record's RMS is refused
  j = io::to_json(doc);
  j["data"]["input"]["file"] = j["data"]["output"]["file"] = "gone.csv";
  io::write_text_file(tmp / "gone.json", j.dump());
  EXPECT_NE(error_of([&] { write_report_from(tmp / "gone.json", tmp / "x.html", ""); }).find("data file gone.csv not found"),
            std::string::npos);
  std::vector<double> other = y;
  for (double& v : other) v += 0.05;
  io::write_columns(tmp / "other.csv", {"t_ms", "pressure", "length"}, {t_ms, x, other});
  EXPECT_NE(error_of([&] { write_report_from(tmp / "ev.json", tmp / "x.html", "", by_hand("other.csv", "pressure", "length")); })
                .find("not the record the evaluation used"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "x.html"));
}

namespace {

// An evaluation document of `model` on track.csv (columns t_ms, pressure, length; 2 ms samples) in
// `dir`, scored over `range` as evaluate scores it (censored unless `censor` is false).
io::EvaluationDocument evaluation_on(const std::string& dir, const ModelParams& model, const std::vector<double>& x,
                                     const std::vector<double>& y, IndexRange range, bool censor = true) {
  std::vector<double> t_ms(x.size());
  for (std::size_t i = 0; i < t_ms.size(); ++i) t_ms[i] = 2.0 * static_cast<double>(i);
  io::write_columns((fs::path(dir) / "track.csv").string(), {"t_ms", "pressure", "length"}, {t_ms, x, y});
  io::EvaluationDocument doc;
  doc.model_file = "m.json";
  doc.model = model;
  doc.data.input_file = doc.data.output_file = "track.csv";
  doc.data.input_column = "pressure";
  doc.data.output_column = "length";
  doc.data.time_column = "t_ms";
  doc.data.time_unit = "ms";
  doc.data.output_unit = "mm";
  doc.data.train = range;
  doc.data.censored = censor;
  doc.result.file = "track.csv";
  doc.result.range = range;
  doc.result.metrics = evaluate_scored(model, x, y, range, InitialState::virgin, censor, &doc.result.censored);
  doc.result.outside_input_limits = input_coverage(model, x, range).outside;
  return doc;
}

// The value cell of a row of the page's "Recorded by the evaluation" table.
std::string recorded_cell(const std::string& html, const std::string& label) {
  const std::string key = html_escape(label) + "</td><td>";
  const auto p = html.find(key);
  if (p == std::string::npos) return "<no row " + label + ">";
  const auto b = p + key.size();
  return html.substr(b, html.find("</td>", b) - b);
}

}  // namespace

// An evaluation document written before the counts were recorded (no "censored_samples", no
// "outside_input_limits") says so on the page: unknown, not 0 (it showed 0). Written again, the
// keys stay absent.
TEST(Report, EvaluationCountsNotRecordedAreNotZero) {
  Tmp tmp;
  const std::vector<double> x = test_input(1500);
  const ModelParams model = test_gpi();
  const io::EvaluationDocument doc = evaluation_on(tmp.dir, model, x, measured_output(model, x), {300, 1200});
  nlohmann::json j = io::to_json(doc);
  ASSERT_TRUE(j["metrics"].contains("censored_samples"));
  j["metrics"].erase("censored_samples");
  j["metrics"].erase("outside_input_limits");
  io::write_text_file(tmp / "ev.json", j.dump(2));
  write_report_from(tmp / "ev.json", tmp / "ev.html", "");
  const std::string html = slurp(tmp / "ev.html");
  EXPECT_EQ(recorded_cell(html, "censored samples (output at its clip limit, no error)"), "not recorded in this document");
  EXPECT_EQ(recorded_cell(html, "samples outside the model's input limits"), "not recorded in this document");
  const io::EvaluationDocument back = io::from_json<io::EvaluationDocument>(j, "ev.json");
  EXPECT_FALSE(back.result.censored_recorded);
  EXPECT_FALSE(back.result.outside_input_limits_recorded);
  EXPECT_FALSE(io::to_json(back)["metrics"].contains("censored_samples"));
  EXPECT_FALSE(io::to_json(back)["metrics"].contains("outside_input_limits"));
  // a current document's counts are shown as recorded
  io::write_text_file(tmp / "now.json", io::to_json(doc).dump(2));
  write_report_from(tmp / "now.json", tmp / "now.html", "");
  const std::string now = slurp(tmp / "now.html");
  EXPECT_EQ(recorded_cell(now, "samples outside the model's input limits"),
            std::to_string(doc.result.outside_input_limits));
  EXPECT_EQ(recorded_cell(now, "censored samples (output at its clip limit, no error)"),
            std::to_string(doc.result.censored));
}

// A document written before censored scoring (hysteron before 2026-11-26: neither data.censored nor
// metrics.censored_samples) of a record whose output clips was scored as recorded: it is read as
// such (it was refused as "not the record the evaluation used") and the page says so. A current
// document whose metrics are not its scoring's is still refused.
TEST(Report, EvaluationBeforeCensoredScoringOfAClippingRecord) {
  Tmp tmp;
  const std::vector<double> x = test_input(1500);
  const ModelParams model = test_gpi();
  std::vector<double> y = measured_output(model, x);
  std::vector<double> sorted = y;
  std::sort(sorted.begin(), sorted.end());
  const double limit = sorted[sorted.size() / 3];  // a sensor's limit at the lower third
  for (double& v : y) v = std::max(v, limit);
  const IndexRange range{100, 1400};
  std::size_t censored = 0;
  const FitMetrics as_censored = evaluate_censored(model, x, y, range, InitialState::virgin, &censored);
  const FitMetrics as_recorded = evaluate(model, x, y, range, InitialState::virgin);
  ASSERT_GT(censored, 0u) << "the record must clip for this test";
  ASSERT_GT(std::abs(as_censored.rms - as_recorded.rms), 1e-3 * as_recorded.rms);

  const io::EvaluationDocument doc = evaluation_on(tmp.dir, model, x, y, range, /*censor=*/false);
  nlohmann::json old = io::to_json(doc);  // as hysteron wrote it then: scored as recorded, no keys
  old["data"].erase("censored");
  old["metrics"].erase("censored_samples");
  old["metrics"].erase("outside_input_limits");
  old["metrics"].erase("output_map");
  io::write_text_file(tmp / "old.json", old.dump(2));
  const LoadedEvaluation le = read_evaluation_json(tmp / "old.json");
  EXPECT_FALSE(le.document.data.censored);
  EXPECT_FALSE(le.data.censor_clipped);
  write_report_from(tmp / "old.json", tmp / "old.html", "");
  const std::string html = slurp(tmp / "old.html");
  EXPECT_NE(html.find("written before hysteron scored a record whose output clips as censored"), std::string::npos);
  EXPECT_EQ(recorded_cell(html, "censored samples (output at its clip limit, no error)"), "not recorded in this document");

  // data.censored present (true) with metrics scored as recorded: not what that document says, refused
  nlohmann::json wrong = old;
  wrong["data"]["censored"] = true;
  io::write_text_file(tmp / "wrong.json", wrong.dump(2));
  EXPECT_NE(error_of([&] { write_report_from(tmp / "wrong.json", tmp / "x.html", ""); })
                .find("not the record the evaluation used"),
            std::string::npos);
  // a document of the hour between (censored_samples, no data.censored) was scored censored
  const io::EvaluationDocument now = evaluation_on(tmp.dir, model, x, y, range, /*censor=*/true);
  nlohmann::json between = io::to_json(now);
  between["data"].erase("censored");
  io::write_text_file(tmp / "between.json", between.dump(2));
  EXPECT_TRUE(read_evaluation_json(tmp / "between.json").data.censor_clipped);
  EXPECT_FALSE(fs::exists(tmp / "x.html"));
}

// metrics.range missing or empty: said as such, with the file (both said "lies beyond").
TEST(Report, EvaluationRangeMissingOrEmpty) {
  Tmp tmp;
  const std::vector<double> x = test_input(1500);
  const ModelParams model = test_gpi();
  const nlohmann::json j = io::to_json(evaluation_on(tmp.dir, model, x, measured_output(model, x), {300, 1200}));
  nlohmann::json missing = j;
  missing["metrics"].erase("range");
  io::write_text_file(tmp / "missing.json", missing.dump());
  const std::string m = error_of([&] { write_report_from(tmp / "missing.json", tmp / "x.html", ""); });
  EXPECT_NE(m.find("missing.json: metrics.range is missing"), std::string::npos) << m;
  EXPECT_EQ(m.find("lies beyond"), std::string::npos) << m;
  nlohmann::json empty = j;
  empty["metrics"]["range"] = nlohmann::json::array({700, 700});
  io::write_text_file(tmp / "empty.json", empty.dump());
  const std::string e = error_of([&] { write_report_from(tmp / "empty.json", tmp / "x.html", ""); });
  EXPECT_NE(e.find("empty.json: metrics.range [700, 700) is empty"), std::string::npos) << e;
  EXPECT_EQ(e.find("lies beyond"), std::string::npos) << e;
  // beyond the record: still said so
  nlohmann::json beyond = j;
  beyond["metrics"]["range"] = nlohmann::json::array({300, 2000});
  io::write_text_file(tmp / "beyond.json", beyond.dump());
  const std::string b = error_of([&] { write_report_from(tmp / "beyond.json", tmp / "x.html", ""); });
  EXPECT_NE(b.find("beyond.json: data: the evaluated range [300, 2000) (metrics.range) lies beyond the 1500 samples"),
            std::string::npos) << b;
  EXPECT_FALSE(fs::exists(tmp / "x.html"));
}

// hysteron report DOC --data/--input/--output/--time-column: each replaces only its own part of the
// document's data (--input alone cleared the output column); the document's time column is looked
// up in the file given and, where it is not there, refused with what to do; every read error
// names the document and the file.
TEST(Report, DataOverrideKeepsTheRestOfTheDocument) {
  Tmp tmp;
  const std::vector<double> x = test_input(1500);
  const ModelParams model = test_gpi();
  const std::vector<double> y = measured_output(model, x);
  io::write_text_file(tmp / "ev.json", io::to_json(evaluation_on(tmp.dir, model, x, y, {300, 1200})).dump(2));
  fs::create_directory(tmp.dir / "moved");
  fs::copy_file(tmp / "track.csv", tmp / "moved/track.csv");
  const std::string moved = tmp / "moved/track.csv";
  // one column given, the other the document's
  FitDataSource only_input;
  only_input.input_file = moved;
  only_input.input_column = "pressure";
  EXPECT_EQ(read_evaluation_json(tmp / "ev.json", only_input).data.y, y);
  FitDataSource only_output;
  only_output.input_file = moved;
  only_output.output_column = "length";
  EXPECT_EQ(read_evaluation_json(tmp / "ev.json", only_output).data.x, x);
  // the file given, the document's time column (t_ms, in ms) read from it
  FitDataSource file_only;
  file_only.input_file = moved;
  const LoadedEvaluation same = read_evaluation_json(tmp / "ev.json", file_only);
  ASSERT_EQ(same.data.t.size(), x.size());
  EXPECT_DOUBLE_EQ(same.data.t[1], 0.002);
  EXPECT_EQ(same.data.files.front(), moved);
  // a file without the document's time column: refused, naming both and what to give
  std::vector<double> t_s(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) t_s[i] = 0.002 * static_cast<double>(i);
  io::write_columns(tmp / "moved/other_time.csv", {"time", "pressure", "length"}, {t_s, x, y});
  FitDataSource no_such_time;
  no_such_time.input_file = tmp / "moved/other_time.csv";
  const std::string e = error_of([&] { write_report_from(tmp / "ev.json", tmp / "x.html", "", no_such_time); });
  EXPECT_NE(e.find(tmp / "ev.json"), std::string::npos) << e;
  EXPECT_NE(e.find("other_time.csv"), std::string::npos) << e;
  EXPECT_NE(e.find("time column t_ms"), std::string::npos) << e;
  EXPECT_NE(e.find("--time-column"), std::string::npos) << e;
  EXPECT_NE(e.find("--no-time"), std::string::npos) << e;
  // ... its own time column (in s), or none
  FitDataSource own_time = no_such_time;
  own_time.time_column = "time";
  const LoadedEvaluation timed = read_evaluation_json(tmp / "ev.json", own_time);
  ASSERT_EQ(timed.data.t.size(), x.size());
  EXPECT_DOUBLE_EQ(timed.data.t[1], 0.002);
  // ... or one whose header gives its unit (read in it, as fit and evaluate read it)
  std::vector<double> t_ms(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) t_ms[i] = 2.0 * static_cast<double>(i);
  io::write_columns(tmp / "moved/header_ms.csv", {"t [ms]", "pressure", "length"}, {t_ms, x, y});
  FitDataSource header_unit;
  header_unit.input_file = tmp / "moved/header_ms.csv";
  header_unit.time_column = "0";
  const LoadedEvaluation in_ms = read_evaluation_json(tmp / "ev.json", header_unit);
  ASSERT_EQ(in_ms.data.t.size(), x.size());
  EXPECT_DOUBLE_EQ(in_ms.data.t[1], 0.002);
  EXPECT_NE(in_ms.data.source.find("time column 0 in ms"), std::string::npos) << in_ms.data.source;
  // a file whose header gives the document's column another unit is read in the file's (the
  // document's ms would draw it 1000x off); a --time-unit that disagrees with the file is refused
  io::write_columns(tmp / "moved/header_s.csv", {"t_ms [s]", "pressure", "length"}, {t_s, x, y});
  FitDataSource in_file_unit;
  in_file_unit.input_file = tmp / "moved/header_s.csv";
  const LoadedEvaluation in_s = read_evaluation_json(tmp / "ev.json", in_file_unit);
  ASSERT_EQ(in_s.data.t.size(), x.size());
  EXPECT_DOUBLE_EQ(in_s.data.t[1], 0.002);
  FitDataSource contradicting = header_unit;
  contradicting.time_unit = "s";
  const std::string u = error_of([&] { (void)read_evaluation_json(tmp / "ev.json", contradicting); });
  EXPECT_NE(u.find("--time-unit s but"), std::string::npos) << u;
  EXPECT_NE(u.find("header_ms.csv"), std::string::npos) << u;
  FitDataSource no_time = no_such_time;
  no_time.no_time = true;
  EXPECT_TRUE(read_evaluation_json(tmp / "ev.json", no_time).data.t.empty());
  // a --time-unit where no time column is left would be ignored: refused, naming the document
  FitDataSource unit_without_column = no_time;
  unit_without_column.time_unit = "ms";
  const std::string w = error_of([&] { (void)read_evaluation_json(tmp / "ev.json", unit_without_column); });
  EXPECT_NE(w.find(tmp / "ev.json"), std::string::npos) << w;
  EXPECT_NE(w.find("--time-unit ms but --no-time"), std::string::npos) << w;
  // an experiment directory draws its own records: an override there would be ignored, refused
  const std::string d = error_of([&] { write_report_from(tmp / "moved", tmp / "x.html", "", file_only); });
  EXPECT_NE(d.find("an experiment directory"), std::string::npos) << d;
  EXPECT_NE(d.find("--data"), std::string::npos) << d;
  // a column the file lacks: the document and the file named
  FitDataSource bad_column = file_only;
  bad_column.input_column = "nosuch";
  const std::string c = error_of([&] { (void)read_evaluation_json(tmp / "ev.json", bad_column); });
  EXPECT_NE(c.find(tmp / "ev.json"), std::string::npos) << c;
  EXPECT_NE(c.find(moved), std::string::npos) << c;
  EXPECT_NE(c.find("nosuch"), std::string::npos) << c;
  EXPECT_FALSE(fs::exists(tmp / "x.html"));
}

TEST(Report, FitJsonRoundTripAndHtml) {
  Tmp tmp;
  const std::vector<double> x = test_input(1500);
  const ModelParams model = test_gpi();
  const std::vector<double> y = measured_output(model, x);
  io::write_columns(tmp / "data.csv", {"pressure", "length"}, {x, y});
  FitReport f;
  f.status = FitStatus::converged;
  f.message = "function tolerance reached";
  f.model_kind = FitModel::gpi;
  f.model = model;
  f.parameters = {{"c0", 40.0, 0.0, true}, {"q", 1.0, 0.01, false}, {"rho", 0.4, std::nan(""), false}};
  f.train = evaluate(model, x, y, {0, 1000});  // the training range's, as `fit` reports them
  FitData data;
  data.input = {"Pressure", "MPa"};
  data.output = {"Contraction", "mm"};
  data.train = {0, 1000};
  const nlohmann::json j = fit_report_to_json(f, data, by_hand("data.csv", "pressure", "length"));
  io::write_text_file(tmp / "fit.json", j.dump(2));
  const LoadedFit lf = read_fit_report_json(tmp / "fit.json");  // data path resolved beside the JSON
  EXPECT_EQ(lf.data.x, x);
  EXPECT_EQ(lf.data.y, y);
  EXPECT_EQ(lf.data.train.end, 1000u);
  EXPECT_EQ(lf.fit.parameters.size(), 3u);
  EXPECT_TRUE(std::isnan(lf.fit.parameters[2].std_error));
  EXPECT_EQ(lf.data.output.unit, "mm");
  write_report_from(tmp / "fit.json", tmp / "fit.html", "hysteron report fit.json --out fit.html");
  const std::string html = slurp(tmp / "fit.html");
  EXPECT_EQ(count(html, "<svg"), 3u);
  EXPECT_NE(html.find("after training (validation)"), std::string::npos);
  EXPECT_NE(html.find("hysteron report fit.json --out fit.html"), std::string::npos);
  EXPECT_NE(html.find(std::string(hysteron_version)), std::string::npos);
  EXPECT_NE(html.find("Pressure [MPa]"), std::string::npos);

  // other schema, other format, malformed JSON, missing data: errors naming the file
  nlohmann::json bad = j;
  bad["schema"] = 99;
  io::write_text_file(tmp / "bad.json", bad.dump());
  EXPECT_NE(error_of([&] { write_report_from(tmp / "bad.json", tmp / "x.html", ""); }).find("bad.json: unsupported"),
            std::string::npos);
  io::write_text_file(tmp / "other.json", R"({"model": "pi"})");
  EXPECT_NE(error_of([&] { write_report_from(tmp / "other.json", tmp / "x.html", ""); })
                .find("other.json: not a hysteron fit report"),
            std::string::npos);
  io::write_text_file(tmp / "broken.json", R"({"format": )");
  EXPECT_NE(error_of([&] { write_report_from(tmp / "broken.json", tmp / "x.html", ""); })
                .find("broken.json: not valid JSON"),
            std::string::npos);
  bad = j;
  bad["data"]["input"]["file"] = "nope.csv";
  io::write_text_file(tmp / "nodata.json", bad.dump());
  EXPECT_NE(error_of([&] { write_report_from(tmp / "nodata.json", tmp / "x.html", ""); }).find("nope.csv"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "x.html"));
  // data given by hand (-d) that are not the fit's record: swapped columns, another record
  const std::string swapped =
      error_of([&] { write_report_from(tmp / "fit.json", tmp / "x.html", "", by_hand("data.csv", "length", "pressure")); });
  EXPECT_NE(swapped.find("does not reproduce the fit's training RMS"), std::string::npos) << swapped;
  std::vector<double> y2 = y;
  for (double& v : y2) v += 0.05;
  io::write_columns(tmp / "other.csv", {"pressure", "length"}, {x, y2});
  const std::string other =
      error_of([&] { write_report_from(tmp / "fit.json", tmp / "x.html", "", by_hand("other.csv", "pressure", "length")); });
  EXPECT_NE(other.find("not the record the fit used"), std::string::npos) << other;
  EXPECT_FALSE(fs::exists(tmp / "x.html"));
}

namespace {
// A small experiment result (gpi-pid's shape, 800 identification samples, 300 per run) with
// a run of each variant in `variants`.
ExperimentResult small_experiment(std::initializer_list<const char*> variants = {"compensated", "faithful",
                                                                                 "baseline"}) {
  ExperimentResult r;
  r.name = "gpi-pid";
  r.title = "test experiment";
  r.seed = 3;
  const std::size_t n = 800;
  r.identification.pressure_mpa = test_input(n);
  r.fit.model_kind = FitModel::gpi;
  r.fit.status = FitStatus::converged;
  r.fit.model = test_gpi();
  r.best_fit = r.fit;
  r.identification.contraction_mm = simulate_record(r.fit.model, r.identification.pressure_mpa);
  r.identification.pressure_command_mpa = r.identification.pressure_mpa;
  for (std::size_t i = 0; i < n; ++i) r.identification.t.push_back(0.01 * static_cast<double>(i));
  r.id_train_end = 500;
  r.published = {"paper, Table 5", {{"", 2.659, 0.7358, 0.8701}}};
  for (const char* variant : variants) {
    TrackingRun run;
    run.variant = variant;
    run.reference = "sine";
    run.description = std::string("the ") + variant + " loop";
    for (std::size_t i = 0; i < 300; ++i) {
      const double t = 0.01 * static_cast<double>(i);
      run.t.push_back(t);
      run.reference_mm.push_back(45 + 40 * std::sin(t));
      run.measured_mm.push_back(run.reference_mm.back() + 0.5 * std::cos(3 * t));
      run.actual_mm.push_back(run.measured_mm.back());
      run.pressure_command_mpa.push_back(0.3);
      run.pressure_mpa.push_back(0.3);
      run.duty.push_back(0.0);
    }
    run.errors = {0.5, 0.3, 0.35};
    r.runs.push_back(run);
  }
  return r;
}
}  // namespace

// `hysteron report DIR` re-rendering an experiment directory: the fitted model's parameter table
// with its standard errors (before, read_experiment_dir read the model alone, and the re-rendered
// page had no table: result.json did not hold the parameters' errors).
TEST(Report, ExperimentDirectoryKeepsTheParametersStandardErrors) {
  Tmp tmp;
  ExperimentResult r = small_experiment();
  r.fit.parameters = {{"r1", 0.125, 0.0031, false, false}, {"w1", 2.5, 0.0, true, false},
                      {"w2", 0.0, 0.0, false, true}, {"c0", -1.75, std::numeric_limits<double>::quiet_NaN()}};
  r.fit.covariance_note = "the Jacobian is rank deficient (test)";
  const std::string dir = tmp / "exp";
  r.write(dir);
  const ExperimentResult back = read_experiment_dir(dir);
  ASSERT_EQ(back.fit.parameters.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(back.fit.parameters[i].name, r.fit.parameters[i].name);
    EXPECT_EQ(back.fit.parameters[i].value, r.fit.parameters[i].value);
    EXPECT_EQ(back.fit.parameters[i].held, r.fit.parameters[i].held);
    EXPECT_EQ(back.fit.parameters[i].at_bound, r.fit.parameters[i].at_bound);
  }
  EXPECT_EQ(back.fit.parameters[0].std_error, 0.0031);
  EXPECT_TRUE(std::isnan(back.fit.parameters[3].std_error));
  EXPECT_EQ(back.fit.covariance_note, r.fit.covariance_note);
  write_report_from(dir, tmp / "exp.html", "hysteron report exp --out exp.html");
  const std::string html = slurp(tmp / "exp.html");
  EXPECT_NE(html.find("std. error"), std::string::npos);
  EXPECT_NE(html.find(">r1</td>"), std::string::npos);
  EXPECT_NE(html.find("the Jacobian is rank deficient (test)"), std::string::npos);
  write_experiment_report(r, tmp / "direct.html", "experiment");
  EXPECT_EQ(count(slurp(tmp / "direct.html"), "std. error"), count(html, "std. error"));
}

TEST(Report, ExperimentDirectoryRoundTripAndHtml) {
  Tmp tmp;
  ExperimentResult r = small_experiment();
  // a trial whose rig diverged (+inf) is written as null and read back as +inf
  const double inf = std::numeric_limits<double>::infinity();
  r.gain_trials = {{"sine", {0.5, 1.0, 2.0}, {0.8, 0.6, inf}, {0.7, 0.65, inf}, 0.5, true},
                   {"triangle", {1.0}, {0.4}, {}, 1.0, false, true}};
  const std::string dir = tmp / "exp";
  r.write(dir);
  const ExperimentResult back = read_experiment_dir(dir);
  EXPECT_EQ(back.gain_trials, r.gain_trials);
  EXPECT_EQ(back.name, "gpi-pid");
  EXPECT_EQ(back.runs.size(), 3u);
  EXPECT_EQ(back.runs[0].reference, "sine");
  EXPECT_EQ(back.identification.contraction_mm, r.identification.contraction_mm);
  write_report_from(dir, tmp / "exp.html", "hysteron report exp --out exp.html");
  const std::string html = slurp(tmp / "exp.html");
  EXPECT_EQ(count(html, "<svg"), 6u);  // Fig. 4, loops, residuals, Figs. 11, 12, 13
  EXPECT_NE(html.find("2.659"), std::string::npos);  // published figure
  EXPECT_NE(html.find("the faithful loop"), std::string::npos);
  // the run's actuator limit and reach, from result.json (a 0.4 MPa muscle: not the papers' 0.6)
  r.pressure_limit_mpa = 0.4;
  r.reach_min_mm = 0.0, r.reach_max_mm = 75.0, r.reach_top_mm = 69.6, r.reach_top_pressure_mpa = 0.401;
  r.write(dir);
  write_report_from(dir, tmp / "exp.html", "hysteron report exp --out exp.html");
  const std::string limits = slurp(tmp / "exp.html");
  EXPECT_NE(limits.find("within 0..0.400 MPa"), std::string::npos);
  EXPECT_NE(limits.find("reached 0.0..75.0 mm; the references are kept below 69.6 mm, where its ascent reached "
                        "0.401 MPa"),
            std::string::npos);

  // write_experiment_report directly gives the same figures
  write_experiment_report(r, tmp / "direct.html", "experiment");
  EXPECT_EQ(count(slurp(tmp / "direct.html"), "<svg"), 6u);

  // broken directories name the file
  fs::remove(dir + "/tracking_faithful_sine.csv");
  EXPECT_NE(error_of([&] { read_experiment_dir(dir); }).find("tracking_faithful_sine.csv: missing file"),
            std::string::npos);
  fs::remove(dir + "/model.json");
  EXPECT_NE(error_of([&] { read_experiment_dir(dir); }).find("model.json: missing file"), std::string::npos);
  io::write_text_file(dir + "/result.json", "{\"experiment\": ");
  EXPECT_NE(error_of([&] { read_experiment_dir(dir); }).find("result.json: not valid JSON"), std::string::npos);
  io::write_text_file(dir + "/result.json", R"({"schema": 7, "experiment": "x", "identification": {}})");
  EXPECT_NE(error_of([&] { read_experiment_dir(dir); }).find("result.json: unsupported schema 7"), std::string::npos);
  fs::remove(dir + "/result.json");
  EXPECT_NE(error_of([&] { read_experiment_dir(dir); }).find("result.json: missing file"), std::string::npos);
  EXPECT_NE(error_of([&] { write_report_from(tmp / "nothing", tmp / "x.html", ""); }).find("no such file"),
            std::string::npos);
}

// ExperimentResult::write replaces the output directory's files as a set: an error while
// writing leaves every file of the earlier run as it was (and no temporary file); a run
// without some of the earlier run's variants removes their CSVs and the earlier report, and
// leaves the user's own files alone.
TEST(Report, ExperimentOutputIsReplacedAsASet) {
  Tmp tmp;
  const std::string dir = tmp / "exp";
  small_experiment({"compensated", "faithful", "learning"}).write(dir);
  std::ofstream(dir + "/report.html") << "<html>the earlier run</html>";
  std::ofstream(dir + "/notes.txt") << "mine";
  const auto snapshot = [&] {
    std::vector<std::pair<std::string, std::string>> files;
    for (const auto& e : fs::directory_iterator(dir)) files.emplace_back(e.path().filename().string(), slurp(e.path()));
    std::sort(files.begin(), files.end());
    return files;
  };
  const auto before = snapshot();
  ASSERT_EQ(before.size(), 9u);  // 3 tracking CSVs, identification, 2 models, result.json, report, notes
  // a run whose last tracking series is malformed: written after the identification and the
  // first runs' CSVs, so without the batch those would have been replaced already
  ExperimentResult bad = small_experiment({"compensated", "faithful", "baseline"});
  bad.identification.contraction_mm.assign(bad.identification.contraction_mm.size(), 1.0);
  bad.runs.back().duty.pop_back();
  const std::string message = test::error_of([&] { bad.write(dir); });
  EXPECT_NE(message.find("tracking_baseline_sine.csv"), std::string::npos) << message;
  EXPECT_EQ(snapshot(), before);  // nothing changed, no temporary file left
  // a new directory that cannot be written is not left behind
  EXPECT_THROW(bad.write(tmp / "new"), Error);
  EXPECT_FALSE(fs::exists(tmp / "new"));
  // a run without the learning variant, with a baseline
  ExperimentResult next = small_experiment({"compensated", "faithful", "baseline"});
  next.seed = 4;
  next.write(dir);
  EXPECT_FALSE(fs::exists(dir + "/tracking_learning_sine.csv"));
  EXPECT_FALSE(fs::exists(dir + "/report.html"));  // it described the earlier run
  EXPECT_TRUE(fs::exists(dir + "/tracking_baseline_sine.csv"));
  EXPECT_EQ(slurp(dir + "/notes.txt"), "mine");
  EXPECT_EQ(read_experiment_dir(dir).seed, 4u);
  EXPECT_EQ(read_experiment_dir(dir).runs.size(), 3u);
  // a directory without an earlier run's result.json: nothing of its own removed
  const std::string other = tmp / "other";
  fs::create_directories(other);
  std::ofstream(other + "/tracking_mine.csv") << "a,b\n1,2\n";
  next.write(other);
  EXPECT_TRUE(fs::exists(other + "/tracking_mine.csv"));
}

