#pragma once
// Internal pieces of the Levenberg-Marquardt identification (not installed):
//   residuals.cpp  residuals and analytic Jacobians (Eq. 12) of the gpi and of the
//                  slope-parametrized models, as Ceres cost functions
//   layouts.cpp    parameter layouts: the gpi chart and the cumulative-slope layout
//                  with its bounds
//   starts.cpp     data-derived initial guesses
//   lm.cpp         the LM driver (multi-start, active set, stall test, covariance)
//   kinds.hpp      one parametrization object per model kind and their registry
//   fit.cpp        detail::fit_core: a dispatcher over the registry
#include <Eigen/Core>
#include <ceres/ceres.h>

#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "detail.hpp"
#include "hysteron/identify.hpp"

namespace hysteron::fitting {

using Clock = std::chrono::steady_clock;

// ---- data ---------------------------------------------------------------------------

struct Data {
  std::span<const double> x, y;
  IndexRange train;  // resolved
  InitialState initial = InitialState::virgin;
  double huber = 0.0;
  double xc = 0.0, xs = 1.0;  // gpi: centre and half-span of the training input (GpiChart)
  // Free output offset by variable projection (slope models, least squares only): the
  // residuals and the Jacobian columns are centred over the training range, which
  // minimises over the offset exactly; the offset is then the mean residual.
  bool free_offset = false;
};

// Residual of Eq. 12, optionally mapped so that its square is the Huber loss:
// f = r for |r| <= d, f = sign(r) sqrt(2 d |r| - d^2) beyond (residuals.cpp, bouc-wen).
template <class T>
inline T robust_residual(const T& r, double d) {
  if (d <= 0) return r;
  // Divided by sqrt(d) when d < 1 (the record is normalised to a unit span): the
  // minimiser is the same, but a tiny d (1e-300) no longer scales the cost and its
  // gradient down to below the solver's absolute gradient tolerance (a "converged"
  // fit after 0 iterations).
  const double w = d < 1.0 ? 1.0 / std::sqrt(d) : 1.0;
  if (r < T(d) && T(-d) < r) return T(w) * r;
  using std::sqrt;
  const T a = r < T(0) ? T(-r) : r;
  const T f = d < 1.0 ? sqrt(T(2.0) * a - T(d)) : sqrt(T(2.0 * d) * a - T(d * d));
  return r < T(0) ? T(-f) : f;
}

struct Ranges {
  double xlo, xhi, ylo, yhi;
  double xspan() const { return xhi - xlo; }
  double yspan() const { return yhi - ylo; }
};

Ranges ranges_of(const Data& d);

// ---- parameter layouts (layouts.cpp) -------------------------------------------------

// gpi: Theta = [c0, c1, c2, c3, q, rho, tau, alpha]
constexpr int kGpi = 8;

// LM chart of the gpi (the fit runs in phi, reports Eq. 13's theta):
//   phi = [S, a, b, m, q, rho, tau, alpha],  xn = (x - xc) / xs,
//   u = (S / a) tanh(a xn + b) + m - (S / a) tanh(b)          (Eq. 5 rewritten)
//   c0 = S / a, c1 = a / xs, c2 = b - a xc / xs, c3 = m - (S / a) tanh(b).
// a is the dimensionless curvature over the input range, S the slope scale
// (u'(xc) xs = S sech^2 b) and m = u(xc). With c0 as the gauge of the scale symmetry
// (Eq. 13) a nearly linear envelope (the piezo record: c1 xs ~ 0.03) lies at the end of a
// curved valley (c1 -> 0 with q, rho, alpha rescaling) along which LM crawls for hundreds of
// iterations; with S held instead, the curvature a moves at a fixed slope scale.
struct GpiChart {
  double xc = 0.0, xs = 1.0;
  std::array<double, kGpi> theta(const double* phi) const;
  std::array<double, kGpi> phi(const double* th) const;
  // d theta / d phi (8 x 8)
  Eigen::Matrix<double, kGpi, kGpi> jacobian(const double* phi) const;
};

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
    const T ri = th[7] * T(i + 1);                                 // Eq. 7
    s.r[static_cast<std::size_t>(i)] = ri;
    s.p[static_cast<std::size_t>(i)] = th[5] * exp(-th[6] * ri);  // Eq. 8
  }
}

GpiParams gpi_params(const double* th, int n);

