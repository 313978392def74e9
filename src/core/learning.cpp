// Iterative learning control (learning.hpp).
#include "hysteron/learning.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "format.hpp"

#include "hysteron/error.hpp"

namespace hysteron {

void LearningParams::validate() const {
  if (period < 2) throw Error(detail::format("learning.period = {}: must be >= 2 samples", period));
  // five buffers of `period` doubles (400 MB at the limit: 2.8 h at 1 kHz); beyond it the C ABI's
  // size_t (e.g. SIZE_MAX) ended in an internal error and Python's 10^9 stalled the process
  if (period > kMaxLearningPeriod)
    throw Error(detail::format("learning.period = {}: must be <= {} samples", period, kMaxLearningPeriod));
  if (!(gain > 0.0 && gain < 2.0)) throw Error(detail::format("learning.gain = {}: must be in (0, 2)", gain));
  if (!(max_correction > 0.0))
    throw Error(detail::format("learning.max_correction = {}: must be > 0", max_correction));
  if (!(rise_tolerance >= 0.0))
    throw Error(detail::format("learning.rise_tolerance = {}: must be >= 0 (infinity: no supervision)", rise_tolerance));
  if (!(max_gain == 0.0 || (max_gain >= gain && max_gain < 2.0)))
    throw Error(detail::format("learning.max_gain = {}: must be 0 (no growth) or in [gain = {}, 2)", max_gain, gain));
  if (max_gain > 0.0 && !std::isfinite(rise_tolerance))
    throw Error("learning.max_gain > 0 needs supervision: a finite rise_tolerance");
  if (half_width > kMaxLearningHalfWidth)
    throw Error(detail::format("learning.half_width = {}: must be <= {}", half_width, kMaxLearningHalfWidth));
  // the taps the update sums (2 reach + 1, reach = binomial_reach(h)) plus the lead and the
  // lookahead must fit in one period, so that every index of the update wraps around at most once
  const std::size_t reach = binomial_reach(half_width);
  if (lead >= period || lookahead >= period || lead + 2 * reach + lookahead >= period)
    throw Error(detail::format("learning: lead + 2 reach + lookahead = {} + 2 x {} + {} must be < period = {} "
                               "samples (reach {}: the Q-filter's taps summed, for half_width {})",
                               lead, reach, lookahead, period, reach, half_width));
}

double binomial_response(std::size_t half_width, double w) noexcept {
  const double c = std::cos(0.5 * w);
  return std::pow(c * c, static_cast<double>(half_width));
}

std::size_t binomial_reach(std::size_t half_width) noexcept {
  // q_m / q_0 = prod_{k=1..m} (h - k + 1) / (h + k): the largest m with q_m >= 1e-18 q_0
  double r = 1.0;
  for (std::size_t m = 1; m <= half_width; ++m) {
    r *= static_cast<double>(half_width - m + 1) / static_cast<double>(half_width + m);
    if (r < 1e-18) return m - 1;
  }
  return half_width;
}

std::size_t learning_update_delay(const LearningParams& p) noexcept {
  const bool whole = p.half_width < p.period && p.lead + 2 * p.half_width + p.lookahead < p.period;
  return p.lead + (whole ? p.half_width : binomial_reach(p.half_width));
}

double learning_contraction(const LearningParams& p, std::span<const double> w,
                            std::span<const std::complex<double>> T) noexcept {
  double worst = 0.0;
  const std::size_t n = std::min(w.size(), T.size());
  for (std::size_t l = 0; l < n; ++l) {
    const std::complex<double> shift = std::polar(1.0, w[l] * static_cast<double>(p.lead));
    const double rho = binomial_response(p.half_width, w[l]) * std::abs(1.0 - p.gain * shift * T[l]);
    if (!(rho <= worst)) worst = rho;  // NaN propagates as "not contracting"
  }
  return worst;
}

IterativeLearning::IterativeLearning(const LearningParams& params) : p_(params) {
  p_.validate();
  // The binomial taps q_m = C(2h, h + m) / 4^h for |m| <= reach (the others are below 1e-18 of
  // q_0 and change no sum of 2h + 1 terms beyond its rounding: |tail| <= 2h x 1e-18 of the total;
  // about 6.4 sqrt(h) of them remain), normalised to sum 1. C(2h, h) itself overflows a double for
  // h > ~510, so: up to kPascalHalfWidth all 2h + 1 by the recurrence q <- (q + shifted q) / 2,
  // which keeps the sum at 1 at every step (O(h^2), sums of positive terms); above it, by the
  // ratio q_m / q_(m-1) = (h - m + 1) / (h + m) from the centre (O(sqrt(h)), relative error about
  // m x 1e-16).
  constexpr std::size_t kPascalHalfWidth = 10000;
  const std::size_t h = p_.half_width;
  reach_ = binomial_reach(h);
  delay_ = learning_update_delay(p_);
  q_.assign(2 * reach_ + 1, 0.0);
  if (h <= kPascalHalfWidth) {
    std::vector<double> all(2 * h + 1, 0.0);
    all[0] = 1.0;
    for (std::size_t n = 1; n < all.size(); ++n) {
      for (std::size_t m = n; m > 0; --m) all[m] = 0.5 * (all[m] + all[m - 1]);
      all[0] *= 0.5;
    }
    double s = 0.0;
    for (double v : all) s += v;
    for (std::size_t i = 0; i < q_.size(); ++i) q_[i] = all[h - reach_ + i] / s;
  } else {
    q_[reach_] = 1.0;
    for (std::size_t m = 1; m <= reach_; ++m)
      q_[reach_ + m] = q_[reach_ - m] =
          q_[reach_ + m - 1] * static_cast<double>(h - m + 1) / static_cast<double>(h + m);
    double s = 0.0;
    for (double v : q_) s += v;
    for (double& v : q_) v /= s;
  }
  c_cur_.assign(p_.period, 0.0);
  c_next_.assign(p_.period, 0.0);
  e_cur_.assign(p_.period, 0.0);
  e_prev_.assign(p_.period, 0.0);
  if (std::isfinite(p_.rise_tolerance)) c_best_.assign(p_.period, 0.0);
  reset();
}

void IterativeLearning::reset() noexcept {
  std::fill(c_cur_.begin(), c_cur_.end(), 0.0);
  std::fill(c_next_.begin(), c_next_.end(), 0.0);
  std::fill(e_cur_.begin(), e_cur_.end(), 0.0);
  std::fill(e_prev_.begin(), e_prev_.end(), 0.0);
  std::fill(c_best_.begin(), c_best_.end(), 0.0);
  k_ = j_ = faults_ = overflows_ = cuts_ = raises_ = 0;
  gain_ = p_.gain;
  sse_ = 0.0;
  least_mse_ = std::numeric_limits<double>::infinity();
  tail_from_best_ = false;
  best_valid_ = skip_tail_ = held_ = false;
}

void IterativeLearning::reset(std::span<const double> correction) {
  if (correction.size() != p_.period)
    throw Error(detail::format("learning: the initial correction has {} values, the period {} samples",
                               correction.size(), p_.period));
  for (std::size_t i = 0; i < correction.size(); ++i)
    if (!std::isfinite(correction[i]))
      throw Error(detail::format("learning: the initial correction's value {} (phase {}) is not finite", correction[i], i));
  reset();
  for (std::size_t i = 0; i < correction.size(); ++i)
    c_cur_[i] = std::clamp(correction[i], -p_.max_correction, p_.max_correction);
}

double IterativeLearning::correction(std::size_t ahead) const noexcept {
  ahead = std::min(ahead, p_.lookahead);
  const std::size_t p = k_ + ahead;
  return p < p_.period ? c_cur_[p] : (held_ ? c_cur_ : c_next_)[p - p_.period];
}

namespace {

// sum_s q[s] (c[s] + L e[s]) over n contiguous samples, four partial sums (no serial
// dependence on one accumulator; the order is fixed, so the result is deterministic).
double weighted_sum(const double* q, const double* c, const double* e, double L, std::ptrdiff_t n) noexcept {
  double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
  std::ptrdiff_t s = 0;
  for (; s + 4 <= n; s += 4) {
    a0 += q[s] * (c[s] + L * e[s]);
    a1 += q[s + 1] * (c[s + 1] + L * e[s + 1]);
    a2 += q[s + 2] * (c[s + 2] + L * e[s + 2]);
    a3 += q[s + 3] * (c[s + 3] + L * e[s + 3]);
  }
  for (; s < n; ++s) a0 += q[s] * (c[s] + L * e[s]);
  return (a0 + a1) + (a2 + a3);
}

}  // namespace

// c_{new}(i) = sum_m q_m [c(i+m) + L e(i+m+d)]. `c` is the previous generation; the
// errors come from e_cur_ (this period, indices already measured) or e_prev_ (the
// period before) as documented in step(). The taps m = -h..h are summed in contiguous
// runs: a run ends where the index of c wraps around the period or the error's source
// changes (at most 3 runs, since the window wraps at most once).
double IterativeLearning::update_at(std::size_t i, const double* c, bool tail) noexcept {
  const auto N = static_cast<std::ptrdiff_t>(p_.period);
  const auto h = static_cast<std::ptrdiff_t>(reach_);  // taps beyond reach_ are negligible
  const auto d = static_cast<std::ptrdiff_t>(p_.lead);
  const auto ii = static_cast<std::ptrdiff_t>(i);
  const double* q = q_.data() + reach_;  // q[m], m = -reach..reach
  double acc = 0.0;
  for (std::ptrdiff_t m = -h; m <= h;) {
    std::ptrdiff_t ci = ii + m;
    if (ci < 0) ci += N;
    if (ci >= N) ci -= N;
    std::ptrdiff_t len = std::min(h - m + 1, N - ci);
    const std::ptrdiff_t t = ii + m + d;
    const double* e;
    if (tail) {  // i in [N - D, N), D = delay_: t >= N is this period's error at t - N
      if (t >= N) {
        e = e_cur_.data() + (t - N);
      } else {
        e = e_prev_.data() + t;
        len = std::min(len, N - t);
      }
    } else {     // t <= the current phase; t < 0 is the previous period's
      if (t < 0) {
        e = e_prev_.data() + (t + N);
        len = std::min(len, -t);
      } else {
        e = e_cur_.data() + t;
      }
    }
    acc += weighted_sum(q + m, c + ci, e, gain_, len);
    m += len;
  }
  // Finite c and e can still overflow the sum (errors of the order of 1e308): then inf, or NaN
  // from inf - inf, which the clamp does not catch. The sample keeps its correction of the
  // generation before, c(i), bounded already; counted in overflows().
  if (!std::isfinite(acc)) {
    ++overflows_;
    return c[i];
  }
  return std::clamp(acc, -p_.max_correction, p_.max_correction);
}

// At phase k of period j, after recording e_j(k):
//   body: c_{j+1}(i) for i = k - D (every error it needs is measured; D = delay_ =
//         learning_update_delay(), at least d + reach_);
//   tail: for j >= 1 and k < D, c_j(i) for i = N + k - D, the end of this
//         period, which needed errors of this period's start (c_{j-1} is still in
//         c_next_ there: the body starts overwriting it only at k = D).
void IterativeLearning::step(double error) noexcept {
  if (!std::isfinite(error)) {
    error = 0.0;
    ++faults_;
  }
  const std::size_t N = p_.period, dh = delay_;
  e_cur_[k_] = error;
  sse_ += error * error;
  if (held_) {
    // the best correction, held: nothing to update
  } else if (k_ >= dh) {
    c_next_[k_ - dh] = update_at(k_ - dh, c_cur_.data(), false);
  } else if (j_ >= 1 && !skip_tail_) {
    c_cur_[N + k_ - dh] = update_at(N + k_ - dh, tail_from_best_ ? c_best_.data() : c_next_.data(), true);
  }
  if (++k_ == N) end_period();
}

// c_cur_ (c_j) is complete and was applied over the period just ended; c_next_ holds
// c_{j+1} except its last D = delay_ samples, which the next period computes from c_j.
void IterativeLearning::end_period() noexcept {
  const double mse = sse_ / static_cast<double>(p_.period);
  // the first period starts from the loop's initial state, not in the periodic steady state
  // the others share: its error is not comparable, so supervision starts after it
  const double allowed = j_ == 0 ? std::numeric_limits<double>::infinity() : 1.0 + p_.rise_tolerance;
  sse_ = 0.0;
  skip_tail_ = false;
  if (held_) {
    // c_cur_ stays
  } else if (std::isfinite(allowed) && (!best_valid_ || mse < least_mse_)) {
    // c_j is the best so far (or the restored best, re-measured): keep it in c_best_, the
    // end of c_{j+1} is computed from there, and the old best's buffer becomes the scratch
    std::swap(c_best_, c_cur_);
    std::swap(c_cur_, c_next_);
    tail_from_best_ = true;
    least_mse_ = mse;
    best_valid_ = true;
    if (cuts_ == 0 && gain_ < p_.max_gain) {  // growth until the first halving
      gain_ = std::min(2.0 * gain_, p_.max_gain);
      ++raises_;
    }
  } else if (std::isfinite(allowed) && mse > allowed * allowed * least_mse_) {
    // worse than the best: apply the best again (complete: no tail to compute) and halve L;
    // c_{j+1} is dropped (c_next_ is the scratch the next period's updates overwrite)
    std::swap(c_cur_, c_best_);
    best_valid_ = false;
    skip_tail_ = true;
    gain_ *= 0.5;
    ++cuts_;
    // held after hold_after_cuts halvings, and at L's floor whatever it says (0 included)
    held_ = cuts_ >= kMaxLearningCuts || (p_.hold_after_cuts > 0 && cuts_ >= p_.hold_after_cuts);
  } else {
    std::swap(c_cur_, c_next_);
    tail_from_best_ = false;
  }
  std::swap(e_cur_, e_prev_);
  k_ = 0;
  ++j_;
}

}  // namespace hysteron
