// Plots through gnuplot: a generated script with inline data, run as a child
// process in a private temporary directory that is always removed (on SIGINT, SIGTERM and
// SIGHUP too, by the CLI's handler).
#include <fcntl.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

extern char** environ;

namespace hysteron::report {

namespace {

namespace fs = std::filesystem;

// A private temporary directory, removed with everything in it on scope exit, and by the CLI's
// signal handler (io::remove_temporary_files) with the files made through file().
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "hysteron-plot-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr)
      throw Error(fmt::format("plot: cannot create a temporary directory: {}", std::strerror(errno)));
    path_ = tmpl;
    registered_.push_back(std::make_unique<io::TemporaryPath>(path_.string(), true));
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }  // then registered_ is unregistered
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  // The path of a file to be made in the directory, registered first.
  fs::path file(const std::string& name) {
    fs::path p = path_ / name;
    registered_.push_back(std::make_unique<io::TemporaryPath>(p.string()));
    return p;
  }

 private:
  fs::path path_;
  std::vector<std::unique_ptr<io::TemporaryPath>> registered_;
};

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// gnuplot single-quoted string: '' stands for '.
std::string quote(std::string_view s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "''";
    else if (c == '\n' || c == '\r') out += ' ';
    else out += c;
  }
  return out + "'";
}

// An axis is plotted relative to a reference when its largest magnitude exceeds this many
// spans (script()).
constexpr double kOffsetRatio = 1e3;

std::string axis_text(const Axis& a) { return a.unit.empty() ? a.label : fmt::format("{} [{}]", a.label, a.unit); }

// Where a drawn line is broken (a blank line in gnuplot's data block).
constexpr std::size_t kBreak = std::numeric_limits<std::size_t>::max();

// Min/max bucket decimation keeping the order of the samples: for a series over time (x never
// decreases), so that each bucket's extremes, the error peaks, survive; the first and the last
// sample too (the x range, and an offset's reference, are the whole series').
std::vector<std::size_t> decimate_over_x(std::span<const double> y, std::size_t max_points) {
  const std::size_t n = y.size();
  const std::size_t buckets = (max_points - 2) / 2;
  std::vector<std::size_t> idx;
  idx.reserve(max_points + 2);
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t lo = b * n / buckets, hi = (b + 1) * n / buckets;
    std::size_t imin = lo, imax = lo;
    for (std::size_t i = lo; i < hi; ++i) {
      if (!std::isfinite(y[i])) {  // keep gaps visible
        imin = imax = i;
        break;
      }
      if (y[i] < y[imin]) imin = i;
      if (y[i] > y[imax]) imax = i;
    }
    idx.push_back(std::min(imin, imax));
    if (imin != imax) idx.push_back(std::max(imin, imax));
  }
  if (idx.front() != 0) idx.insert(idx.begin(), 0);
  if (idx.back() != n - 1) idx.push_back(n - 1);
  return idx;
}

