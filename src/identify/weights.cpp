// Constrained linear least squares and recursive least squares for the weights
// of models with fixed thresholds and envelopes.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "../core/rls_update.hpp"
#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

namespace detail {

namespace {

// Envelope values (u_a, u_m) of a structure at x.
inline void envelopes(const Structure<double>& s, double x, double& u_a, double& u_d) {
  u_a = envelope_value<double>(s.asc_kind, s.asc_c.data(), x);
  u_d = s.asymmetric ? envelope_value<double>(s.desc_kind, s.desc_c.data(), x) : u_a;
}

// One operator update; returns u_m.
inline double operators_step(const Structure<double>& s, double x, double* y) {
  double u_a, u_d;
  envelopes(s, x, u_a, u_d);
  const std::size_t n = s.r.size();
  if (!s.asymmetric) {
    for (std::size_t i = 0; i < n; ++i) y[i] = ops::generalized_play<double>(u_a, s.r[i], y[i]);
  } else {
    for (std::size_t i = 0; i < n; ++i) y[i] = ops::asymmetric_play<double>(u_a, u_d, s.r[i], y[i]);
  }
  return 0.5 * (u_a + u_d);
}

void initial_operator_state(const Structure<double>& s, InitialState initial, double x0, std::vector<double>& y) {
  double v = 0.0;
  if (initial == InitialState::relaxed) v = envelope_value<double>(s.asc_kind, s.asc_c.data(), x0);
  if (!std::isfinite(v)) v = 0.0;
  std::fill(y.begin(), y.end(), v);
}

}  // namespace

Eigen::MatrixXd regressors(const Structure<double>& s, std::span<const double> x, IndexRange range,
                           InitialState initial) {
  const std::size_t n = s.r.size();
  Eigen::MatrixXd phi(static_cast<Eigen::Index>(range.end - range.begin), static_cast<Eigen::Index>(n + 1));
  std::vector<double> y(n);
  initial_operator_state(s, initial, x.empty() ? 0.0 : x[0], y);
  for (std::size_t k = 0; k < range.end; ++k) {
    const double um = operators_step(s, x[k], y.data());
    if (k >= range.begin) {
      const auto row = static_cast<Eigen::Index>(k - range.begin);
      phi(row, 0) = um;
      for (std::size_t i = 0; i < n; ++i) phi(row, static_cast<Eigen::Index>(i + 1)) = y[i];
    }
  }
  return phi;
}

namespace {

// Rows of A processed at a time by the normal-equation passes: the only m-sized
// scratch of nnls/bounded_ls is one block of (centred) rows, kLsBlock x n.
constexpr Eigen::Index kLsBlock = 4096;

// Lawson-Hanson active set on the normal equations G t = h of min ||A t - b||,
// t >= 0 (G = A^T A, h = A^T b), column-scaled by d_j = sqrt(G_jj) (the column
// norms of A). Columns with d_j <= 1e-12 max d stay at 0.
Eigen::VectorXd nnls_normal(const Eigen::MatrixXd& G0, const Eigen::VectorXd& h0) {
  const Eigen::Index n = G0.cols();
  Eigen::VectorXd d = G0.diagonal().cwiseMax(0.0).cwiseSqrt();
  const double dmax = n > 0 ? d.maxCoeff() : 0.0;
  std::vector<bool> usable(static_cast<std::size_t>(n));
  for (Eigen::Index j = 0; j < n; ++j) {
    usable[static_cast<std::size_t>(j)] = d(j) > 1e-12 * dmax && d(j) > 0;
    if (!usable[static_cast<std::size_t>(j)]) d(j) = 1.0;
  }
  const Eigen::VectorXd dinv = d.cwiseInverse();
  const Eigen::MatrixXd G = dinv.asDiagonal() * G0 * dinv.asDiagonal();
  const Eigen::VectorXd h = h0.cwiseProduct(dinv);
  Eigen::VectorXd t = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(static_cast<std::size_t>(n), false);
  const double tol = 1e-12 * std::max(1.0, n > 0 ? h.cwiseAbs().maxCoeff() : 0.0);
  auto solve_passive = [&](Eigen::VectorXd& z) {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index j = 0; j < n; ++j)
      if (passive[static_cast<std::size_t>(j)]) idx.push_back(j);
    const auto m = static_cast<Eigen::Index>(idx.size());
    Eigen::MatrixXd Gp(m, m);
    Eigen::VectorXd hp(m);
    for (Eigen::Index a = 0; a < m; ++a) {
      hp(a) = h(idx[static_cast<std::size_t>(a)]);
      for (Eigen::Index c = 0; c < m; ++c) Gp(a, c) = G(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(c)]);
    }
    // tiny ridge for numerically collinear operator columns
    Gp.diagonal().array() += 1e-13;
    const Eigen::VectorXd zp = Gp.ldlt().solve(hp);
    z.setZero(n);
    for (Eigen::Index a = 0; a < m; ++a) z(idx[static_cast<std::size_t>(a)]) = zp(a);
  };
  Eigen::VectorXd z(n);
  for (int outer = 0; outer < 3 * static_cast<int>(n) + 10; ++outer) {
    const Eigen::VectorXd w = h - G * t;
    Eigen::Index jmax = -1;
    double wmax = tol;
    for (Eigen::Index j = 0; j < n; ++j)
      if (usable[static_cast<std::size_t>(j)] && !passive[static_cast<std::size_t>(j)] && w(j) > wmax) {
        wmax = w(j);
        jmax = j;
      }
    if (jmax < 0) break;
    passive[static_cast<std::size_t>(jmax)] = true;
    for (int inner = 0; inner < 3 * static_cast<int>(n) + 10; ++inner) {
      solve_passive(z);
      bool feasible = true;
      for (Eigen::Index j = 0; j < n; ++j)
        if (passive[static_cast<std::size_t>(j)] && z(j) <= 0) feasible = false;
      if (feasible) {
        t = z;
        break;
      }
      double alpha = 1.0;
      for (Eigen::Index j = 0; j < n; ++j)
        if (passive[static_cast<std::size_t>(j)] && z(j) <= 0) alpha = std::min(alpha, t(j) / (t(j) - z(j)));
      t += alpha * (z - t);
      for (Eigen::Index j = 0; j < n; ++j)
        if (passive[static_cast<std::size_t>(j)] && t(j) <= 1e-15) {
          passive[static_cast<std::size_t>(j)] = false;
          t(j) = 0.0;
        }
    }
  }
  return t.cwiseProduct(dinv);
}

