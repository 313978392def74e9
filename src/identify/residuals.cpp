// Residuals of Eq. 12 and their analytic Jacobians (forward-mode sensitivities through
// the operator recursion) for the gpi of Eqs. 6-8 and for the slope-parametrized models,
// as Ceres cost functions, full (m residuals) or compressed (p + 1 residuals of a blocked QR,
// RowQr: what LM is given); the autodiff functors they are tested against.
#include <Eigen/Core>
#include <Eigen/QR>
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "detail.hpp"
#include "fit_internal.hpp"
#include "hysteron/error.hpp"

namespace hysteron {
namespace fitting {

namespace {

// Centres the m residuals and the columns of the row-major m x p Jacobian (free offset).
void project_offset(int m, int p, double* res, double* J) {
  if (m <= 0) return;
  Eigen::Map<Eigen::VectorXd> r(res, m);
  r.array() -= r.mean();
  if (!J) return;
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Jm(J, m, p);
  const Eigen::RowVectorXd mean = Jm.colwise().mean();
  Jm.rowwise() -= mean;
}

// robust_residual for the hand-written Jacobians, with its slope df/dr.
inline double robust_residual_with_slope(double r, double d, double& slope) {
  const double f = robust_residual<double>(r, d);
  const double w = d > 0 && d < 1.0 ? 1.0 / std::sqrt(d) : 1.0;
  // inside: f = w r; outside: f = w sgn(r) sqrt(2 d |r| - d^2), df/dr = w^2 d / |f|
  slope = d <= 0 || std::abs(r) < d ? w : w * w * d / std::abs(f);
  return f;
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

}  // namespace

namespace {

// Residuals (and, if want_j, their Jacobian rows) of the gpi in one pass with plain
// doubles: forward-mode sensitivities through the recursion. Each play output is either
// held (its derivative is carried from the previous sample) or equals u - r_i / u + r_i
// (derivative of the envelope and of r_i = alpha i). The branch tests are those of
// ops::generalized_play, so this is the derivative the Jets of GpiFunctor compute (tested
// to 1e-10). emit(row, f, jr) gets each training row in order (jr: 8 values, or nullptr).
template <class Emit>
void gpi_pass(const Data& d, int n, const double* th, bool want_j, Emit&& emit) {
  const double c0 = th[0], c1 = th[1], c2 = th[2], c3 = th[3], q = th[4], rho = th[5], tau = th[6], alpha = th[7];
  const auto nn = static_cast<std::size_t>(n);
  std::vector<double> r(nn), e(nn), p(nn), y(nn, 0.0), g(5 * nn, 0.0);  // g: dy_i/d(c0..c3, alpha)
  for (std::size_t i = 0; i < nn; ++i) {
    r[i] = alpha * static_cast<double>(i + 1);
    e[i] = std::exp(-tau * r[i]);
    p[i] = rho * e[i];
  }
  double du[4];
  auto env = [&](double x) {
    const double t = detail::tanh_fast(c1 * x + c2);
    const double sl = c0 * (1.0 - t * t);
    du[0] = t;
    du[1] = sl * x;
    du[2] = sl;
    du[3] = 1.0;
    return c0 * t + c3;
  };
  if (d.initial == InitialState::relaxed) {
    const double u0 = env(d.x[0]);
    for (std::size_t i = 0; i < nn; ++i) {
      y[i] = u0;
      std::copy(du, du + 4, &g[5 * i]);
    }
  }
  for (std::size_t k = 0; k < d.train.end; ++k) {
    const double u = env(d.x[k]);
    double out = q * u;
    double dc0 = q * du[0], dc1 = q * du[1], dc2 = q * du[2], dc3 = q;
    double dal = 0, drho = 0, dtau = 0;
    for (std::size_t i = 0; i < nn; ++i) {
      double* gi = &g[5 * i];
      const double hi = u + r[i], lo = u - r[i];
      const double ii = static_cast<double>(i + 1);
      if (!(y[i] < hi)) {  // hmin(u + r, y)
        y[i] = hi;
        gi[0] = du[0], gi[1] = du[1], gi[2] = du[2], gi[3] = 1.0, gi[4] = ii;
      }
      if (!(lo < y[i])) {  // hmax(u - r, .)
        y[i] = lo;
        gi[0] = du[0], gi[1] = du[1], gi[2] = du[2], gi[3] = 1.0, gi[4] = -ii;
      }
      const double py = p[i] * y[i];
      out += py;
      dc0 += p[i] * gi[0];
      dc1 += p[i] * gi[1];
      dc2 += p[i] * gi[2];
      dc3 += p[i] * gi[3];
      dal += p[i] * gi[4] - tau * ii * py;
      drho += e[i] * y[i];
      dtau -= r[i] * py;
    }
    if (k < d.train.begin) continue;
    const double rr = d.y[k] - out;
    double df = 1.0;
    const double f = robust_residual_with_slope(rr, d.huber, df);
    const std::size_t row = k - d.train.begin;
    if (!want_j) {
      emit(row, f, static_cast<const double*>(nullptr));
      continue;
    }
    const double jr[kGpi] = {-df * dc0, -df * dc1, -df * dc2, -df * dc3, -df * u, -df * drho, -df * dtau, -df * dal};
    emit(row, f, static_cast<const double*>(jr));
  }
}

}  // namespace

// Residuals (and, if J != nullptr, their row-major m x 8 Jacobian) of the gpi (gpi_pass).
void gpi_evaluate(const Data& d, int n, const double* th, double* res, double* J) {
  gpi_pass(d, n, th, J != nullptr, [&](std::size_t row, double f, const double* jr) {
    res[row] = f;
    if (jr) std::copy(jr, jr + kGpi, J + kGpi * row);
  });
}

namespace {

// The gpi cost in the chart: residuals from theta(phi), J_phi = J_theta dtheta/dphi.
class GpiChartCost final : public ceres::CostFunction {
 public:
  GpiChartCost(const Data& d, int n) : d_(d), n_(n), chart_{d.xc, d.xs} {
    set_num_residuals(static_cast<int>(d.train.end - d.train.begin));
    mutable_parameter_block_sizes()->push_back(kGpi);
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const auto th = chart_.theta(params[0]);
    for (double v : th)
      if (!std::isfinite(v)) return false;
    if (!jacobians || !jacobians[0]) {
      gpi_evaluate(d_, n_, th.data(), residuals, nullptr);
      if (d_.free_offset) project_offset(num_residuals(), kGpi, residuals, nullptr);
      return true;
    }
    // J_theta into Ceres' buffer, then J_phi = J_theta dtheta/dphi in place, kChartRows rows at a
    // time through a small copy (no m x 8 scratch per cost function: issue 13, `fit` memory).
    // Each block is a GEMM of at least kChartRows rows (the last one takes the remainder), as the
    // whole product was: the same sums in the same order, so the same bits.
    const auto m = static_cast<Eigen::Index>(d_.train.end - d_.train.begin);
    gpi_evaluate(d_, n_, th.data(), residuals, jacobians[0]);
    if (d_.free_offset) project_offset(num_residuals(), kGpi, residuals, jacobians[0]);
    const Eigen::Matrix<double, kGpi, kGpi> D = chart_.jacobian(params[0]);
    using Rows = Eigen::Matrix<double, Eigen::Dynamic, kGpi, Eigen::RowMajor>;
    Eigen::Map<Rows> J(jacobians[0], m, kGpi);
    Rows block;
    for (Eigen::Index r0 = 0; r0 < m;) {
      const Eigen::Index b = m - r0 < 2 * kChartRows ? m - r0 : kChartRows;
      block = J.middleRows(r0, b);
      J.middleRows(r0, b).noalias() = block * D;
      r0 += b;
    }
    return true;
  }

