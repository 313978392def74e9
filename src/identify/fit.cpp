// Levenberg-Marquardt identification through Ceres with automatic
// differentiation through the operator recursion (Eqs. 12-16).
#include <Eigen/Eigenvalues>
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <numeric>
#include <random>
#include <thread>

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
  double xc = 0.0, xs = 1.0;  // gpi: centre and half-span of the training input (GpiChart)
  // Free output offset by variable projection (slope models, least squares only): the
  // residuals and the Jacobian columns are centred over the training range, which
  // minimises over the offset exactly; the offset is then the mean residual.
  bool free_offset = false;
};

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

// robust_residual for the hand-written Jacobians, with its slope df/dr.
inline double robust_residual_with_slope(double r, double d, double& slope) {
  const double f = robust_residual<double>(r, d);
  slope = f == r ? 1.0 : d / std::abs(f);  // d/dr sqrt(2 d |r| - d^2) = d / |f|
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

// Residuals (and, if J != nullptr, their row-major m x 8 Jacobian) of the gpi in
// one pass with plain doubles: forward-mode sensitivities through the recursion.
// Each play output is either held (its derivative is carried from the previous
// sample) or equals u - r_i / u + r_i (derivative of the envelope and of r_i =
// alpha i). The branch tests are those of ops::generalized_play, so this is the
// derivative the Jets of GpiFunctor compute (tested to 1e-10).
void gpi_evaluate(const Data& d, int n, const double* th, double* res, double* J) {
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
    res[row] = f;
    if (J) {
      double* jr = J + kGpi * row;
      jr[0] = -df * dc0, jr[1] = -df * dc1, jr[2] = -df * dc2, jr[3] = -df * dc3;
      jr[4] = -df * u, jr[5] = -df * drho, jr[6] = -df * dtau, jr[7] = -df * dal;
    }
  }
}

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
  std::array<double, kGpi> theta(const double* phi) const {
    const double S = phi[0], a = phi[1], b = phi[2], m = phi[3];
    return {S / a, a / xs, b - a * xc / xs, m - S / a * std::tanh(b), phi[4], phi[5], phi[6], phi[7]};
  }
  std::array<double, kGpi> phi(const double* th) const {
    const double a = th[1] * xs, b = th[2] + th[1] * xc;
    return {th[0] * a, a, b, th[3] + th[0] * std::tanh(b), th[4], th[5], th[6], th[7]};
  }
  // d theta / d phi (row-major 8 x 8)
  Eigen::Matrix<double, kGpi, kGpi> jacobian(const double* phi) const {
    const double S = phi[0], a = phi[1], b = phi[2], t = std::tanh(b);
    Eigen::Matrix<double, kGpi, kGpi> T = Eigen::Matrix<double, kGpi, kGpi>::Identity();
    T(0, 0) = 1.0 / a, T(0, 1) = -S / (a * a);
    T(1, 1) = 1.0 / xs;
    T(2, 1) = -xc / xs, T(2, 2) = 1.0;
    T(3, 0) = -t / a, T(3, 1) = S * t / (a * a), T(3, 2) = -S / a * (1.0 - t * t), T(3, 3) = 1.0;
    return T;
  }
};

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
    const auto m = static_cast<Eigen::Index>(d_.train.end - d_.train.begin);
    Jt_.resize(m, kGpi);
    gpi_evaluate(d_, n_, th.data(), residuals, Jt_.data());
    if (d_.free_offset) project_offset(num_residuals(), kGpi, residuals, Jt_.data());
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, kGpi, Eigen::RowMajor>>(jacobians[0], m, kGpi).noalias() =
        Jt_ * chart_.jacobian(params[0]);
    return true;
  }

 private:
  Data d_;
  int n_;
  GpiChart chart_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, kGpi, Eigen::RowMajor> Jt_;
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
      s.p[i] = kind == FitModel::mpi_asym ? sl[i + 1] : sl[i + 1] - sl[i];
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
      case FitModel::pi: return PiParams{s.q, s.r, s.p, {}, {}};
      case FitModel::gpi: {  // the free-weight variant (thresholds r_i, weights p_i)
        GpiParams g;
        g.envelope = Envelope::tanh(th[0], th[1], th[2], th[3]);
        g.q = s.q;
        g.n = static_cast<int>(s.r.size());
        g.r = s.r;
        g.p = s.p;
        return g;
      }
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
    } else if (env == 4) {
      for (int i = 0; i < 4; ++i) out.push_back(fmt::format("c{}", i));
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

// Residuals (and, if J != nullptr, their row-major m x size() Jacobian) of a
// slope-parametrized model in one pass with plain doubles (forward-mode
// sensitivities; the branch tests are those of ops::asymmetric_play / dead_zone, so
// this is the derivative the Jets of SlopeFunctor compute, tested to 1e-10).
// pi / mpi-deadzone: the play outputs do not depend on theta (identity envelope,
// fixed thresholds): dv/ds_j = y_{j-1} - y_j (y_0 = x); dead zones: out =
// v + sum g_k S_k(v), d out/dv = 1 + sum of the active g_k, d out/dD_j = S_j - S_{j+1}.
// mpi-asym: each play output is held (keeps its 8-vector of envelope derivatives)
// or equals u_a - r_i (ascending coefficients) or u_d + r_i (descending ones).
void slope_evaluate(const Data& d, const SlopeLayout& L, const double* th, double* res, double* J) {
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
    res[rix] = f;
    if (!J) continue;
    double* jr = J + P * rix;
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
  }
}

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

// Runs fn(k) for k = 0..count-1, the k spread over up to `threads` threads (0: one per
// hardware thread; 1: in order on this thread). Each k is independent, so the
// results do not depend on the thread count. The first exception (lowest k) thrown
// by a task is rethrown once all have finished. If a thread cannot be created the
// work runs on the threads that exist.
template <class Fn>
void for_each_start(std::size_t count, int threads, Fn&& fn) {
  std::size_t t = threads > 0 ? static_cast<std::size_t>(threads) : std::max(1u, std::thread::hardware_concurrency());
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
  std::vector<int> at_bound;  // parameters held on their lower bound (see solve)
};