// Calls f(Ac, bc) for each block of kLsBlock rows of A, b (no copy of A beyond one
// block): Ac, bc are the block less the column means amean, bmean if `centre` (the
// subtraction done per row, as for an explicitly centred copy: no cancellation of
// A^T A - m mu mu^T), else the block itself.
template <class F>
void for_each_block(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, bool centre, const Eigen::RowVectorXd& amean,
                    double bmean, F&& f) {
  Eigen::MatrixXd Ac;
  Eigen::VectorXd bc;
  for (Eigen::Index k0 = 0; k0 < A.rows(); k0 += kLsBlock) {
    const Eigen::Index rows = std::min(kLsBlock, A.rows() - k0);
    Ac = A.middleRows(k0, rows);
    bc = b.segment(k0, rows);
    if (centre) {
      Ac.rowwise() -= amean;
      bc.array() -= bmean;
    }
    f(Ac, bc);
  }
}

// The normal equations G = Ac^T Ac, h = Ac^T (bc - Ac lo) in one pass over A's rows
// (Ac, bc as in for_each_block).
void normal_equations(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lo, bool centre,
                      const Eigen::RowVectorXd& amean, double bmean, Eigen::MatrixXd& G, Eigen::VectorXd& h) {
  G.setZero(A.cols(), A.cols());
  h.setZero(A.cols());
  const bool shift = !lo.isZero(0.0);
  for_each_block(A, b, centre, amean, bmean, [&](const Eigen::MatrixXd& Ac, Eigen::VectorXd& bc) {
    if (shift) bc.noalias() -= Ac * lo;
    G.selfadjointView<Eigen::Lower>().rankUpdate(Ac.transpose());
    h.noalias() += Ac.transpose() * bc;
  });
  G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
}

// The residual sum of squares ||Ac t - bc||^2 (Ac, bc as in for_each_block).
double residual_sse(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& t, bool centre,
                    const Eigen::RowVectorXd& amean, double bmean) {
  double sse = 0.0;
  for_each_block(A, b, centre, amean, bmean,
                 [&](const Eigen::MatrixXd& Ac, const Eigen::VectorXd& bc) { sse += (Ac * t - bc).squaredNorm(); });
  return sse;
}

}  // namespace

Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  Eigen::MatrixXd G;
  Eigen::VectorXd h;
  normal_equations(A, b, Eigen::VectorXd::Zero(A.cols()), false, Eigen::RowVectorXd(), 0.0, G, h);
  return nnls_normal(G, h);
}

