// Levenberg-Marquardt identification through Ceres with automatic
// differentiation through the operator recursion (Eqs. 12-16).
#include <Eigen/Eigenvalues>
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>
#include <random>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

namespace {

using Clock = std::chrono::steady_clock;

// ---- data and residuals -----------------------------------------------------------

struct Data {
  std::span<const double> x, y;
  IndexRange train;  // resolved
  InitialState initial = InitialState::virgin;
  double huber = 0.0;
};

// Residual of Eq. 12, optionally mapped so that its square is the Huber loss:
// f = r for |r| <= d, f = sign(r) sqrt(2 d |r| - d^2) beyond.
template <class T>
inline T robust_residual(const T& r, double d) {
  if (d <= 0) return r;
  if (r < T(d) && T(-d) < r) return r;
  using std::sqrt;
  const T a = r < T(0) ? T(-r) : r;
  const T f = sqrt(T(2.0 * d) * a - T(d * d));
  return r < T(0) ? T(-f) : f;
}

// Simulates the structure over [0, train.end) and writes the residuals of the train range.
template <class T>
void residuals_of(const Structure<T>& s, const Data& d, T* res) {
  std::vector<T> y(s.r.size(), T(0));
  if (d.initial == InitialState::relaxed) {
    const T u0 = envelope_value<T>(s.asc_kind, s.asc_c.data(), d.x[0]);
    std::fill(y.begin(), y.end(), u0);
  }
  for (std::size_t k = 0; k < d.train.end; ++k) {
    const T out = structure_step<T>(s, d.x[k], y.data());
    if (k >= d.train.begin) res[k - d.train.begin] = robust_residual<T>(T(d.y[k]) - out, d.huber);
  }
}

// ---- gpi: Theta = [c0, c1, c2, c3, q, rho, tau, alpha] -------------------------------

constexpr int kGpi = 8;

template <class T>
void build_gpi(const T* th, int n, Structure<T>& s) {
  s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
  s.asc_c = {th[0], th[1], th[2], th[3]};
  s.desc_c = s.asc_c;
  s.q = th[4];
  s.r.resize(static_cast<std::size_t>(n));
  s.p.resize(static_cast<std::size_t>(n));
  using std::exp;
  for (int i = 0; i < n; ++i) {
    const T ri = th[7] * T(i + 1);                    // Eq. 7
    s.r[static_cast<std::size_t>(i)] = ri;
    s.p[static_cast<std::size_t>(i)] = th[5] * exp(-th[6] * ri);  // Eq. 8
  }
}

struct GpiFunctor {
  Data d;
  int n;
  template <class T>
  bool operator()(const T* th, T* res) const {
    Structure<T> s;
    build_gpi(th, n, s);
    residuals_of(s, d, res);
    return true;
  }
};

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

// ---- models linear in their weights: cumulative-slope parametrization ---------------
// theta = [envelope coefficients (mpi-asym: 4 ascending + 4 descending)],
//         s_0..s_n (s_0 = q, s_i = q + p_1 + ... + p_i),
//         mpi-deadzone: d_1..d_J (positive side, z ascending), then the negative side
//         (z descending): cumulative output slopes g0 + g_1 + ... + g_j, with g0 = 1.
struct SlopeLayout {
  FitModel kind = FitModel::pi;
  std::vector<double> r;       // fixed thresholds (ascending)
  std::vector<double> zp, zn;  // fixed forward dead-zone thresholds (v units)
  int env = 0;                 // number of envelope coefficients (0 or 8)
  int size() const { return env + static_cast<int>(r.size() + 1 + zp.size() + zn.size()); }

  template <class T>
  void build(const T* th, Structure<T>& s) const {
    if (env == 8) {
      s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
      s.asc_c = {th[0], th[1], th[2], th[3]};
      s.desc_c = {th[4], th[5], th[6], th[7]};
      s.asymmetric = true;
    }
    const T* sl = th + env;
    const std::size_t n = r.size();
    s.q = sl[0];
    s.r.resize(n);
    s.p.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      s.r[i] = T(r[i]);
      s.p[i] = sl[i + 1] - sl[i];
    }
    if (kind == FitModel::mpi_deadzone) {
      s.has_dead_zones = true;
      s.g0 = T(1);
      s.z.clear();
      s.g.clear();
      const T* dz = sl + n + 1;
      for (const std::vector<double>* side : {&zp, &zn}) {
        T prev(1);
        for (double z : *side) {
          s.z.push_back(T(z));
          s.g.push_back(*dz - prev);
          prev = *dz++;
        }
      }
    }
  }

