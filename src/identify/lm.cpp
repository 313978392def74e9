// The Levenberg-Marquardt driver (through Ceres): one start with the stall test and the
// active-set step for lower bounds, many starts on several threads, and the standard
// errors of the best one.
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <thread>

#include "fit_internal.hpp"

namespace hysteron::fitting {

namespace {

// solve(): LM first runs at most kProbe iterations before the parameters that ended on
// their lower bound are held there (enough for LM to settle onto an active bound, few
// enough not to crawl along it).
constexpr int kProbe = 40;
// solve(): a parameter is on its bound when within kOnBound of its scale.
constexpr double kOnBound = 1e-4;
// standard_errors(): Ceres (DENSE_SVD) refuses when (s_min / s_max)^2 of J < 1e-14; the
// rank test uses 1e-12, a margin of 100 over that.
constexpr double kRankTolerance = 1e-12;
// solve_starts(): Jacobian-sized buffers one LM start holds (measured with heaptrack: Ceres'
// DenseSparseMatrix, its evaluation scratch and per-iteration vectors, about 3.6 for the gpi)
// and the memory the concurrent starts may use together before they run one at a time.
constexpr double kLmCopies = 4.0;
constexpr double kLmConcurrentBytes = 512.0 * 1024 * 1024;

class Progress : public ceres::IterationCallback {
 public:
  Progress(const FitOptions& o, int start) : o_(o), start_(start) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (o_.progress) o_.progress(start_, s.iteration, s.cost);
    // a stop ends LM here; solve_once then throws Stopped (no exception through Ceres)
    if (o_.stop_requested && o_.stop_requested()) return ceres::SOLVER_ABORT;
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const FitOptions& o_;
  int start_;
};

// Stops LM when the cost is stationary: its relative decrease over the last `window`
// iterations is at most `tol` (FitOptions::stall_iterations / stall_tolerance). LM on a
// flat valley (bounded weights of mpi-asym on the piezo record) otherwise crawls to the
// iteration limit at 1e-7 per iteration, which Eq. 12's per-iteration test (1e-10) never stops.
class Stall : public ceres::IterationCallback {
 public:
  Stall(int window, double tol) : tol_(tol), costs_(static_cast<std::size_t>(window) + 1) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    costs_[seen_ % costs_.size()] = s.cost;  // ring of the last window + 1 costs
    ++seen_;
    if (seen_ < costs_.size()) return ceres::SOLVER_CONTINUE;
    const double old = costs_[seen_ % costs_.size()];  // the cost `window` iterations ago
    const double drop = (old - s.cost) / std::max(s.cost, std::numeric_limits<double>::min());
    if (!(drop <= tol_)) return ceres::SOLVER_CONTINUE;
    decrease_ = drop;
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  double decrease() const { return decrease_; }

 private:
  double tol_;
  std::vector<double> costs_;
  std::size_t seen_ = 0;
  double decrease_ = 0.0;
};

// Builds the problem for one start; `theta` must outlive it (it is the parameter block).
std::unique_ptr<ceres::Problem> make_problem(const LmProblem& lm, const Data& d, std::vector<double>& theta,
                                             const std::vector<double>& lower, const std::vector<int>& held) {
  auto problem = std::make_unique<ceres::Problem>();
  lm.add_costs(*problem, d, theta.data());
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (std::isfinite(lower[i])) problem->SetParameterLowerBound(theta.data(), static_cast<int>(i), lower[i]);
  if (!held.empty() && held.size() < theta.size())
    problem->SetManifold(theta.data(), new ceres::SubsetManifold(static_cast<int>(theta.size()), held));
  return problem;
}

Solved solve_once(const LmProblem& lm, const Data& d, std::vector<double> theta, const std::vector<double>& lower,
                  const std::vector<int>& held, const FitOptions& o, int start, int max_iterations) {
  Solved out;
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (std::isfinite(lower[i])) theta[i] = std::max(theta[i], lower[i]);
  auto problem = make_problem(lm, d, theta, lower, held);
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.gradient_tolerance = o.gradient_tolerance;
  so.parameter_tolerance = o.parameter_tolerance;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  detail::check_stop(o);
  Progress cb(o, start);
  if (o.progress || o.stop_requested) so.callbacks.push_back(&cb);
  Stall stall(o.stall_iterations, o.stall_tolerance);
  if (o.stall_tolerance > 0) so.callbacks.push_back(&stall);
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem.get(), &summary);
  detail::check_stop(o);
  out.theta = theta;
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  out.iterations = static_cast<int>(summary.iterations.size()) - 1;
  out.termination = summary.termination_type;
  out.message = summary.message;
  if (summary.termination_type == ceres::USER_SUCCESS) {
    out.termination = ceres::CONVERGENCE;
    out.message = fmt::format("Cost stationary: relative decrease {:.3e} over the last {} iterations <= {:.1e}",
                              stall.decrease(), o.stall_iterations, o.stall_tolerance);
  }
  out.usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost);
  return out;
}