Eigen::VectorXd bounded_ls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lo,
                           double* offset, double* sse) {
  Eigen::MatrixXd G;
  Eigen::VectorXd h;
  if (!offset) {
    normal_equations(A, b, lo, false, Eigen::RowVectorXd(), 0.0, G, h);
    const Eigen::VectorXd t = lo + nnls_normal(G, h);
    if (sse) *sse = residual_sse(A, b, t, false, Eigen::RowVectorXd(), 0.0);
    return t;
  }
  const Eigen::RowVectorXd amean = A.colwise().mean();
  const double bmean = b.mean();
  normal_equations(A, b, lo, true, amean, bmean, G, h);
  const Eigen::VectorXd t = lo + nnls_normal(G, h);
  *offset = bmean - amean.dot(t);
  if (sse) *sse = residual_sse(A, b, t, true, amean, bmean);
  return t;
}

ModelParams with_weights(const ModelParams& model, const Structure<double>& s, double q, const std::vector<double>& p) {
  return std::visit(
      [&](const auto& m) -> ModelParams {
        using M = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<M, MaxwellSlipParams>) {
          // q = k0 + sum k_i, p_i = -k_i (models.hpp)
          auto out = m;
          out.delta = s.r;
          out.k.resize(p.size());
          out.k0 = q;
          for (std::size_t i = 0; i < p.size(); ++i) {
            if (p[i] > 0)
              throw Error(fmt::format("maxwell-slip: weight {} = {} > 0 has no spring (k_i = -p_i >= 0)", i, p[i]));
            out.k[i] = -p[i];
            out.k0 += p[i];
          }
          return out;
        } else if constexpr (requires { m.q; m.r; m.p; } && !std::is_same_v<M, RatePiParams>) {
          auto out = m;
          out.q = q;
          out.r = s.r;
          out.p = p;
          return out;
        } else {
          throw Error(fmt::format("{}: not linear in PI weights", model_name(m)));
        }
      },
      model);
}

}  // namespace detail