  ModelParams params(const double* th) const {
    Structure<double> s;
    build(th, s);
    switch (kind) {
      case FitModel::pi: return PiParams{s.q, s.r, s.p, {}};
      case FitModel::mpi_asym: {
        MpiAsymParams m;
        m.ascending = Envelope::tanh(th[0], th[1], th[2], th[3]);
        m.descending = Envelope::tanh(th[4], th[5], th[6], th[7]);
        m.q = s.q;
        m.r = s.r;
        m.p = s.p;
        return m;
      }
      default: {
        MpiDeadzoneParams m;
        m.q = s.q;
        m.r = s.r;
        m.p = s.p;
        m.g0 = 1.0;
        m.z = s.z;
        m.g = s.g;
        return m;
      }
    }
  }

  // Reported parameters: envelope coefficients, q, p_i, g_j (a linear map M of theta).
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    if (env == 8) {
      for (int i = 0; i < 4; ++i) out.push_back(fmt::format("asc.c{}", i));
      for (int i = 0; i < 4; ++i) out.push_back(fmt::format("desc.c{}", i));
    }
    out.push_back("q");
    for (std::size_t i = 0; i < r.size(); ++i) out.push_back(fmt::format("p{}", i + 1));
    for (std::size_t j = 0; j < zp.size() + zn.size(); ++j) out.push_back(fmt::format("g{}", j + 1));
    return out;
  }
  Eigen::MatrixXd report_map() const {
    const int m = size();
    Eigen::MatrixXd M = Eigen::MatrixXd::Identity(m, m);
    const int n = static_cast<int>(r.size());
    for (int i = 1; i <= n; ++i) M(env + i, env + i - 1) = -1.0;
    int k = env + n + 1;
    for (const std::vector<double>* side : {&zp, &zn}) {
      for (std::size_t j = 0; j < side->size(); ++j, ++k)
        if (j > 0) M(k, k - 1) = -1.0;
    }
    return M;
  }
};

struct SlopeFunctor {
  Data d;
  const SlopeLayout* layout;
  template <class T>
  bool operator()(T const* const* th, T* res) const {
    Structure<T> s;
    layout->build(th[0], s);
    residuals_of(s, d, res);
    return true;
  }
};

// ---- solving ------------------------------------------------------------------

class Progress : public ceres::IterationCallback {
 public:
  Progress(const FitOptions& o, int start) : o_(o), start_(start) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (o_.progress) o_.progress(start_, s.iteration, s.cost);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const FitOptions& o_;
  int start_;
};

struct Problem {
  std::unique_ptr<ceres::Problem> problem;
  std::vector<double> theta;
};

struct Solved {
  std::vector<double> theta;
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;
  ceres::TerminationType termination = ceres::FAILURE;
  std::string message;
  bool usable = false;
};

// Builds the problem for one start; `theta` must outlive it (it is the parameter block).
std::unique_ptr<ceres::Problem> make_problem(FitModel kind, const Data& d, int n, const SlopeLayout* layout,
                                             std::vector<double>& theta, const std::vector<double>& lower,
                                             const std::vector<int>& held) {
  auto problem = std::make_unique<ceres::Problem>();
  const int m = static_cast<int>(d.train.end - d.train.begin);
  ceres::CostFunction* cost = nullptr;
  if (kind == FitModel::gpi) {
    cost = new ceres::AutoDiffCostFunction<GpiFunctor, ceres::DYNAMIC, kGpi>(new GpiFunctor{d, n}, m);
  } else {
    auto* dyn = new ceres::DynamicAutoDiffCostFunction<SlopeFunctor, 10>(new SlopeFunctor{d, layout});
    dyn->AddParameterBlock(static_cast<int>(theta.size()));
    dyn->SetNumResiduals(m);
    cost = dyn;
  }
  problem->AddResidualBlock(cost, nullptr, theta.data());
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (std::isfinite(lower[i])) problem->SetParameterLowerBound(theta.data(), static_cast<int>(i), lower[i]);
  if (!held.empty() && held.size() < theta.size())
    problem->SetManifold(theta.data(), new ceres::SubsetManifold(static_cast<int>(theta.size()), held));
  return problem;
}

