#pragma once
// Exact inverses of the hysteresis models (desired output -> input).
//
// pi, gpi, mpi-deadzone: analytical. The dead zones are inverted piecewise
// linearly (memoryless), the PI part by the inverse PI of Eqs. 9-11
//   x = gamma^-1( q' v + sum_i p'_i x_i ),  x_i = F_{r'_i}[v]          (Eqs. 9-10)
//   q' = 1/q,  r'_i = q r_i + sum_{j<i} p_j (r_i - r_j),
//   p'_i = -p_i / ((q + sum_{j<=i} p_j)(q + sum_{j<i} p_j))           (Eq. 11)
// mpi-asym: no closed form; each sample solves f(x) = y exactly for the
// current operator state, with f strictly increasing, by safeguarded Newton
// steps inside a shrinking bracket (to machine precision, not an approximation).
// preisach, kp, bouc-wen, rate-pi: the same by bracketing on the kernel's output for
// the next input (Illinois false position with bisection steps, to machine precision).
// The preisach output jumps where relays switch: an output inside a jump gives the
// input at the jump (the smallest input whose output reaches it).
//
// Saturation: an output beyond the reachable range gives the nearest input
// limit (never NaN, never outside the limits); the inverse's state then
// follows the forward model driven by the saturated input, so it stays exact.
//
// Starting state: an inverse can be started from any forward state that a
// forward model reaches from its virgin state (reset(const ModelState&)), so
// that Inverse(forward(x)) == x sample by sample.
#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

#include "hysteron/models.hpp"

namespace hysteron {

struct InverseOptions {
  // Input limits to saturate at. Unset (infinite) fields fall back to the model's
  // input_limits; for a saturating envelope (tanh, atan) with no limit at all, the
  // inverse stops where the envelope reaches 1e-9 of its range from its asymptote.
  // Limits that share nothing with the model's finite input_limits (its training range)
  // are refused (hysteron::Error): the inverse could only command inputs never fitted.
  Limits input_limits;
};

namespace detail {
// Eq. 11's inverse-PI thresholds r'_i and weights p'_i, in O(n), written to r_inv and p_inv (r.size() each), for a PI
// with direct weight q, thresholds 0 < r_1 < r_2 ... and weights p whose sums q + p_1 + ... + p_i are all > 0:
//   r'_i = r'_{i-1} + (q + p_1 + ... + p_{i-1}) (r_i - r_{i-1})  (r'_0 = r_0 = 0),
// equal to q r_i + sum_{j<i} p_j (r_i - r_j) in exact arithmetic, summed from nonnegative terms (the slopes of the
// loading curve times the threshold gaps). Inverse (construction, set_weights) and the generated C use it.
void inverse_pi_parameters(double q, std::span<const double> r, std::span<const double> p, double* r_inv,
                           double* p_inv) noexcept;
}  // namespace detail

class Inverse {
 public:
  // Throws hysteron::Error if the model is not invertible, naming the condition
  // (e.g. "q + p_1 + ... + p_3 = -0.1 must be > 0").
  explicit Inverse(ModelParams params, InverseOptions options = {});

  // The parameters and options it was made from (set_weights does not change them, so after
  // set_weights Inverse(params(), options()) is the inverse of the original weights; before, it
  // is the same inverse in the virgin state).
  const ModelParams& params() const noexcept { return params_; }
  const InverseOptions& options() const noexcept { return options_; }
  const Structure<double>& structure() const noexcept { return s_; }
  // The input limits the inverse saturates at (raw input units).
  const Limits& limits() const noexcept { return lim_raw_; }
  bool analytical() const noexcept { return !s_.asymmetric && !kernel_; }

  // Virgin state (matches Model::reset()).
  void reset() noexcept;
  // Start consistently from a forward model's state. Throws hysteron::Error if the
  // state has the wrong size, is not finite, or cannot be reached by the model
  // (pi, gpi, mpi-deadzone: operator outputs whose spread breaks |d_i - d_j| <= r_j - r_i;
  // mpi-asym, necessary conditions only: y_1 < u - r_1, or |y_i - y_j| > r_j - r_i;
  // docs/models.md).
  void reset(const ModelState& forward_state);

  // One sample: the (raw) input that makes the model output y_desired. A model with
  // output_gain / input_scale < 0 is decreasing; its inverse is exact all the same. Never
  // allocates, never throws; a non-finite y_desired holds the last input and
  // is counted in faults(). A finite y_desired beyond what the model can output inside
  // the limits saturates at the limit in its direction (however large).
  double step(double y_desired) noexcept;
  // Batch. Throws hysteron::Error on unequal sizes or a non-finite value.
  void simulate(std::span<const double> y, std::span<double> x);
  std::vector<double> simulate(std::span<const double> y);