// LM with an active-set step for the lower bounds. Ceres projects steps onto the
// bounds, and LM crawls along an active bound (piezo gpi: tau -> 0, 200 iterations
// without convergence). So LM runs first for at most kProbe iterations; parameters
// that end on their bound (within kOnBound of their scale) are then held there and LM
// solves the others, unconstrained in the interior; otherwise LM continues. The
// better solution is kept; `at_bound` lists the parameters held on a bound.
Solved solve(const LmProblem& lm, const Data& d, const std::vector<double>& theta, const std::vector<double>& lower,
             const std::vector<int>& held, const FitOptions& o, int start) {
  // Only the gpi of Eqs. 6-8 (LmProblem::active_set): on the slope models (p_i >= 0 bounds
  // of mpi-asym) weights touch the bound and leave it again as the envelopes move, and
  // holding them costs accuracy (mpi-openloop experiment: compensated max error 2.5 -> 4.1 mm).
  if (!lm.active_set()) return solve_once(lm, d, theta, lower, held, o, start, o.max_iterations);
  const int first = std::min(o.max_iterations, kProbe);
  Solved out = solve_once(lm, d, theta, lower, held, o, start, first);
  const int left = o.max_iterations - std::max(0, out.iterations);
  if (!out.usable || left <= 0) return out;
  std::vector<int> active = held;
  for (std::size_t i = 0; i < lower.size(); ++i) {
    if (!std::isfinite(lower[i]) || std::find(held.begin(), held.end(), static_cast<int>(i)) != held.end()) continue;
    const double scale = std::max(std::abs(theta[i]), std::abs(lower[i]));
    if (out.theta[i] - lower[i] <= kOnBound * scale) active.push_back(static_cast<int>(i));
  }
  const bool bound = active.size() > held.size() && active.size() < theta.size();
  if (!bound && out.termination != ceres::NO_CONVERGENCE) return out;
  std::vector<double> at = out.theta;
  for (std::size_t k = held.size(); k < active.size(); ++k)
    at[static_cast<std::size_t>(active[k])] = lower[static_cast<std::size_t>(active[k])];
  Solved again = solve_once(lm, d, at, lower, bound ? active : held, o, start, left);
  if (again.usable && again.final_cost <= out.final_cost) {
    again.initial_cost = out.initial_cost;
    // Ceres' "Number of iterations: N" counts the second pass only: say the whole count
    if (again.termination == ceres::NO_CONVERGENCE)
      again.message = fmt::format("Maximum number of iterations reached: {} in all ({} before and {} after {})",
                                  out.iterations + again.iterations, out.iterations, again.iterations,
                                  bound ? fmt::format("holding {} parameter(s) on their lower bounds",
                                                      active.size() - held.size())
                                        : std::string("a restart from the first pass's end"));
    again.iterations += out.iterations;
    if (bound) again.at_bound.assign(active.begin() + static_cast<std::ptrdiff_t>(held.size()), active.end());
    return again;
  }
  return out;
}

}  // namespace

