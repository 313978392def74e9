// Kernels of preisach, kp, bouc-wen and rate-pi (see kernels.hpp, models.hpp).
#include "kernels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <variant>
#include <vector>

#include "format.hpp"
#include "hysteron/error.hpp"
#include "validate.hpp"

namespace hysteron::detail {

namespace {

inline double unit_ramp(double s) noexcept { return s <= 0.0 ? 0.0 : s >= 1.0 ? 1.0 : s; }

// ---- Preisach grid (shared by the relay and the ramp kernels) ------------------------

struct Grid {
  double q = 0.0;
  int n = 0;               // levels
  double h = 1.0;          // cell width
  std::vector<double> t;   // t_0..t_n
  std::vector<double> w;   // row-major triangle, w[i (i + 1) / 2 + j]

  Grid(const PreisachGrid& g, std::string_view model) {
    require_finite(g.q, model, "q");
    require_finite(g.lo, model, "lo");
    require_finite(g.hi, model, "hi");
    check_limits(g.input_limits, model);
    if (g.levels < 1 || g.levels > max_preisach_levels)
      throw Error(detail::format("{}: levels must be in 1..{}, got {}", model, max_preisach_levels, g.levels));
    if (!(g.lo < g.hi)) throw Error(detail::format("{}: the grid needs lo < hi, got [{}, {}]", model, g.lo, g.hi));
    n = g.levels;
    const std::size_t nw = static_cast<std::size_t>(n) * static_cast<std::size_t>(n + 1) / 2;
    if (g.w.size() != nw)
      throw Error(detail::format("{}: w has {} entries; a grid of {} levels has levels (levels + 1) / 2 = {} hysterons",
                                 model, g.w.size(), n, nw));
    for (std::size_t k = 0; k < nw; ++k) require_finite(g.w[k], model, detail::format("w[{}]", k));
    q = g.q;
    h = (g.hi - g.lo) / n;
    if (!(h > 0) || !std::isfinite(h)) throw Error(detail::format("{}: the grid cell (hi - lo) / levels = {} is not usable", model, h));
    t.resize(static_cast<std::size_t>(n) + 1);
    for (int k = 0; k <= n; ++k) t[static_cast<std::size_t>(k)] = g.lo + k * h;
    t.back() = g.hi;
    w = g.w;
  }
  static std::size_t row(int i) { return static_cast<std::size_t>(i) * static_cast<std::size_t>(i + 1) / 2; }
  // |q x + sum w_k b_k| with every b_k in [0, 1] (relays, ramps); x - t_k within 2 max(|x|, 1) + |t_k|
  double amplification() const noexcept {
    double a = 2.0 + std::abs(q) + std::max(std::abs(t.front()), std::abs(t.back()));
    for (double wk : w) a += std::abs(wk);
    return a;
  }
  std::string invertibility() const {
    if (!(q > 0)) return detail::format("q = {} must be > 0 (the output must rise between switching thresholds)", q);
    for (std::size_t k = 0; k < w.size(); ++k)
      if (w[k] < 0) return detail::format("w[{}] = {} must be >= 0 (a negative hysteron makes the output fall)", k, w[k]);
    return {};
  }
};

// Relays: per row i (alpha_i = t_{i+1}) the number b_i of relays on (those with the
// lowest beta: a relay with a lower beta is switched off later); prefix sums of the
// row's weights give the output in O(levels).
class PreisachKernel final : public Kernel {
 public:
  explicit PreisachKernel(const PreisachParams& p) : g_(p, "preisach") {
    const int n = g_.n;
    off_.resize(static_cast<std::size_t>(n));
    std::size_t o = 0;
    for (int i = 0; i < n; ++i) {
      off_[static_cast<std::size_t>(i)] = o;
      o += static_cast<std::size_t>(i) + 2;
    }
    c_.assign(o, 0.0);
    for (int i = 0; i < n; ++i) {
      double s = 0.0;
      for (int j = 0; j <= i; ++j) {
        s += g_.w[Grid::row(i) + static_cast<std::size_t>(j)];
        c_[off_[static_cast<std::size_t>(i)] + static_cast<std::size_t>(j) + 1] = s;
      }
    }
    b_.assign(static_cast<std::size_t>(n), 0);
    reset();
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<PreisachKernel>(*this); }
  void reset() noexcept override { reset_relaxed(0.0); }
  void reset_relaxed(double x) noexcept override {
    const double* t = g_.t.data();
    for (int i = 0; i < g_.n; ++i) {
      if (t[i + 1] <= x) {
        b_[static_cast<std::size_t>(i)] = i + 1;
      } else {  // on iff (alpha + beta) / 2 <= x
        const double v = 2 * x - t[i + 1];
        b_[static_cast<std::size_t>(i)] = static_cast<int>(std::upper_bound(t, t + i + 1, v) - t);
      }
    }
  }
  double peek(double x) const noexcept override { return eval<false>(*this, x); }
  double step(double x) noexcept override { return eval<true>(*this, x); }
  std::size_t state_size() const noexcept override { return b_.size(); }
  void get_state(double* out) const noexcept override {
    for (std::size_t i = 0; i < b_.size(); ++i) out[i] = b_[i];
  }
  void set_state(const double* in, double /*x_max: the states are bounded by construction*/) override {
    for (std::size_t i = 0; i < b_.size(); ++i)
      if (!(in[i] >= 0 && in[i] <= static_cast<double>(i + 1) && in[i] == std::floor(in[i])))
        throw Error(detail::format("preisach: state[{}] = {} must be an integer count of relays on in 0..{}", i, in[i], i + 1));
    for (std::size_t i = 0; i < b_.size(); ++i) b_[i] = static_cast<int>(in[i]);
  }
  std::string invertibility() const override { return g_.invertibility(); }
  double min_slope() const noexcept override { return g_.q; }
  double amplification() const noexcept override { return g_.amplification(); }
  std::size_t num_features() const noexcept override { return g_.w.size() + 1; }
  void features(double x, double* out) const noexcept override {
    out[0] = x;
    std::size_t k = 1;
    for (int i = 0; i < g_.n; ++i)
      for (int j = 0; j <= i; ++j) out[k++] = j < b_[static_cast<std::size_t>(i)] ? 1.0 : 0.0;
  }