// Builds the problem for one start; `theta` must outlive it (it is the parameter block).
std::unique_ptr<ceres::Problem> make_problem(FitModel /*kind*/, const Data& d, int n, const SlopeLayout* layout,
                                             std::vector<double>& theta, const std::vector<double>& lower,
                                             const std::vector<int>& held) {
  auto problem = std::make_unique<ceres::Problem>();
  ceres::CostFunction* cost = nullptr;
  if (layout == nullptr) {  // the gpi of Eqs. 6-8
    cost = new GpiChartCost(d, n);
  } else {
    cost = new SlopeCost(d, layout);
  }
  problem->AddResidualBlock(cost, nullptr, theta.data());
  if (layout && layout->ridge > 0 && !layout->r.empty() && layout->kind != FitModel::mpi_asym)
    problem->AddResidualBlock(new RidgeCost(layout), nullptr, theta.data());
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (std::isfinite(lower[i])) problem->SetParameterLowerBound(theta.data(), static_cast<int>(i), lower[i]);
  if (!held.empty() && held.size() < theta.size())
    problem->SetManifold(theta.data(), new ceres::SubsetManifold(static_cast<int>(theta.size()), held));
  return problem;
}

Solved solve_once(FitModel kind, const Data& d, int n, const SlopeLayout* layout, std::vector<double> theta,
                  const std::vector<double>& lower, const std::vector<int>& held, const FitOptions& o, int start,
                  int max_iterations) {
  Solved out;
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (std::isfinite(lower[i])) theta[i] = std::max(theta[i], lower[i]);
  auto problem = make_problem(kind, d, n, layout, theta, lower, held);
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
  Progress cb(o, start);
  if (o.progress) so.callbacks.push_back(&cb);
  Stall stall(o.stall_iterations, o.stall_tolerance);
  if (o.stall_tolerance > 0) so.callbacks.push_back(&stall);
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem.get(), &summary);
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
// that end on their bound (within 1e-4 of their scale) are then held there and LM
// solves the others, unconstrained in the interior; otherwise LM continues. The
// better solution is kept; `at_bound` lists the parameters held on a bound.
Solved solve(FitModel kind, const Data& d, int n, const SlopeLayout* layout, const std::vector<double>& theta,
             const std::vector<double>& lower, const std::vector<int>& held, const FitOptions& o, int start) {
  // Only the gpi of Eqs. 6-8: on the slope models (p_i >= 0 bounds of mpi-asym) weights touch the
  // bound and leave it again as the envelopes move, and holding them costs accuracy
  // (mpi-openloop experiment: compensated max error 2.5 -> 4.1 mm).
  if (layout != nullptr) return solve_once(kind, d, n, layout, theta, lower, held, o, start, o.max_iterations);
  constexpr int kProbe = 40;
  const int first = std::min(o.max_iterations, kProbe);
  Solved out = solve_once(kind, d, n, layout, theta, lower, held, o, start, first);
  const int left = o.max_iterations - std::max(0, out.iterations);
  if (!out.usable || left <= 0) return out;
  std::vector<int> active = held;
  for (std::size_t i = 0; i < lower.size(); ++i) {
    if (!std::isfinite(lower[i]) || std::find(held.begin(), held.end(), static_cast<int>(i)) != held.end()) continue;
    const double scale = std::max(std::abs(theta[i]), std::abs(lower[i]));
    if (out.theta[i] - lower[i] <= 1e-4 * scale) active.push_back(static_cast<int>(i));
  }
  const bool bound = active.size() > held.size() && active.size() < theta.size();
  if (!bound && out.termination != ceres::NO_CONVERGENCE) return out;
  std::vector<double> at = out.theta;
  for (std::size_t k = held.size(); k < active.size(); ++k)
    at[static_cast<std::size_t>(active[k])] = lower[static_cast<std::size_t>(active[k])];
  Solved again = solve_once(kind, d, n, layout, at, lower, bound ? active : held, o, start, left);
  if (again.usable && again.final_cost <= out.final_cost) {
    again.initial_cost = out.initial_cost;
    again.iterations += out.iterations;
    if (bound) again.at_bound.assign(active.begin() + static_cast<std::ptrdiff_t>(held.size()), active.end());
    return again;
  }
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
    // Ceres (DENSE_SVD) refuses when (s_min / s_max)^2 of J < 1e-14; the singular values
    // of J itself (not eigenvalues of J^T J, which lose half the digits) with a margin.
    const Eigen::VectorXd sv = Eigen::BDCSVD<Eigen::MatrixXd>(Jf).singularValues();
    const double smax = sv.size() ? sv.maxCoeff() : 0.0, smin = sv.size() ? sv.minCoeff() : 0.0;
    if (!(smax > 0) || !(smin * smin > 1e-12 * smax * smax)) {
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
    rep.parameters[i].std_error = rep.parameters[i].held || rep.parameters[i].at_bound ? 0.0 : std::sqrt(std::max(0.0, v));
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

// For fixed envelope, alpha and tau the gpi output is linear in (q, rho): solve
// them by NNLS and return the sum of squared errors.
// Bounded least squares t >= lo for A t ~ b, with a free offset when `centre` (columns
// and target centred: the offset is eliminated exactly). Returns t; *sse the residual.
Eigen::VectorXd bounded_ls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lo, bool centre,
                           double* sse) {
  if (!centre) {
    const Eigen::VectorXd t = lo + detail::nnls(A, b - A * lo);
    *sse = (A * t - b).squaredNorm();
    return t;
  }
  const Eigen::MatrixXd Ac = A.rowwise() - A.colwise().mean();
  const Eigen::VectorXd bc = b.array() - b.mean();
  const Eigen::VectorXd t = lo + detail::nnls(Ac, bc - Ac * lo);
  *sse = (Ac * t - bc).squaredNorm();
  return t;
}

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
  double sse = 0;
  const Eigen::VectorXd t = bounded_ls(A, b, lo, d.free_offset, &sse);
  th[4] = t(0);
  th[5] = t(1);
  return sse;
}

