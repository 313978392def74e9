// The common fit of the kinds linear in their weights (SlopeParametrization): LM on
// every start of the kind, the best mapped into the report by the kind.
#include <fmt/format.h>

#include "kinds.hpp"

namespace hysteron::fitting {

std::string indexed(std::string_view key, std::size_t i) { return fmt::format("{}[{}]", key, i); }

double tanh_absorbed_factor(std::string_view name, std::string_view prefix, double a, double b) {
  if (!name.starts_with(prefix)) return 0.0;
  name.remove_prefix(prefix.size());
  if (name == "c[0]" || name == "c[3]") return b;
  if (name == "c[1]") return 1.0 / a;
  if (name == "c[2]") return 1.0;
  return 0.0;
}

Eigen::MatrixXd cumulative_report_map(const SlopeLayout& L) {
  const int m = L.size();
  Eigen::MatrixXd M = Eigen::MatrixXd::Identity(m, m);
  const int n = static_cast<int>(L.r.size());
  for (int i = 1; i <= n; ++i) M(L.env + i, L.env + i - 1) = -1.0;
  int k = L.env + n + 1;
  for (const std::vector<double>* side : {&L.zp, &L.zn}) {
    for (std::size_t j = 0; j < side->size(); ++j, ++k)
      if (j > 0) M(k, k - 1) = -1.0;
  }
  return M;
}

void SlopeParametrization::fit(const Data& d, const Ranges& rg, const FitOptions& o, FitReport& rep) const {
  const double margin = std::max(o.positivity_margin, 1e-12);
  const Starts st = starts(d, rg, o);
  const std::vector<SlopeLayout>& layouts = st.layouts;
  std::vector<std::vector<double>> lowers;
  for (std::size_t k = 0; k < st.theta.size(); ++k)
    lowers.push_back(slope_lower(layouts[k], st.theta[k], rg, margin, o.min_slope));
  std::vector<SlopeLm> lms;
  lms.reserve(layouts.size());
  for (const SlopeLayout& L : layouts) lms.emplace_back(&L);
  std::vector<const LmProblem*> problems;
  for (const SlopeLm& lm : lms) problems.push_back(&lm);
  auto [solved, kbest] = solve_starts(problems, d, st.theta, lowers, {}, o, rep);
  if (kbest == std::string::npos) {
    rep.status = FitStatus::failed;
    rep.message = "no start gave a usable solution";
    return;
  }
  const Solved& best = solved[kbest];
  const SlopeLayout& layout = layouts[kbest];
  const std::vector<double>& lower = lowers[kbest];
  rep.model = model(layout, best.theta.data());
  // The start is the least-squares weights: a minimum of the cost without Huber, and with it
  // while every residual lies inside the loss's quadratic zone (|r| < d: there the Huber cost
  // is the least-squares one, scaled). (With Huber the offset is not free: rep.model's is 0.)
  finish_status(rep, best, d.huber == 0 || max_abs_residual(rep.model, d) < d.huber);
  rep.initial_cost = best.initial_cost;
  rep.final_cost = best.final_cost;
  rep.iterations = best.iterations;
  if (d.free_offset) units_map(rep.model).output_offset = projected_offset(rep.model, d);
  const Eigen::MatrixXd M = report_map(layout);
  const Eigen::VectorXd v =
      M * Eigen::Map<const Eigen::VectorXd>(best.theta.data(), static_cast<Eigen::Index>(best.theta.size())) +
      report_shift(layout);
  const auto nm = names(layout);
  for (std::size_t i = 0; i < nm.size(); ++i) rep.parameters.push_back({nm[i], v(static_cast<Eigen::Index>(i))});
  if (o.compute_covariance) {
    // (with --huber the Jacobian is the robust residuals', which are scaled by 1/sqrt(d):
    // the plain SSE with it made the standard errors sqrt(d) too small)
    const double sse = fitted_sse(rep.model, d);
    // the envelopes' constants c[3] (report and LM index 3, and 7 for mpi-asym's second)
    std::vector<int> levels;
    for (int i = 3; i < layout.env; i += 4) levels.push_back(i);
    standard_errors_level_held(
        lms[kbest], d, best.theta, lower, best.at_bound, M, sse, levels.empty() ? -1 : 3, levels,
        "the envelopes' c[3] and output_offset are not separately identifiable from this record (a common shift of "
        "the c[3]s acts only through the plays' virgin start); the other standard errors are those with the first "
        "envelope's c[3] held, the c[3]s have none",
        rep);
    if (!best.at_bound.empty())
      rep.covariance_note += fmt::format("{}{} cumulative slope(s) q + p_1 + ... + p_i ended on the invertibility bound "
                                         "and were held there (their uncertainty is not included)",
                                         rep.covariance_note.empty() ? "" : "; ", best.at_bound.size());
  }
}

}  // namespace hysteron::fitting