 private:
  // Self = const PreisachKernel for peek (Commit = false: no write is instantiated).
  template <bool Commit, class Self>
  static double eval(Self& k, double x) noexcept {
    const double* t = k.g_.t.data();
    const int n = k.g_.n;
    // rows with alpha_i = t_{i+1} <= x switch fully on; in the others the relays with
    // beta_j = t_j >= x switch off (J = number of t_j < x).
    const int up = static_cast<int>(std::upper_bound(t + 1, t + n + 1, x) - (t + 1));
    const int lim = static_cast<int>(std::lower_bound(t, t + n, x) - t);
    double s = 0.0;
    for (int i = 0; i < n; ++i) {
      const int b = i < up ? i + 1 : std::min(k.b_[static_cast<std::size_t>(i)], lim);
      if constexpr (Commit) k.b_[static_cast<std::size_t>(i)] = b;
      s += k.c_[k.off_[static_cast<std::size_t>(i)] + static_cast<std::size_t>(b)];
    }
    return k.g_.q * x + s;
  }

  Grid g_;
  std::vector<std::size_t> off_;
  std::vector<double> c_;
  std::vector<int> b_;
};

// Ramp hysterons: R_ij = max(s_i, min(s_j, R_ij)), s_k = clamp((x - t_k) / h, 0, 1).
class KpKernel final : public Kernel {
 public:
  explicit KpKernel(const KpParams& p) : g_(p, "kp") {
    y_.assign(g_.w.size(), 0.0);
    reset();
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<KpKernel>(*this); }
  void reset() noexcept override { reset_relaxed(0.0); }
  // A decaying oscillation x +- A around x: the ramp (i, j) is pushed up to s_i(x + A) at each
  // peak and down to s_j(x - A) at each trough, until the two meet, at A = (t_i - t_j) / 2
  // where unsaturated: it is left at s((x - (t_i + t_j) / 2) / h), 1/2 at (alpha_i + beta_j) / 2
  // = (t_i + t_j + h) / 2 as the relay's switch (PreisachKernel::reset_relaxed), and mirrored
  // with the input (x -> -x, R -> 1 - R maps ramp (i, j) to ramp (L-1-j, L-1-i)). It lies in
  // [s_i(x), s_j(x)] by construction. (It was centred at (t_i + t_j) / 2, half a cell low: a
  // kp fit was not equivariant to the input's sign on a record starting inside the grid.)
  void reset_relaxed(double x) noexcept override {
    const double* t = g_.t.data();
    for (int i = 0; i < g_.n; ++i)
      for (int j = 0; j <= i; ++j) {
        const double lo = unit_ramp((x - t[i]) / g_.h), hi = unit_ramp((x - t[j]) / g_.h);
        const double mid = unit_ramp((x - 0.5 * (t[i] + t[j])) / g_.h);
        y_[Grid::row(i) + static_cast<std::size_t>(j)] = std::clamp(mid, lo, hi);
      }
  }
  double peek(double x) const noexcept override { return eval<false>(*this, x); }
  double step(double x) noexcept override { return eval<true>(*this, x); }
  std::size_t state_size() const noexcept override { return y_.size(); }
  void get_state(double* out) const noexcept override { std::copy(y_.begin(), y_.end(), out); }
  void set_state(const double* in, double /*x_max: the states are bounded by construction*/) override {
    for (std::size_t k = 0; k < y_.size(); ++k)
      if (!(in[k] >= 0 && in[k] <= 1)) throw Error(detail::format("kp: state[{}] = {} must be in [0, 1]", k, in[k]));
    std::copy(in, in + y_.size(), y_.begin());
  }
  std::string invertibility() const override { return g_.invertibility(); }
  double min_slope() const noexcept override { return g_.q; }
  double amplification() const noexcept override { return g_.amplification(); }
  std::size_t num_features() const noexcept override { return y_.size() + 1; }
  void features(double x, double* out) const noexcept override {
    out[0] = x;
    std::copy(y_.begin(), y_.end(), out + 1);
  }