// ---- branches of the loop and envelope fits ------------------------------------

// Points (input, output) of a curve, one per input bin.
struct Curve {
  std::vector<double> x, y;
};

// Ascending and descending branches and the centre line of the loop: each sample
// is classified by the direction of the input (a turning point is declared when
// the input moves back by more than 1 % of its span, so noise does not flip it);
// per input bin, the mean input and output of each branch; the centre line is the
// average of both branches in the bins where both exist (the anhysteretic curve).
struct Branches {
  Curve asc, desc, centre;
};

Branches loop_branches(const Data& d, const Ranges& rg) {
  constexpr int kBins = 32;
  const double eps = 0.01 * rg.xspan();
  std::vector<double> sx[2], sy[2], cnt[2];
  for (int b = 0; b < 2; ++b) sx[b].assign(kBins, 0.0), sy[b].assign(kBins, 0.0), cnt[b].assign(kBins, 0.0);
  int dir = 0;  // +1 rising, -1 falling, 0 not yet known
  double ext = d.x[d.train.begin], lo = ext, hi = ext;
  for (std::size_t k = d.train.begin; k < d.train.end; ++k) {
    const double xk = d.x[k];
    if (dir == 0) {
      lo = std::min(lo, xk), hi = std::max(hi, xk);
      if (xk > lo + eps) dir = 1, ext = xk;
      else if (xk < hi - eps) dir = -1, ext = xk;
    } else if (dir == 1) {
      if (xk > ext) ext = xk;
      else if (xk < ext - eps) dir = -1, ext = xk;
    } else {
      if (xk < ext) ext = xk;
      else if (xk > ext + eps) dir = 1, ext = xk;
    }
    if (dir == 0) continue;
    const int side = dir > 0 ? 0 : 1;
    const int b = std::clamp(static_cast<int>((xk - rg.xlo) / rg.xspan() * kBins), 0, kBins - 1);
    const auto bi = static_cast<std::size_t>(b);
    sx[side][bi] += xk;
    sy[side][bi] += d.y[k];
    cnt[side][bi] += 1;
  }
  Branches out;
  for (std::size_t b = 0; b < kBins; ++b) {
    const bool has[2] = {cnt[0][b] > 0, cnt[1][b] > 0};
    if (has[0]) out.asc.x.push_back(sx[0][b] / cnt[0][b]), out.asc.y.push_back(sy[0][b] / cnt[0][b]);
    if (has[1]) out.desc.x.push_back(sx[1][b] / cnt[1][b]), out.desc.y.push_back(sy[1][b] / cnt[1][b]);
    if (has[0] && has[1]) {
      out.centre.x.push_back(0.5 * (sx[0][b] / cnt[0][b] + sx[1][b] / cnt[1][b]));
      out.centre.y.push_back(0.5 * (sy[0][b] / cnt[0][b] + sy[1][b] / cnt[1][b]));
    }
  }
  return out;
}

// c0 tanh(c1 x + c2) + c3 fitted to a curve (c0, c1 > 0): grid over the slope
// a = c1 xs and the shift b, (c0, c3) by linear least squares, then a few
// Gauss-Newton steps on all four. Falls back to a line through the ranges.
std::array<double, 4> fit_tanh(const Curve& c, const Ranges& rg, double a_fixed = 0.0) {
  const double xc = 0.5 * (rg.xlo + rg.xhi), xs = 0.5 * rg.xspan();
  const double ys = 0.5 * rg.yspan(), yc = 0.5 * (rg.ylo + rg.yhi);
  std::array<double, 4> best{ys / std::tanh(0.1), 0.1 / xs, -0.1 * xc / xs, yc};
  const std::size_t m = c.x.size();
  if (m < 4) return best;
  auto sse_of = [&](const std::array<double, 4>& t) {
    double s = 0;
    for (std::size_t k = 0; k < m; ++k) {
      const double e = c.y[k] - (t[0] * std::tanh(t[1] * c.x[k] + t[2]) + t[3]);
      s += e * e;
    }
    return s;
  };
  double best_sse = std::numeric_limits<double>::infinity();
  for (int ia = 0; ia < (a_fixed > 0 ? 1 : 24); ++ia) {
    const double a = a_fixed > 0 ? a_fixed : 0.05 * std::pow(100.0, ia / 23.0);  // 0.05 .. 5
    for (int ib = -24; ib <= 24; ++ib) {
      const double b = 0.125 * ib;
      double st = 0, sy = 0, stt = 0, sty = 0;
      for (std::size_t k = 0; k < m; ++k) {
        const double t = std::tanh(a * (c.x[k] - xc) / xs + b);
        st += t, sy += c.y[k], stt += t * t, sty += t * c.y[k];
      }
      const double mm = static_cast<double>(m);
      const double det = mm * stt - st * st;
      if (!(det > 1e-14 * mm * mm)) continue;
      const double c0 = (mm * sty - st * sy) / det;
      if (!(c0 > 0)) continue;
      const std::array<double, 4> t{c0, a / xs, b - a * xc / xs, (sy - c0 * st) / mm};
      const double e = sse_of(t);
      if (e < best_sse) best_sse = e, best = t;
    }
  }
  // Gauss-Newton with step halving on the 4 coefficients.
  for (int it = 0; it < 20 && std::isfinite(best_sse) && !(a_fixed > 0); ++it) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    for (std::size_t k = 0; k < m; ++k) {
      const double t = std::tanh(best[1] * c.x[k] + best[2]);
      const double sl = best[0] * (1 - t * t);
      const Eigen::Vector4d jr(t, sl * c.x[k], sl, 1.0);
      const double e = c.y[k] - (best[0] * t + best[3]);
      A += jr * jr.transpose();
      g += jr * e;
    }
    A.diagonal() *= 1.0 + 1e-9;
    const Eigen::Vector4d step = A.ldlt().solve(g);
    bool improved = false;
    for (double h = 1.0; h > 1e-3; h *= 0.5) {
      std::array<double, 4> t = best;
      for (int i = 0; i < 4; ++i) t[static_cast<std::size_t>(i)] += h * step(i);
      if (!(t[0] > 0 && t[1] > 0)) continue;
      const double e = sse_of(t);
      if (e < best_sse) {
        improved = best_sse - e > 1e-12 * best_sse;
        best_sse = e, best = t;
        break;
      }
    }
    if (!improved) break;
  }
  return best;
}

