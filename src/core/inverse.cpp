#include "hysteron/inverse.hpp"

#include "format.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hysteron/error.hpp"
#include "kernels.hpp"
#include "play_kernel.hpp"
#include "validate.hpp"

namespace hysteron {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

// Deviation map between a PI operator and its inverse (see docs/models.md):
// for play deviations d_i = u - y_i of a PI with direct weight q and weights p,
// the inverse operators have deviations d'_i = q d_i + sum_{j<i} p_j (d_i - d_j).
// The same map with (q', p') takes d' back to d. O(n) with running sums.
void map_deviations(double q, const std::vector<double>& p, const double* d, double* out) noexcept {
  double psum = 0.0, pdsum = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    out[i] = q * d[i] + psum * d[i] - pdsum;
    psum += p[i];
    pdsum += p[i] * d[i];
  }
}

}  // namespace

void detail::inverse_pi_parameters(double q, std::span<const double> r, std::span<const double> p, double* r_inv,
                                   double* p_inv) noexcept {
  double prev = q, r_sum = 0.0, r_prev = 0.0;  // prev = q + sum_{j<i} p_j, the loading curve's slope before r_i
  for (std::size_t i = 0; i < r.size(); ++i) {
    r_sum += prev * (r[i] - r_prev);
    r_prev = r[i];
    const double cur = prev + p[i];
    r_inv[i] = r_sum;
    p_inv[i] = -p[i] / (cur * prev);
    prev = cur;
  }
}