namespace {

// Cumulative-slope solution s (s_0 = q, s_i = q + p_1 + ... + p_i) -> q, p.
// Operators whose transformed column vanished on the data get p_i = 0.
// (norms: the column norms of A)
void slopes_to_weights(const Eigen::VectorXd& sl, const Eigen::VectorXd& norms, double& q, std::vector<double>& p) {
  Eigen::VectorXd s = sl;
  const double amax = norms.maxCoeff();
  for (Eigen::Index i = 1; i < s.size(); ++i)
    if (norms(i) <= 1e-12 * amax) s(i) = s(i - 1);
  q = s(0);
  p.resize(static_cast<std::size_t>(s.size() - 1));
  for (Eigen::Index i = 1; i < s.size(); ++i) p[static_cast<std::size_t>(i - 1)] = s(i) - s(i - 1);
}

double dead_zone_value(double v, double z) { return ops::dead_zone<double>(v, z); }

// Forward dead zones from the inverse map S'(y) = y + sum g'_k S_{z'_k}(y), given on one
// side by its breakpoints zs (ordered away from 0) and cumulative slopes c_1..c_J (c_0 = 1).
void invert_side(const std::vector<double>& zs, const std::vector<double>& c, std::vector<double>& z_out,
                 std::vector<double>& g_out) {
  double value = 0.0, prev_z = 0.0, prev_c = 1.0;
  for (std::size_t j = 0; j < zs.size(); ++j) {
    value += prev_c * (zs[j] - prev_z);  // S'(z'_j)
    z_out.push_back(value);
    g_out.push_back(1.0 / c[j] - 1.0 / prev_c);
    prev_z = zs[j];
    prev_c = c[j];
  }
}

// Calls f(P, k0) for each block of at most kLsBlock regressor rows (detail::regressors) of
// s over `range`, simulated one block at a time (P: rows x (n + 1), rows k0.. of the range;
// f may overwrite it). Memory: one block, not the m x (n + 1) matrix (issue 13: `fit` memory).
template <class F>
void for_each_regressor_block(const Structure<double>& s, std::span<const double> x, IndexRange range,
                              InitialState initial, F&& f) {
  const std::size_t n = s.r.size();
  Eigen::MatrixXd phi(std::min<Eigen::Index>(detail::kLsBlock, static_cast<Eigen::Index>(range.end - range.begin)),
                      static_cast<Eigen::Index>(n + 1));
  std::vector<double> y(n);
  detail::initial_operator_state(s, initial, x.empty() ? 0.0 : x[0], y);
  Eigen::Index fill = 0, k0 = 0;
  for (std::size_t k = 0; k < range.end; ++k) {
    const double um = detail::operators_step(s, x[k], y.data());
    if (k < range.begin) continue;
    phi(fill, 0) = um;
    for (std::size_t i = 0; i < n; ++i) phi(fill, static_cast<Eigen::Index>(i + 1)) = y[i];
    if (++fill == phi.rows()) {
      f(Eigen::Ref<Eigen::MatrixXd>(phi), k0);
      k0 += fill;
      fill = 0;
    }
  }
  if (fill > 0) f(Eigen::Ref<Eigen::MatrixXd>(phi.topRows(fill)), k0);
}

// fit_weights with dead zones (the mpi-deadzone's start): nnls of A = [slope columns of the
// regressors (a_i = phi_i - phi_{i+1}, a_n = phi_n), dead-zone columns] and the target rhs,
// shifted by the lower bounds, A streamed twice a block at a time (for_each_regressor_block) instead of held (phi, its slope columns
// and A: three m x (n + 1 + nz) matrices before; issue 13: `fit` memory): pass 1 the span of
// u_m (the bound's scale) and the norms of the slope columns (slopes_to_weights), pass 2 the
// normal equations of the blocks of A and rhs - A lo, as nnls forms them; the same solution
// to rounding.
ModelParams fit_deadzone_weights(const MpiDeadzoneParams& m, std::span<const double> x, std::span<const double> y,
                                 const WeightFitOptions& o, IndexRange r) {
  MpiDeadzoneParams pi_part = m;
  pi_part.z.clear();
  pi_part.g.clear();
  const Structure<double> s = canonical_structure(pi_part);
  // Inverse dead-zone thresholds in output units, reached by the data only.
  const auto [ylo, yhi] = std::minmax_element(y.begin() + static_cast<std::ptrdiff_t>(r.begin),
                                              y.begin() + static_cast<std::ptrdiff_t>(r.end));
  std::vector<double> zp, zn;
  for (double z : m.z) {
    if (!std::isfinite(z)) throw Error("fit_weights: mpi-deadzone z must be finite");
    if (z > 0 && z < *yhi) zp.push_back(z);
    if (z < 0 && z > *ylo) zn.push_back(z);
  }
  std::sort(zp.begin(), zp.end());
  zp.erase(std::unique(zp.begin(), zp.end()), zp.end());
  std::sort(zn.begin(), zn.end(), std::greater<>());
  zn.erase(std::unique(zn.begin(), zn.end()), zn.end());
  const auto npi = static_cast<Eigen::Index>(s.r.size() + 1);
  const auto nz = static_cast<Eigen::Index>(zp.size() + zn.size());
  auto to_slopes = [](Eigen::Ref<Eigen::MatrixXd> P) {  // slope columns in place (ascending: col i + 1 still phi's)
    for (Eigen::Index i = 0; i + 1 < P.cols(); ++i) P.col(i) -= P.col(i + 1);
  };
  // pass 1: the span of u_m, the norms of the slope columns
  Eigen::RowVectorXd asq = Eigen::RowVectorXd::Zero(npi);
  double umin = std::numeric_limits<double>::infinity(), umax = -umin;
  for_each_regressor_block(s, x, r, o.initial_state, [&](Eigen::Ref<Eigen::MatrixXd> P, Eigen::Index) {
    umin = std::min(umin, P.col(0).minCoeff());
    umax = std::max(umax, P.col(0).maxCoeff());
    to_slopes(P);
    asq += P.colwise().squaredNorm();
  });
  const double uspan = std::max(umax - umin, 1e-300);
  const double scale = detail::span_of(y.subspan(r.begin, r.end - r.begin)) / uspan;
  Eigen::VectorXd lo(npi + nz);
  lo.head(npi).setConstant(o.margin * scale);
  lo.tail(nz).setConstant(std::max(o.margin, 1e-9));
  // pass 2: G = A^T A, h = A^T (rhs - A lo), a block of rows of A at a time
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(npi + nz, npi + nz), A;
  Eigen::VectorXd h = Eigen::VectorXd::Zero(npi + nz), rhs;
  for_each_regressor_block(s, x, r, o.initial_state, [&](Eigen::Ref<Eigen::MatrixXd> P, Eigen::Index k0) {
    const Eigen::Index rows = P.rows();
    to_slopes(P);
    A.resize(rows, npi + nz);
    A.leftCols(npi) = P;
    rhs.resize(rows);
    for (Eigen::Index k = 0; k < rows; ++k) {
      const double yk = y[r.begin + static_cast<std::size_t>(k0 + k)];
      double b = yk;
      Eigen::Index col = npi;
      for (const std::vector<double>* side : {&zp, &zn}) {
        const std::vector<double>& zs = *side;
        for (std::size_t j = 0; j < zs.size(); ++j) {
          const double sj = dead_zone_value(yk, zs[j]);
          const double sj1 = j + 1 < zs.size() ? dead_zone_value(yk, zs[j + 1]) : 0.0;
          A(k, col++) = -(sj - sj1);
          if (j == 0) b -= sj;
        }
      }
      rhs(k) = b;
    }
    rhs.noalias() -= A * lo;
    G.selfadjointView<Eigen::Lower>().rankUpdate(A.transpose());
    h.noalias() += A.transpose() * rhs;
  });
  G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
  const Eigen::VectorXd t = detail::nnls_normal(G, h);
  const Eigen::VectorXd sol = lo + t;
  double q;
  std::vector<double> p;
  slopes_to_weights(sol.head(npi), asq.cwiseSqrt().transpose(), q, p);
  MpiDeadzoneParams out = m;
  out.q = q;
  out.r = s.r;
  out.p = p;
  out.g0 = 1.0;
  out.z.clear();
  out.g.clear();
  std::vector<double> cp(sol.data() + npi, sol.data() + npi + static_cast<Eigen::Index>(zp.size()));
  std::vector<double> cn(sol.data() + npi + static_cast<Eigen::Index>(zp.size()), sol.data() + npi + nz);
  invert_side(zp, cp, out.z, out.g);
  invert_side(zn, cn, out.z, out.g);
  return out;
}

// fit_weights without a dead zone: bounded_ls of the cumulative-slope columns A (the slope
// columns of the regressors) and target b = y over `r`, A streamed twice a block at a time
// (for_each_regressor_block) instead of held (two m x (n + 1) matrices before): pass 1
// the column sums (the means for the free offset), the column norms (slopes_to_weights)
// and the span of u_m (the bound's scale), pass 2 the normal equations of the centred
// rows, as bounded_ls forms them block by block; the same solution to rounding (the sums
// are taken in another order).
void streamed_slope_ls(const Structure<double>& s, std::span<const double> x, std::span<const double> y, IndexRange r,
                       const WeightFitOptions& options, double& q, std::vector<double>& p, double& offset) {
  const auto nc = static_cast<Eigen::Index>(s.r.size() + 1);
  const auto m = static_cast<double>(r.end - r.begin);
  const auto b_of = [&](Eigen::Index k0, Eigen::Index rows) {
    return Eigen::Map<const Eigen::VectorXd>(y.data() + r.begin + static_cast<std::size_t>(k0), rows);
  };
  // mpi-asym is invertible with q > 0 and every p_i >= 0 (its numerical inverse refuses a
  // negative weight: the output folds back), not with positive cumulative slopes: its
  // columns stay the regressors and the bounds are on q and the weights themselves.
  const bool weights = s.asymmetric;
  auto to_slopes = [weights](Eigen::Ref<Eigen::MatrixXd> P) {  // slope columns in place (ascending: col i + 1 still phi's)
    if (weights) return;
    for (Eigen::Index i = 0; i + 1 < P.cols(); ++i) P.col(i) -= P.col(i + 1);
  };
  Eigen::RowVectorXd asum = Eigen::RowVectorXd::Zero(nc), asq = Eigen::RowVectorXd::Zero(nc);
  double bsum = 0.0, umin = std::numeric_limits<double>::infinity(), umax = -umin;
  for_each_regressor_block(s, x, r, options.initial_state, [&](Eigen::Ref<Eigen::MatrixXd> P, Eigen::Index k0) {
    umin = std::min(umin, P.col(0).minCoeff());
    umax = std::max(umax, P.col(0).maxCoeff());
    to_slopes(P);
    asum += P.colwise().sum();
    asq += P.colwise().squaredNorm();
    bsum += b_of(k0, P.rows()).sum();
  });
  const double uspan = std::max(umax - umin, 1e-300);
  const double scale = detail::span_of(y.subspan(r.begin, r.end - r.begin)) / uspan;
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(nc, options.margin * scale);
  if (weights) lo.tail(nc - 1).setZero();  // mpi-asym: q >= margin * scale, p_i >= 0
  const bool centre = options.free_offset;
  const Eigen::RowVectorXd amean = centre ? Eigen::RowVectorXd(asum / m) : Eigen::RowVectorXd::Zero(nc);
  const double bmean = centre ? bsum / m : 0.0;
  // the normal equations G = Ac^T Ac, h = Ac^T (bc - Ac lo) (as detail::normal_equations)
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(nc, nc);
  Eigen::VectorXd h = Eigen::VectorXd::Zero(nc), bc;
  const bool shift = !lo.isZero(0.0);
  for_each_regressor_block(s, x, r, options.initial_state, [&](Eigen::Ref<Eigen::MatrixXd> P, Eigen::Index k0) {
    to_slopes(P);
    bc = b_of(k0, P.rows());
    if (centre) {
      P.rowwise() -= amean;
      bc.array() -= bmean;
    }
    if (shift) bc.noalias() -= P * lo;
    G.selfadjointView<Eigen::Lower>().rankUpdate(P.transpose());
    h.noalias() += P.transpose() * bc;
  });
  G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
  const Eigen::VectorXd t = lo + detail::nnls_normal(G, h);
  offset = centre ? bmean - amean.dot(t) : 0.0;
  if (weights) {
    q = t(0);
    p.assign(t.data() + 1, t.data() + nc);
    return;
  }
  slopes_to_weights(t, asq.cwiseSqrt().transpose(), q, p);
}

}  // namespace