// Thinning of a path in the plane (a loop: output against input, which goes back and forth):
// the series' box is cut into g x g cells and the path is drawn through the first sample of
// each cell it enters for the first time, broken where it goes on through cells already drawn.
// Every sample lies in a drawn cell, and every drawn segment joins neighbouring cells (or two
// consecutive samples), so the picture is the record's at the cells' resolution: bucketing by y
// over the sample order instead joins the ends of a loop's branches across it (a solid band for
// a long periodic record). g starts at 1024 cells and halves until at most max_points are drawn;
// the last g tried, the largest with 4 g^2 <= max_points (each new cell adds at most a break, a
// start and its sample), always draws the whole path.
std::vector<std::size_t> thin_path(std::span<const double> x, std::span<const double> y, std::size_t max_points) {
  const std::size_t n = x.size();
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  std::array<std::size_t, 4> extremes{kBreak, kBreak, kBreak, kBreak};  // the samples at x0, x1, y0, y1
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) {
      if (x[i] < x0) x0 = x[i], extremes[0] = i;
      if (x[i] > x1) x1 = x[i], extremes[1] = i;
      if (y[i] < y0) y0 = y[i], extremes[2] = i;
      if (y[i] > y1) y1 = y[i], extremes[3] = i;
    }
  std::size_t g_last = 2;  // (max_points >= 16)
  while (4 * (2 * g_last) * (2 * g_last) <= max_points && g_last < 1024) g_last *= 2;
  std::vector<std::size_t> idx;
  std::vector<unsigned char> drawn;
  for (std::size_t g = 1024;; g /= 2) {
    const bool last = g <= g_last;
    const auto cell_of = [&](double v, double lo, double hi) {
      // halves: a box from -1e308 to 1e308 has no finite span
      const double f = (0.5 * v - 0.5 * lo) / (0.5 * hi - 0.5 * lo);
      if (!(f > 0)) return std::size_t{0};
      return std::min(g - 1, static_cast<std::size_t>(static_cast<double>(g) * std::min(f, 1.0)));
    };
    idx.clear();
    drawn.assign(g * g, 0);
    std::size_t cell = kBreak, first = kBreak;  // the cell the path is in, and its first sample
    for (std::size_t i = 0; i < n && (last || idx.size() <= max_points); ++i) {
      if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
        if (!idx.empty() && idx.back() != kBreak) idx.push_back(kBreak);  // keep gaps visible
        cell = first = kBreak;
        continue;
      }
      const std::size_t c = cell_of(x[i], x0, x1) * g + cell_of(y[i], y0, y1);
      if (c == cell) continue;
      const std::size_t previous = first;
      cell = c, first = i;
      if (drawn[c]) continue;
      drawn[c] = 1;
      if (previous != kBreak && (idx.empty() || idx.back() != previous)) {  // enters from a drawn cell
        if (!idx.empty() && idx.back() != kBreak) idx.push_back(kBreak);
        idx.push_back(previous);
      } else if (previous == kBreak && !idx.empty() && idx.back() != kBreak) {
        idx.push_back(kBreak);
      }
      idx.push_back(i);
    }
    if (idx.size() + 8 <= max_points || last) {
      // the samples at the box's edges too (a lone point each, where the path does not draw them), as far as
      // max_points allows: the axes' ranges, and an offset's reference, are the whole series'
      for (std::size_t e : extremes)
        if (e != kBreak && idx.size() + 2 <= max_points && std::find(idx.begin(), idx.end(), e) == idx.end())
          idx.push_back(kBreak), idx.push_back(e);
      return idx;
    }
  }
}

// The samples of a series to draw, in order (kBreak: break the line there), at most about
// max_points of them.
std::vector<std::size_t> decimate(std::span<const double> x, std::span<const double> y, std::size_t max_points) {
  const std::size_t n = x.size();
  std::vector<std::size_t> idx;
  if (n <= max_points) {
    idx.resize(n);
    for (std::size_t i = 0; i < n; ++i) idx[i] = i;
    return idx;
  }
  bool over_x = true;  // x never decreases over its finite samples: a series over time or index
  double last = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n && over_x; ++i)
    if (std::isfinite(x[i])) over_x = x[i] >= last, last = x[i];
  return over_x ? decimate_over_x(y, max_points) : thin_path(x, y, max_points);
}