Inverse::Inverse(ModelParams params, InverseOptions options)
    : params_(std::move(params)), options_(options), s_(detail::structure_of(params_)),
      kernel_(detail::make_kernel(params_)) {
  const std::string_view name = model_name(params_);
  const Limits& ml = input_limits(params_);
  lim_.lo = std::isinf(options.input_limits.lo) ? ml.lo : options.input_limits.lo;
  lim_.hi = std::isinf(options.input_limits.hi) ? ml.hi : options.input_limits.hi;
  if (std::isnan(lim_.lo) || std::isnan(lim_.hi) || !(lim_.lo < lim_.hi))
    throw Error(detail::format("{}: inverse input limits must satisfy lo < hi, got [{}, {}]", name, lim_.lo, lim_.hi));
  // Limits that share no part with the model's input_limits (its training range, as fit sets them):
  // the inverse could only command inputs the model never saw, e.g. limits in MPa on a model in kPa
  // (0..0.6 against 8..626); the CLI's --limits said so, Python's Inverse and export_c and the C
  // ABI's hysteron_inverse_create took them silently (review of 2026-12-01)
  if (ml.bounded() && !(std::max(lim_.lo, ml.lo) < std::min(lim_.hi, ml.hi)))
    throw Error(detail::format("{}: inverse input limits [{}, {}] lie outside the model's input_limits [{}, {}] (its "
                               "training range): the inverse could only command inputs the model was never fitted "
                               "on; give them in the model's input unit, overlapping its input_limits",
                               name, lim_.lo, lim_.hi, ml.lo, ml.hi));
  // From here on lim_ is in model coordinates (a mirrored input, input_scale < 0, swaps lo and hi).
  const UnitsMap& um = s_.units;
  const Limits raw = lim_;
  lim_ = um.to_model(lim_);

  if (kernel_) {
    if (const std::string why = kernel_.get()->invertibility(); !why.empty())
      throw Error(detail::format("{}: not invertible: {}", name, why));
    if (!lim_.bounded())
      throw Error(detail::format("{}: the numerical inverse needs finite input_limits [lo, hi] to bracket the input (a "
                                 "fitted model has them: its training input range)",
                                 name));
    const Limits back = um.from_model(lim_);
    lim_raw_ = Limits{std::isfinite(raw.lo) ? raw.lo : back.lo, std::isfinite(raw.hi) ? raw.hi : back.hi};
    reset();
    return;
  }
  const std::size_t n = s_.r.size();
  if (!(s_.q > 0))
    throw Error(detail::format("{}: not invertible: q (plus the weights of zero-threshold operators) = {} must be > 0, "
                            "otherwise the output is flat after every reversal",
                            name, s_.q));
  if (!s_.asymmetric) {
    // Eq. 11: partial sums q + p_1 + ... + p_i must stay positive.
    double sum = s_.q;
    for (std::size_t i = 0; i < n; ++i) {
      sum += s_.p[i];
      if (!(sum > 0))
        throw Error(detail::format("{}: not invertible: q + p_1 + ... + p_{} = {} must be > 0 (Eq. 11; the loading "
                                "curve must be strictly increasing)",
                                name, i + 1, sum));
    }
    qi_ = 1.0 / s_.q;
    ri_.resize(n);
    pi_.resize(n);
    detail::inverse_pi_parameters(s_.q, s_.r, s_.p, ri_.data(), pi_.data());  // Eq. 11, O(n)
    if (s_.has_dead_zones) {
      if (!(s_.g0 > 0))
        throw Error(detail::format("{}: not invertible: g0 (plus weights of zero dead zones) = {} must be > 0", name, s_.g0));
      // Positive side: breakpoints 0 < z_1 < z_2 ..., slope after z_k = g0 + sum g_j (z_j in (0, z_k]).
      zp_ = {0.0};
      dp_ = {0.0};
      sp_ = {s_.g0};
      for (std::size_t k = 0; k < s_.z.size(); ++k) {
        if (!(s_.z[k] > 0)) continue;
        const double dz = s_.z[k] - zp_.back();
        dp_.push_back(dp_.back() + sp_.back() * dz);
        zp_.push_back(s_.z[k]);
        sp_.push_back(sp_.back() + s_.g[k]);
        if (!(sp_.back() > 0))
          throw Error(detail::format("{}: not invertible: g0 + weights of dead zones in (0, {}] = {} must be > 0", name,
                                  s_.z[k], sp_.back()));
      }
      // Negative side: 0 > z_1 > z_2 ... (walk z from the largest negative down).
      zn_ = {0.0};
      dn_ = {0.0};
      sn_ = {s_.g0};
      for (std::size_t kk = s_.z.size(); kk-- > 0;) {
        if (!(s_.z[kk] < 0)) continue;
        const double dz = s_.z[kk] - zn_.back();  // negative
        dn_.push_back(dn_.back() + sn_.back() * dz);
        zn_.push_back(s_.z[kk]);
        sn_.push_back(sn_.back() + s_.g[kk]);
        if (!(sn_.back() > 0))
          throw Error(detail::format("{}: not invertible: g0 + weights of dead zones in [{}, 0) = {} must be > 0", name,
                                  s_.z[kk], sn_.back()));
      }
    }
    // Saturating envelopes with no limit: stop 1e-9 of the range short of the asymptote.
    env_ = Envelope{s_.asc_kind, s_.asc_c};
    fenv_ = FastEnvelope(env_);
    const Envelope& env = env_;
    const double span = env.range_hi() - env.range_lo();
    if (std::isinf(lim_.lo) && std::isfinite(span)) lim_.lo = env.inverse(env.range_lo() + 1e-9 * span);
    if (std::isinf(lim_.hi) && std::isfinite(span)) lim_.hi = env.inverse(env.range_hi() - 1e-9 * span);
    u_lo_ = std::isinf(lim_.lo) ? -kInf : env.value(lim_.lo);
    u_hi_ = std::isinf(lim_.hi) ? kInf : env.value(lim_.hi);
    update_output_bounds();
    xi_.assign(n, 0.0);
    scratch_.assign(n, 0.0);
    dev_.assign(n, 0.0);
    y_.assign(n, 0.0);
  } else {
    for (std::size_t i = 0; i < n; ++i)
      if (s_.p[i] < 0)
        throw Error(detail::format("{}: not invertible: the numerical inverse of mpi-asym needs every weight p_i >= 0 "
                                "(then the output is strictly increasing in the input for every state; negative "
                                "weights make it fold back and the inverse jump), got p[{}] = {}", name, i,
                                s_.p[i]));
    if (!lim_.bounded())
      throw Error(detail::format("{}: the numerical inverse needs finite input_limits [lo, hi] to bracket the input", name));
    y_.assign(n, 0.0);
    env_lo_ = envelopes_at(lim_.lo);
    env_hi_ = envelopes_at(lim_.hi);
  }
  // Raw limits: the caller's where given (a command never leaves them by rounding).
  const Limits back = um.from_model(lim_);  // infinite limits stay infinite
  lim_raw_ = Limits{std::isfinite(raw.lo) ? raw.lo : back.lo, std::isfinite(raw.hi) ? raw.hi : back.hi};
  reset();
}