  // True if the last step saturated at an input limit.
  bool saturated() const noexcept { return saturated_; }
  double input() const noexcept { return std::clamp(s_.units.from_model(x_), lim_raw_.lo, lim_raw_.hi); }
  std::size_t faults() const noexcept { return faults_; }
  // Analytical inverse: step() clamps the desired PI output v (model coordinates, after the
  // dead zones' inverse) to output_bounds(); a side is infinite where its limit is unbounded.
  Limits output_bounds() const noexcept { return {v_lo_, v_hi_}; }
  // The equivalent forward-model state after the last step.
  ModelState forward_state() const;

  // Replaces the weights of the model being inverted, in place (an adaptive inverse,
  // docs/control.md): q and p_1..p_n of structure(), in its canonical order (thresholds
  // increasing; the weights of zero-threshold operators are part of q). The forward
  // operator state (the input history) is kept, so the next step inverts the model with
  // the new weights from the same memory: the analytical inverse (pi, gpi, mpi-deadzone)
  // recomputes Eq. 11's q', r'_i, p'_i and re-derives its operator state from the forward
  // state; mpi-asym brackets with the new weights. Envelopes, thresholds, dead zones and
  // the units map are unchanged. Never allocates, never throws: returns false and changes
  // nothing if p has the wrong size, a weight is not finite, or the weights break the
  // constructor's invertibility conditions (q > 0 and q + p_1 + ... + p_i > 0; mpi-asym:
  // q > 0 and p_i >= 0), or the model is not of the PI family.
  bool set_weights(double q, std::span<const double> p) noexcept;

  // Everything step() changes, as numbers (the inverse's operator or kernel state, the last
  // input, saturated() and faults()). restore(snapshot()) on an inverse of the same parameters
  // and options steps exactly as this one from here on (a running inverse saved and loaded
  // again, e.g. Python's pickle). restore throws hysteron::Error, the inverse unchanged, on a
  // snapshot of another size, a non-finite value, an input outside the limits or a state the
  // model cannot reach, as far as reset(const ModelState&) checks it (mpi-asym: necessary
  // conditions only, see there).
  std::vector<double> snapshot() const;
  void restore(std::span<const double> snapshot);

 private:
  double step_analytical(double y) noexcept;
  double step_numerical(double y) noexcept;
  double step_kernel(double y) noexcept;
  double dead_zone_inverse(double y) const noexcept;
  // mpi-asym: both envelopes and their slopes at one input (one tanh per side).
  struct EnvelopesAt {
    double ua, ud, da, dd;
  };
  EnvelopesAt envelopes_at(double x) const noexcept;
  double forward_tentative(const EnvelopesAt& e, double* dfdx) const noexcept;

  ModelParams params_;
  InverseOptions options_;
  Structure<double> s_;
  Limits lim_;      // in model coordinates (see UnitsMap)
  Limits lim_raw_;  // the same in raw input units
  Envelope env_;       // gamma (symmetric models)
  FastEnvelope fenv_;  // the same, for step()
  double u_lo_ = 0.0, u_hi_ = 0.0;  // envelope values at the limits
  // analytical inverse: a PI output below v_lo_ (above v_hi_) is unreachable at any input inside
  // the limits, so step() clamps the desired one to [v_lo_, v_hi_] (it saturates the same, and the
  // inverse-PI sums cannot overflow); -inf (+inf) where the low (high) limit is unbounded
  double v_lo_ = -std::numeric_limits<double>::infinity(), v_hi_ = std::numeric_limits<double>::infinity();
  void update_output_bounds() noexcept;
  // analytical inverse: inverse-PI parameters and state (Eqs. 9-11)
  double qi_ = 1.0;
  std::vector<double> ri_, pi_;
  std::vector<double> xi_, scratch_, dev_;  // x'_i, tentative x'_i, deviations
  double v_prev_ = 0.0;
  // dead-zone inverse tables: breakpoints and slopes (positive and negative side)
  std::vector<double> zp_, dp_, sp_, zn_, dn_, sn_;
  // numerical inverse: forward operator state (PI family) or the kind's kernel
  detail::KernelCopy kernel_;
  std::vector<double> y_;
  EnvelopesAt env_lo_{}, env_hi_{};  // mpi-asym: at lim_.lo and lim_.hi (constant)
  double x_ = 0.0;
  bool saturated_ = false;
  std::size_t faults_ = 0;
};

}  // namespace hysteron