 private:
  static constexpr Eigen::Index kChartRows = 4096;
  Data d_;
  int n_;
  GpiChart chart_;
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

}  // namespace


namespace {

// Residuals (and, if want_j, their Jacobian rows of size() values) of a
// slope-parametrized model in one pass with plain doubles (forward-mode
// sensitivities; the branch tests are those of ops::asymmetric_play / dead_zone, so
// this is the derivative the Jets of SlopeFunctor compute, tested to 1e-10).
// pi / mpi-deadzone: the play outputs do not depend on theta (identity envelope,
// fixed thresholds): dv/ds_j = y_{j-1} - y_j (y_0 = x); dead zones: out =
// v + sum g_k S_k(v), d out/dv = 1 + sum of the active g_k, d out/dD_j = S_j - S_{j+1}.
// mpi-asym: each play output is held (keeps its 8-vector of envelope derivatives)
// or equals u_a - r_i (ascending coefficients) or u_d + r_i (descending ones).
// emit(row, f, jr) gets each training row in order (jr: size() values, or nullptr).
template <class Emit>
void slope_pass(const Data& d, const SlopeLayout& L, const double* th, bool want_j, Emit&& emit) {
  const std::size_t n = L.r.size();
  const std::size_t P = static_cast<std::size_t>(L.size());
  const std::size_t env = static_cast<std::size_t>(L.env);
  const bool asym = L.env == 8, sym = L.env == 4, enveloped = asym || sym;
  const double* sl = th + env;
  // g: d y_i / d(4 coefficients of the envelope eside[i]: 0 ascending, 1 descending)
  std::vector<double> p(n), y(n, 0.0), g(enveloped ? 4 * n : 0, 0.0);
  std::vector<unsigned char> eside(n, 0);
  for (std::size_t i = 0; i < n; ++i) p[i] = asym ? sl[i + 1] : sl[i + 1] - sl[i];
  // dead zones: thresholds and slopes g_k = D_k - D_{k-1} (D_0 = 1 per side)
  const std::size_t nz = L.zp.size() + L.zn.size();
  std::vector<double> z, gz, S(nz);
  std::vector<std::size_t> side_end;  // one past the last index of each side
  {
    const double* dz = sl + n + 1;
    for (const std::vector<double>* side : {&L.zp, &L.zn}) {
      double prev = 1.0;
      for (double zz : *side) {
        z.push_back(zz);
        gz.push_back(*dz - prev);
        prev = *dz++;
      }
      side_end.push_back(z.size());
    }
  }
  const double *ca = th, *cd = th + 4;
  auto tanh_env = [](const double* c, double x, double* du) {
    const double t = detail::tanh_fast(c[1] * x + c[2]);
    const double s = c[0] * (1.0 - t * t);
    du[0] = t, du[1] = s * x, du[2] = s, du[3] = 1.0;
    return c[0] * t + c[3];
  };
  double dua[4] = {0, 0, 0, 0}, dud[4] = {0, 0, 0, 0};
  if (d.initial == InitialState::relaxed) {
    const double u0 = enveloped ? tanh_env(ca, d.x[0], dua) : d.x[0];
    for (std::size_t i = 0; i < n; ++i) {
      y[i] = u0;
      if (enveloped) std::copy(dua, dua + 4, &g[4 * i]);
    }
  }
  const double q = sl[0];
  std::vector<double> row(want_j ? P : 0);
  for (std::size_t k = 0; k < d.train.end; ++k) {
    const double x = d.x[k];
    double ua = x, ud = x;
    if (asym) ua = tanh_env(ca, x, dua), ud = tanh_env(cd, x, dud);
    if (sym) ua = ud = tanh_env(ca, x, dua), std::copy(dua, dua + 4, dud);
    for (std::size_t i = 0; i < n; ++i) {
      const double hi = ud + L.r[i], lo = ua - L.r[i];
      if (!(y[i] < hi)) {  // hmin(u_d + r, y)
        y[i] = hi;
        if (enveloped) std::copy(dud, dud + 4, &g[4 * i]), eside[i] = asym ? 1 : 0;
      }
      if (!(lo < y[i])) {  // hmax(u_a - r, .)
        y[i] = lo;
        if (enveloped) std::copy(dua, dua + 4, &g[4 * i]), eside[i] = 0;
      }
    }
    const double u = asym ? 0.5 * (ua + ud) : ua;
    double v = q * u;
    for (std::size_t i = 0; i < n; ++i) v += p[i] * y[i];
    double out = v, dv = 1.0;
    for (std::size_t j = 0; j < nz; ++j) {
      // ops::dead_zone: z > 0: max{v - z, 0}; z < 0: min{v - z, 0}; z = 0: v
      bool on = true;
      if (0.0 < z[j]) on = !(v - z[j] < 0.0);
      else if (z[j] < 0.0) on = !(0.0 < v - z[j]);
      S[j] = on ? v - z[j] : 0.0;
      out += gz[j] * S[j];
      if (on) dv += gz[j];
    }
    if (k < d.train.begin) continue;
    const double rr = d.y[k] - out;
    double df = 1.0;
    const double f = robust_residual_with_slope(rr, d.huber, df);
    const std::size_t rix = k - d.train.begin;
    if (!want_j) {
      emit(rix, f, static_cast<const double*>(nullptr));
      continue;
    }
    double* jr = row.data();
    const double a = -df * dv;  // d f / d v
    if (asym) {
      for (int c = 0; c < 4; ++c) jr[c] = 0.5 * q * dua[c], jr[4 + c] = 0.5 * q * dud[c];
      for (std::size_t i = 0; i < n; ++i) {
        const double* gi = &g[4 * i];
        double* ji = jr + 4 * eside[i];
        for (int c = 0; c < 4; ++c) ji[c] += p[i] * gi[c];
      }
      for (int c = 0; c < 8; ++c) jr[c] *= a;
      jr[env] = a * u;
      for (std::size_t i = 0; i < n; ++i) jr[env + 1 + i] = a * y[i];
    } else {
      if (sym) {  // d v / d c = q du + sum_i p_i dy_i
        for (int c = 0; c < 4; ++c) jr[c] = q * dua[c];
        for (std::size_t i = 0; i < n; ++i)
          for (int c = 0; c < 4; ++c) jr[c] += p[i] * g[4 * i + static_cast<std::size_t>(c)];
        for (int c = 0; c < 4; ++c) jr[c] *= a;
        jr += 4;
      }
      // v = s_0 u + sum_i (s_{i+1} - s_i) y_i
      for (std::size_t j = 0; j <= n; ++j) jr[j] = a * ((j == 0 ? u : y[j - 1]) - (j < n ? y[j] : 0.0));
      std::size_t j0 = 0;
      for (std::size_t e : side_end) {
        for (std::size_t j = j0; j < e; ++j) jr[n + 1 + j] = -df * (S[j] - (j + 1 < e ? S[j + 1] : 0.0));
        j0 = e;
      }
    }
    emit(rix, f, static_cast<const double*>(row.data()));
  }
}

}  // namespace

// Residuals (and, if J != nullptr, their row-major m x size() Jacobian) of a slope layout (slope_pass).
void slope_evaluate(const Data& d, const SlopeLayout& L, const double* th, double* res, double* J) {
  const std::size_t P = static_cast<std::size_t>(L.size());
  slope_pass(d, L, th, J != nullptr, [&](std::size_t row, double f, const double* jr) {
    res[row] = f;
    if (jr) std::copy(jr, jr + P, J + P * row);
  });
}


namespace {

// Ridge residuals w p_i = w (s_i - s_{i-1}), i = 1..n, of a cumulative-slope layout.
class RidgeCost final : public ceres::CostFunction {
 public:
  explicit RidgeCost(const SlopeLayout* layout) : layout_(layout) {
    set_num_residuals(static_cast<int>(layout->r.size()));
    mutable_parameter_block_sizes()->push_back(layout->size());
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const std::size_t n = layout_->r.size(), P = static_cast<std::size_t>(layout_->size());
    const double w = layout_->ridge;
    const double* sl = params[0] + layout_->env;
    for (std::size_t i = 0; i < n; ++i) residuals[i] = w * (sl[i + 1] - sl[i]);
    if (jacobians && jacobians[0]) {
      std::fill(jacobians[0], jacobians[0] + n * P, 0.0);
      for (std::size_t i = 0; i < n; ++i) {
        double* jr = jacobians[0] + i * P + static_cast<std::size_t>(layout_->env);
        jr[i] = -w;
        jr[i + 1] = w;
      }
    }
    return true;
  }

