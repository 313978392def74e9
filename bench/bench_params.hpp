#pragma once
// The PI-family models the benchmarks time (bench_models.cpp, bench_kinds.cpp): set by
// hand with plausible magnitudes (pressure-like input in MPa), every invertibility
// condition of models.hpp met.
#include <cmath>
#include <string_view>
#include <vector>

#include "hysteron/models.hpp"

namespace hysteron::bench {

// n thresholds spread over [0, 0.6], weights decaying with the threshold.
inline void pi_operators(int n, std::vector<double>& r, std::vector<double>& p) {
  r.resize(static_cast<std::size_t>(n));
  p.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    r[static_cast<std::size_t>(i)] = 0.6 * (i + 1) / (n + 1);
    p[static_cast<std::size_t>(i)] = 0.5 * std::exp(-3.0 * r[static_cast<std::size_t>(i)]) / n * 10;
  }
}

// kind: "pi", "gpi", "mpi-deadzone" or "mpi-asym" (anything else: mpi-asym), with n
// operators and the given input limits.
inline ModelParams pi_family_model(std::string_view kind, int n, Limits limits) {
  std::vector<double> r, p;
  pi_operators(n, r, p);
  if (kind == "pi") return PiParams{0.5, r, p, limits, {}};
  if (kind == "gpi") {
    GpiParams g;  // magnitudes like Table 2 of the GPI paper (pressure in MPa)
    g.envelope = Envelope::tanh(1.0, 2.0, -0.6, 0.6);
    g.q = 0.8;
    g.n = n;
    g.rho = 0.4;
    g.tau = 5.0;
    g.alpha = 0.3 / n;
    g.input_limits = limits;
    return g;
  }
  if (kind == "mpi-deadzone") return MpiDeadzoneParams{0.5, r, p, 1.0, {0.2, 0.4, 0.6}, {0.1, 0.2, -0.1}, limits, {}};
  MpiAsymParams a;
  a.ascending = Envelope::tanh(1.0, 2.0, -0.6, 0.6);
  a.descending = Envelope::tanh(1.1, 1.8, -0.5, 0.6);
  a.q = 0.8;
  a.r = r;
  a.p = p;
  a.input_limits = limits;
  return a;
}

}  // namespace hysteron::bench