void Inverse::reset() noexcept {
  if (kernel_) kernel_.get()->reset();
  std::fill(xi_.begin(), xi_.end(), 0.0);
  std::fill(y_.begin(), y_.end(), 0.0);
  v_prev_ = 0.0;
  x_ = std::clamp(0.0, lim_.lo, lim_.hi);
  saturated_ = false;
  faults_ = 0;
}

void Inverse::reset(const ModelState& fs) {
  const std::string_view name = model_name(params_);
  if (kernel_) {
    detail::Kernel& k = *kernel_.get();
    if (fs.y.size() != k.state_size())
      throw Error(detail::format("{}: inverse start state has {} entries, the model's state has {}", name, fs.y.size(),
                                 k.state_size()));
    if (!std::isfinite(fs.u)) throw Error(detail::format("{}: inverse start state u is not finite", name));
    k.set_state(fs.y.data(), detail::input_bound(s_, &k));
    x_ = std::clamp(fs.u, lim_.lo, lim_.hi);
    saturated_ = false;
    faults_ = 0;
    return;
  }
  const std::size_t n = s_.r.size();
  if (fs.y.size() != n)
    throw Error(detail::format("{}: inverse start state has {} operator outputs, the model has {}", name, fs.y.size(), n));
  if (!std::isfinite(fs.u)) throw Error(detail::format("{}: inverse start state u is not finite", name));
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(fs.y[i])) throw Error(detail::format("{}: inverse start state y[{}] is not finite", name, i));
  detail::check_state_bound(detail::format("{}: inverse start state", name), s_, detail::input_bound(s_, nullptr), fs);
  double scale = std::abs(fs.u);
  for (double v : fs.y) scale = std::max(scale, std::abs(v));
  const double tol = 1e-9 * std::max(1.0, scale);
  if (s_.asymmetric) {
    // Reachability, necessary conditions (docs/models.md): a step sets y_i = max(u_a - r_i, min(u_d + r_i, y_i)), so
    // y_1 >= u - r_1 for u = u_a of the last input, and (max and min being 1-Lipschitz)
    // |y_i - y_{i-1}| <= r_i - r_{i-1} holds on from the virgin (all 0) and relaxed (all u) states. The virgin
    // operators pair with any u (the model's is 0, the inverse's the envelope of its start input): the first
    // condition is not checked on them. The upper bound y_i <= max(u_a - r_i, u_d + r_i) is not checked (see there).
    bool virgin = true;
    for (double v : fs.y) virgin = virgin && v == 0.0;
    if (n > 0 && !virgin && fs.y[0] < fs.u - s_.r[0] - tol)
      throw Error(detail::format("{}: inverse start state is not reachable by the model: operator 1 (r = {}) has "
                                 "y_1 = {} below u - r_1 = {} (every input sets it to at least u_a - r_1)",
                                 name, s_.r[0], fs.y[0], fs.u - s_.r[0]));
    for (std::size_t i = 1; i < n; ++i)
      if (std::abs(fs.y[i] - fs.y[i - 1]) > s_.r[i] - s_.r[i - 1] + tol)
        throw Error(detail::format("{}: inverse start state is not reachable by the model: operator {} (r = {}) is "
                                   "{} from operator {} (y_{} = {}, y_{} = {}), more than r_{} - r_{} = {} (no "
                                   "input takes two operators further apart than their thresholds differ)",
                                   name, i + 1, s_.r[i], fs.y[i] - fs.y[i - 1], i, i + 1, fs.y[i], i, fs.y[i - 1],
                                   i + 1, i, s_.r[i] - s_.r[i - 1]));
  }
  saturated_ = false;
  faults_ = 0;
  if (s_.asymmetric) {
    std::copy(fs.y.begin(), fs.y.end(), y_.begin());
    const Envelope env{s_.asc_kind, s_.asc_c};
    const double x = env.inverse(fs.u);
    x_ = std::clamp(std::isfinite(x) ? x : 0.0, lim_.lo, lim_.hi);
    return;
  }
  // Reachability: |d_1| <= r_1 and |d_i - d_{i-1}| <= r_i - r_{i-1} (1-Lipschitz memory curve).
  double d_prev = 0.0, r_prev = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    dev_[i] = fs.u - fs.y[i];
    if (std::abs(dev_[i] - d_prev) > s_.r[i] - r_prev + tol)
      throw Error(detail::format("{}: inverse start state is not reachable by the model: operator {} (r = {}) deviates by "
                              "{} from the input, operator {} by {}",
                              name, i + 1, s_.r[i], dev_[i], i, d_prev));
    d_prev = dev_[i];
    r_prev = s_.r[i];
  }
  double v = s_.q * fs.u;
  for (std::size_t i = 0; i < n; ++i) v += s_.p[i] * fs.y[i];
  map_deviations(s_.q, s_.p, dev_.data(), scratch_.data());
  for (std::size_t i = 0; i < n; ++i) xi_[i] = v - scratch_[i];
  v_prev_ = v;
  const Envelope env{s_.asc_kind, s_.asc_c};
  const double x = env.inverse(fs.u);
  x_ = std::clamp(std::isfinite(x) ? x : 0.0, lim_.lo, lim_.hi);
}