 private:
  const SlopeLayout* layout_;
};

class SlopeCost final : public ceres::CostFunction {
 public:
  SlopeCost(const Data& d, const SlopeLayout* layout) : d_(d), layout_(layout) {
    set_num_residuals(static_cast<int>(d.train.end - d.train.begin));
    mutable_parameter_block_sizes()->push_back(layout->size());
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    slope_evaluate(d_, *layout_, params[0], residuals, jacobians ? jacobians[0] : nullptr);
    if (d_.free_offset)
      project_offset(num_residuals(), layout_->size(), residuals, jacobians ? jacobians[0] : nullptr);
    return true;
  }

 private:
  Data d_;
  const SlopeLayout* layout_;
};

// ---- compressed least squares (issue 13: `fit` memory) --------------------------------
// LM sees p + 1 residuals r' = [Q^T r; ||(I - Q Q^T) r||] with the Jacobian J' = [R; 0]
// instead of the m residuals r and the m x p Jacobian J = Q R. Then J'^T J' = J^T J,
// J'^T r' = J^T r, ||r'|| = ||r|| and ||J' d + r'|| = ||J d + r|| for every step d, so LM
// (its normal equations, Jacobi scaling diag(J^T J), model and actual cost changes) takes
// the same steps in exact arithmetic. R and r' come from a blocked Householder QR of the
// rows [1, J, r] (the column of ones only with the free offset: its Householder reflection
// removes the mean, so the trailing block is the centred problem of project_offset),
// kBlockRows rows at a time. Memory: one block of rows and the (c + kBlockRows) x c stack,
// instead of m residuals and the m x p Jacobian (and Ceres' copies of them).
class RowQr {
 public:
  static constexpr Eigen::Index kBlockRows = 4096;
  using Rows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  // p Jacobian columns (0: residuals only), plus the column of ones if `offset`; each
  // block of Jacobian rows is multiplied by D (p x p) before it is folded, if D is given.
  RowQr(int p, bool offset, const Eigen::MatrixXd* D = nullptr)
      : p_(p), off_(offset ? 1 : 0), c_(off_ + p + 1), D_(D), w_(Workspace::acquire(p, c_)) {}
  RowQr(const RowQr&) = delete;
  RowQr& operator=(const RowQr&) = delete;
  ~RowQr() { Workspace::release(); }
  // One row: residual f and (if p > 0) its p Jacobian entries jr.
  void add(double f, const double* jr) {
    w_.res[static_cast<std::size_t>(fill_)] = f;
    if (p_ > 0 && jr) std::copy(jr, jr + p_, w_.jac.begin() + static_cast<std::ptrdiff_t>(fill_ * p_));
    if (++fill_ == kBlockRows) flush();
  }
  // After the last row: the p_out + 1 residuals r' and, if J, the (p_out + 1) x p_out
  // row-major J' = [R_JJ; 0] (p_ == p_out). Residuals only (p_ == 0): r' = [0; ||r||].
  void finish(int p_out, double* res, double* J) {
    flush();
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(c_, c_);  // rows beyond those folded stay zero
    R.topRows(k_) = w_.stack.topRows(k_);
    for (Eigen::Index i = 0; i < p_out; ++i) res[i] = p_ > 0 ? R(off_ + i, c_ - 1) : 0.0;
    res[p_out] = R(c_ - 1, c_ - 1);
    if (!J) return;
    for (Eigen::Index i = 0; i < p_; ++i)
      for (Eigen::Index j = 0; j < p_; ++j) J[i * p_ + j] = R(off_ + i, off_ + j);
    std::fill(J + p_ * p_, J + p_ * (p_ + 1), 0.0);
  }