std::string script(const PlotSpec& spec, std::string_view format, const std::string& out) {
  const Labels& l = spec.labels;
  if (l.title.empty()) throw Error("plot: the title is empty");
  if (l.x.label.empty() || l.y.label.empty())
    throw Error(fmt::format("plot '{}': every axis needs a label", l.title));
  if (spec.series.empty()) throw Error(fmt::format("plot '{}': no data (no series)", l.title));
  if (spec.width < 100 || spec.height < 100 || spec.max_points < 16)
    throw Error(fmt::format("plot '{}': size below 100 px or max_points below 16", l.title));
  std::size_t finite = 0;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Series& s : spec.series) {
    if (s.label.empty()) throw Error(fmt::format("plot '{}': a series has no legend label", l.title));
    if (s.x.size() != s.y.size())
      throw Error(fmt::format("plot '{}': series '{}' has {} x and {} y values", l.title, s.label, s.x.size(),
                              s.y.size()));
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) {
        ++finite;
        lo = std::min({lo, s.x[i], s.y[i]});
        hi = std::max({hi, s.x[i], s.y[i]});
      }
  }
  if (finite == 0) throw Error(fmt::format("plot '{}': no finite data to plot (empty or all NaN)", l.title));

  // An axis whose values ride on an offset far beyond their span (a sensor 1e6 +- 0.001) is
  // plotted relative to a round reference named in its label: written with 9 digits, or
  // labelled by gnuplot's ticks, the signal itself was lost (a flat line at 1e+06).
  const auto offset_of = [](double a, double b) {
    if (!(b > a) || std::max(std::abs(a), std::abs(b)) <= kOffsetRatio * (b - a)) return 0.0;
    const double step = std::pow(10.0, std::floor(std::log10(b - a)) + 1);  // above the span's digits
    return std::round(0.5 * (a + b) / step) * step;
  };
  const auto range_of = [&](bool y) {
    double a = std::numeric_limits<double>::infinity(), b = -a;
    for (const Series& s : spec.series)
      for (std::size_t i = 0; i < s.x.size(); ++i)
        if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) {
          const double v = y ? s.y[i] : s.x[i];
          a = std::min(a, v), b = std::max(b, v);
        }
    return std::pair{a, b};
  };
  double x0 = 0, y0 = 0;
  if (spec.equal_axes) {
    x0 = y0 = offset_of(lo, hi);
    lo -= x0, hi -= x0;
  } else {
    const auto [xa, xb] = range_of(false);
    const auto [ya, yb] = range_of(true);
    x0 = offset_of(xa, xb), y0 = offset_of(ya, yb);
  }
  const auto label = [](const Axis& a, double ref) {
    return ref == 0 ? axis_text(a) : fmt::format("{} {} {:.15g}", axis_text(a), ref > 0 ? "-" : "+", std::abs(ref));
  };

  std::string g;
  if (format == "svg")
    g += fmt::format("set terminal svg size {},{} enhanced font 'Helvetica,13' background '#ffffff'\n", spec.width,
                     spec.height);
  else
    g += fmt::format("set terminal pngcairo size {},{} enhanced font 'Sans,10' background '#ffffff'\n", spec.width,
                     spec.height);
  g += fmt::format("set output {}\n", quote(out));
  g += fmt::format("set title {} noenhanced\n", quote(l.title));
  g += fmt::format("set xlabel {} noenhanced\n", quote(label(l.x, x0)));
  g += fmt::format("set ylabel {} noenhanced\n", quote(label(l.y, y0)));
  g += "set grid lc rgb '#dddddd'\nset key top left box opaque noenhanced samplen 2\nset border lw 1\n";
  if (spec.equal_axes && hi > lo) {
    const double pad = 0.03 * (hi - lo);
    g += fmt::format("set xrange [{:.9g}:{:.9g}]\nset yrange [{:.9g}:{:.9g}]\nset size ratio -1\n", lo - pad,
                     hi + pad, lo - pad, hi + pad);
  }
  for (std::size_t k = 0; k < spec.series.size(); ++k) {
    const Series& s = spec.series[k];
    g += fmt::format("$d{} << EOD\n", k);
    bool any = false;
    for (std::size_t i : decimate(s.x, s.y, spec.max_points)) {
      if (i != kBreak && std::isfinite(s.x[i]) && std::isfinite(s.y[i])) {
        g += fmt::format("{:.9g} {:.9g}\n", s.x[i] - x0, s.y[i] - y0);
        any = true;
      } else {
        g += "\n";
      }
    }
    if (!any) g += "NaN NaN\n";  // an empty block would be an error; a NaN point plots nothing
    g += "EOD\n";
  }
  g += "plot ";
  for (std::size_t k = 0; k < spec.series.size(); ++k) {
    const Series& s = spec.series[k];
    std::string with;
    if (s.style == "points") with = "points pt 7 ps 0.35";
    else if (s.style == "linespoints") with = "linespoints pt 7 ps 0.4 lw 1.5";
    else if (s.style == "lines") with = "lines lw 1.5";
    else throw Error(fmt::format("plot '{}': unknown style '{}' (lines, points, linespoints)", l.title, s.style));
    if (!s.color.empty()) with += fmt::format(" lc rgb {}", quote(s.color));
    if (s.dashed) with += " dt 2";
    g += fmt::format("{}$d{} using 1:2 with {} title {}", k ? ", \\\n     " : "", k, with, quote(s.label));
  }
  g += "\nunset output\n";
  return g;
}

