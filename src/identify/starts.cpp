// Data-derived initial guesses of the LM fits: the loop's branches and centre line,
// tanh envelope fits, weights by constrained least squares on a decimated record, and
// the ranking of candidate starts by their error.
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "fit_internal.hpp"
#include "hysteron/error.hpp"

namespace hysteron::fitting {

namespace {

// decimate(): the screening of start candidates runs on about kDecimatedSamples samples
// (the operators are rate independent, so the ranking is nearly that of the full record).
constexpr std::size_t kDecimatedSamples = 2500;
// The alpha grid of the starts: kAlphas threshold spacings, log-spaced from
// kAlphaLow to kAlphaLow kAlphaRatio (gpi, gpi free weights; mpi-asym: kAsymAlphaRatio) times half
// the envelope-output span over n: from nearly linear to thresholds past the span.
constexpr int kAlphas = 14;
constexpr double kAlphaLow = 0.01;
constexpr double kAlphaRatio = 250.0;  // kAlphaLow .. 2.5
// mpi-asym: up to 1 (its thresholds act on both envelopes, whose gap already carries
// the loop width).
constexpr double kAsymAlphaRatio = 100.0;  // kAlphaLow .. 1
// loop_branches(): input bins of the branch and centre-line curves (enough points for a
// 4-coefficient tanh fit, few enough to average the noise of each bin).
constexpr int kBranchBins = 32;
// loop_branches(): a turning point needs the input to move back by this fraction of its
// span (noise does not flip the direction).
constexpr double kTurnFraction = 0.01;
// fit_tanh(): the curvature grid a = c1 xs (log-spaced kTanhSlopes points over
// kTanhSlopeLow .. kTanhSlopeLow * kTanhSlopeRatio), the shift grid b = kTanhShiftStep i,
// |i| <= kTanhShifts, and kTanhGaussNewton Gauss-Newton steps after it.
constexpr int kTanhSlopes = 24;
constexpr double kTanhSlopeLow = 0.05;
constexpr double kTanhSlopeRatio = 100.0;
constexpr int kTanhShifts = 24;
constexpr double kTanhShiftStep = 0.125;
constexpr int kTanhGaussNewton = 20;
// gpi_envelopes(): fixed curvatures a = c1 xs of the extra envelope starts (multi-start
// over the envelope shape: nearly linear to strongly saturating).
constexpr double kEnvelopeCurvatures[] = {0.25, 0.6, 1.2, 2.5};
// fit_tau(): weights below this fraction of the largest are left out of log p_i.
constexpr double kTauWeightFloor = 1e-6;
// gpi_starts(): tau candidates kTauLow / (alpha n) (nearly constant weights) and
// kTauHigh / (alpha n) (decaying over the threshold range), besides the fitted one.
constexpr double kTauLow = 1e-3;
constexpr double kTauHigh = 1.0;
// gpi_starts(): relative jitter of alpha with FitOptions::seed != 0.
constexpr double kAlphaJitter = 0.1;

}  // namespace

Ranges ranges_of(const Data& d) {
  const auto xs = d.x.subspan(d.train.begin, d.train.end - d.train.begin);
  const auto ys = d.y.subspan(d.train.begin, d.train.end - d.train.begin);
  const auto [xl, xh] = std::minmax_element(xs.begin(), xs.end());
  const auto [yl, yh] = std::minmax_element(ys.begin(), ys.end());
  return {*xl, *xh, *yl, *yh};
}

namespace {

// A start candidate's structure: tanh envelopes (ascending a, descending b; the same
// for a symmetric model), thresholds r_i = alpha i (i = 1..n), weights to be solved.
Structure<double> candidate_structure(const std::array<double, 4>& a, const std::array<double, 4>& b, bool asymmetric,
                                      double alpha, int n) {
  Structure<double> s;
  s.asc_kind = s.desc_kind = EnvelopeKind::tanh;
  s.asymmetric = asymmetric;
  s.asc_c = a;
  s.desc_c = b;
  for (int i = 1; i <= n; ++i) s.r.push_back(alpha * i);
  s.p.assign(s.r.size(), 0.0);
  return s;
}

// For fixed envelope, alpha and tau the gpi output is linear in (q, rho): solve
// them by NNLS (with the free offset when d.free_offset) and return the sum of
// squared errors.
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
  double sse = 0, offset = 0;
  const Eigen::VectorXd t = detail::bounded_ls(A, b, lo, d.free_offset ? &offset : nullptr, &sse);
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
  const double eps = kTurnFraction * rg.xspan();
  std::vector<double> sx[2], sy[2], cnt[2];
  for (int b = 0; b < 2; ++b) sx[b].assign(kBranchBins, 0.0), sy[b].assign(kBranchBins, 0.0), cnt[b].assign(kBranchBins, 0.0);
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
    const int b = std::clamp(static_cast<int>((xk - rg.xlo) / rg.xspan() * kBranchBins), 0, kBranchBins - 1);
    const auto bi = static_cast<std::size_t>(b);
    sx[side][bi] += xk;
    sy[side][bi] += d.y[k];
    cnt[side][bi] += 1;
  }
  Branches out;
  for (std::size_t b = 0; b < kBranchBins; ++b) {
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
  for (int ia = 0; ia < (a_fixed > 0 ? 1 : kTanhSlopes); ++ia) {
    const double a = a_fixed > 0 ? a_fixed : kTanhSlopeLow * std::pow(kTanhSlopeRatio, ia / (kTanhSlopes - 1.0));  // 0.05 .. 5
    for (int ib = -kTanhShifts; ib <= kTanhShifts; ++ib) {
      const double b = kTanhShiftStep * ib;
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
  for (int it = 0; it < kTanhGaussNewton && std::isfinite(best_sse) && !(a_fixed > 0); ++it) {
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

}  // namespace

// Envelope output span over the input range.
double envelope_span(const std::array<double, 4>& c, const Ranges& rg) {
  return std::abs(c[0] * (std::tanh(c[1] * rg.xhi + c[2]) - std::tanh(c[1] * rg.xlo + c[2])));
}

namespace {

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
  double sse = 0, offset = 0;
  const Eigen::VectorXd sl = detail::bounded_ls(A, b, lo, d.free_offset ? &offset : nullptr, &sse);
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
    if (!(p[i] > kTauWeightFloor * pmax)) continue;
    const double w = p[i], ly = std::log(p[i]);
    sw += w, sx += w * r[i], sy += w * ly, sxx += w * r[i] * r[i], sxy += w * r[i] * ly;
  }
  const double det = sw * sxx - sx * sx;
  if (!(sw > 0) || !(det > 1e-14 * sw * sxx)) return std::numeric_limits<double>::quiet_NaN();
  return -(sw * sxy - sx * sy) / det;
}

// Reversals of the input over [begin, end) taken every `step`-th sample: direction changes by
// more than `band` (each counted once).
std::size_t count_reversals(std::span<const double> x, std::size_t begin, std::size_t end, std::size_t step,
                            double band) {
  if (begin >= end) return 0;
  std::size_t n = 0;
  int dir = 0;
  double lo = x[begin], hi = x[begin];  // the extreme since the last reversal
  for (std::size_t k = begin; k < end; k += step) {
    const double v = x[k];
    if (dir >= 0 && v > hi) hi = v;
    if (dir <= 0 && v < lo) lo = v;
    if (dir >= 0 && v < hi - band) {  // falling from hi
      n += dir > 0;
      dir = -1;
      lo = v;
    } else if (dir <= 0 && v > lo + band) {  // rising from lo
      n += dir < 0;
      dir = 1;
      hi = v;
    }
  }
  return n;
}

// The record decimated to about 2500 samples for the screening of start candidates; the
// operators are rate independent, so the ranking is nearly that of the full record at 1/s of
// the cost. Every s-th sample from the start, unless that loses the input's reversals (a long
// periodic record whose period divides s: the strided input is constant, and no start survived;
// or aliased into fewer, smaller loops): then each block of 2 s samples gives its least and its
// largest input, in order, which keeps every reversal wider than a block.
struct Decimated {
  std::vector<double> x, y;
  Data d;
};
Decimated decimate(const Data& d) {
  const std::size_t m = d.train.end - d.train.begin;
  const std::size_t st = std::max<std::size_t>(1, m / kDecimatedSamples);
  Decimated out;
  IndexRange tr;
  bool strided = true;
  if (st > 1) {
    const auto [lo, hi] = std::minmax_element(d.x.begin() + static_cast<std::ptrdiff_t>(d.train.begin),
                                              d.x.begin() + static_cast<std::ptrdiff_t>(d.train.end));
    const double band = 0.1 * (*hi - *lo);
    const std::size_t first = (d.train.begin + st - 1) / st * st;  // the first strided sample in the range
    double slo = std::numeric_limits<double>::infinity(), shi = -slo;
    for (std::size_t k = first; k < d.train.end; k += st) slo = std::min(slo, d.x[k]), shi = std::max(shi, d.x[k]);
    const std::size_t full = count_reversals(d.x, d.train.begin, d.train.end, 1, band);
    const std::size_t kept = count_reversals(d.x, first, d.train.end, st, band);
    strided = !(shi - slo < 0.9 * (*hi - *lo)) && 2 * kept >= full;
  }
  if (strided) {
    for (std::size_t k = 0; k < d.train.end; k += st) out.x.push_back(d.x[k]), out.y.push_back(d.y[k]);
    tr = {(d.train.begin + st - 1) / st, out.x.size()};
  } else {
    const std::size_t b = 2 * st;
    std::size_t begin_out = 0;
    for (const auto& [from, to] : {std::pair{std::size_t{0}, d.train.begin}, std::pair{d.train.begin, d.train.end}}) {
      if (from == d.train.begin) begin_out = out.x.size();
      for (std::size_t k = from; k < to; k += b) {
        const std::size_t e = std::min(to, k + b);
        std::size_t imin = k, imax = k;
        for (std::size_t i = k; i < e; ++i) {
          if (d.x[i] < d.x[imin]) imin = i;
          if (d.x[i] > d.x[imax]) imax = i;
        }
        for (const std::size_t i : {std::min(imin, imax), std::max(imin, imax)}) {
          out.x.push_back(d.x[i]);
          out.y.push_back(d.y[i]);
          if (imin == imax) break;
        }
      }
    }
    tr = {begin_out, out.x.size()};
  }
  out.d = d;
  out.d.x = out.x;
  out.d.y = out.y;
  out.d.train = tr;
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
  for (double a : kEnvelopeCurvatures) envs.push_back(fit_tanh(centre, rg, a));
  return envs;
}

// A candidate start of a slope layout, ranked by the SSE of its constrained LS weights.
struct SlopeCand {
  double sse;
  SlopeLayout layout;
  std::vector<double> th;
};

// The best num_starts candidates (lowest SSE first) appended to layouts and starts.
void take_best(std::vector<SlopeCand>& cands, const FitOptions& o, std::vector<SlopeLayout>& layouts,
               std::vector<std::vector<double>>& starts) {
  std::sort(cands.begin(), cands.end(), [](const SlopeCand& x, const SlopeCand& y) { return x.sse < y.sse; });
  for (std::size_t k = 0; k < cands.size() && static_cast<int>(k) < o.num_starts; ++k) {
    layouts.push_back(cands[k].layout);
    starts.push_back(cands[k].th);
  }
}

}  // namespace

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
  auto j = [&](double v) { return o.seed == 0 ? v : v * (1.0 + detail::uniform_draw(rng, -kAlphaJitter, kAlphaJitter)); };
  struct Cand {
    double sse;
    std::vector<double> th;
  };
  std::vector<Cand> cands;
  const double margin = lb_rel;
  for (const auto& env : envs)
  for (int ia = 0; ia < kAlphas; ++ia) {
    const double U = envelope_span(env, rg);
    const double f = kAlphaLow * std::pow(kAlphaRatio, ia / (kAlphas - 1.0));  // 0.01 .. 2.5
    const double alpha = j(f) * 0.5 * U / n;
    const Structure<double> s = candidate_structure(env, env, false, alpha, n);
    double q = 1;
    std::vector<double> p;
    cls_weights(d, s, margin, q, p);
    const double tf = fit_tau(s.r, p);
    std::vector<double> taus{kTauLow / (alpha * n), kTauHigh / (alpha * n)};
    if (std::isfinite(tf)) taus.push_back(std::max(tf, kTauLow / (alpha * n)));
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
  std::vector<SlopeCand> cands;
  const std::pair<std::array<double, 4>, std::array<double, 4>> pairs[2] = {{ea, ed}, {ce, ce}};
  for (const auto& [a, b] : pairs) {
    const double U = 0.5 * (envelope_span(a, rg) + envelope_span(b, rg));
    const double scale = rg.yspan() / std::max(U, 1e-300);
    for (int ia = 0; ia < kAlphas; ++ia) {
      const double alpha = kAlphaLow * std::pow(kAsymAlphaRatio, ia / (kAlphas - 1.0)) * 0.5 * U / n;
      const Structure<double> s = candidate_structure(a, b, true, alpha, n);
      double q = 1;
      std::vector<double> p;
      const double sse = cls_weights(d, s, margin * scale, q, p);
      if (!std::isfinite(sse)) continue;
      SlopeCand c{sse, {}, {}};
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
  take_best(cands, o, layouts, starts);
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
  std::vector<SlopeCand> cands;
  for (const auto& env : gpi_envelopes(d, rg)) {
    const double U = envelope_span(env, rg);
    const double scale = rg.yspan() / std::max(U, 1e-300);
    for (int ia = 0; ia < kAlphas; ++ia) {
      const double alpha = kAlphaLow * std::pow(kAlphaRatio, ia / (kAlphas - 1.0)) * 0.5 * U / n;
      const Structure<double> s = candidate_structure(env, env, false, alpha, n);
      double q = 1;
      std::vector<double> p;
      const double sse = cls_weights(d, s, margin * scale, q, p);
      if (!std::isfinite(sse)) continue;
      SlopeCand c{sse, {}, {}};
      c.layout.kind = FitModel::gpi;
      c.layout.env = 4;
      c.layout.r = s.r;
      c.th.assign(env.begin(), env.end());
      const auto sl = slopes(q, p);
      c.th.insert(c.th.end(), sl.begin(), sl.end());
      cands.push_back(std::move(c));
    }
  }
  take_best(cands, o, layouts, starts);
  if (starts.empty()) throw Error("fit: gpi (free weights): no usable start");
}

}  // namespace hysteron::fitting

namespace hysteron {

std::vector<double> default_thresholds(std::span<const double> x, int n) {
  const double span = detail::span_of(x);
  std::vector<double> r;
  for (int i = 1; i < n; ++i) r.push_back(i * span / (2.0 * n));
  return r;
}


}  // namespace hysteron