 private:
  // The buffers of one RowQr, kept per thread between evaluations: an evaluation used to
  // allocate and zero a block of Jacobian rows (4096 p doubles) and the stack, which was
  // 6 % of an experiment's time (perf, mpi-openloop). A RowQr built while another is alive on
  // the same thread (not done today) gets the next workspace of the thread's pool.
  struct Workspace {
    Eigen::MatrixXd stack;  // rows [0, k_): R so far; then the block being folded
    Eigen::HouseholderQR<Eigen::MatrixXd> qr;
    std::vector<double> res, jac;
    Rows block;
    // Sized for p Jacobian columns and c stack columns; the depth counts only a workspace
    // handed out (a throwing resize leaves it as it was).
    static Workspace& acquire(Eigen::Index p, Eigen::Index c) {
      auto& pool = pool_();
      auto& depth = depth_();
      if (pool.size() <= depth) pool.push_back(std::make_unique<Workspace>());
      Workspace& w = *pool[depth];
      w.stack.resize(c + kBlockRows, c);  // every entry read is written first (flush)
      if (w.res.size() < static_cast<std::size_t>(kBlockRows)) w.res.resize(kBlockRows);
      if (w.jac.size() < static_cast<std::size_t>(kBlockRows * p)) w.jac.resize(static_cast<std::size_t>(kBlockRows * p));
      ++depth;
      return w;
    }
    static void release() noexcept { --depth_(); }

