// Round trip through an installed hysteron: GPI forward then its exact inverse.
#include <hysteron/inverse.hpp>
#include <hysteron/models.hpp>

#include <cmath>
#include <cstdio>

int main() {
  hysteron::GpiParams g;
  g.envelope = hysteron::Envelope::tanh(1.0, 2.0, -0.6, 0.6);
  g.q = 0.8;
  g.n = 10;
  g.rho = 0.4;
  g.tau = 5.0;
  g.alpha = 0.03;
  g.input_limits = {0.0, 0.6};
  hysteron::Model model(g);
  hysteron::Inverse inverse(g);
  double worst = 0;
  for (int k = 0; k < 1000; ++k) {
    const double x = 0.3 + 0.25 * std::sin(0.01 * k) * std::cos(0.003 * k);
    worst = std::fmax(worst, std::fabs(inverse.step(model.step(x)) - x));
  }
  std::printf("consumer: max round-trip error %.3g\n", worst);
  return worst < 1e-12 ? 0 : 1;
}