Solved solve(FitModel kind, const Data& d, int n, const SlopeLayout* layout, std::vector<double> theta,
             const std::vector<double>& lower, const std::vector<int>& held, const FitOptions& o, int start) {
  Solved out;
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (std::isfinite(lower[i])) theta[i] = std::max(theta[i], lower[i]);
  auto problem = make_problem(kind, d, n, layout, theta, lower, held);
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.gradient_tolerance = o.gradient_tolerance;
  so.parameter_tolerance = o.parameter_tolerance;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  Progress cb(o, start);
  if (o.progress) so.callbacks.push_back(&cb);
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem.get(), &summary);
  out.theta = theta;
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  out.iterations = static_cast<int>(summary.iterations.size()) - 1;
  out.termination = summary.termination_type;
  out.message = summary.message;
  out.usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost);
  return out;
}

// Standard errors of theta (cov = s^2 (J^T J)^-1), mapped by M to reported parameters.
void standard_errors(FitModel kind, const Data& d, int n, const SlopeLayout* layout, std::vector<double> theta,
                     const std::vector<double>& lower, const std::vector<int>& held, const Eigen::MatrixXd& M,
                     double sse, FitReport& rep) {
  auto problem = make_problem(kind, d, n, layout, theta, lower, held);
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.num_threads = 1;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks{{theta.data(), theta.data()}};
  const auto p = static_cast<Eigen::Index>(theta.size());
  // Rank check first (ceres::Covariance would log an error for a singular problem).
  {
    ceres::CRSMatrix crs;
    double cost = 0;
    problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, &crs);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int r = 0; r < crs.num_rows; ++r)
      for (int k = crs.rows[static_cast<std::size_t>(r)]; k < crs.rows[static_cast<std::size_t>(r) + 1]; ++k)
        J(r, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
    std::vector<Eigen::Index> keep;
    for (Eigen::Index c = 0; c < J.cols(); ++c)
      if (std::find(held.begin(), held.end(), static_cast<int>(c)) == held.end()) keep.push_back(c);
    Eigen::MatrixXd Jf(J.rows(), static_cast<Eigen::Index>(keep.size()));
    for (std::size_t c = 0; c < keep.size(); ++c) Jf.col(static_cast<Eigen::Index>(c)) = J.col(keep[c]);
    const Eigen::MatrixXd JtJ = Jf.transpose() * Jf;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(JtJ, Eigen::EigenvaluesOnly);
    const double lmax = es.eigenvalues().maxCoeff(), lmin = es.eigenvalues().minCoeff();
    if (!(lmax > 0) || !(lmin > 1e-13 * lmax)) {
      rep.covariance_note =
          "covariance not computed: the Jacobian is rank deficient (parameters not identifiable from this record)";
      return;
    }
  }
  if (!cov.Compute(blocks, problem.get())) {
    rep.covariance_note =
        "covariance not computed: the Jacobian is rank deficient (parameters not identifiable from this record)";
    return;
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> C(p, p);
  cov.GetCovarianceBlock(theta.data(), theta.data(), C.data());
  const double m = static_cast<double>(d.train.end - d.train.begin);
  const double free = static_cast<double>(theta.size() - held.size());
  const double s2 = sse / std::max(1.0, m - free);
  const Eigen::MatrixXd Cr = s2 * (M * C * M.transpose());
  for (std::size_t i = 0; i < rep.parameters.size(); ++i) {
    const double v = Cr(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i));
    rep.parameters[i].std_error = rep.parameters[i].held ? 0.0 : std::sqrt(std::max(0.0, v));
  }
  if (d.huber > 0) rep.covariance_note = "standard errors are approximate with the Huber loss";
}

// ---- data-derived initial guesses --------------------------------------------------

struct Ranges {
  double xlo, xhi, ylo, yhi;
  double xspan() const { return xhi - xlo; }
  double yspan() const { return yhi - ylo; }
};

Ranges ranges_of(const Data& d) {
  const auto xs = d.x.subspan(d.train.begin, d.train.end - d.train.begin);
  const auto ys = d.y.subspan(d.train.begin, d.train.end - d.train.begin);
  const auto [xl, xh] = std::minmax_element(xs.begin(), xs.end());
  const auto [yl, yh] = std::minmax_element(ys.begin(), ys.end());
  return {*xl, *xh, *yl, *yh};
}