   private:
    static std::vector<std::unique_ptr<Workspace>>& pool_() {
      thread_local std::vector<std::unique_ptr<Workspace>> pool;
      return pool;
    }
    static std::size_t& depth_() {
      thread_local std::size_t depth = 0;
      return depth;
    }
  };

  // Folds the buffered rows into R: [R; 1 J D r] -> R.
  void flush() {
    if (fill_ == 0) return;
    Eigen::Map<Rows> J(w_.jac.data(), fill_, p_);
    if (D_ && p_ > 0) {
      w_.block = J;
      J.noalias() = w_.block * *D_;
    }
    auto& stack = w_.stack;
    for (Eigen::Index i = 0; i < fill_; ++i) {
      const Eigen::Index row = k_ + i;
      if (off_) stack(row, 0) = 1.0;
      for (Eigen::Index j = 0; j < p_; ++j) stack(row, off_ + j) = J(i, j);
      stack(row, c_ - 1) = w_.res[static_cast<std::size_t>(i)];
    }
    const Eigen::Index total = k_ + fill_;
    w_.qr.compute(stack.topRows(total));
    k_ = std::min(total, c_);
    stack.topRows(k_) = w_.qr.matrixQR().topRows(k_).triangularView<Eigen::Upper>();
    fill_ = 0;
  }