// Layout: the kernel's state (kinds without PI structure), or x'_1..x'_n and v (analytical), or the
// forward operator outputs y_1..y_n (mpi-asym); then the last input (model coordinates),
// saturated (0/1) and faults.
std::vector<double> Inverse::snapshot() const {
  std::vector<double> s;
  if (kernel_) {
    s.resize(kernel_.get()->state_size());
    kernel_.get()->get_state(s.data());
  } else if (s_.asymmetric) {
    s = y_;
  } else {
    s = xi_;
    s.push_back(v_prev_);
  }
  s.insert(s.end(), {x_, saturated_ ? 1.0 : 0.0, static_cast<double>(faults_)});
  return s;
}

void Inverse::restore(std::span<const double> s) {
  const std::string what = detail::format("{}: inverse snapshot", model_name(params_));
  const std::size_t m = kernel_ ? kernel_.get()->state_size() : s_.asymmetric ? y_.size() : xi_.size() + 1;
  detail::check_snapshot_size(s, m + 3, what);
  for (std::size_t i = 0; i < m + 1; ++i) detail::snapshot_finite(s[i], detail::format("{}[{}]", what, i));
  if (!(s[m] >= lim_.lo && s[m] <= lim_.hi))
    throw Error(detail::format("{}: the last input {} is outside the limits [{}, {}] (model coordinates)", what, s[m],
                               lim_.lo, lim_.hi));
  Inverse next(*this);
  if (kernel_) next.kernel_.get()->set_state(s.data(), detail::input_bound(s_, kernel_.get()));  // checks it
  else if (s_.asymmetric) std::copy(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(m), next.y_.begin());
  else {
    std::copy(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(m - 1), next.xi_.begin());
    next.v_prev_ = s[m - 1];
  }
  next.x_ = s[m];
  next.saturated_ = detail::snapshot_count(s[m + 1], what + " saturated", 1.0) == 1;
  next.faults_ = detail::snapshot_count(s[m + 2], what + " faults");
  if (!kernel_) Inverse(next).reset(next.forward_state());  // a state the model can reach (throws otherwise)
  *this = std::move(next);
}

ModelState Inverse::forward_state() const {
  ModelState fs;
  if (kernel_) {
    fs.y.resize(kernel_.get()->state_size());
    kernel_.get()->get_state(fs.y.data());
    fs.u = x_;
    return fs;
  }
  const std::size_t n = s_.r.size();
  if (s_.asymmetric) {
    fs.y = y_;
    fs.u = envelope_value<double>(s_.asc_kind, s_.asc_c.data(), x_);
    return fs;
  }
  std::vector<double> dprime(n), d(n);
  double u = qi_ * v_prev_;
  for (std::size_t i = 0; i < n; ++i) {
    dprime[i] = v_prev_ - xi_[i];
    u += pi_[i] * xi_[i];
  }
  map_deviations(qi_, pi_, dprime.data(), d.data());
  fs.y.resize(n);
  for (std::size_t i = 0; i < n; ++i) fs.y[i] = u - d[i];
  fs.u = u;
  return fs;
}