ModelParams fit_weights(const ModelParams& model, std::span<const double> x, std::span<const double> y,
                        const WeightFitOptions& options) {
  detail::check_record(x, y, "fit_weights");
  const IndexRange r = detail::check_range(options.train, x.size(), "fit_weights");
  if (!(options.margin >= 0) || !std::isfinite(options.margin)) throw Error("fit_weights: margin must be >= 0");
  {  // a constant input leaves the weights undetermined (q came out near 1e294)
    const auto [lo, hi] = std::minmax_element(x.begin() + static_cast<std::ptrdiff_t>(r.begin),
                                              x.begin() + static_cast<std::ptrdiff_t>(r.end));
    if (!(*hi > *lo)) throw Error(fmt::format("fit_weights: the input is constant ({}) over the training range", *lo));
  }
  const UnitsMap um = units_map(model);
  if (!um.identity()) {
    // Work in model coordinates and keep the units map (models.hpp).
    std::vector<double> xm(x.size()), ym(y.size());
    for (std::size_t k = 0; k < x.size(); ++k) xm[k] = um.to_model(x[k]), ym[k] = um.model_output(y[k]);
    ModelParams core = model;
    units_map(core) = UnitsMap{};
    ModelParams out = fit_weights(core, xm, ym, options);
    const double c = units_map(out).output_offset;  // the free offset, in model output units
    units_map(out) = um;
    units_map(out).output_offset = um.output(c);
    return out;
  }
  if (const auto* dz = std::get_if<MpiDeadzoneParams>(&model)) return fit_deadzone_weights(*dz, x, y, options, r);
  const Structure<double> s = canonical_structure(model);
  double q, offset;
  std::vector<double> p;
  streamed_slope_ls(s, x, y, r, options, q, p, offset);
  ModelParams out = detail::with_weights(model, s, q, p);
  units_map(out).output_offset = offset;
  return out;
}