  Eigen::Index p_, off_, c_;
  const Eigen::MatrixXd* D_;
  Workspace& w_;
  Eigen::Index k_ = 0, fill_ = 0;
};

// The gpi cost in the chart (GpiChartCost), compressed (RowQr): kGpi + 1 residuals.
class CompressedGpiChartCost final : public ceres::CostFunction {
 public:
  CompressedGpiChartCost(const Data& d, int n) : d_(d), n_(n), chart_{d.xc, d.xs} {
    set_num_residuals(kGpi + 1);
    mutable_parameter_block_sizes()->push_back(kGpi);
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const auto th = chart_.theta(params[0]);
    for (double v : th)
      if (!std::isfinite(v)) return false;
    const bool want_j = jacobians && jacobians[0];
    const Eigen::MatrixXd D = want_j ? Eigen::MatrixXd(chart_.jacobian(params[0])) : Eigen::MatrixXd();
    RowQr qr(want_j ? kGpi : 0, d_.free_offset, want_j ? &D : nullptr);  // J_phi = J_theta dtheta/dphi
    gpi_pass(d_, n_, th.data(), want_j, [&](std::size_t, double f, const double* jr) { qr.add(f, jr); });
    qr.finish(kGpi, residuals, want_j ? jacobians[0] : nullptr);
    return true;
  }

 private:
  Data d_;
  int n_;
  GpiChart chart_;
};

// The cost of a slope layout (SlopeCost), compressed (RowQr): size() + 1 residuals.
class CompressedSlopeCost final : public ceres::CostFunction {
 public:
  CompressedSlopeCost(const Data& d, const SlopeLayout* layout) : d_(d), layout_(layout) {
    set_num_residuals(layout->size() + 1);
    mutable_parameter_block_sizes()->push_back(layout->size());
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const bool want_j = jacobians && jacobians[0];
    const int p = layout_->size();
    RowQr qr(want_j ? p : 0, d_.free_offset);
    slope_pass(d_, *layout_, params[0], want_j, [&](std::size_t, double f, const double* jr) { qr.add(f, jr); });
    qr.finish(p, residuals, want_j ? jacobians[0] : nullptr);
    return true;
  }