std::string gnuplot_binary() {
  const char* env = std::getenv("HYSTERON_GNUPLOT");
  return env && *env ? env : "gnuplot";
}

}  // namespace

std::string render(const PlotSpec& spec, std::string_view format) {
  if (format != "svg" && format != "png")
    throw Error(fmt::format("plot: unknown format '{}' (svg or png)", format));
  TempDir tmp;
  const fs::path out = tmp.file(fmt::format("plot.{}", format));
  const fs::path gp = tmp.file("plot.gp");
  const fs::path log = tmp.file("gnuplot.log");
  {
    std::ofstream f(gp, std::ios::binary);
    f << script(spec, format, out.string());
    if (!f) throw Error(fmt::format("plot: cannot write the gnuplot script in {}", tmp.path().string()));
  }
  const std::string bin = gnuplot_binary();
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  std::string arg0 = bin, arg1 = gp.string();
  char* argv[] = {arg0.data(), arg1.data(), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, bin.c_str(), &fa, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0)
    throw Error(fmt::format("plot '{}': cannot run the gnuplot binary '{}': {} (install gnuplot, e.g. "
                            "apt-get install gnuplot-nox, or set HYSTERON_GNUPLOT to its path)",
                            spec.labels.title, bin, std::strerror(rc)));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw Error(fmt::format("plot: waiting for gnuplot failed: {}", std::strerror(errno)));
  std::string messages = read_file(log);
  while (!messages.empty() && (messages.back() == '\n' || messages.back() == ' ')) messages.pop_back();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
      throw Error(fmt::format("plot '{}': the gnuplot binary '{}' was not found (install gnuplot, e.g. apt-get "
                              "install gnuplot-nox, or set HYSTERON_GNUPLOT)",
                              spec.labels.title, bin));
    throw Error(fmt::format("plot '{}': gnuplot failed (status {}): {}", spec.labels.title,
                            WIFEXITED(status) ? WEXITSTATUS(status) : -1, messages));
  }
  std::string bytes = read_file(out);
  if (bytes.empty())
    throw Error(fmt::format("plot '{}': gnuplot wrote no output{}{}", spec.labels.title, messages.empty() ? "" : ": ",
                            messages));
  return bytes;
}

void plot(const PlotSpec& spec, const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  std::string format;
  if (ext == ".svg" || ext == ".SVG") format = "svg";
  else if (ext == ".png" || ext == ".PNG") format = "png";
  else throw Error(fmt::format("{}: unknown plot format '{}' (use .svg or .png)", path, ext));
  io::write_text_file(path, render(spec, format));
}

ThinnedPoints thin_for_plot(std::span<const double> x, std::span<const double> y, std::size_t max_points) {
  if (x.size() != y.size())
    throw Error(fmt::format("plot: cannot thin {} x and {} y values", x.size(), y.size()));
  if (max_points < 16) throw Error("plot: max_points below 16");
  ThinnedPoints p;
  const std::vector<std::size_t> idx = decimate(x, y, max_points);
  p.x.reserve(idx.size()), p.y.reserve(idx.size());
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i : idx) {
    p.x.push_back(i == kBreak ? nan : x[i]);
    p.y.push_back(i == kBreak ? nan : y[i]);
  }
  return p;
}

Series thinned_series(std::string label, std::span<const double> x, std::span<const double> y, std::string color,
                      bool dashed, std::string style) {
  ThinnedPoints p = thin_for_plot(x, y, PlotSpec{}.max_points);
  return {std::move(label), std::move(p.x), std::move(p.y), std::move(style), std::move(color), dashed};
}

namespace {

std::vector<double> index_axis(std::size_t n) {
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<double>(i);
  return v;
}

void same_length(std::span<const double> a, std::span<const double> b, const Labels& l, const char* what) {
  if (a.size() != b.size())
    throw Error(fmt::format("plot '{}': {} have different lengths ({} and {})", l.title, what, a.size(), b.size()));
}

}  // namespace