double Inverse::dead_zone_inverse(double y) const noexcept {
  if (y >= 0) {
    std::size_t k = 0;
    while (k + 1 < dp_.size() && dp_[k + 1] <= y) ++k;
    return zp_[k] + (y - dp_[k]) / sp_[k];
  }
  std::size_t k = 0;
  while (k + 1 < dn_.size() && dn_[k + 1] >= y) ++k;
  return zn_[k] + (y - dn_[k]) / sn_[k];
}

double Inverse::step(double y) noexcept {
  if (!std::isfinite(y)) {
    ++faults_;
    return input();
  }
  const double ym = s_.model_output(y);
  const double xm = kernel_ ? step_kernel(ym) : s_.asymmetric ? step_numerical(ym) : step_analytical(ym);
  // the limit itself, not a rounding of it (model hi is raw lo when mirrored)
  if (saturated_) return (xm >= lim_.hi) != s_.units.mirrored() ? lim_raw_.hi : lim_raw_.lo;
  return std::clamp(s_.units.from_model(xm), lim_raw_.lo, lim_raw_.hi);
}

double Inverse::step_analytical(double y) noexcept {
  const std::size_t n = s_.r.size();
  // Beyond [v_lo_, v_hi_] the model cannot reach v inside the limits: clamped, it still
  // saturates at the limit in its direction, and q' v + sum p'_i x'_i cannot overflow to inf - inf.
  const double v = std::clamp(s_.has_dead_zones ? dead_zone_inverse(y) : y, v_lo_, v_hi_);
  // Eqs. 9-10 on the tentative state.
  const double* pi = pi_.data();
  double* sc = scratch_.data();
  const double u = qi_ * v + detail::play_weighted_sum(v, ri_.data(), pi, xi_.data(), sc, n);
  // u = +-inf toward a bounded limit saturates there below; NaN, or inf toward an unbounded
  // side (a desired output beyond a double's range there), is held like a non-finite y
  if (std::isnan(u) || (u == kInf && u_hi_ == kInf) || (u == -kInf && u_lo_ == -kInf)) {
    ++faults_;
    return x_;
  }
  if (u >= u_lo_ && u <= u_hi_) {
    xi_.swap(scratch_);
    v_prev_ = v;
    saturated_ = false;
    x_ = std::clamp(fenv_.inverse(u), lim_.lo, lim_.hi);  // gamma^-1, finite on [u_lo, u_hi]
    return x_;
  }
  // Saturated: drive the forward model with the limit and re-derive the inverse state.
  const bool high = u > u_hi_;
  const double uc = high ? u_hi_ : u_lo_;
  double* d = dev_.data();
  double u_prev = qi_ * v_prev_;
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = v_prev_ - xi_[i];
    u_prev += pi[i] * xi_[i];
  }
  map_deviations(qi_, pi_, d, sc);  // sc = forward deviations
  double vc = s_.q * uc;
  for (std::size_t i = 0; i < n; ++i) {
    const double yi = ops::generalized_play<double>(uc, s_.r[i], u_prev - sc[i]);
    vc += s_.p[i] * yi;
    d[i] = uc - yi;
  }
  map_deviations(s_.q, s_.p, d, sc);
  for (std::size_t i = 0; i < n; ++i) xi_[i] = vc - sc[i];
  v_prev_ = vc;
  saturated_ = true;
  x_ = high ? lim_.hi : lim_.lo;
  return x_;
}

Inverse::EnvelopesAt Inverse::envelopes_at(double x) const noexcept {
  EnvelopesAt e;
  Envelope{s_.asc_kind, s_.asc_c}.value_and_derivative(x, e.ua, e.da);
  Envelope{s_.desc_kind, s_.desc_c}.value_and_derivative(x, e.ud, e.dd);
  return e;
}

