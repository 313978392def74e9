// The covariance step of recursive least squares with forgetting, shared by hysteron::Rls
// (identify.hpp) and the adaptive inverse (experiment.hpp); docs/identification.md,
// docs/control.md "Adaptive inverse".
//
// Standard exponential forgetting,
//   K = P phi / (lambda + phi^T P phi),  P <- (P - K phi^T P) / lambda,  R <- lambda R + phi phi^T,
// while trace(P) stays within `cap` (the prior's trace). Where it would not (the data leave
// directions unexcited, e.g. a held input, and forgetting grows P there as lambda^-k), the
// information is forgotten only along phi (Kulhavy's directional forgetting,
//   eps = lambda - (1 - lambda) / (phi^T P phi),  R <- R + eps phi phi^T,
//   P <- P - eps P phi phi^T P / (1 + eps phi^T P phi),  K = P phi / (1 + phi^T P phi)):
// nothing grows in the unexcited directions, and along phi the information settles at the
// forgetting's own level lambda |phi|^2 / (1 - lambda) instead of growing without end (as a
// uniform rescaling of P at the cap makes it: the condition number then grows with the hold
// until rounding makes P indefinite). A P that is no longer positive definite (phi^T P phi < 0,
// a diagonal entry <= 0, anything non-finite) is reset to the prior and reported.
// Allocation-free, noexcept, deterministic. P, R and their priors are m x m symmetric (either
// storage order). Which step applies is known before P is written: the standard step's trace is
// sum_i (P_ii - (P phi)_i^2 / denom) / lambda.
#pragma once

#include <cmath>
#include <cstddef>

namespace hysteron::detail {

enum class RlsOutcome {
  standard,  // exponential forgetting
  bounded,   // directional forgetting (the standard step would have left trace(P) above the cap)
  reset,     // P was not positive definite: reset to the prior (and then updated from it)
  skipped,   // nothing learned (even the prior gives no valid step: non-finite phi)
};

struct RlsMatrices {
  double* P;           // covariance
  double* R;           // information P^-1 kept alongside, or nullptr
  const double* P0;    // priors
  const double* R0;    // (nullptr when R is)
  double* pphi;        // out: P phi before the step (the gain's direction)
  std::size_t m;
  double cap;          // trace bound (the prior's trace)
};

namespace rls_internal {

// pphi = P phi, denom = lambda + phi^T P phi; false where phi^T P phi < 0 or non-finite.
inline bool load(const RlsMatrices& a, const double* phi, double lambda, double& denom) noexcept {
  const std::size_t m = a.m;
  denom = lambda;
  bool finite = true;
  for (std::size_t i = 0; i < m; ++i) {
    double s = 0.0;
    for (std::size_t j = 0; j < m; ++j) s += a.P[i * m + j] * phi[j];
    a.pphi[i] = s;
    denom += phi[i] * s;
    finite = finite && std::isfinite(a.P[i * m + i]);
  }
  return denom >= lambda && std::isfinite(denom) && finite;
}

inline void to_prior(const RlsMatrices& a) noexcept {
  for (std::size_t k = 0; k < a.m * a.m; ++k) a.P[k] = a.P0[k];
  if (a.R)
    for (std::size_t k = 0; k < a.m * a.m; ++k) a.R[k] = a.R0[k];
}

// Positive diagonal, finite entries; the trace.
inline bool healthy(const RlsMatrices& a, double& tr) noexcept {
  const std::size_t m = a.m;
  tr = 0.0;
  bool ok = true;
  for (std::size_t i = 0; i < m; ++i) {
    ok = ok && a.P[i * m + i] > 0;
    tr += a.P[i * m + i];
  }
  return ok && std::isfinite(tr);
}

// Kulhavy's directional forgetting: forgets only along phi (r = phi^T P phi > 0, pphi = P phi).
inline void directional(const RlsMatrices& a, const double* phi, double lambda, double r, double& gain) noexcept {
  const std::size_t m = a.m;
  const double eps = lambda - (1.0 - lambda) / r;
  const double c = eps / (lambda * (1.0 + r));  // eps / (1 + eps r), 1 + eps r = lambda (1 + r) > 0
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = i; j < m; ++j) {
      a.P[i * m + j] = a.P[j * m + i] = a.P[i * m + j] - c * a.pphi[i] * a.pphi[j];
      if (a.R) a.R[i * m + j] = a.R[j * m + i] = a.R[i * m + j] + eps * phi[i] * phi[j];
    }
  gain = 1.0 / (1.0 + r);
}

}  // namespace rls_internal

// One covariance step for the regressor phi. On return `gain` is the factor of the estimate's
// update, theta += gain * pphi * e (0: no update).
inline RlsOutcome rls_covariance_step(const RlsMatrices& a, const double* phi, double lambda, double& gain) noexcept {
  using namespace rls_internal;
  const std::size_t m = a.m;
  RlsOutcome out = RlsOutcome::standard;
  double denom = 0.0;
  gain = 0.0;
  for (std::size_t i = 0; i < m; ++i)
    if (!std::isfinite(phi[i])) return RlsOutcome::skipped;  // a non-finite regressor: P is not at fault
  if (!load(a, phi, lambda, denom)) {
    to_prior(a);
    if (!load(a, phi, lambda, denom)) return RlsOutcome::skipped;
    out = RlsOutcome::reset;
  }
  const double r = denom - lambda;  // phi^T P phi >= 0
  const double inv = 1.0 / denom;
  double trace = 0.0;  // of the standard step's P
  for (std::size_t i = 0; i < m; ++i) trace += (a.P[i * m + i] - a.pphi[i] * a.pphi[i] * inv) / lambda;
  if (trace <= a.cap) {  // standard step
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t j = i; j < m; ++j) {
        a.P[i * m + j] = a.P[j * m + i] = (a.P[i * m + j] - a.pphi[i] * a.pphi[j] * inv) / lambda;
        if (a.R) a.R[i * m + j] = a.R[j * m + i] = lambda * a.R[i * m + j] + phi[i] * phi[j];
      }
    gain = inv;
  } else {  // directional forgetting instead (phi = 0: nothing to learn or forget)
    if (out == RlsOutcome::standard) out = RlsOutcome::bounded;
    if (r > 0) directional(a, phi, lambda, r, gain);
  }
  double tr = 0.0;
  if (!healthy(a, tr)) {
    to_prior(a);
    gain = 0.0;
    return RlsOutcome::reset;
  }
  if (tr > a.cap) {  // what directional forgetting can still add (along phi), and rounding
    const double k = a.cap / tr;
    for (std::size_t i = 0; i < m * m; ++i) a.P[i] *= k;
    if (a.R)
      for (std::size_t i = 0; i < m * m; ++i) a.R[i] /= k;
  }
  return out;
}

}  // namespace hysteron::detail
