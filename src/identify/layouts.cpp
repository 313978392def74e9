// Parameter layouts of the LM fits: the chart of the gpi of Eqs. 6-8 and the bounds of
// the cumulative-slope layout shared by the models linear in their weights.
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fit_internal.hpp"

namespace hysteron::fitting {

std::array<double, kGpi> GpiChart::theta(const double* phi) const {
  const double S = phi[0], a = phi[1], b = phi[2], m = phi[3];
  return {S / a, a / xs, b - a * xc / xs, m - S / a * std::tanh(b), phi[4], phi[5], phi[6], phi[7]};
}

std::array<double, kGpi> GpiChart::phi(const double* th) const {
  const double a = th[1] * xs, b = th[2] + th[1] * xc;
  return {th[0] * a, a, b, th[3] + th[0] * std::tanh(b), th[4], th[5], th[6], th[7]};
}

Eigen::Matrix<double, kGpi, kGpi> GpiChart::jacobian(const double* phi) const {
  const double S = phi[0], a = phi[1], b = phi[2], t = std::tanh(b);
  Eigen::Matrix<double, kGpi, kGpi> T = Eigen::Matrix<double, kGpi, kGpi>::Identity();
  T(0, 0) = 1.0 / a, T(0, 1) = -S / (a * a);
  T(1, 1) = 1.0 / xs;
  T(2, 1) = -xc / xs, T(2, 2) = 1.0;
  T(3, 0) = -t / a, T(3, 1) = S * t / (a * a), T(3, 2) = -S / a * (1.0 - t * t), T(3, 3) = 1.0;
  return T;
}

GpiParams gpi_params(const double* th, int n) {
  GpiParams g;
  g.envelope = Envelope::tanh(th[0], th[1], th[2], th[3]);
  g.q = th[4];
  g.n = n;
  g.rho = th[5];
  g.tau = th[6];
  g.alpha = th[7];
  return g;
}

// Slope vector [s_0..s_n] of weights q, p.
std::vector<double> slopes(double q, const std::vector<double>& p) {
  std::vector<double> s{q};
  for (double pi : p) s.push_back(s.back() + pi);
  return s;
}

// Lower bounds of a slope-parametrized start: cumulative slopes >= margin * scale
// (invertibility), dead-zone slopes >= margin, envelope c0, c1 > 0.
std::vector<double> slope_lower(const SlopeLayout& layout, const std::vector<double>& th, const Ranges& rg,
                                double margin, double min_slope) {
  std::vector<double> lower(static_cast<std::size_t>(layout.size()), -std::numeric_limits<double>::infinity());
  Structure<double> s0;
  layout.build(th.data(), s0);
  double uspan = rg.xspan();
  if (layout.env > 0) {
    // mpi-asym: the mean of both envelopes' spans (its slope after a reversal is q (gamma_a' + gamma_d') / 2),
    // so that the bound does not depend on which branch is called ascending (a negated input swaps them)
    const auto span_of = [&](EnvelopeKind k, const std::array<double, 4>& c) {
      return std::abs(envelope_value<double>(k, c.data(), rg.xhi) - envelope_value<double>(k, c.data(), rg.xlo));
    };
    uspan = span_of(s0.asc_kind, s0.asc_c);
    if (s0.asymmetric) uspan = 0.5 * (uspan + span_of(s0.desc_kind, s0.desc_c));
    for (int i : {0, 1, 4, 5})
      if (i < layout.env) lower[static_cast<std::size_t>(i)] = margin * std::abs(th[static_cast<std::size_t>(i)]);
  }
  const double scale = rg.yspan() / std::max(uspan, 1e-300);
  const auto env = static_cast<std::size_t>(layout.env);
  // Cumulative slopes (q for mpi-asym, whose p_i >= 0 keep every later slope above q)
  // >= min_slope * scale: the inverse slope is bounded (FitOptions::min_slope).
  for (std::size_t i = env; i < env + layout.r.size() + 1; ++i)
    lower[i] = (layout.kind == FitModel::mpi_asym && i > env ? margin : min_slope) * scale;
  for (std::size_t i = env + layout.r.size() + 1; i < lower.size(); ++i) lower[i] = min_slope;
  return lower;
}


}  // namespace hysteron::fitting