double Inverse::forward_tentative(const EnvelopesAt& e, double* dfdx) const noexcept {
  const double ua = e.ua, ud = e.ud, da = e.da, dd = e.dd;
  double f = s_.q * 0.5 * (ua + ud);
  double df = s_.q * 0.5 * (da + dd);
  for (std::size_t i = 0; i < s_.r.size(); ++i) {
    // y_i = max{lo, min{hi, y_i}} exactly as the operator (lo may exceed hi).
    const double lo = ua - s_.r[i], hi = ud + s_.r[i];
    const double m = std::min(hi, y_[i]);
    if (lo > m) {
      f += s_.p[i] * lo;
      df += s_.p[i] * da;
    } else {
      f += s_.p[i] * m;
      if (hi < y_[i]) df += s_.p[i] * dd;
    }
  }
  *dfdx = df;
  return f;
}

double Inverse::step_numerical(double y) noexcept {
  double df = 0.0;
  double a = lim_.lo, b = lim_.hi;
  const double fa = forward_tentative(env_lo_, &df);
  const double fb = forward_tentative(env_hi_, &df);
  double x;
  EnvelopesAt ex{};  // the envelopes at x, once x has been evaluated
  bool have_ex = false;
  if (y >= fb) {
    x = b;
    saturated_ = y > fb;
    ex = env_hi_, have_ex = true;
  } else if (y <= fa) {
    x = a;
    saturated_ = y < fa;
    ex = env_lo_, have_ex = true;
  } else {
    saturated_ = false;
    // Safeguarded Newton inside the bracket [a, b] with f(a) < y < f(b).
    x = std::clamp(x_, a, b);
    for (int it = 0; it < 200; ++it) {
      ex = envelopes_at(x);
      have_ex = true;
      const double fx = forward_tentative(ex, &df);
      if (fx == y) break;
      if (fx < y) a = x; else b = x;
      double xn = x - (fx - y) / df;
      if (!(df > 0) || !(xn > a && xn < b)) xn = 0.5 * (a + b);
      if (b - a <= 4 * kEps * std::max(std::abs(a), std::abs(b)) || xn == x) {
        have_ex = xn == x;
        x = xn;
        break;
      }
      x = xn;
      have_ex = false;
    }
  }
  // Commit: the forward operators driven by x.
  if (!have_ex) ex = envelopes_at(x);
  for (std::size_t i = 0; i < s_.r.size(); ++i) y_[i] = ops::asymmetric_play<double>(ex.ua, ex.ud, s_.r[i], y_[i]);
  x_ = x;
  return x_;
}

double Inverse::step_kernel(double y) noexcept {
  detail::Kernel& k = *kernel_.get();
  double a = lim_.lo, b = lim_.hi;
  const double fa = k.peek(a), fb = k.peek(b);
  double x;
  if (y >= fb) {
    x = b;
    saturated_ = y > fb;
  } else if (y <= fa) {
    x = a;
    saturated_ = y < fa;
  } else {
    saturated_ = false;
    // Bracket f(a) < y <= f(b) (f nondecreasing), narrowed first by the last input.
    double ga = fa - y, gb = fb - y;   // true residuals at a and b
    double wa = ga, wb = gb;           // Illinois weights
    const double x0 = std::clamp(x_, a, b);
    if (x0 > a && x0 < b) {
      const double g = k.peek(x0) - y;
      if (g < 0) a = x0, ga = wa = g; else b = x0, gb = wb = g;
    }
    int side = 0;
    for (int it = 0; it < 300 && gb != 0.0; ++it) {
      if (b - a <= 2 * kEps * std::max(std::abs(a), std::abs(b))) break;
      double xn = it % 4 == 3 ? 0.5 * (a + b) : b - wb * (b - a) / (wb - wa);  // false position, every 4th a bisection
      if (!(xn > a && xn < b)) xn = 0.5 * (a + b);
      if (!(xn > a && xn < b)) break;  // no double between a and b
      const double g = k.peek(xn) - y;
      if (g < 0) {
        a = xn;
        ga = wa = g;
        if (side == -1) wb *= 0.5;
        side = -1;
      } else {
        b = xn;
        gb = wb = g;
        if (side == 1) wa *= 0.5;
        side = 1;
      }
    }
    // The smallest input reaching y to the bracket's resolution; a when it is closer
    // (continuous kinds: both are within rounding of the solution).
    x = -ga < gb && b - a <= 4 * kEps * std::max({std::abs(a), std::abs(b), 1e-300}) ? a : b;
  }
  k.step(x);
  x_ = x;
  return x_;
}