 private:
  // Self = const KpKernel for peek (Commit = false: no write is instantiated).
  template <bool Commit, class Self>
  static double eval(Self& k, double x) noexcept {
    const double* t = k.g_.t.data();
    const int n = k.g_.n;
    const double ih = 1.0 / k.g_.h;
    double s[max_preisach_levels];  // s_j = ramp position of threshold t_j (levels <= max, validated)
    for (int j = 0; j < n; ++j) s[j] = unit_ramp((x - t[j]) * ih);
    const double* w = k.g_.w.data();
    auto* y = k.y_.data();
    double sum = 0.0;
    std::size_t idx = 0;
    for (int i = 0; i < n; ++i) {
      const double si = s[i];
      for (int j = 0; j <= i; ++j, ++idx) {
        const double v = std::max(si, std::min(s[j], y[idx]));
        if constexpr (Commit) y[idx] = v;
        sum += w[idx] * v;
      }
    }
    return k.g_.q * x + sum;
  }

  Grid g_;
  std::vector<double> y_;
};

// ---- Bouc-Wen ---------------------------------------------------------------------

class BoucWenKernel final : public Kernel {
 public:
  explicit BoucWenKernel(const BoucWenParams& p) : p_(p) {
    for (auto [v, k] : {std::pair{p.kx, "kx"}, {p.kw, "kw"}, {p.rho, "rho"}, {p.sigma, "sigma"}, {p.n, "n"}})
      require_finite(v, "bouc-wen", k);
    check_limits(p.input_limits, "bouc-wen");
    if (!(p.rho > 0)) throw Error(detail::format("bouc-wen: rho must be > 0, got {}", p.rho));
    if (!(p.sigma >= 0)) throw Error(detail::format("bouc-wen: sigma must be >= 0 (otherwise w leaves [-1, 1]), got {}", p.sigma));
    if (!(p.n >= 1 && p.n <= 20)) throw Error(detail::format("bouc-wen: n must be in [1, 20], got {}", p.n));
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<BoucWenKernel>(*this); }
  void reset() noexcept override { reset_relaxed(0.0); }
  void reset_relaxed(double x) noexcept override {
    x_ = x;
    w_ = 0.0;
  }
  double peek(double x) const noexcept override { return p_.kx * x + p_.kw * next_w(x); }
  double step(double x) noexcept override {
    w_ = next_w(x);
    x_ = x;
    return p_.kx * x + p_.kw * w_;
  }
  std::size_t state_size() const noexcept override { return 2; }
  void get_state(double* out) const noexcept override {
    out[0] = x_;
    out[1] = w_;
  }
  void set_state(const double* in, double x_max) override {
    if (!(std::abs(in[0]) <= x_max))
      throw Error(detail::format("bouc-wen: state[0] (last input) = {} must be finite and within the input bound {}", in[0],
                                 x_max));
    if (!(in[1] >= -1 && in[1] <= 1)) throw Error(detail::format("bouc-wen: state[1] = w = {} must be in [-1, 1]", in[1]));
    x_ = in[0];
    w_ = in[1];
  }
  // slope kx + kw dw/dx with dw/dx in [0, rho max(1, 2 sigma)] for |w| <= 1
  double min_slope() const noexcept override { return p_.kx + std::min(p_.kw, 0.0) * bouc_wen_max_dwdx(p_.rho, p_.sigma); }
  // |kx x + kw w| with |w| <= 1; the increment x - x_ within 2 max(|x|, 1)
  double amplification() const noexcept override { return 2.0 + std::abs(p_.kx) + std::abs(p_.kw); }
  std::string invertibility() const override {
    const double smin = min_slope();
    if (!(smin > 0))
      return detail::format("kx + min(kw, 0) rho max(1, 2 sigma) = {} must be > 0 (the output must rise with the "
                            "input on every branch)", smin);
    return {};
  }