// Half the vertical gap between the falling and rising branches, median over
// input bins (the loop half-height), in output units.
double loop_half_height(const Data& d, const Ranges& rg) {
  constexpr int kBins = 20;
  std::vector<double> su(kBins, 0), sd(kBins, 0), nu(kBins, 0), nd(kBins, 0);
  for (std::size_t k = d.train.begin + 1; k < d.train.end; ++k) {
    const double dx = d.x[k] - d.x[k - 1];
    if (dx == 0) continue;
    int b = static_cast<int>((d.x[k] - rg.xlo) / rg.xspan() * kBins);
    b = std::clamp(b, 0, kBins - 1);
    if (dx > 0) {
      su[static_cast<std::size_t>(b)] += d.y[k];
      nu[static_cast<std::size_t>(b)] += 1;
    } else {
      sd[static_cast<std::size_t>(b)] += d.y[k];
      nd[static_cast<std::size_t>(b)] += 1;
    }
  }
  std::vector<double> gaps;
  for (std::size_t b = 0; b < kBins; ++b)
    if (nu[b] > 0 && nd[b] > 0) gaps.push_back(std::abs(sd[b] / nd[b] - su[b] / nu[b]) / 2);
  if (gaps.empty()) return 0.05 * rg.yspan();
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
  return std::max(gaps[gaps.size() / 2], 1e-3 * rg.yspan());
}

// For fixed envelope, alpha and tau the gpi output is linear in (q, rho): solve
// them by NNLS and return the sum of squared errors.
double gpi_linear_seed(const Data& d, int n, double* th, double lower_q, double lower_rho) {
  Structure<double> s;
  th[4] = 1.0;
  th[5] = 1.0;
  build_gpi(th, n, s);
  const auto m = static_cast<Eigen::Index>(d.train.end - d.train.begin);
  Eigen::MatrixXd A(m, 2);
  Eigen::VectorXd b(m);
  std::vector<double> y(static_cast<std::size_t>(n), 0.0);
  if (d.initial == InitialState::relaxed) std::fill(y.begin(), y.end(), envelope_value<double>(s.asc_kind, s.asc_c.data(), d.x[0]));
  for (std::size_t k = 0; k < d.train.end; ++k) {
    const double u = envelope_value<double>(s.asc_kind, s.asc_c.data(), d.x[k]);
    double z = 0.0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      y[i] = ops::generalized_play<double>(u, s.r[i], y[i]);
      z += s.p[i] * y[i];
    }
    if (k >= d.train.begin) {
      const auto row = static_cast<Eigen::Index>(k - d.train.begin);
      A(row, 0) = u;
      A(row, 1) = z;
      b(row) = d.y[k];
    }
  }
  const Eigen::Vector2d lo(lower_q, lower_rho);
  const Eigen::VectorXd t = lo + detail::nnls(A, b - A * lo);
  th[4] = t(0);
  th[5] = t(1);
  return (A * t - b).squaredNorm();
}

std::vector<std::vector<double>> gpi_starts(const Data& d, int n, const FitOptions& o, double lb_rel) {
  const Ranges rg = ranges_of(d);
  const double xc = 0.5 * (rg.xlo + rg.xhi), xs = 0.5 * rg.xspan();
  const double c0 = 0.5 * rg.yspan();
  const double h = loop_half_height(d, rg);
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> jit(-0.1, 0.1);
  auto j = [&](double v) { return o.seed == 0 ? v : v * (1.0 + jit(rng)); };
  struct Cand {
    double sse;
    std::vector<double> th;
  };
  std::vector<Cand> cands;
  for (double a : {0.4, 1.0, 2.0}) {
    for (double bshift : {-0.5, 0.0, 0.5}) {
      const double aa = j(a);
      const double c1 = aa / xs, c2 = -aa * xc / xs + bshift;
      const double g_lo = c0 * std::tanh(-aa + bshift), g_hi = c0 * std::tanh(aa + bshift);
      const double K = rg.yspan() / (g_hi - g_lo);
      const double c3 = rg.ylo / K - g_lo;
      const double uhalf = 0.5 * (g_hi - g_lo);
      const double f_w = std::clamp(2.0 * (h / K) / uhalf, 0.05, 2.0);
      for (double f : {f_w, 0.5, 1.0}) {
        const double alpha = j(f) * uhalf / n;
        for (double tr : {0.05, 0.5, 2.5}) {
          std::vector<double> th{c0, c1, c2, c3, 1.0, 1.0, tr / (alpha * n), alpha};
          const double sse = gpi_linear_seed(d, n, th.data(), lb_rel * K, lb_rel * K);
          if (std::isfinite(sse)) cands.push_back({sse, th});
        }
      }
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) { return a.sse < b.sse; });
  std::vector<std::vector<double>> out;
  for (const Cand& c : cands) {
    if (static_cast<int>(out.size()) >= o.num_starts) break;
    out.push_back(c.th);
  }
  return out;
}