// Envelope output span over the input range.
double envelope_span(const std::array<double, 4>& c, const Ranges& rg) {
  return std::abs(c[0] * (std::tanh(c[1] * rg.xhi + c[2]) - std::tanh(c[1] * rg.xlo + c[2])));
}

// Weights of a PI on envelope output u with thresholds r (cumulative slopes >= margin), by NNLS.
// Returns the SSE; q and p receive the weights.
// With `direct`, q and every p_i themselves are kept >= margin (the mpi-asym layout).
double cls_weights(const Data& d, const Structure<double>& s, double margin, double& q, std::vector<double>& p,
                   Eigen::MatrixXd* phi_out = nullptr, bool direct = false) {
  const IndexRange tr = d.train;
  const Eigen::MatrixXd phi = detail::regressors(s, d.x, tr, d.initial);
  const auto m = phi.rows();
  const auto k = phi.cols();
  // cumulative slopes: a_i = phi_i - phi_{i+1}, a_n = phi_n
  Eigen::MatrixXd A = phi;
  if (!direct)
    for (Eigen::Index i = 0; i + 1 < k; ++i) A.col(i) -= phi.col(i + 1);
  Eigen::VectorXd b(m);
  for (Eigen::Index j = 0; j < m; ++j) b(j) = d.y[tr.begin + static_cast<std::size_t>(j)];
  const Eigen::VectorXd lo = Eigen::VectorXd::Constant(k, margin);
  double sse = 0;
  const Eigen::VectorXd sl = bounded_ls(A, b, lo, d.free_offset, &sse);
  q = sl(0);
  p.resize(static_cast<std::size_t>(k - 1));
  for (Eigen::Index i = 1; i < k; ++i) p[static_cast<std::size_t>(i - 1)] = direct ? sl(i) : sl(i) - sl(i - 1);
  if (phi_out) *phi_out = phi;
  return sse;
}

// rho, tau of Eq. 8 from free weights on r_i: weighted log-linear fit
// log p_i = log rho - tau r_i over the positive weights (weights p_i).
double fit_tau(const std::vector<double>& r, const std::vector<double>& p) {
  double pmax = 0;
  for (double v : p) pmax = std::max(pmax, v);
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!(p[i] > 1e-6 * pmax)) continue;
    const double w = p[i], ly = std::log(p[i]);
    sw += w, sx += w * r[i], sy += w * ly, sxx += w * r[i] * r[i], sxy += w * r[i] * ly;
  }
  const double det = sw * sxx - sx * sx;
  if (!(sw > 0) || !(det > 1e-14 * sw * sxx)) return std::numeric_limits<double>::quiet_NaN();
  return -(sw * sxy - sx * sy) / det;
}

// The record decimated to about 2500 samples (every s-th sample from the start)
// for the screening of start candidates; the operators are rate independent, so
// the ranking is nearly that of the full record at 1/s of the cost.
struct Decimated {
  std::vector<double> x, y;
  Data d;
};
Decimated decimate(const Data& d) {
  const std::size_t m = d.train.end - d.train.begin;
  const std::size_t st = std::max<std::size_t>(1, m / 2500);
  Decimated out;
  for (std::size_t k = 0; k < d.train.end; k += st) out.x.push_back(d.x[k]), out.y.push_back(d.y[k]);
  out.d = d;
  out.d.x = out.x;
  out.d.y = out.y;
  out.d.train = {(d.train.begin + st - 1) / st, out.x.size()};
  out.d.huber = 0;
  return out;
}

// Envelopes: the free tanh fit of the loop's centre line, and fits with a fixed
// curvature c1 xs (multi-start over the envelope shape).
std::vector<std::array<double, 4>> gpi_envelopes(const Data& d, const Ranges& rg) {
  const Branches br = loop_branches(d, rg);
  Curve centre = br.centre;
  if (centre.x.size() < 4) {
    centre = Curve{};
    for (std::size_t k = d.train.begin; k < d.train.end; ++k) centre.x.push_back(d.x[k]), centre.y.push_back(d.y[k]);
  }
  std::vector<std::array<double, 4>> envs{fit_tanh(centre, rg)};
  for (double a : {0.25, 0.6, 1.2, 2.5}) envs.push_back(fit_tanh(centre, rg, a));
  return envs;
}