 private:
  double next_w(double x) const noexcept {
    return bouc_wen_increment<double>(w_, x - x_, p_.rho, p_.sigma, p_.n, [](double v) { return v; });
  }

  BoucWenParams p_;
  double x_ = 0.0, w_ = 0.0;
};

// ---- rate-dependent PI -----------------------------------------------------------

class RatePiKernel final : public Kernel {
 public:
  explicit RatePiKernel(const RatePiParams& p) : p_(p) {
    require_finite(p.q, "rate-pi", "q");
    for (auto [v, k] : {std::pair{p.c, "c"}, {p.tau, "tau"}, {p.dt, "dt"}}) require_finite(v, "rate-pi", k);
    check_limits(p.input_limits, "rate-pi");
    if (p.r.size() != p.p.size())
      throw Error(detail::format("rate-pi: r has {} entries but p has {} (one weight per threshold)", p.r.size(), p.p.size()));
    if (p.r.size() > max_operators)
      throw Error(detail::format("rate-pi: r has {} entries; at most {} operators are supported", p.r.size(), max_operators));
    for (std::size_t i = 0; i < p.r.size(); ++i) {
      require_finite(p.r[i], "rate-pi", detail::format("r[{}]", i));
      require_finite(p.p[i], "rate-pi", detail::format("p[{}]", i));
      if (p.r[i] < 0) throw Error(detail::format("rate-pi: r[{}] = {} must be >= 0", i, p.r[i]));
    }
    if (!(p.c >= 0)) throw Error(detail::format("rate-pi: c must be >= 0 (thresholds grow with the rate), got {}", p.c));
    if (!(p.tau >= 0)) throw Error(detail::format("rate-pi: tau must be >= 0 [s], got {}", p.tau));
    if (!(p.dt > 0)) throw Error(detail::format("rate-pi: dt must be > 0 [s], got {}", p.dt));
    if (p.r.empty() && p.q == 0.0) throw Error("rate-pi: the model has no operator and q = 0 (output is constant)");
    // A threshold must move slower than the input: r_i c d(rate) <= (tau + dt) / 2 per
    // unit of input step, otherwise the output depends discontinuously on the past and
    // an inverse amplifies rounding from sample to sample.
    const double rmax = p.r.empty() ? 0.0 : *std::max_element(p.r.begin(), p.r.end());
    if (p.c * rmax > 0.5 * (p.tau + p.dt))
      throw Error(detail::format("rate-pi: c max(r) = {} must be <= (tau + dt) / 2 = {} (a threshold must move slower "
                                 "than the input)", p.c * rmax, 0.5 * (p.tau + p.dt)));
    y_.assign(p.r.size(), 0.0);
    gain_ = p.dt / (p.tau + p.dt);
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<RatePiKernel>(*this); }
  void reset() noexcept override { reset_relaxed(0.0); }
  void reset_relaxed(double x) noexcept override {
    std::fill(y_.begin(), y_.end(), x);
    x_ = x;
    rate_ = 0.0;
  }
  double peek(double x) const noexcept override {
    const double f = 1.0 + p_.c * rate_;
    double s = 0.0;
    for (std::size_t i = 0; i < y_.size(); ++i) {
      const double r = p_.r[i] * f;
      s += p_.p[i] * std::max(x - r, std::min(x + r, y_[i]));
    }
    return p_.q * x + s;
  }
  double step(double x) noexcept override {
    const double f = 1.0 + p_.c * rate_;
    double s = 0.0;
    for (std::size_t i = 0; i < y_.size(); ++i) {
      const double r = p_.r[i] * f;
      y_[i] = std::max(x - r, std::min(x + r, y_[i]));
      s += p_.p[i] * y_[i];
    }
    rate_ += gain_ * (std::abs(x - x_) / p_.dt - rate_);
    // a rate < 2.2e-308 is 0: f = 1 + c rate is 1 either way for c < 1e291 (flush.hpp). A branch,
    // not flush_subnormal's select: almost never taken, it stays off the rate's dependency chain
    // (the select cost 16 % of BM_KindStep/rate-pi/10; rate >= 0, so no abs)
    if (rate_ < std::numeric_limits<double>::min()) [[unlikely]] rate_ = 0.0;
    x_ = x;
    return p_.q * x + s;
  }
  std::size_t state_size() const noexcept override { return y_.size() + 2; }
  void get_state(double* out) const noexcept override {
    std::copy(y_.begin(), y_.end(), out);
    out[y_.size()] = x_;
    out[y_.size() + 1] = rate_;
  }
  void set_state(const double* in, double x_max) override {
    for (std::size_t i = 0; i < y_.size() + 2; ++i)
      if (!std::isfinite(in[i])) throw Error(detail::format("rate-pi: state[{}] = {} must be finite", i, in[i]));
    if (!(in[y_.size() + 1] >= 0)) throw Error(detail::format("rate-pi: the rate state = {} must be >= 0", in[y_.size() + 1]));
    // what inputs within x_max reach (amplification): |x| <= M, rate <= 2 M / dt, |y_i| <= M (1 + r_i f)
    const double m = std::max(x_max, 1.0), rate_max = 2.0 * m / p_.dt, f = 1.0 + 2.0 * p_.c / p_.dt;
    if (!(std::abs(in[y_.size()]) <= x_max))
      throw Error(detail::format("rate-pi: state[{}] (last input) = {} is beyond the input bound {}", y_.size(),
                                 in[y_.size()], x_max));
    if (!(in[y_.size() + 1] <= rate_max))
      throw Error(detail::format("rate-pi: the rate state = {} is beyond what inputs within the input bound reach ({})",
                                 in[y_.size() + 1], rate_max));
    for (std::size_t i = 0; i < y_.size(); ++i)
      if (!(std::abs(in[i]) <= m * (1.0 + p_.r[i] * f)))
        throw Error(detail::format("rate-pi: state[{}] = {} is beyond what inputs within the input bound reach ({})", i,
                                   in[i], m * (1.0 + p_.r[i] * f)));
    std::copy(in, in + y_.size(), y_.begin());
    x_ = in[y_.size()];
    rate_ = in[y_.size() + 1];
  }
  double min_slope() const noexcept override { return p_.q; }
  // rate <= 2 max(|x|, 1) / dt, thresholds r_i (1 + c rate), |y_i| <= |x| + r_i (1 + c rate)
  double amplification() const noexcept override {
    double w = std::abs(p_.q), rmax = 0.0;
    for (std::size_t i = 0; i < p_.r.size(); ++i) w += std::abs(p_.p[i]), rmax = std::max(rmax, p_.r[i]);
    const double f = 1.0 + 2.0 * p_.c / p_.dt;  // 1 + c rate per unit of max(|x|, 1)
    return std::max({2.0 / p_.dt + 2.0, f, (w + 1.0) * (2.0 + rmax * f)});
  }
  std::string invertibility() const override {
    if (!(p_.q > 0)) return detail::format("q = {} must be > 0", p_.q);
    for (std::size_t i = 0; i < p_.p.size(); ++i)
      if (p_.p[i] < 0)
        return detail::format("p[{}] = {} must be >= 0 (with thresholds that change from sample to sample only "
                              "nonnegative weights keep the output increasing)", i, p_.p[i]);
    return {};
  }
  std::size_t num_features() const noexcept override { return y_.size() + 1; }
  void features(double x, double* out) const noexcept override {
    out[0] = x;
    std::copy(y_.begin(), y_.end(), out + 1);
  }

 private:
  RatePiParams p_;
  std::vector<double> y_;
  double x_ = 0.0, rate_ = 0.0, gain_ = 1.0;
};

// The one map from a kind's parameters to its kernel (void: a kind with PI structure).
template <class P> struct KernelOf { using type = void; };
template <> struct KernelOf<PreisachParams> { using type = PreisachKernel; };
template <> struct KernelOf<KpParams> { using type = KpKernel; };
template <> struct KernelOf<BoucWenParams> { using type = BoucWenKernel; };
template <> struct KernelOf<RatePiParams> { using type = RatePiKernel; };
template <class P> using kernel_of = typename KernelOf<std::decay_t<P>>::type;

}  // namespace

std::unique_ptr<Kernel> make_kernel(const ModelParams& params) {
  return std::visit(
      [](const auto& m) -> std::unique_ptr<Kernel> {
        using K = kernel_of<decltype(m)>;
        if constexpr (std::is_void_v<K>) return nullptr; else return std::make_unique<K>(m);
      },
      params);
}

bool has_kernel(const ModelParams& params) noexcept {
  return std::visit([](const auto& m) { return !std::is_void_v<kernel_of<decltype(m)>>; }, params);
}

}  // namespace hysteron::detail