namespace {
// detail::set_lm_compression (tests): LM on the compressed costs (default) or the m residuals.
std::atomic<bool> compress_lm{true};
}  // namespace

bool lm_compression() { return compress_lm.load(); }

// (The Huber loss of these kinds is in their residuals, robust_residual, not a Ceres loss:
// the compression is exact with it too.)
void GpiLm::add_costs(ceres::Problem& problem, const Data& d, double* theta) const {
  problem.AddResidualBlock(lm_compression() ? make_compressed_gpi_chart_cost(d, n) : make_gpi_chart_cost(d, n),
                           nullptr, theta);
}

void SlopeLm::add_costs(ceres::Problem& problem, const Data& d, double* theta) const {
  problem.AddResidualBlock(lm_compression() ? make_compressed_slope_cost(d, layout) : make_slope_cost(d, layout),
                           nullptr, theta);
  if (layout->ridge > 0 && !layout->r.empty() && layout->kind != FitModel::mpi_asym)
    problem.AddResidualBlock(make_ridge_cost(layout), nullptr, theta);
}

namespace {

// Rows of the Jacobian folded into R per step of the blocked QR below.
constexpr Eigen::Index kQrBlockRows = 4096;

// The R factor (p x p, upper triangular, R^T R = J^T J) of the Jacobian of every residual
// block of `problem` at `theta`, restricted to the columns `keep` (the free parameters), by
// a blocked Householder QR: [R; next rows] -> R, kQrBlockRows rows at a time. Memory: one
// evaluation of the blocks (what one LM iteration holds: p + 1 rows for the compressed
// costs of GpiLm and SlopeLm, whose [R; 0] has this R up to signs) plus (p + kQrBlockRows) x p,
// instead of the several m x p copies (sparse, dense, SVD work and its thin U) of
// ceres::Covariance's DENSE_SVD (issue 13: `fit` memory). False if a block cannot be
// evaluated, has more than one parameter block, or a loss function (the caller then uses
// ceres::Covariance).
bool jacobian_r(ceres::Problem& problem, const double* theta, int p, const std::vector<Eigen::Index>& keep,
                Eigen::MatrixXd& R) {
  std::vector<ceres::ResidualBlockId> ids;
  problem.GetResidualBlocks(&ids);
  const auto f = static_cast<Eigen::Index>(keep.size());
  R = Eigen::MatrixXd::Zero(0, f);
  Eigen::MatrixXd stack;
  std::vector<double> res, jac;
  for (const ceres::ResidualBlockId id : ids) {
    const ceres::CostFunction* cost = problem.GetCostFunctionForResidualBlock(id);
    if (problem.GetLossFunctionForResidualBlock(id) != nullptr) return false;
    if (cost->parameter_block_sizes().size() != 1 || cost->parameter_block_sizes()[0] != p) return false;
    const auto m = static_cast<std::size_t>(cost->num_residuals());
    res.assign(m, 0.0);
    jac.assign(m * static_cast<std::size_t>(p), 0.0);
    const double* params[1] = {theta};
    double* jacs[1] = {jac.data()};
    if (!cost->Evaluate(params, res.data(), jacs)) return false;
    std::vector<double>().swap(res);
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
        jac.data(), static_cast<Eigen::Index>(m), p);
    for (Eigen::Index r0 = 0; r0 < J.rows(); r0 += kQrBlockRows) {
      const Eigen::Index b = std::min(kQrBlockRows, J.rows() - r0);
      stack.resize(R.rows() + b, f);
      stack.topRows(R.rows()) = R;
      for (Eigen::Index c = 0; c < f; ++c) stack.block(R.rows(), c, b, 1) = J.block(r0, keep[static_cast<std::size_t>(c)], b, 1);
      const Eigen::HouseholderQR<Eigen::MatrixXd> qr(stack);
      const Eigen::Index k = std::min(stack.rows(), f);
      R = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
    }
  }
  if (R.rows() < f) {  // fewer residuals than parameters: pad (rank deficient)
    Eigen::MatrixXd P = Eigen::MatrixXd::Zero(f, f);
    P.topRows(R.rows()) = R;
    R = P;
  }
  return true;
}

}  // namespace