int num_parameters(const FitOptions& o) {
  const int n = o.num_operators;
  switch (o.model) {
    case FitModel::gpi: return kGpi;
    case FitModel::pi: return n;
    case FitModel::mpi_deadzone: return n + 1 + o.num_dead_zones;
    case FitModel::mpi_asym: return 8 + n + 1;
  }
  return n;
}

FitReport invalid(std::string msg, FitModel kind, Clock::time_point t0) {
  FitReport rep;
  rep.status = FitStatus::invalid_input;
  rep.model_kind = kind;
  rep.message = std::move(msg);
  rep.time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return rep;
}

void finish_status(FitReport& rep, const Solved& best) {
  switch (best.termination) {
    case ceres::CONVERGENCE: rep.status = FitStatus::converged; break;
    case ceres::NO_CONVERGENCE: rep.status = FitStatus::no_convergence; break;
    default: rep.status = best.usable ? FitStatus::no_convergence : FitStatus::failed; break;
  }
  rep.message = best.message;
}

// Runs LM on several slope-parametrized starts and fills the report.
void fit_slopes(const Data& d, const SlopeLayout& layout, const std::vector<std::vector<double>>& starts,
                const std::vector<double>& lower, const FitOptions& o, FitReport& rep) {
  Solved best;
  best.final_cost = std::numeric_limits<double>::infinity();
  int k = 0;
  for (const auto& th : starts) {
    Solved s = solve(o.model, d, 0, &layout, th, lower, {}, o, k++);
    rep.total_iterations += std::max(0, s.iterations);
    if (s.usable && s.final_cost < best.final_cost) best = std::move(s);
  }
  rep.num_starts = static_cast<int>(starts.size());
  if (!best.usable) {
    rep.status = FitStatus::failed;
    rep.message = "no start gave a usable solution";
    return;
  }
  finish_status(rep, best);
  rep.initial_cost = best.initial_cost;
  rep.final_cost = best.final_cost;
  rep.iterations = best.iterations;
  rep.model = layout.params(best.theta.data());
  const Eigen::MatrixXd M = layout.report_map();
  const Eigen::VectorXd v = M * Eigen::Map<const Eigen::VectorXd>(best.theta.data(), static_cast<Eigen::Index>(best.theta.size()));
  const auto names = layout.names();
  for (std::size_t i = 0; i < names.size(); ++i) rep.parameters.push_back({names[i], v(static_cast<Eigen::Index>(i))});
  if (o.compute_covariance) {
    const std::vector<double> yp = simulate_record(rep.model, d.x.subspan(0, d.train.end), d.initial);
    double sse = 0;
    for (std::size_t j = d.train.begin; j < d.train.end; ++j) sse += (d.y[j] - yp[j]) * (d.y[j] - yp[j]);
    standard_errors(o.model, d, 0, &layout, best.theta, lower, {}, M, sse, rep);
  }
}

// Slope vector [s_0..s_n] of weights q, p.
std::vector<double> slopes(double q, const std::vector<double>& p) {
  std::vector<double> s{q};
  for (double pi : p) s.push_back(s.back() + pi);
  return s;
}

}  // namespace

std::string_view fit_model_name(FitModel model) noexcept {
  switch (model) {
    case FitModel::gpi: return "gpi";
    case FitModel::pi: return "pi";
    case FitModel::mpi_deadzone: return "mpi-deadzone";
    case FitModel::mpi_asym: return "mpi-asym";
  }
  return "gpi";
}

