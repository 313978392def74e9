// Simulate a GPI model (GPI paper, Eqs. 5-8) on a decaying triangle input and
// invert its output exactly: the input must come back to 1e-9.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <hysteron/inverse.hpp>
#include <hysteron/models.hpp>

int main() {
  hysteron::GpiParams g;
  g.envelope = hysteron::Envelope::tanh(60.0, 4.0, -0.5, 30.0);  // gamma(x) = c0 tanh(c1 x + c2) + c3
  g.q = 0.8;
  g.n = 10;
  g.rho = 0.4;
  g.tau = 0.1;
  g.alpha = 2.0;
  g.input_limits = {0.0, 0.6};  // [MPa]

  std::vector<double> x;  // pressure [MPa]: triangles 0.6, 0.5, ..., 0.1 MPa
  for (double a = 0.6; a > 0.05; a -= 0.1)
    for (int k = 0; k < 400; ++k) x.push_back(a * (1.0 - std::abs(2.0 * k / 400.0 - 1.0)));

  hysteron::Model model(g);
  const std::vector<double> y = model.simulate(x);  // contraction [mm]
  hysteron::Inverse inverse(g);
  const std::vector<double> back = inverse.simulate(y);

  double err = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) err = std::max(err, std::abs(back[i] - x[i]));
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  fmt::print("GPI: {} samples, output {:.2f}..{:.2f} mm; inverse round trip max error {:.3g} MPa\n", x.size(), *lo,
             *hi, err);
  return err < 1e-9 ? 0 : 1;
}