 private:
  Data d_;
  const SlopeLayout* layout_;
};

// A cost given by a pass over its rows (RowPass), compressed (RowQr): p + 1 residuals.
class CompressedRowCost final : public ceres::CostFunction {
 public:
  CompressedRowCost(int p, RowPass pass) : p_(p), pass_(std::move(pass)) {
    set_num_residuals(p + 1);
    mutable_parameter_block_sizes()->push_back(p);
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const bool want_j = jacobians && jacobians[0];
    RowQr qr(want_j ? p_ : 0, false);
    if (!pass_(params[0], want_j, [&](double f, const double* jr) { qr.add(f, jr); })) return false;
    qr.finish(p_, residuals, want_j ? jacobians[0] : nullptr);
    return true;
  }

 private:
  int p_;
  RowPass pass_;
};

}  // namespace

ceres::CostFunction* make_gpi_chart_cost(const Data& d, int n) { return new GpiChartCost(d, n); }
ceres::CostFunction* make_slope_cost(const Data& d, const SlopeLayout* layout) { return new SlopeCost(d, layout); }
ceres::CostFunction* make_compressed_gpi_chart_cost(const Data& d, int n) { return new CompressedGpiChartCost(d, n); }
ceres::CostFunction* make_compressed_slope_cost(const Data& d, const SlopeLayout* layout) {
  return new CompressedSlopeCost(d, layout);
}
ceres::CostFunction* make_ridge_cost(const SlopeLayout* layout) { return new RidgeCost(layout); }
ceres::CostFunction* make_compressed_row_cost(int p, RowPass pass) { return new CompressedRowCost(p, std::move(pass)); }

}  // namespace fitting

using fitting::Data;
using fitting::GpiFunctor;
using fitting::kGpi;
using fitting::SlopeFunctor;
using fitting::SlopeLayout;

namespace {

// The layout of the test hooks below: the fits build theirs in starts.cpp (envelope
// parameters: 8 for mpi-asym, 4 for gpi; dead zones only for mpi-deadzone).
SlopeLayout make_slope_layout(FitModel model, std::span<const double> theta, std::span<const double> r,
                              std::span<const double> zp, std::span<const double> zn, const char* who) {
  SlopeLayout L;
  L.kind = model;
  L.env = model == FitModel::mpi_asym ? 8 : model == FitModel::gpi ? 4 : 0;
  L.r.assign(r.begin(), r.end());
  if (model == FitModel::mpi_deadzone) L.zp.assign(zp.begin(), zp.end()), L.zn.assign(zn.begin(), zn.end());
  if (theta.size() != static_cast<std::size_t>(L.size()))
    throw Error(fmt::format("{}: theta must have {} entries, got {}", who, L.size(), theta.size()));
  return L;
}

}  // namespace

void gpi_residuals(std::span<const double> theta, int n, std::span<const double> x, std::span<const double> y,
                   IndexRange train, InitialState initial, double huber, bool autodiff, Eigen::VectorXd& residuals,
                   Eigen::MatrixXd& jacobian) {
  if (theta.size() != static_cast<std::size_t>(kGpi)) throw Error("gpi_residuals: theta must have 8 entries");
  if (n < 1) throw Error("gpi_residuals: n must be >= 1");
  detail::check_record(x, y, "gpi_residuals");
  const IndexRange tr = detail::check_range(train, x.size(), "gpi_residuals: train");
  const Data d{x, y, tr, initial, huber};
  const auto m = static_cast<Eigen::Index>(tr.end - tr.begin);
  residuals.resize(m);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(m, kGpi);
  if (autodiff) {
    ceres::AutoDiffCostFunction<GpiFunctor, ceres::DYNAMIC, kGpi> cost(new GpiFunctor{d, n}, static_cast<int>(m));
    const double* params[1] = {theta.data()};
    double* jacs[1] = {J.data()};
    cost.Evaluate(params, residuals.data(), jacs);
  } else {
    gpi_evaluate(d, n, theta.data(), residuals.data(), J.data());
  }
  jacobian = J;
}

void slope_residuals(FitModel model, std::span<const double> theta, std::span<const double> r,
                     std::span<const double> zp, std::span<const double> zn, std::span<const double> x,
                     std::span<const double> y, IndexRange train, InitialState initial, double huber, bool autodiff,
                     Eigen::VectorXd& residuals, Eigen::MatrixXd& jacobian) {
  const SlopeLayout L = make_slope_layout(model, theta, r, zp, zn, "slope_residuals");
  detail::check_record(x, y, "slope_residuals");
  const IndexRange tr = detail::check_range(train, x.size(), "slope_residuals: train");
  const Data d{x, y, tr, initial, huber};
  const auto m = static_cast<Eigen::Index>(tr.end - tr.begin);
  residuals.resize(m);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(m, L.size());
  if (autodiff) {
    ceres::DynamicAutoDiffCostFunction<SlopeFunctor, 10> cost(new SlopeFunctor{d, &L});
    cost.AddParameterBlock(L.size());
    cost.SetNumResiduals(static_cast<int>(m));
    const double* params[1] = {theta.data()};
    double* jacs[1] = {J.data()};
    cost.Evaluate(params, residuals.data(), jacs);
  } else {
    slope_evaluate(d, L, theta.data(), residuals.data(), J.data());
  }
  jacobian = J;
}

namespace detail {

namespace {

LmNormalEquations normal_equations(const ceres::CostFunction& cost, const double* theta) {
  const int p = cost.parameter_block_sizes()[0];
  LmNormalEquations out;
  out.residuals = cost.num_residuals();
  Eigen::VectorXd r(out.residuals);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(out.residuals, p);
  const double* params[1] = {theta};
  double* jacs[1] = {J.data()};
  if (!cost.Evaluate(params, r.data(), jacs)) throw Error("normal_equations: the cost cannot be evaluated");
  out.cost = 0.5 * r.squaredNorm();
  out.gradient = J.transpose() * r;
  out.jtj = J.transpose() * J;
  return out;
}

}  // namespace

LmNormalEquations gpi_normal_equations(std::span<const double> theta, int n, double xc, double xs,
                                       std::span<const double> x, std::span<const double> y, IndexRange train,
                                       InitialState initial, double huber, bool free_offset, bool compressed) {
  if (theta.size() != static_cast<std::size_t>(kGpi)) throw Error("gpi_normal_equations: theta must have 8 entries");
  check_record(x, y, "gpi_normal_equations");
  fitting::Data d{x, y, check_range(train, x.size(), "gpi_normal_equations: train"), initial, huber};
  d.xc = xc;
  d.xs = xs;
  d.free_offset = free_offset;
  const std::unique_ptr<ceres::CostFunction> cost(compressed ? fitting::make_compressed_gpi_chart_cost(d, n)
                                                             : fitting::make_gpi_chart_cost(d, n));
  const auto phi = fitting::GpiChart{xc, xs}.phi(theta.data());
  return normal_equations(*cost, phi.data());
}

LmNormalEquations slope_normal_equations(FitModel model, std::span<const double> theta, std::span<const double> r,
                                         std::span<const double> zp, std::span<const double> zn,
                                         std::span<const double> x, std::span<const double> y, IndexRange train,
                                         InitialState initial, double huber, bool free_offset, bool compressed) {
  const SlopeLayout L = make_slope_layout(model, theta, r, zp, zn, "slope_normal_equations");
  check_record(x, y, "slope_normal_equations");
  fitting::Data d{x, y, check_range(train, x.size(), "slope_normal_equations: train"), initial, huber};
  d.free_offset = free_offset;
  const std::unique_ptr<ceres::CostFunction> cost(compressed ? fitting::make_compressed_slope_cost(d, &L)
                                                             : fitting::make_slope_cost(d, &L));
  return normal_equations(*cost, theta.data());
}

}  // namespace detail

}  // namespace hysteron
