// Fit a GPI model to measured data: Festo 10 mm muscle, force [N] (column 0)
// against pressure [kPa] (column 1), if the shared data set is present; else
// to data simulated here (and the program says so).
// Usage: 02_fit_measured [festo10mm_20cm_test8.csv]
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <hysteron/identify.hpp>
#include <hysteron/io/table.hpp>

int main(int argc, char** argv) {
  const std::string path =
      argc > 1 ? argv[1] : "../shared/data/pam-force-pressure/festo10mm_20cm_test8.csv";
  std::vector<double> x, y;
  if (std::filesystem::exists(path)) {
    const auto p = hysteron::io::read_column(path, "1");  // pressure [kPa]
    const auto f = hysteron::io::read_column(path, "0");  // force [N]
    for (std::size_t i = 0; i < p.size(); i += 5) {        // 15000 -> 3000 samples
      x.push_back(p[i]);
      y.push_back(f[i]);
    }
    fmt::print("measured data: {} ({} samples used)\n", path, x.size());
  } else {
    hysteron::GpiParams g;
    g.envelope = hysteron::Envelope::tanh(300.0, 0.004, -0.5, 150.0);
    g.q = 0.8;
    g.rho = 0.4;
    g.tau = 0.01;
    g.alpha = 20.0;
    for (double a = 600; a > 50; a -= 100)
      for (int k = 0; k < 400; ++k) x.push_back(a * (1.0 - std::abs(2.0 * k / 400.0 - 1.0)));
    y = hysteron::simulate_record(g, x);
    for (std::size_t i = 0; i < y.size(); ++i) y[i] += 0.5 * std::sin(0.7 * static_cast<double>(i));
    fmt::print("{} not found: fitting data simulated in this example instead\n", path);
  }
  hysteron::FitOptions o;
  o.model = hysteron::FitModel::gpi;
  o.num_operators = 10;
  const hysteron::FitReport r = hysteron::fit(x, y, o);
  fmt::print("{}\n", r.full_report());
  const bool good = r.status != hysteron::FitStatus::invalid_input && r.status != hysteron::FitStatus::failed &&
                    r.train.r2 > 0.95;
  fmt::print("R^2 = {:.5f}, RMS = {:.3g} N ({:.2f} % of span): {}\n", r.train.r2, r.train.rms,
             r.train.rms_percent_span, good ? "ok" : "FAILED");
  return good ? 0 : 1;
}