FitModel fit_model_from_name(std::string_view name) {
  for (FitModel m : {FitModel::gpi, FitModel::pi, FitModel::mpi_deadzone, FitModel::mpi_asym})
    if (fit_model_name(m) == name) return m;
  throw Error(fmt::format("unknown model '{}' (expected gpi, pi, mpi-deadzone or mpi-asym)", name));
}

std::string_view fit_status_name(FitStatus status) noexcept {
  switch (status) {
    case FitStatus::not_run: return "not_run";
    case FitStatus::converged: return "converged";
    case FitStatus::no_convergence: return "no_convergence";
    case FitStatus::failed: return "failed";
    case FitStatus::invalid_input: return "invalid_input";
  }
  return "not_run";
}

bool FitOptions::is_valid(std::string* error) const {
  auto fail = [&](std::string msg) {
    if (error) *error = std::move(msg);
    return false;
  };
  if (num_operators < 1 || num_operators > 200) return fail(fmt::format("num_operators must be in 1..200, got {}", num_operators));
  if (num_dead_zones < 0 || num_dead_zones > 50) return fail(fmt::format("num_dead_zones must be in 0..50, got {}", num_dead_zones));
  if (!(huber_delta >= 0) || !std::isfinite(huber_delta)) return fail(fmt::format("huber_delta must be >= 0, got {}", huber_delta));
  if (num_starts < 1 || num_starts > 54) return fail(fmt::format("num_starts must be in 1..54, got {}", num_starts));
  if (max_iterations < 1) return fail(fmt::format("max_iterations must be >= 1, got {}", max_iterations));
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0))
    return fail("tolerances must be >= 0");
  if (!(positivity_margin >= 0 && positivity_margin < 0.1))
    return fail(fmt::format("positivity_margin must be in [0, 0.1), got {}", positivity_margin));
  return true;
}

std::vector<double> default_thresholds(std::span<const double> x, int n) {
  const double span = detail::span_of(x);
  std::vector<double> r;
  for (int i = 1; i < n; ++i) r.push_back(i * span / (2.0 * n));
  return r;
}