void standard_errors(const LmProblem& lm, const Data& d, std::vector<double> theta, const std::vector<double>& lower,
                     const std::vector<int>& held, const Eigen::MatrixXd& M, double sse, FitReport& rep) {
  auto problem = make_problem(lm, d, theta, lower, held);
  const auto p = static_cast<Eigen::Index>(theta.size());
  std::vector<Eigen::Index> keep;
  for (Eigen::Index c = 0; c < p; ++c)
    if (std::find(held.begin(), held.end(), static_cast<int>(c)) == held.end()) keep.push_back(c);
  const char* rank_deficient =
      "covariance not computed: the Jacobian is rank deficient (parameters not identifiable from this record)";
  // Rank check first (ceres::Covariance would log an error for a singular problem): Ceres
  // (DENSE_SVD) refuses when (s_min / s_max)^2 of J < 1e-14; the singular values of J itself
  // (not eigenvalues of J^T J, which lose half the digits: those of R, J = Q R) with a margin.
  Eigen::MatrixXd R;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(p, p);
  if (jacobian_r(*problem, theta.data(), static_cast<int>(p), keep, R)) {
    // cov = (J^T J)^-1 = V S^-2 V^T from the SVD of R (that of J: R^T R = J^T J), as
    // ceres::Covariance's DENSE_SVD computes it from J (no truncation: the rank test
    // above is stricter than its own); held parameters have zero rows and columns.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeFullV);
    const Eigen::VectorXd sv = svd.singularValues();
    const double smax = sv.size() ? sv.maxCoeff() : 0.0, smin = sv.size() ? sv.minCoeff() : 0.0;
    if (!(smax > 0) || !(smin * smin > kRankTolerance * smax * smax)) {
      rep.covariance_note = rank_deficient;
      return;
    }
    const Eigen::MatrixXd V = svd.matrixV();
    const Eigen::MatrixXd Cf = V * sv.array().square().inverse().matrix().asDiagonal() * V.transpose();
    for (std::size_t i = 0; i < keep.size(); ++i)
      for (std::size_t j = 0; j < keep.size(); ++j)
        C(keep[i], keep[j]) = Cf(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
  } else {
    // a loss function or another layout (no fit here has either since bouc-wen's Huber
    // moved into its residuals, 481d63b; kept for LmProblems that add one): ceres::Covariance
    {
      ceres::CRSMatrix crs;
      double cost = 0;
      problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, &crs);
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
      for (int r = 0; r < crs.num_rows; ++r)
        for (int k = crs.rows[static_cast<std::size_t>(r)]; k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k)
          J(r, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
      // (with held parameters, the problem's SubsetManifold makes Ceres evaluate the free columns only)
      Eigen::MatrixXd Jf(J.rows(), static_cast<Eigen::Index>(keep.size()));
      if (J.cols() == Jf.cols())
        Jf = std::move(J);
      else
        for (std::size_t c = 0; c < keep.size(); ++c) Jf.col(static_cast<Eigen::Index>(c)) = J.col(keep[c]);
      const Eigen::VectorXd sv = Eigen::BDCSVD<Eigen::MatrixXd>(Jf).singularValues();
      const double smax = sv.size() ? sv.maxCoeff() : 0.0, smin = sv.size() ? sv.minCoeff() : 0.0;
      if (!(smax > 0) || !(smin * smin > kRankTolerance * smax * smax)) {
        rep.covariance_note = rank_deficient;
        return;
      }
    }
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;
    co.num_threads = 1;
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> blocks{{theta.data(), theta.data()}};
    if (!cov.Compute(blocks, problem.get())) {
      rep.covariance_note = rank_deficient;
      return;
    }
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Cr(p, p);
    cov.GetCovarianceBlock(theta.data(), theta.data(), Cr.data());
    C = Cr;
  }
  const double m = static_cast<double>(d.train.end - d.train.begin);
  const double free = static_cast<double>(theta.size() - held.size());
  const double s2 = sse / std::max(1.0, m - free);
  const Eigen::MatrixXd Cr = s2 * (M * C * M.transpose());
  for (std::size_t i = 0; i < rep.parameters.size(); ++i) {
    const double v = Cr(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i));
    rep.parameters[i].std_error = rep.parameters[i].held || rep.parameters[i].at_bound ? 0.0 : std::sqrt(std::max(0.0, v));
  }
  if (d.huber > 0) rep.covariance_note = "standard errors are approximate with the Huber loss";
}