// ---- models linear in their weights: cumulative-slope parametrization ---------------
// theta = [envelope coefficients (gpi with free weights: 4; mpi-asym: 4 ascending + 4 descending)],
//         s_0..s_n (s_0 = q, s_i = q + p_1 + ... + p_i; mpi-asym: q, p_1..p_n, all >= 0),
//         mpi-deadzone: d_1..d_J (positive side, z ascending), then the negative side
//         (z descending): cumulative output slopes g0 + g_1 + ... + g_j, with g0 = 1.
struct SlopeLayout {
  FitModel kind = FitModel::pi;
  std::vector<double> r;       // fixed thresholds (ascending)
  std::vector<double> zp, zn;  // fixed forward dead-zone thresholds (v units)
  int env = 0;                 // number of envelope coefficients (0, 4: one tanh, 8: two)
  double ridge = 0.0;          // > 0: extra residuals ridge * p_i (cumulative-slope layouts only)
  int size() const { return env + static_cast<int>(r.size() + 1 + zp.size() + zn.size()); }
  // mpi-asym holds the weights themselves (q, p_1..p_n >= 0), the others cumulative slopes.
  bool direct_weights() const { return kind == FitModel::mpi_asym; }

  template <class T>
  void build(const T* th, Structure<T>& s) const {
    if (env == 8) {
      s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
      s.asc_c = {th[0], th[1], th[2], th[3]};
      s.desc_c = {th[4], th[5], th[6], th[7]};
      s.asymmetric = true;
    } else if (env == 4) {
      s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
      s.asc_c = {th[0], th[1], th[2], th[3]};
      s.desc_c = s.asc_c;
      s.asymmetric = false;
    }
    const T* sl = th + env;
    const std::size_t n = r.size();
    s.q = sl[0];
    s.r.resize(n);
    s.p.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      s.r[i] = T(r[i]);
      // mpi-asym: weights directly (bounded >= 0 so that the output is strictly
      // increasing in the input for every state: its numerical inverse needs it);
      // the others: cumulative slopes (partial sums > 0, Eq. 11).
      s.p[i] = direct_weights() ? sl[i + 1] : sl[i + 1] - sl[i];
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
};

// Slope vector [s_0..s_n] of weights q, p.
std::vector<double> slopes(double q, const std::vector<double>& p);

// Lower bounds of a slope-parametrized start: cumulative slopes >= margin * scale
// (invertibility), dead-zone slopes >= margin, envelope c0, c1 > 0.
std::vector<double> slope_lower(const SlopeLayout& layout, const std::vector<double>& th, const Ranges& rg,
                                double margin, double min_slope);

// ---- residuals and costs (residuals.cpp) --------------------------------------------

// Residuals (and, if J != nullptr, their row-major m x 8 Jacobian) of the gpi.
void gpi_evaluate(const Data& d, int n, const double* th, double* res, double* J);
// Residuals (and, if J != nullptr, their row-major m x size() Jacobian) of a slope layout.
void slope_evaluate(const Data& d, const SlopeLayout& L, const double* th, double* res, double* J);

// The gpi cost in the chart (GpiChart): residuals from theta(phi), J_phi = J_theta dtheta/dphi.
ceres::CostFunction* make_gpi_chart_cost(const Data& d, int n);
// The cost of a slope layout (analytic Jacobian; free offset by projection if d.free_offset).
ceres::CostFunction* make_slope_cost(const Data& d, const SlopeLayout* layout);
// Ridge residuals w p_i = w (s_i - s_{i-1}), i = 1..n, of a cumulative-slope layout.
ceres::CostFunction* make_ridge_cost(const SlopeLayout* layout);
// The same two costs compressed to p + 1 residuals r' = [Q^T r; ||(I - Q Q^T) r||] with the
// Jacobian [R; 0], J = Q R by a blocked QR of the rows (issue 13: `fit` memory): the same
// cost, J^T r and J^T J, so the same LM steps, without m x p buffers (residuals.cpp: RowQr).
ceres::CostFunction* make_compressed_gpi_chart_cost(const Data& d, int n);
ceres::CostFunction* make_compressed_slope_cost(const Data& d, const SlopeLayout* layout);
// Any cost with one parameter block of p values given row by row, compressed the same way:
// pass(theta, want_j, add) calls add(f, jr) for each residual f in order (jr: its p Jacobian
// entries if want_j, else ignored) and returns false if theta cannot be evaluated (bouc-wen).
using RowPass = std::function<bool(const double* theta, bool want_j,
                                   const std::function<void(double f, const double* jr)>& add)>;
ceres::CostFunction* make_compressed_row_cost(int p, RowPass pass);
// Whether GpiLm, SlopeLm and bouc-wen's LM give LM the compressed costs
// (default; false: the m residuals).
bool lm_compression();

// ---- data-derived starts (starts.cpp) -----------------------------------------------

// Data-derived gpi starts (Eq. 13's theta), best first.
std::vector<std::vector<double>> gpi_starts(const Data& full, int n, const FitOptions& o, double lb_rel);
// mpi-asym starts (layouts and theta), best first.
void asym_starts(const Data& full, int n, const FitOptions& o, double margin, std::vector<SlopeLayout>& layouts,
                 std::vector<std::vector<double>>& starts);
// Free-weight gpi starts (layouts and theta), best first.
void gpi_free_starts(const Data& full, int n, const FitOptions& o, double margin, std::vector<SlopeLayout>& layouts,
                     std::vector<std::vector<double>>& starts);
// Envelope output span over the input range.
double envelope_span(const std::array<double, 4>& c, const Ranges& rg);

// ---- the LM driver (lm.cpp) ---------------------------------------------------------

// What the LM driver needs of one start: its cost function(s) and whether the
// lower bounds are handled by an active set (see solve()).
struct LmProblem {
  virtual ~LmProblem() = default;
  virtual void add_costs(ceres::Problem& problem, const Data& d, double* theta) const = 0;
  virtual bool active_set() const { return false; }
  // Whether its costs are the compressed ones (no m x p buffers: solve_starts does not cap
  // the concurrent starts by memory).
  virtual bool compressed() const { return false; }
};

struct GpiLm final : LmProblem {
  int n = 0;
  explicit GpiLm(int n_) : n(n_) {}
  void add_costs(ceres::Problem& problem, const Data& d, double* theta) const override;
  bool active_set() const override { return true; }
  bool compressed() const override { return lm_compression(); }
};

struct SlopeLm final : LmProblem {
  const SlopeLayout* layout;
  explicit SlopeLm(const SlopeLayout* l) : layout(l) {}
  void add_costs(ceres::Problem& problem, const Data& d, double* theta) const override;
  bool compressed() const override { return lm_compression(); }
};

struct Solved {
  std::vector<double> theta;
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;
  ceres::TerminationType termination = ceres::FAILURE;
  std::string message;
  bool usable = false;
  std::vector<int> at_bound;  // parameters held on their lower bound (see solve)
};

// Refines every start by LM, concurrently on FitOptions::num_threads threads (problems:
// one per start); adds their iterations to rep.total_iterations, sets rep.num_starts and
// returns the solutions with the index of the usable one of lowest cost (the first on
// ties; npos if none is usable).
std::pair<std::vector<Solved>, std::size_t> solve_starts(const std::vector<const LmProblem*>& problems, const Data& d,
                                                         const std::vector<std::vector<double>>& starts,
                                                         const std::vector<std::vector<double>>& lowers,
                                                         const std::vector<int>& held, const FitOptions& o,
                                                         FitReport& rep);

// Standard errors of theta (cov = s^2 (J^T J)^-1), mapped by M to reported parameters.
void standard_errors(const LmProblem& lm, const Data& d, std::vector<double> theta, const std::vector<double>& lower,
                     const std::vector<int>& held, const Eigen::MatrixXd& M, double sse, FitReport& rep);

// standard_errors, and when it finds the Jacobian rank deficient with the offset free
// (projected out of the residuals), once more with the LM parameter `level` held too: an
// envelope's constant, which moves the output by a constant like the offset except through
// the plays' virgin start (on a long record, or from a relaxed start exactly, the two are one
// direction). The reported parameters `no_error` then get none and `note` is the covariance
// note. level < 0: standard_errors alone.
void standard_errors_level_held(const LmProblem& lm, const Data& d, const std::vector<double>& theta,
                                const std::vector<double>& lower, const std::vector<int>& held, const Eigen::MatrixXd& M,
                                double sse, int level, const std::vector<int>& no_error, const char* note,
                                FitReport& rep);

// Status and message of the report from the best solution.
void finish_status(FitReport& rep, const Solved& best, bool start_is_minimum);

// The output offset eliminated by the projection (d.free_offset): the mean residual of the model.
double projected_offset(const ModelParams& model, const Data& d);
// Sum of squared errors of the model over the training range.
double model_sse(const ModelParams& model, const Data& d);
// The same for the residuals LM minimised: robust_residual's with d.huber > 0 (the variance
// estimate that goes with their Jacobian in standard_errors), model_sse's otherwise.
double fitted_sse(const ModelParams& model, const Data& d);
// The largest |y - model| over the training range.
double max_abs_residual(const ModelParams& model, const Data& d);

}  // namespace hysteron::fitting