// ---- Rls ------------------------------------------------------------------------

Rls::Rls(const ModelParams& model, double lambda, double p0)
    : model_(model), s_(canonical_structure(model)), lambda_(lambda) {
  if (s_.has_dead_zones)
    throw Error("rls: mpi-deadzone is not linear in its weights (use fit_weights or fit)");
  if (!(lambda > 0 && lambda <= 1)) throw Error(fmt::format("rls: lambda must be in (0, 1], got {}", lambda));
  if (!(p0 > 0) || !std::isfinite(p0)) throw Error(fmt::format("rls: p0 must be > 0, got {}", p0));
  const std::size_t n = s_.r.size();
  const auto m = static_cast<Eigen::Index>(n + 1);
  y_.assign(n, 0.0);
  theta_.resize(m);
  theta_(0) = s_.q;
  for (std::size_t i = 0; i < n; ++i) theta_(static_cast<Eigen::Index>(i + 1)) = s_.p[i];
  phi_ = Eigen::VectorXd::Zero(m);
  Pphi_ = Eigen::VectorXd::Zero(m);
  P_ = Eigen::MatrixXd::Identity(m, m) * p0;
  P0_ = P_;
  cap_ = P0_.trace();
}

void Rls::reset_state(InitialState initial, double x0) noexcept {
  double v = 0.0;
  if (initial == InitialState::relaxed) v = envelope_value<double>(s_.asc_kind, s_.asc_c.data(), s_.units.to_model(x0));
  if (!std::isfinite(v)) v = 0.0;
  std::fill(y_.begin(), y_.end(), v);
}