void standard_errors_level_held(const LmProblem& lm, const Data& d, const std::vector<double>& theta,
                                const std::vector<double>& lower, const std::vector<int>& held, const Eigen::MatrixXd& M,
                                double sse, int level, const std::vector<int>& no_error, const char* note,
                                FitReport& rep) {
  standard_errors(lm, d, theta, lower, held, M, sse, rep);
  // standard_errors sets every parameter's error (0 for held or bound ones) or none
  const auto none = [&] {
    return std::all_of(rep.parameters.begin(), rep.parameters.end(),
                       [](const FitParameter& p) { return std::isnan(p.std_error); });
  };
  if (level < 0 || !d.free_offset || !none() || std::find(held.begin(), held.end(), level) != held.end()) return;
  std::vector<int> with_level = held;
  with_level.push_back(level);
  rep.covariance_note.clear();
  standard_errors(lm, d, theta, lower, with_level, M, sse, rep);
  if (none()) return;
  for (int i : no_error) rep.parameters[static_cast<std::size_t>(i)].std_error = std::numeric_limits<double>::quiet_NaN();
  rep.covariance_note = note;
}

void finish_status(FitReport& rep, const Solved& best, bool start_is_minimum) {
  switch (best.termination) {
    case ceres::CONVERGENCE: rep.status = FitStatus::converged; break;
    case ceres::NO_CONVERGENCE: rep.status = FitStatus::no_convergence; break;
    default: rep.status = best.usable ? FitStatus::no_convergence : FitStatus::failed; break;
  }
  rep.message = best.message;
  // A solver that never moved from a start that is not a minimum by construction
  // (start_is_minimum: the least-squares weights of the slope kinds, without Huber or with
  // every residual inside its quadratic zone)
  // has not shown convergence unless the start already fits to rounding: it stopped
  // because a tolerance was met at the start (a cost scaled to nothing).
  constexpr double rounding_cost = 1e-20;  // 0.5 sum r^2 of 1e6 residuals of 1e-13
  if (!start_is_minimum && rep.status == FitStatus::converged && best.iterations <= 0 &&
      best.final_cost > rounding_cost) {
    rep.status = FitStatus::no_convergence;
    rep.message = fmt::format("the solver did not move from its start ({}); the fit is not known to be a minimum",
                              best.message);
  }
}

