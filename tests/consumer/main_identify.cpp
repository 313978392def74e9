// hysteron::identify: fit a PI model to data made by a known PI.
#include <hysteron/identify.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

int main() {
  hysteron::PiParams truth;
  truth.r = {0.0, 0.1, 0.2, 0.3};
  truth.p = {1.0, 0.6, 0.3, 0.1};
  hysteron::Model model(truth);
  std::vector<double> x(2000), y(2000);
  for (std::size_t k = 0; k < x.size(); ++k) {
    x[k] = 0.6 * std::sin(0.01 * static_cast<double>(k)) * std::exp(-0.0005 * static_cast<double>(k));
    y[k] = model.step(x[k]);
  }
  hysteron::FitOptions options;
  options.model = hysteron::FitModel::pi;
  options.num_operators = 8;
  const hysteron::FitReport report = hysteron::fit(x, y, options);
  std::printf("consumer identify: %s, RMS %.3g %% of span\n", report.message.c_str(), report.train.rms_percent_span);
  return hysteron::has_model(report.status) && report.train.rms_percent_span < 5.0 ? 0 : 1;
}