void Inverse::simulate(std::span<const double> y, std::span<double> x) {
  const std::string_view name = model_name(params_);
  if (x.size() != y.size())
    throw Error(detail::format("{}: inverse simulate: {} desired outputs but room for {} inputs", name, y.size(), x.size()));
  for (std::size_t k = 0; k < y.size(); ++k)
    if (!std::isfinite(y[k]))
      throw Error(detail::format("{}: inverse simulate: desired output sample {} is not finite ({})", name, k, y[k]));
  for (std::size_t k = 0; k < y.size(); ++k) x[k] = step(y[k]);
}

std::vector<double> Inverse::simulate(std::span<const double> y) {
  std::vector<double> x(y.size());
  simulate(y, x);
  return x;
}

}  // namespace hysteron

namespace hysteron {

bool Inverse::set_weights(double q, std::span<const double> p) noexcept {
  const std::size_t n = s_.r.size();
  if (!analytical() && !s_.asymmetric) return false;  // not a PI-family model
  if (p.size() != n || !std::isfinite(q) || !(q > 0)) return false;
  if (s_.asymmetric) {
    for (double w : p)
      if (!std::isfinite(w) || !(w >= 0)) return false;
    s_.q = q;
    std::copy(p.begin(), p.end(), s_.p.begin());  // y_ is the forward state already
    return true;
  }
  double sum = q;
  for (double w : p) {
    sum += w;
    if (!std::isfinite(w) || !(sum > 0)) return false;
  }
  // The forward state from the inverse's state with the old weights (as in forward_state()):
  // d'_i = v - x'_i, u = q' v + sum p'_i x'_i, d = map(q', p')(d').
  double* d = dev_.data();
  double* sc = scratch_.data();
  double u = qi_ * v_prev_;
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = v_prev_ - xi_[i];
    u += pi_[i] * xi_[i];
  }
  map_deviations(qi_, pi_, d, sc);  // sc = forward deviations u - y_i
  // Eq. 11 with the new weights, as the constructor computes it (the same bits for the same weights).
  s_.q = q;
  std::copy(p.begin(), p.end(), s_.p.begin());
  qi_ = 1.0 / q;
  detail::inverse_pi_parameters(q, s_.r, s_.p, ri_.data(), pi_.data());
  // The inverse's state from the same forward state with the new weights (as in reset(state)):
  // v = q u + sum p_i y_i, x'_i = v - map(q, p)(d)_i.
  double v = q * u;
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = sc[i];
    v += p[i] * (u - d[i]);
  }
  map_deviations(q, s_.p, d, sc);
  for (std::size_t i = 0; i < n; ++i) xi_[i] = v - sc[i];
  v_prev_ = v;
  update_output_bounds();
  return true;
}

void Inverse::update_output_bounds() noexcept {
  // At an input u inside the limits every play |y_i| <= |u| + r_i, so |v(u)| <= B(u) = |q| |u| +
  // sum |p_i| (|u| + r_i); and the model is increasing, so inside [u_lo, u_hi] v >= v(u_lo) >=
  // -B(u_lo) and v <= B(u_hi). A desired v beyond saturates; clamping it to 2 B + 1 keeps the
  // direction and the sums finite.
  const auto bound = [&](double u) {
    if (!std::isfinite(u)) return kInf;
    double b = std::abs(s_.q) * std::abs(u);
    for (std::size_t i = 0; i < s_.p.size(); ++i) b += std::abs(s_.p[i]) * (std::abs(u) + s_.r[i]);
    return std::isfinite(b) ? 2.0 * b + 1.0 : kInf;
  };
  v_lo_ = -bound(u_lo_);
  v_hi_ = bound(u_hi_);
}

}  // namespace hysteron