std::pair<std::vector<Solved>, std::size_t> solve_starts(const std::vector<const LmProblem*>& problems, const Data& d,
                                                         const std::vector<std::vector<double>>& starts,
                                                         const std::vector<std::vector<double>>& lowers,
                                                         const std::vector<int>& held, const FitOptions& o,
                                                         FitReport& rep) {
  std::vector<Solved> solved(starts.size());
  // With the default thread count (0: one per usable CPU) the concurrent starts of an
  // uncompressed cost (the full problems of detail::set_lm_compression(false)) are capped by memory: each holds about
  // kLmCopies m x p Jacobian-sized buffers (Ceres' dense Jacobian and its evaluation scratch,
  // residual vectors), so on a long record they run one after the other instead of
  // multiplying the peak (issue 13: `fit` memory). Compressed costs (GpiLm, SlopeLm, bouc-wen
  // without a loss) hold one block of rows per start: no cap. The result does not depend on
  // the number of threads; an explicit num_threads is kept.
  const bool small = std::all_of(problems.begin(), problems.end(), [](const LmProblem* p) { return p->compressed(); });
  int threads = o.num_threads;
  if (threads == 0 && !starts.empty() && !small) {
    const double rows = static_cast<double>(d.train.end);
    const double per_start = kLmCopies * rows * static_cast<double>(starts.front().size() + 1) * sizeof(double);
    const auto hw = static_cast<double>(usable_cpus());
    threads = static_cast<int>(std::clamp(std::floor(kLmConcurrentBytes / per_start), 1.0, hw));
  }
  detail::parallel_for(starts.size(), threads, [&](std::size_t k) {
    solved[k] = solve(*problems[k], d, starts[k], lowers[k], held, o, static_cast<int>(k));
  });
  std::size_t best = std::string::npos;
  for (std::size_t k = 0; k < solved.size(); ++k) {
    rep.total_iterations += std::max(0, solved[k].iterations);
    if (solved[k].usable && (best == std::string::npos || solved[k].final_cost < solved[best].final_cost)) best = k;
  }
  rep.num_starts = static_cast<int>(starts.size());
  return {std::move(solved), best};
}

namespace {

// fn(y - model) for each sample of the training range, in order (the model run from the
// record's start).
template <class Fn>
void for_each_residual(const ModelParams& model, const Data& d, Fn&& fn) {
  const std::vector<double> yp = simulate_record(model, d.x.subspan(0, d.train.end), d.initial);
  for (std::size_t j = d.train.begin; j < d.train.end; ++j) fn(d.y[j] - yp[j]);
}

}  // namespace

double projected_offset(const ModelParams& model, const Data& d) {
  double c = 0;
  for_each_residual(model, d, [&](double r) { c += r; });
  return c / static_cast<double>(d.train.end - d.train.begin);
}

double model_sse(const ModelParams& model, const Data& d) {
  double sse = 0;
  for_each_residual(model, d, [&](double r) { sse += r * r; });
  return sse;
}

double max_abs_residual(const ModelParams& model, const Data& d) {
  double m = 0;
  for_each_residual(model, d, [&](double r) { m = std::max(m, std::abs(r)); });
  return m;
}

double fitted_sse(const ModelParams& model, const Data& d) {
  double sse = 0;
  for_each_residual(model, d, [&](double r) {
    const double f = robust_residual(r, d.huber);  // r itself without Huber
    sse += f * f;
  });
  return sse;
}

}  // namespace hysteron::fitting

namespace hysteron::detail {

bool set_lm_compression(bool on) { return fitting::compress_lm.exchange(on); }

// Runs fn(k) for k = 0..count-1, the k spread over up to `threads` threads (0: one per
// usable CPU; 1: in order on this thread). Each k is independent, so the
// results do not depend on the thread count. The first exception (lowest k) thrown
// by a task is rethrown once all have finished. If a thread cannot be created the
// work runs on the threads that exist.
void parallel_for(std::size_t count, int threads, const std::function<void(std::size_t)>& fn) {
  std::size_t t = threads > 0 ? static_cast<std::size_t>(threads) : usable_cpus();
  t = std::min(t, count);
  if (t <= 1) {
    for (std::size_t k = 0; k < count; ++k) fn(k);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors(count);
  auto work = [&] {
    for (std::size_t k; (k = next.fetch_add(1)) < count;) {
      try {
        fn(k);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(t - 1);
  for (std::size_t i = 0; i + 1 < t; ++i) {
    try {
      pool.emplace_back(work);
    } catch (const std::system_error&) {
      break;
    }
  }
  work();
  for (auto& th : pool) th.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace hysteron::detail