FitReport fit(std::span<const double> x, std::span<const double> y, const FitOptions& o) {
  const auto t0 = Clock::now();
  std::string why;
  if (!o.is_valid(&why)) return invalid("invalid options: " + why, o.model, t0);
  IndexRange tr;
  try {
    detail::check_record(x, y, "fit");
    tr = detail::check_range(o.train, x.size(), "fit: train");
  } catch (const Error& e) {
    return invalid(e.what(), o.model, t0);
  }
  const int np = num_parameters(o);
  const std::size_t m = tr.end - tr.begin;
  if (m < 10 * static_cast<std::size_t>(np))
    return invalid(fmt::format("fit: {} training samples are too few for {} parameters (need at least {})", m, np, 10 * np),
                   o.model, t0);
  Data d{x, y, tr, o.initial_state, o.huber_delta};
  const Ranges rg = ranges_of(d);
  if (!(rg.xspan() > 0)) return invalid("fit: the input is constant over the training range", o.model, t0);
  if (!(rg.yspan() > 0)) return invalid("fit: the output is constant over the training range", o.model, t0);

  FitReport rep;
  rep.model_kind = o.model;
  const int n = o.num_operators;
  try {
    if (o.model == FitModel::gpi) {
      const double lb = std::max(o.positivity_margin, 1e-12);
      const auto starts = gpi_starts(d, n, o, lb);
      Solved best;
      best.final_cost = std::numeric_limits<double>::infinity();
      std::vector<double> lower;
      std::vector<int> held;
      std::vector<double> best_lower;
      int k = 0;
      for (const auto& th : starts) {
        // bounds of Eq. 13 plus q, alpha > 0, relative to the start's scale
        lower.assign(kGpi, -std::numeric_limits<double>::infinity());
        for (int i : {0, 1, 4, 5, 6, 7}) lower[static_cast<std::size_t>(i)] = lb * std::abs(th[static_cast<std::size_t>(i)]);
        held.clear();
        if (o.gpi_fix_scale) held.push_back(0);
        Solved s = solve(FitModel::gpi, d, n, nullptr, th, lower, held, o, k++);
        rep.total_iterations += std::max(0, s.iterations);
        if (s.usable && s.final_cost < best.final_cost) {
          best = std::move(s);
          best_lower = lower;
        }
      }
      rep.num_starts = static_cast<int>(starts.size());
      if (!best.usable) {
        rep.status = FitStatus::failed;
        rep.message = "no start gave a usable solution";
      } else {
        finish_status(rep, best);
        rep.initial_cost = best.initial_cost;
        rep.final_cost = best.final_cost;
        rep.iterations = best.iterations;
        rep.model = gpi_params(best.theta.data(), n);
        static const char* names[kGpi] = {"c0", "c1", "c2", "c3", "q", "rho", "tau", "alpha"};
        for (int i = 0; i < kGpi; ++i)
          rep.parameters.push_back({names[i], best.theta[static_cast<std::size_t>(i)],
                                    std::numeric_limits<double>::quiet_NaN(), o.gpi_fix_scale && i == 0});
        if (o.gpi_fix_scale)
          rep.covariance_note =
              "c0 held at its data-derived value: Eq. 13 has the exact scale symmetry (c0,c3,alpha,q,rho,tau) -> "
              "(k c0,k c3,k alpha,q/k,rho/k,tau/k)";
        if (o.compute_covariance) {
          const std::vector<double> yp = simulate_record(rep.model, x.subspan(0, tr.end), o.initial_state);
          double sse = 0;
          for (std::size_t j = tr.begin; j < tr.end; ++j) sse += (y[j] - yp[j]) * (y[j] - yp[j]);
          const std::string note = rep.covariance_note;
          standard_errors(FitModel::gpi, d, n, nullptr, best.theta, best_lower, o.gpi_fix_scale ? std::vector<int>{0} : std::vector<int>{},
                          Eigen::MatrixXd::Identity(kGpi, kGpi), sse, rep);
          if (!note.empty() && rep.covariance_note != note)
            rep.covariance_note = rep.covariance_note.empty() ? note : note + "; " + rep.covariance_note;
        }
      }
    } else {
      SlopeLayout layout;
      layout.kind = o.model;
      std::vector<std::vector<double>> starts;
      const double margin = std::max(o.positivity_margin, 1e-12);
      WeightFitOptions wo;
      wo.initial_state = o.initial_state;
      wo.train = tr;
      wo.margin = margin;
      const auto xs = x.subspan(tr.begin, tr.end - tr.begin);
      if (o.model == FitModel::pi) {
        PiParams pi;
        pi.r = default_thresholds(xs, n);
        pi.p.assign(pi.r.size(), 0.0);
        const auto fw = std::get<PiParams>(fit_weights(pi, x, y, wo));
        layout.r = fw.r;
        starts.push_back(slopes(fw.q, fw.p));
      } else if (o.model == FitModel::mpi_deadzone) {
        MpiDeadzoneParams dz;
        dz.r = default_thresholds(xs, n);
        dz.p.assign(dz.r.size(), 0.0);
        const int J = o.num_dead_zones;
        for (int j = 1; j <= J; ++j) {
          const double z = rg.ylo + j * rg.yspan() / (J + 1);
          if (std::abs(z) > 1e-6 * rg.yspan()) dz.z.push_back(z);
        }
        dz.g.assign(dz.z.size(), 0.0);
        const auto fw = std::get<MpiDeadzoneParams>(fit_weights(dz, x, y, wo));
        layout.r = canonical_structure(fw).r;
        // forward dead zones of the seed, split by side (ascending / descending away from 0)
        std::vector<std::pair<double, double>> pos, neg;
        for (std::size_t j = 0; j < fw.z.size(); ++j) (fw.z[j] > 0 ? pos : neg).push_back({fw.z[j], fw.g[j]});
        std::sort(pos.begin(), pos.end());
        std::sort(neg.begin(), neg.end(), std::greater<>());
        std::vector<double> seedA = slopes(fw.q, fw.p), seedB;
        for (auto* side : {&pos, &neg}) {
          double c = 1.0;
          for (auto& [z, g] : *side) {
            (side == &pos ? layout.zp : layout.zn).push_back(z);
            c += g;
            seedA.push_back(c);
          }
        }
        // second start: the classical PI (no dead-zone action)
        PiParams pi;
        pi.r = layout.r;
        pi.p.assign(pi.r.size(), 0.0);
        const auto fp = std::get<PiParams>(fit_weights(pi, x, y, wo));
        seedB = slopes(fp.q, fp.p);
        seedB.resize(seedA.size(), 1.0);
        if (canonical_structure(fp).r.size() == layout.r.size()) starts.push_back(seedB);
        starts.push_back(seedA);
      } else {  // mpi-asym: start from the gpi fit (exactly representable)
        FitOptions go = o;
        go.model = FitModel::gpi;
        go.compute_covariance = false;
        const FitReport g = fit(x, y, go);
        if (g.status != FitStatus::converged && g.status != FitStatus::no_convergence) {
          rep = g;
          rep.model_kind = o.model;
          rep.message = "mpi-asym: the gpi seed fit failed: " + g.message;
          rep.time_s = std::chrono::duration<double>(Clock::now() - t0).count();
          return rep;
        }
        const auto& gp = std::get<GpiParams>(g.model);
        const Structure<double> s = canonical_structure(gp);
        layout.env = 8;
        layout.r = s.r;
        std::vector<double> th(gp.envelope.c.begin(), gp.envelope.c.end());
        th.insert(th.end(), gp.envelope.c.begin(), gp.envelope.c.end());
        const auto sl = slopes(s.q, s.p);
        th.insert(th.end(), sl.begin(), sl.end());
        starts.push_back(th);
        rep.total_iterations += g.total_iterations;
      }
      std::vector<double> lower(static_cast<std::size_t>(layout.size()), -std::numeric_limits<double>::infinity());
      // weights: invertibility (cumulative slopes >= margin * scale); envelopes: c0, c1 > 0
      const Structure<double> s0 = [&] {
        Structure<double> s;
        layout.build(starts.front().data(), s);
        return s;
      }();
      double uspan = rg.xspan();
      if (layout.env == 8) {
        uspan = std::abs(envelope_value<double>(s0.asc_kind, s0.asc_c.data(), rg.xhi) -
                         envelope_value<double>(s0.asc_kind, s0.asc_c.data(), rg.xlo));
        for (int i : {0, 1, 4, 5}) lower[static_cast<std::size_t>(i)] = margin * std::abs(starts.front()[static_cast<std::size_t>(i)]);
      }
      const double scale = rg.yspan() / std::max(uspan, 1e-300);
      for (std::size_t i = static_cast<std::size_t>(layout.env); i < layout.env + layout.r.size() + 1; ++i) lower[i] = margin * scale;
      for (std::size_t i = layout.env + layout.r.size() + 1; i < lower.size(); ++i) lower[i] = margin;
      fit_slopes(d, layout, starts, lower, o, rep);
    }
  } catch (const Error& e) {
    return invalid(e.what(), o.model, t0);
  }
  if (rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence) {
    // The model is identified on the training input range: the inverse saturates there.
    std::visit([&](auto& fitted) { fitted.input_limits = Limits{rg.xlo, rg.xhi}; }, rep.model);
  }
  if (rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence)
    rep.train = evaluate(rep.model, x, y, tr, o.initial_state);
  rep.time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return rep;
}