void plot_hysteresis_loops(std::span<const double> input, std::span<const double> measured,
                           std::span<const double> model, const Labels& labels, const std::string& path,
                           std::size_t major_end) {
  same_length(input, measured, labels, "input and measured output");
  if (!model.empty()) same_length(input, model, labels, "input and model output");
  PlotSpec spec{labels, {}};
  const std::size_t n = input.size();
  const std::size_t split = major_end > 0 && major_end < n ? major_end : n;
  auto part = [&](std::span<const double> y, std::size_t b, std::size_t e, std::string label, std::string color,
                  bool dashed) {
    spec.series.push_back(
        thinned_series(std::move(label), input.subspan(b, e - b), y.subspan(b, e - b), std::move(color), dashed));
  };
  const bool split_loops = split < n;
  part(measured, 0, split, split_loops ? "measured, major loop" : "measured", "#d62728", false);
  if (split_loops) part(measured, split, n, "measured, minor loops", "#ff9896", false);
  if (!model.empty()) {
    part(model, 0, split, split_loops ? "model, major loop" : "model", "#1f77b4", true);
    if (split_loops) part(model, split, n, "model, minor loops", "#17becf", true);
  }
  plot(spec, path);
}

void plot_identification_input(std::span<const double> t, std::span<const double> command,
                               std::span<const double> measured, const Labels& labels, const std::string& path) {
  same_length(t, command, labels, "time and command");
  PlotSpec spec{labels, {thinned_series("command", t, command, "#1f77b4", false)}};
  if (!measured.empty()) {
    same_length(t, measured, labels, "time and measured input");
    spec.series.push_back(thinned_series("measured", t, measured, "#d62728", false));
  }
  plot(spec, path);
}

void plot_tracking(std::span<const double> t, std::span<const double> desired, std::span<const double> actual,
                   const Labels& labels, const std::string& path) {
  same_length(t, desired, labels, "time and desired output");
  same_length(t, actual, labels, "time and actual output");
  plot({labels,
        {thinned_series("desired", t, desired, "#222222", true), thinned_series("actual", t, actual, "#d62728", false)}},
       path);
}

void plot_tracking_error(std::span<const double> t, std::span<const double> desired,
                         std::span<const double> actual, const Labels& labels, const std::string& path) {
  same_length(t, desired, labels, "time and desired output");
  same_length(t, actual, labels, "time and actual output");
  std::vector<double> e(t.size());
  for (std::size_t i = 0; i < e.size(); ++i) e[i] = desired[i] - actual[i];
  plot({labels, {thinned_series("error (desired - actual)", t, e, "#1f77b4", false)}}, path);
}

void plot_desired_vs_actual(std::span<const double> desired, std::span<const double> actual, const Labels& labels,
                            const std::string& path) {
  same_length(desired, actual, labels, "desired and actual output");
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : desired)
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  PlotSpec spec{labels, {thinned_series("actual", desired, actual, "#d62728", false, "points")}};
  if (hi >= lo) spec.series.push_back({"ideal (actual = desired)", {lo, hi}, {lo, hi}, "lines", "#222222", true});
  spec.equal_axes = true;
  spec.width = 640;
  spec.height = 600;
  plot(spec, path);
}

void plot_fit_residuals(std::span<const double> x, std::span<const double> measured,
                        std::span<const double> model, const Labels& labels, const std::string& path) {
  same_length(measured, model, labels, "measured and model output");
  const std::vector<double> index = x.empty() ? index_axis(measured.size()) : std::vector<double>{};
  const std::span<const double> xs = x.empty() ? std::span<const double>(index) : x;
  if (xs.size() != measured.size())
    throw Error(fmt::format("plot '{}': x and residuals have different lengths ({} and {})", labels.title,
                            xs.size(), measured.size()));
  std::vector<double> r(measured.size());
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = measured[i] - model[i];
  plot({labels, {thinned_series("residual (measured - model)", xs, r, "#2ca02c", false)}}, path);
}

}  // namespace hysteron::report
