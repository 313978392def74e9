// The gpi of Eqs. 6-8 (FitModel::gpi): tanh envelope, thresholds r_i = alpha i and
// weights p_i = rho exp(-tau r_i); LM in the chart of GpiChart with the active-set step
// for its lower bounds, from data-derived starts (starts.cpp: gpi_starts).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

// The curvature a = c1 xs of the chart is kept >= kMinCurvature: tanh(a xn) is then
// linear to 3e-7, and c0 = S / a stays small enough for c3 to keep its digits.
constexpr double kMinCurvature = 1e-3;

class GpiKind final : public Parametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::gpi && !o.gpi_free_weights; }
  int num_parameters(const FitOptions&) const override { return kGpi; }
  // The envelope, alpha (output units) and tau (their inverse) take the scales.
  double absorbed_factor(std::string_view name, double a, double b) const override {
    if (const double f = tanh_absorbed_factor(name, "", a, b); f != 0.0) return f;
    if (name == "alpha") return b;
    if (name == "tau") return 1.0 / b;
    return 1.0;
  }

  void fit(const Data& d, const Ranges& rg, const FitOptions& o, FitReport& rep) const override {
    const int n = o.num_operators;
    const double lb = std::max(o.positivity_margin, 1e-12);
    const auto starts = gpi_starts(d, n, o, lb);
    const GpiChart chart{d.xc, d.xs};
    std::vector<std::vector<double>> phis, lowers;
    for (const auto& th : starts) {
      // LM runs in the chart phi = [S, a, b, m, q, rho, tau, alpha] (GpiChart). Bounds of
      // Eq. 13 (c0, c1 > 0 <=> S, a > 0; rho, tau > 0) plus q, alpha > 0, relative to the
      // start's scale; the curvature a >= kMinCurvature.
      const auto ph = chart.phi(th.data());
      std::vector<double>& lower = lowers.emplace_back(kGpi, -std::numeric_limits<double>::infinity());
      for (int i : {0, 4, 5, 6, 7}) lower[static_cast<std::size_t>(i)] = lb * std::abs(ph[static_cast<std::size_t>(i)]);
      lower[1] = kMinCurvature;
      // Minimum slope after a reversal (FitOptions::min_slope): dy/du = q >= min_slope
      // times the mean dy/du of the start's envelope over the training range.
      const double uspan = envelope_span({th[0], th[1], th[2], th[3]}, rg);
      if (uspan > 0) lower[4] = std::max(lower[4], o.min_slope * rg.yspan() / uspan);
      phis.emplace_back(ph.begin(), ph.end());
    }
    std::vector<int> held;
    if (o.gpi_fix_scale) held.push_back(0);
    const GpiLm lm(n);
    const std::vector<const LmProblem*> problems(phis.size(), &lm);
    auto [solved, kbest] = solve_starts(problems, d, phis, lowers, held, o, rep);
    Solved best;
    std::vector<double> best_lower;
    if (kbest != std::string::npos) {
      best = std::move(solved[kbest]);
      best_lower = lowers[kbest];
    }
    if (!best.usable) {
      rep.status = FitStatus::failed;
      rep.message = "no start gave a usable solution";
      return;
    }
    finish_status(rep, best, /*start_is_minimum=*/false);
    rep.initial_cost = best.initial_cost;
    rep.final_cost = best.final_cost;
    rep.iterations = best.iterations;
    const auto theta = chart.theta(best.theta.data());
    rep.model = gpi_params(theta.data(), n);
    if (d.free_offset) units_map(rep.model).output_offset = projected_offset(rep.model, d);
    // The model file's keys: c[0..3], q, rho, tau, alpha.
    static const char* names[kGpi] = {"c[0]", "c[1]", "c[2]", "c[3]", "q", "rho", "tau", "alpha"};
    std::vector<int> fixed;
    if (o.gpi_fix_scale) fixed.push_back(0);
    for (int i : best.at_bound) fixed.push_back(i);  // (not insert: g++ 12 -Warray-bounds false positive)
    // chart index i maps to Eq. 13 index i for the bounded parameters (a -> c1, S -> c0)
    for (int i = 0; i < kGpi; ++i) {
      const bool on_bound = std::find(best.at_bound.begin(), best.at_bound.end(), i) != best.at_bound.end();
      rep.parameters.push_back({names[i], theta[static_cast<std::size_t>(i)],
                                std::numeric_limits<double>::quiet_NaN(), false, on_bound});
    }
    if (o.gpi_fix_scale)
      rep.covariance_note = fmt::format(
          "scale gauge: Eq. 13 has the exact symmetry (c0,c3,alpha,q,rho,tau) -> (k c0,k c3,k alpha,q/k,rho/k,tau/k); "
          "it is fixed by holding S = c0 c1 xs = {:.6g} (xs = {:.6g}, half the training input span) at its "
          "data-derived value, and the standard errors are those of this gauge",
          best.theta[0], d.xs);
    if (o.compute_covariance) {
      // (with --huber the Jacobian is the robust residuals', which are scaled by 1/sqrt(d):
      // the plain SSE with it made the standard errors sqrt(d) too small)
      const double sse = fitted_sse(rep.model, d);
      const std::string note = rep.covariance_note;
      // the chart's m = c3 + c0 tanh(b) (index 3) is the envelope's level
      standard_errors_level_held(
          lm, d, best.theta, best_lower, fixed, chart.jacobian(best.theta.data()), sse, 3, {3},
          "c[3] and output_offset are not separately identifiable from this record (only their sum is: the envelope's "
          "level c3 + c0 tanh(c1 xc + c2) at the training input's centre xc acts only through the plays' virgin "
          "start); the other standard errors are those with that level held, c[3] has none",
          rep);
      if (!note.empty() && rep.covariance_note != note)
        rep.covariance_note = rep.covariance_note.empty() ? note : note + "; " + rep.covariance_note;
    }
  }
};

}  // namespace

const Parametrization& gpi_kind() {
  static const GpiKind k;
  return k;
}

}  // namespace hysteron::fitting