std::string FitReport::brief_report() const {
  return fmt::format("{} fit: {} after {} iterations ({} starts), cost {:.6g} -> {:.6g}, train rms {:.6g} ({:.3g}% of span), {:.3f} s",
                     fit_model_name(model_kind), fit_status_name(status), iterations, num_starts, initial_cost,
                     final_cost, train.rms, train.rms_percent_span, time_s);
}

std::string FitReport::full_report() const {
  std::string out = brief_report() + "\n";
  if (!message.empty()) out += fmt::format("message: {}\n", message);
  out += fmt::format("{:<10} {:>16} {:>14}\n", "parameter", "value", "std error");
  for (const auto& p : parameters)
    out += fmt::format("{:<10} {:>16.8g} {:>14}\n", p.name, p.value,
                       p.held ? std::string("held") : (std::isnan(p.std_error) ? std::string("-") : fmt::format("{:.4g}", p.std_error)));
  if (!covariance_note.empty()) out += fmt::format("note: {}\n", covariance_note);
  out += fmt::format("train: rms {:.6g}  max {:.6g}  mae {:.6g}  rms {:.4g}% of span  r2 {:.6f}  n {}\n", train.rms,
                     train.max, train.mae, train.rms_percent_span, train.r2, train.n);
  return out;
}

}  // namespace hysteron