// Data-derived gpi starts: the envelope from a tanh fit of the loop's centre line;
// with it fixed the output is linear in (q, p_i) for fixed thresholds r_i = alpha i,
// so for a log grid of alpha over (0, half the envelope-output span)/n the weights
// are solved by constrained LS, (rho, tau) fitted to them log-linearly, (q, rho)
// re-solved by NNLS for the exponential law and the candidates ranked by SSE.
std::vector<std::vector<double>> gpi_starts(const Data& full, int n, const FitOptions& o, double lb_rel) {
  const Decimated dec = decimate(full);
  const Data& d = dec.d;
  const Ranges rg = ranges_of(d);
  const auto envs = gpi_envelopes(d, rg);
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> jit(-0.1, 0.1);
  auto j = [&](double v) { return o.seed == 0 ? v : v * (1.0 + jit(rng)); };
  struct Cand {
    double sse;
    std::vector<double> th;
  };
  std::vector<Cand> cands;
  constexpr int kAlphas = 14;
  const double margin = lb_rel;
  for (const auto& env : envs)
  for (int ia = 0; ia < kAlphas; ++ia) {
    const double U = envelope_span(env, rg);
    const double f = 0.01 * std::pow(250.0, ia / (kAlphas - 1.0));  // 0.01 .. 2.5
    const double alpha = j(f) * 0.5 * U / n;
    Structure<double> s;
    s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
    s.asc_c = s.desc_c = {env[0], env[1], env[2], env[3]};
    for (int i = 1; i <= n; ++i) s.r.push_back(alpha * i);
    s.p.assign(s.r.size(), 0.0);
    double q = 1;
    std::vector<double> p;
    cls_weights(d, s, margin, q, p);
    const double tf = fit_tau(s.r, p);
    std::vector<double> taus{1e-3 / (alpha * n), 1.0 / (alpha * n)};
    if (std::isfinite(tf)) taus.push_back(std::max(tf, 1e-3 / (alpha * n)));
    for (double tau : taus) {
      std::vector<double> th{env[0], env[1], env[2], env[3], 1.0, 1.0, tau, alpha};
      const double sse = gpi_linear_seed(d, n, th.data(), margin, margin);
      if (std::isfinite(sse)) cands.push_back({sse, th});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) { return a.sse < b.sse; });
  std::vector<std::vector<double>> out;
  for (const Cand& c : cands) {
    if (static_cast<int>(out.size()) >= o.num_starts) break;
    // distinct alphas only
    bool dup = false;
    for (const auto& t : out) dup = dup || std::abs(t[7] - c.th[7]) < 1e-9 * std::abs(c.th[7]);
    if (!dup) out.push_back(c.th);
  }
  return out;
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
    uspan = std::abs(envelope_value<double>(s0.asc_kind, s0.asc_c.data(), rg.xhi) -
                     envelope_value<double>(s0.asc_kind, s0.asc_c.data(), rg.xlo));
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

// mpi-asym starts: envelope pairs (ascending/descending branch fits; the centre
// line for both), thresholds r_i = alpha i on the alpha grid of gpi_starts, weights
// by constrained LS; the best num_starts by SSE.
void asym_starts(const Data& full, int n, const FitOptions& o, double margin, std::vector<SlopeLayout>& layouts,
                 std::vector<std::vector<double>>& starts) {
  const Decimated dec = decimate(full);
  const Data& d = dec.d;
  const Ranges rg = ranges_of(d);
  const Branches br = loop_branches(d, rg);
  Curve all;
  for (std::size_t k = d.train.begin; k < d.train.end; ++k) all.x.push_back(d.x[k]), all.y.push_back(d.y[k]);
  const auto ce = fit_tanh(br.centre.x.size() >= 4 ? br.centre : all, rg);
  const auto ea = br.asc.x.size() >= 4 ? fit_tanh(br.asc, rg) : ce;
  const auto ed = br.desc.x.size() >= 4 ? fit_tanh(br.desc, rg) : ce;
  struct Cand {
    double sse;
    SlopeLayout layout;
    std::vector<double> th;
  };
  std::vector<Cand> cands;
  const std::pair<std::array<double, 4>, std::array<double, 4>> pairs[2] = {{ea, ed}, {ce, ce}};
  for (const auto& [a, b] : pairs) {
    const double U = 0.5 * (envelope_span(a, rg) + envelope_span(b, rg));
    const double scale = rg.yspan() / std::max(U, 1e-300);
    constexpr int kAlphas = 14;
    for (int ia = 0; ia < kAlphas; ++ia) {
      const double alpha = 0.01 * std::pow(100.0, ia / (kAlphas - 1.0)) * 0.5 * U / n;
      Structure<double> s;
      s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
      s.asymmetric = true;
      s.asc_c = {a[0], a[1], a[2], a[3]};
      s.desc_c = {b[0], b[1], b[2], b[3]};
      for (int i = 1; i <= n; ++i) s.r.push_back(alpha * i);
      s.p.assign(s.r.size(), 0.0);
      double q = 1;
      std::vector<double> p;
      const double sse = cls_weights(d, s, margin * scale, q, p);
      if (!std::isfinite(sse)) continue;
      Cand c{sse, {}, {}};
      c.layout.kind = FitModel::mpi_asym;
      c.layout.env = 8;
      c.layout.r = s.r;
      c.th.assign(a.begin(), a.end());
      c.th.insert(c.th.end(), b.begin(), b.end());
      c.th.push_back(q);  // mpi-asym layout: q, then the weights themselves, >= 0
      for (double pi : p) c.th.push_back(std::max(pi, 0.0));
      cands.push_back(std::move(c));
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& x, const Cand& y) { return x.sse < y.sse; });
  for (std::size_t k = 0; k < cands.size() && static_cast<int>(k) < o.num_starts; ++k) {
    layouts.push_back(cands[k].layout);
    starts.push_back(cands[k].th);
  }
  if (starts.empty()) throw Error("fit: mpi-asym: no usable start");
}

// Free-weight gpi starts: the envelopes of gpi_starts (centre-line tanh fits) with
// thresholds r_i = alpha i on its alpha grid and cumulative slopes by constrained LS;
// the best num_starts by SSE.
void gpi_free_starts(const Data& full, int n, const FitOptions& o, double margin, std::vector<SlopeLayout>& layouts,
                     std::vector<std::vector<double>>& starts) {
  const Decimated dec = decimate(full);
  const Data& d = dec.d;
  const Ranges rg = ranges_of(d);
  struct Cand {
    double sse;
    SlopeLayout layout;
    std::vector<double> th;
  };
  std::vector<Cand> cands;
  for (const auto& env : gpi_envelopes(d, rg)) {
    const double U = envelope_span(env, rg);
    const double scale = rg.yspan() / std::max(U, 1e-300);
    constexpr int kAlphas = 14;
    for (int ia = 0; ia < kAlphas; ++ia) {
      const double alpha = 0.01 * std::pow(250.0, ia / (kAlphas - 1.0)) * 0.5 * U / n;
      Structure<double> s;
      s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
      s.asc_c = s.desc_c = {env[0], env[1], env[2], env[3]};
      for (int i = 1; i <= n; ++i) s.r.push_back(alpha * i);
      s.p.assign(s.r.size(), 0.0);
      double q = 1;
      std::vector<double> p;
      const double sse = cls_weights(d, s, margin * scale, q, p);
      if (!std::isfinite(sse)) continue;
      Cand c{sse, {}, {}};
      c.layout.kind = FitModel::gpi;
      c.layout.env = 4;
      c.layout.r = s.r;
      c.th.assign(env.begin(), env.end());
      const auto sl = slopes(q, p);
      c.th.insert(c.th.end(), sl.begin(), sl.end());
      cands.push_back(std::move(c));
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& x, const Cand& y) { return x.sse < y.sse; });
  for (std::size_t k = 0; k < cands.size() && static_cast<int>(k) < o.num_starts; ++k) {
    layouts.push_back(cands[k].layout);
    starts.push_back(cands[k].th);
  }
  if (starts.empty()) throw Error("fit: gpi (free weights): no usable start");
}

int num_parameters(const FitOptions& o) {
  const int n = o.num_operators;
  switch (o.model) {
    case FitModel::gpi: return o.gpi_free_weights ? 4 + n + 1 : kGpi;
    case FitModel::pi: return n;
    case FitModel::mpi_deadzone: return n + 1 + o.num_dead_zones;
    case FitModel::mpi_asym: return 8 + n + 1;
    case FitModel::automatic: return n;
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

// Refines every start by LM, concurrently on FitOptions::num_threads threads (layouts:
// one per start for the slope models, nullptr for the gpi); adds their iterations to
// rep.total_iterations, sets rep.num_starts and returns the solutions with the index of
// the usable one of lowest cost (the first on ties; npos if none is usable).
std::pair<std::vector<Solved>, std::size_t> solve_starts(FitModel kind, const Data& d, int n,
                                                         const std::vector<SlopeLayout>* layouts,
                                                         const std::vector<std::vector<double>>& starts,
                                                         const std::vector<std::vector<double>>& lowers,
                                                         const std::vector<int>& held, const FitOptions& o,
                                                         FitReport& rep) {
  std::vector<Solved> solved(starts.size());
  for_each_start(starts.size(), o.num_threads, [&](std::size_t k) {
    solved[k] = solve(kind, d, n, layouts ? &(*layouts)[k] : nullptr, starts[k], lowers[k], held, o, static_cast<int>(k));
  });
  std::size_t best = std::string::npos;
  for (std::size_t k = 0; k < solved.size(); ++k) {
    rep.total_iterations += std::max(0, solved[k].iterations);
    if (solved[k].usable && (best == std::string::npos || solved[k].final_cost < solved[best].final_cost)) best = k;
  }
  rep.num_starts = static_cast<int>(starts.size());
  return {std::move(solved), best};
}

// Runs LM on several slope-parametrized starts and fills the report.
void fit_slopes(const Data& d, const std::vector<SlopeLayout>& layouts, const std::vector<std::vector<double>>& starts,
                const std::vector<std::vector<double>>& lowers, const FitOptions& o, FitReport& rep) {
  auto [solved, kbest] = solve_starts(o.model, d, 0, &layouts, starts, lowers, {}, o, rep);
  if (kbest == std::string::npos) {
    rep.status = FitStatus::failed;
    rep.message = "no start gave a usable solution";
    return;
  }
  const Solved& best = solved[kbest];
  const SlopeLayout& layout = layouts[kbest];
  const std::vector<double>& lower = lowers[kbest];
  finish_status(rep, best);
  rep.initial_cost = best.initial_cost;
  rep.final_cost = best.final_cost;
  rep.iterations = best.iterations;
  rep.model = layout.params(best.theta.data());
  if (d.free_offset) {  // the offset eliminated by the projection: the mean residual
    const std::vector<double> yp = simulate_record(rep.model, d.x.subspan(0, d.train.end), d.initial);
    double c = 0;
    for (std::size_t j = d.train.begin; j < d.train.end; ++j) c += d.y[j] - yp[j];
    units_map(rep.model).output_offset = c / static_cast<double>(d.train.end - d.train.begin);
  }
  const Eigen::MatrixXd M = layout.report_map();
  const Eigen::VectorXd v = M * Eigen::Map<const Eigen::VectorXd>(best.theta.data(), static_cast<Eigen::Index>(best.theta.size()));
  const auto names = layout.names();
  for (std::size_t i = 0; i < names.size(); ++i) rep.parameters.push_back({names[i], v(static_cast<Eigen::Index>(i))});
  if (o.compute_covariance) {
    const std::vector<double> yp = simulate_record(rep.model, d.x.subspan(0, d.train.end), d.initial);
    double sse = 0;
    for (std::size_t j = d.train.begin; j < d.train.end; ++j) sse += (d.y[j] - yp[j]) * (d.y[j] - yp[j]);
    standard_errors(o.model, d, 0, &layout, best.theta, lower, best.at_bound, M, sse, rep);
    if (!best.at_bound.empty())
      rep.covariance_note += fmt::format("{}{} cumulative slope(s) q + p_1 + ... + p_i ended on the invertibility bound "
                                         "and were held there (their uncertainty is not included)",
                                         rep.covariance_note.empty() ? "" : "; ", best.at_bound.size());
  }
}

}  // namespace

std::string_view fit_model_name(FitModel model) noexcept {
  switch (model) {
    case FitModel::gpi: return "gpi";
    case FitModel::pi: return "pi";
    case FitModel::mpi_deadzone: return "mpi-deadzone";
    case FitModel::mpi_asym: return "mpi-asym";
    case FitModel::automatic: return "auto";
  }
  return "gpi";
}

FitModel fit_model_from_name(std::string_view name) {
  for (FitModel m : {FitModel::gpi, FitModel::pi, FitModel::mpi_deadzone, FitModel::mpi_asym, FitModel::automatic})
    if (fit_model_name(m) == name) return m;
  throw Error(fmt::format("unknown model '{}' (expected gpi, pi, mpi-deadzone, mpi-asym or auto)", name));
}

std::string_view fit_status_name(FitStatus status) noexcept {
  switch (status) {
    case FitStatus::not_run: return "not_run";
    case FitStatus::converged: return "converged";
    case FitStatus::no_convergence: return "no_convergence";
    case FitStatus::failed: return "failed";
    case FitStatus::invalid_input: return "invalid_input";
    case FitStatus::poor_fit: return "poor_fit";
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
  if (stall_iterations < 1 || stall_iterations > 100000)
    return fail(fmt::format("stall_iterations must be in 1..100000, got {}", stall_iterations));
  if (!(stall_tolerance >= 0) || !std::isfinite(stall_tolerance))
    return fail(fmt::format("stall_tolerance must be >= 0, got {}", stall_tolerance));
  if (num_threads < 0 || num_threads > 256) return fail(fmt::format("num_threads must be in 0..256, got {}", num_threads));
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0))
    return fail("tolerances must be >= 0");
  if (!(weight_regularization >= 0) || !std::isfinite(weight_regularization))
    return fail(fmt::format("weight_regularization must be >= 0, got {}", weight_regularization));
  if (!(positivity_margin >= 0 && positivity_margin < 0.1))
    return fail(fmt::format("positivity_margin must be in [0, 0.1), got {}", positivity_margin));
  if (!(min_slope > 0 && min_slope < 1)) return fail(fmt::format("min_slope must be in (0, 1), got {}", min_slope));
  if (!(holdout_fraction >= 0.05 && holdout_fraction <= 0.5))
    return fail(fmt::format("holdout_fraction must be in [0.05, 0.5], got {}", holdout_fraction));
  if (!(poor_fit_ratio == 0 || (poor_fit_ratio >= 1 && std::isfinite(poor_fit_ratio))))
    return fail(fmt::format("poor_fit_ratio must be 0 (off) or >= 1, got {}", poor_fit_ratio));
  return true;
}

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
  SlopeLayout L;
  L.kind = model;
  L.env = model == FitModel::mpi_asym ? 8 : model == FitModel::gpi ? 4 : 0;
  L.r.assign(r.begin(), r.end());
  if (model == FitModel::mpi_deadzone) L.zp.assign(zp.begin(), zp.end()), L.zn.assign(zn.begin(), zn.end());
  if (theta.size() != static_cast<std::size_t>(L.size()))
    throw Error(fmt::format("slope_residuals: theta must have {} entries, got {}", L.size(), theta.size()));
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

std::vector<double> default_thresholds(std::span<const double> x, int n) {
  const double span = detail::span_of(x);
  std::vector<double> r;
  for (int i = 1; i < n; ++i) r.push_back(i * span / (2.0 * n));
  return r;
}

FitReport detail::fit_core(std::span<const double> x, std::span<const double> y, const FitOptions& options,
                           bool free_offset) {
  const auto t0 = Clock::now();
  // The starts may run on several threads: the caller's progress callback is called
  // one call at a time (a mutex per fit).
  std::mutex progress_mutex;
  FitOptions o = options;
  if (options.progress)
    o.progress = [&progress_mutex, &f = options.progress](int start, int iteration, double cost) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      f(start, iteration, cost);
    };
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
  d.free_offset = free_offset && o.huber_delta == 0.0;
  const Ranges rg = ranges_of(d);
  d.xc = 0.5 * (rg.xlo + rg.xhi);
  d.xs = std::max(0.5 * rg.xspan(), std::numeric_limits<double>::min());
  if (!(rg.xspan() > 0)) return invalid("fit: the input is constant over the training range", o.model, t0);
  if (!(rg.yspan() > 0)) return invalid("fit: the output is constant over the training range", o.model, t0);

  FitReport rep;
  rep.model_kind = o.model;
  const int n = o.num_operators;
  try {
    if (o.model == FitModel::gpi && !o.gpi_free_weights) {
      const double lb = std::max(o.positivity_margin, 1e-12);
      const auto starts = gpi_starts(d, n, o, lb);
      const GpiChart chart{d.xc, d.xs};
      std::vector<std::vector<double>> phis, lowers;
      for (const auto& th : starts) {
        // LM runs in the chart phi = [S, a, b, m, q, rho, tau, alpha] (GpiChart). Bounds of
        // Eq. 13 (c0, c1 > 0 <=> S, a > 0; rho, tau > 0) plus q, alpha > 0, relative to the
        // start's scale; the curvature a >= 1e-3 (tanh(a xn) is then linear to 3e-7, and
        // c0 = S / a stays small enough for c3 to keep its digits).
        const auto ph = chart.phi(th.data());
        std::vector<double>& lower = lowers.emplace_back(kGpi, -std::numeric_limits<double>::infinity());
        for (int i : {0, 4, 5, 6, 7}) lower[static_cast<std::size_t>(i)] = lb * std::abs(ph[static_cast<std::size_t>(i)]);
        lower[1] = 1e-3;
        // Minimum slope after a reversal (FitOptions::min_slope): dy/du = q >= min_slope
        // times the mean dy/du of the start's envelope over the training range.
        const double uspan = envelope_span({th[0], th[1], th[2], th[3]}, rg);
        if (uspan > 0) lower[4] = std::max(lower[4], o.min_slope * rg.yspan() / uspan);
        phis.emplace_back(ph.begin(), ph.end());
      }
      std::vector<int> held;
      if (o.gpi_fix_scale) held.push_back(0);
      auto [solved, kbest] = solve_starts(FitModel::gpi, d, n, nullptr, phis, lowers, held, o, rep);
      Solved best;
      std::vector<double> best_lower;
      if (kbest != std::string::npos) {
        best = std::move(solved[kbest]);
        best_lower = lowers[kbest];
      }
      if (!best.usable) {
        rep.status = FitStatus::failed;
        rep.message = "no start gave a usable solution";
      } else {
        finish_status(rep, best);
        rep.initial_cost = best.initial_cost;
        rep.final_cost = best.final_cost;
        rep.iterations = best.iterations;
        const auto theta = chart.theta(best.theta.data());
        rep.model = gpi_params(theta.data(), n);
        if (d.free_offset) {  // the offset eliminated by the projection: the mean residual
          const std::vector<double> yp = simulate_record(rep.model, x.subspan(0, tr.end), o.initial_state);
          double c = 0;
          for (std::size_t j = tr.begin; j < tr.end; ++j) c += y[j] - yp[j];
          units_map(rep.model).output_offset = c / static_cast<double>(m);
        }
        static const char* names[kGpi] = {"c0", "c1", "c2", "c3", "q", "rho", "tau", "alpha"};
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
          const std::vector<double> yp = simulate_record(rep.model, x.subspan(0, tr.end), o.initial_state);
          double sse = 0;
          for (std::size_t j = tr.begin; j < tr.end; ++j) sse += (y[j] - yp[j]) * (y[j] - yp[j]);
          const std::string note = rep.covariance_note;
          standard_errors(FitModel::gpi, d, n, nullptr, best.theta, best_lower, fixed,
                          chart.jacobian(best.theta.data()), sse, rep);
          if (!note.empty() && rep.covariance_note != note)
            rep.covariance_note = rep.covariance_note.empty() ? note : note + "; " + rep.covariance_note;
        }
      }
    } else {
      SlopeLayout layout;
      layout.kind = o.model;
      std::vector<SlopeLayout> layouts;  // one per start (mpi-asym), else `layout` for all
      std::vector<std::vector<double>> starts;
      const double margin = std::max(o.positivity_margin, 1e-12);
      WeightFitOptions wo;
      wo.initial_state = o.initial_state;
      wo.train = tr;
      wo.margin = o.min_slope;
      wo.free_offset = d.free_offset;
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
        dz.p.assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
        const int J = o.num_dead_zones;
        for (int j = 1; j <= J; ++j) {
          const double z = rg.ylo + j * rg.yspan() / (J + 1);
          if (std::abs(z) > 1e-6 * rg.yspan()) dz.z.push_back(z);
        }
        dz.g.assign(dz.z.size(), 0.0);
        // Threshold scale: r_i = f i span(x) / (2n) for f in {1, 1/2, 1/4, 1/8}, weights
        // by constrained LS; ranked by the SSE of the training record plus that of a
        // second pass of the same input (the model continued from the state the first
        // pass leaves). One loop from the virgin state cannot tell wide thresholds
        // (whose virgin ascent differs from every later one) from narrow ones; the
        // second pass can (rig record: 16 mm validation RMS with f = 1).
        MpiDeadzoneParams fw;
        {
          std::vector<double> x2(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(tr.end));
          x2.insert(x2.end(), xs.begin(), xs.end());
          double best_sse = std::numeric_limits<double>::infinity();
          for (double f : {1.0, 0.5, 0.25, 0.125}) {
            dz.r = default_thresholds(xs, n);
            for (double& ri : dz.r) ri *= f;
            MpiDeadzoneParams c;
            try {
              c = std::get<MpiDeadzoneParams>(fit_weights(dz, x, y, wo));
            } catch (const Error&) {
              continue;
            }
            const std::vector<double> y2 = simulate_record(c, x2, o.initial_state);
            double sse = 0;
            for (std::size_t k = tr.begin; k < tr.end; ++k) {
              const double e1 = y[k] - y2[k], e2 = y[k] - y2[tr.end + k - tr.begin];
              sse += e1 * e1 + e2 * e2;
            }
            if (sse < best_sse) best_sse = sse, fw = c;
          }
          if (!std::isfinite(best_sse)) throw Error("fit: mpi-deadzone: no usable start");
        }
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
        layout.ridge = std::sqrt(o.weight_regularization * static_cast<double>(m)) * rg.xspan();
      } else if (o.model == FitModel::gpi) {  // free weights: one envelope + CLS cumulative slopes
        gpi_free_starts(d, n, o, margin, layouts, starts);
      } else {  // mpi-asym: two envelopes (branch fits or the centre line) + CLS weights
        asym_starts(d, n, o, margin, layouts, starts);
      }
      if (layouts.empty()) layouts.assign(starts.size(), layout);
      std::vector<std::vector<double>> lowers;
      for (std::size_t k = 0; k < starts.size(); ++k)
        lowers.push_back(slope_lower(layouts[k], starts[k], rg, margin, o.min_slope));
      fit_slopes(d, layouts, starts, lowers, o, rep);
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
                       p.held ? std::string("held") : p.at_bound ? std::string("at bound") : (std::isnan(p.std_error) ? std::string("-") : fmt::format("{:.4g}", p.std_error)));
  if (!covariance_note.empty()) out += fmt::format("note: {}\n", covariance_note);
  out += fmt::format("train: rms {:.6g}  max {:.6g}  mae {:.6g}  rms {:.4g}% of span  r2 {:.6f}  n {}\n", train.rms,
                     train.max, train.mae, train.rms_percent_span, train.r2, train.n);
  return out;
}

}  // namespace hysteron