double Rls::step(double x, double y) noexcept {
  if (!std::isfinite(x) || !std::isfinite(y)) {
    ++faults_;
    return last_;
  }
  const double pr = step_model(s_.to_model(x), s_.model_output(y));
  return last_ = s_.units.output(pr);
}

double Rls::step_model(double x, double y) noexcept {
  double u_a = envelope_value<double>(s_.asc_kind, s_.asc_c.data(), x);
  double u_d = s_.asymmetric ? envelope_value<double>(s_.desc_kind, s_.desc_c.data(), x) : u_a;
  const std::size_t n = y_.size();
  phi_(0) = 0.5 * (u_a + u_d);
  for (std::size_t i = 0; i < n; ++i) {
    y_[i] = s_.asymmetric ? ops::asymmetric_play<double>(u_a, u_d, s_.r[i], y_[i])
                          : ops::generalized_play<double>(u_a, s_.r[i], y_[i]);
    phi_(static_cast<Eigen::Index>(i + 1)) = y_[i];
  }
  const double pred = theta_.dot(phi_);
  const double e = y - pred;
  if (!std::isfinite(e)) {
    ++faults_;
    return pred;
  }
  const detail::RlsMatrices a{P_.data(), nullptr, P0_.data(), nullptr, Pphi_.data(),
                              static_cast<std::size_t>(P_.rows()), cap_};
  double gain = 0.0;
  switch (detail::rls_covariance_step(a, phi_.data(), lambda_, gain)) {
    case detail::RlsOutcome::standard: break;
    case detail::RlsOutcome::bounded: ++bounded_; break;
    case detail::RlsOutcome::reset: ++resets_; ++faults_; break;
    case detail::RlsOutcome::skipped: ++faults_; break;
  }
  theta_ += Pphi_ * (gain * e);
  return pred;
}

ModelParams Rls::params() const {
  std::vector<double> p(static_cast<std::size_t>(theta_.size() - 1));
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = theta_(static_cast<Eigen::Index>(i + 1));
  ModelParams out = detail::with_weights(model_, s_, theta_(0), p);
  // RLS does not constrain its estimate (the adaptive inverse projects its own): an estimate
  // the kind refuses (gpi q <= 0 on the Festo record, issue: rls_fit returned q = -0.797 that
  // Model() then refused) is said here, not handed on.
  try {
    validate_model(out);
  } catch (const Error& e) {
    throw Error(fmt::format("rls: the estimated weights make no valid {} model ({}); RLS does not constrain "
                            "them: use fit_weights (bounded) or fit, or a record that excites every operator",
                            model_name(model_), e.what()));
  }
  return out;
}

ModelParams rls_fit(const ModelParams& model, std::span<const double> x, std::span<const double> y, double lambda,
                    int passes, InitialState initial) {
  detail::check_record(x, y, "rls_fit");
  if (passes < 1 || passes > 10000) throw Error(fmt::format("rls_fit: passes must be in 1..10000, got {}", passes));
  Rls rls(model, lambda);
  for (int pass = 0; pass < passes; ++pass) {
    rls.reset_state(initial, x[0]);
    for (std::size_t k = 0; k < x.size(); ++k) rls.step(x[k], y[k]);
  }
  return rls.params();
}

}  // namespace hysteron
