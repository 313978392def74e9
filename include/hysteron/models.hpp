#pragma once
// Hysteresis models of the Prandtl-Ishlinskii family and their common
// canonical structure. Equation numbers refer to
// ../shared/papers/gpi-lm-feedforward-pid.txt unless noted.
//
// Every model is the same pipeline, evaluated once per sample:
//
//   u_a = gamma_a(x),  u_d = gamma_d(x)                       envelopes (Eq. 5)
//   y_i = max{ u_a - r_i, min{ u_d + r_i, y_i } }             operators (Eqs. 1, 4)
//   v   = q u_m + sum_i p_i y_i,   u_m = (u_a + u_d) / 2       superposition (Eqs. 3, 6)
//   out = g0 v + sum_k g_k S_{z_k}(v)   (dead-zone MPI only)   output dead zones
//
//   model          envelopes               direct term  dead zones
//   pi             identity                q x          -
//   gpi            tanh (or any), shared   q gamma(x)   -
//   mpi-deadzone   identity                q x          yes
//   mpi-asym       gamma_a != gamma_d      q u_m        -
//
// mpi-asym (../shared/papers/mpi-asymmetric-openloop.txt lost its equations):
// the paper replaces the play by "two more flexible elementary operators to
// independently describe the ascending branch and descending branch". We use
// the asymmetric generalized play: while the input rises, an operator's output
// is pushed up by the ascending envelope gamma_a(x) - r_i; while it falls, it is
// pushed down by the descending envelope gamma_d(x) + r_i. With fixed envelopes
// the output is linear in (q, p_i), so the weights can be identified by
// recursive least squares as in the paper; the envelopes (e.g. two tanh or an
// affine and a tanh) let the rising and falling branches have different
// curvature, which a classical PI (whose loops are point-symmetric about their
// centre) cannot produce. Its inverse has no closed form and is computed
// exactly per sample by monotone bracketing (see inverse.hpp).
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "hysteron/envelope.hpp"
#include "hysteron/operators.hpp"

namespace hysteron {

// Closed input interval [lo, hi]; infinite by default.
struct Limits {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool bounded() const noexcept { return lo > -std::numeric_limits<double>::infinity() &&
                                         hi < std::numeric_limits<double>::infinity(); }
  bool operator==(const Limits&) const = default;
};

// Largest number of operators (plays, or dead zones) of one model: a model file
// with more is refused at load (a 10^7-operator file used to be accepted).
inline constexpr std::size_t max_operators = 100000;

// The map between the user's raw units and the model's own coordinates, shared by
// every model kind (docs/model-files.md, "Units map"):
//   x_m = (x - input_origin) / input_scale              model input
//   y   = output_offset + output_gain * M(x_m)          raw output
// where M is the kind's model below (its virgin state is "at rest at x = input_origin").
// fit() writes it so that one fit is equivariant to offsets, scales and the output's
// sign: a negative output_gain gives a decreasing model. A negative input_scale mirrors the
// input (M sees it negated): the model increases with x when output_gain / input_scale > 0.
// fit() writes one for an mpi-asym whose descending bound takes priority where the envelopes
// cross (the mirror image of the kind's form). Identity by default (old model files have
// none); input_limits stay in raw input units.
struct UnitsMap {
  double input_origin = 0.0;
  double input_scale = 1.0;  // != 0; < 0: mirrored input
  double output_offset = 0.0;
  double output_gain = 1.0;  // != 0
  bool identity() const noexcept {
    return input_origin == 0.0 && input_scale == 1.0 && output_offset == 0.0 && output_gain == 1.0;
  }
  bool mirrored() const noexcept { return input_scale < 0; }
  // True when the raw output increases with the raw input (M increasing).
  bool increasing() const noexcept { return (output_gain > 0) == (input_scale > 0); }
  double to_model(double x) const noexcept { return (x - input_origin) / input_scale; }
  double from_model(double xm) const noexcept { return input_origin + input_scale * xm; }
  // Raw input limits in model coordinates (lo and hi swap when mirrored; infinite stay infinite) and back.
  Limits to_model(const Limits& raw) const noexcept {
    const double a = std::isinf(raw.lo) ? (mirrored() ? -raw.lo : raw.lo) : to_model(raw.lo);
    const double b = std::isinf(raw.hi) ? (mirrored() ? -raw.hi : raw.hi) : to_model(raw.hi);
    return mirrored() ? Limits{b, a} : Limits{a, b};
  }
  Limits from_model(const Limits& m) const noexcept {
    const double a = std::isinf(m.lo) ? (mirrored() ? -m.lo : m.lo) : from_model(m.lo);
    const double b = std::isinf(m.hi) ? (mirrored() ? -m.hi : m.hi) : from_model(m.hi);
    return mirrored() ? Limits{b, a} : Limits{a, b};
  }
  double output(double m) const noexcept { return output_offset + output_gain * m; }
  double model_output(double y) const noexcept { return (y - output_offset) / output_gain; }
  bool operator==(const UnitsMap&) const = default;
};

// Classical PI, Eq. 3 plus an optional direct term:  y = q x + sum_i p_i F_{r_i}[x].
// Free thresholds r_i >= 0 and weights p_i (any sign). Eq. 3 is q = 0.
struct PiParams {
  double q = 0.0;
  std::vector<double> r;
  std::vector<double> p;
  Limits input_limits;  // saturation limits of the inverse (optional)
  UnitsMap units;
};

// Generalized PI, Eq. 6:  y = q gamma(x) + sum_{i=1..n} p(r_i) y_i,  with
// r_i = alpha i (Eq. 7) and p(r_i) = rho exp(-tau r_i) (Eq. 8).
// Free-weight variant: when `r` is non-empty, r and p are used as given and
// n, rho, tau, alpha are ignored.
struct GpiParams {
  Envelope envelope = Envelope::tanh(1.0, 1.0, 0.0, 0.0);  // Eq. 5
  double q = 1.0;
  int n = 10;
  double rho = 0.0;
  double tau = 0.0;
  double alpha = 0.0;
  std::vector<double> r;
  std::vector<double> p;
  Limits input_limits;
  UnitsMap units;
};

// Modified PI with one-sided dead zones (Kuhnen; mpi-deadzone-switching-valves.txt):
//   v = q x + sum_i p_i F_{r_i}[x],   y = g0 v + sum_k g_k S_{z_k}(v),  z_k != 0.
struct MpiDeadzoneParams {
  double q = 1.0;
  std::vector<double> r;
  std::vector<double> p;
  double g0 = 1.0;
  std::vector<double> z;
  std::vector<double> g;
  Limits input_limits;
  UnitsMap units;
};

// Modified PI with asymmetric ascending/descending operators (see above):
//   y = q (gamma_a(x) + gamma_d(x)) / 2 + sum_i p_i A_{r_i}[x].
struct MpiAsymParams {
  Envelope ascending = Envelope::identity();
  Envelope descending = Envelope::identity();
  double q = 1.0;
  std::vector<double> r;
  std::vector<double> p;
  Limits input_limits;
  UnitsMap units;
};

// ---- kinds beyond the PI family (docs/models.md, "Other model kinds") ----------------
// They run on their own per-sample kernels (src/core/kernels.cpp); their exact inverse is
// computed per sample by monotone bracketing (inverse.hpp). Model coordinates as above.

// Preisach (relay hysterons) and Krasnosel'skii-Pokrovskii (ramp hysterons) on a
// triangular grid over [lo, hi] (Mayergoyz 2003, ch. 1; Krasnosel'skii & Pokrovskii 1989):
//   t_k = lo + k h,  h = (hi - lo) / levels,  k = 0..levels
//   hysteron (i, j), 0 <= j <= i < levels: up at alpha_i = t_{i+1}, down at beta_j = t_j
//   y = q x + sum_{j<=i} w_ij R_ij[x],   w stored row by row: w[i (i + 1) / 2 + j]
// preisach: R_ij is the relay with outputs 0 / 1; its memory is the staircase of the
//   Preisach plane (per row alpha_i the number of relays on), i.e. the wiping-out stack
//   of input extrema quantised to the grid: a step costs O(levels).
// kp: R_ij is the ramp play  max(s((x - t_i) / h), min(s((x - t_j) / h), R))  with
//   s = clamp(., 0, 1): the relay with its jump spread over one grid cell (continuous
//   output). A step costs O(levels^2).
// Invertible (strictly increasing in x for every state) when q > 0 and every w_ij >= 0.
struct PreisachGrid {
  double q = 0.0;
  double lo = 0.0;
  double hi = 1.0;
  int levels = 0;  // 1..max_levels
  std::vector<double> w;
  Limits input_limits;
  UnitsMap units;
};
inline constexpr int max_preisach_levels = 200;
struct PreisachParams : PreisachGrid {};
struct KpParams : PreisachGrid {};

// Bouc-Wen in its normalised form (Ikhouane & Rodellar 2007), integrated over the input
// increment of each sample (rate-independent: only the sampled input path matters):
//   y = kx x + kw w,   dw/dx = rho (1 - (sigma sgn(dx w) + 1 - sigma) |w|^n),  |w| <= 1
// explicit steps of 1 / (2 rho n) per input increment (kernels.hpp: bouc_wen_increment), w
// clamped to [-1, 1] (the bound of the exact solution).
// rho > 0, sigma >= 0, 1 <= n <= 20. kw > 0 gives clockwise (elasto-plastic) loops,
// kw < 0 the counterclockwise loops of actuators (y = d x - h, the piezo form).
// Invertible when kx + min(kw, 0) rho max(1, 2 sigma) > 0 (dw/dx <= rho max(1, 2 sigma)).
// The largest dw/dx of the Bouc-Wen state over |w| <= 1 and both directions:
// rho max(1, 2 sigma). The smallest slope of the output is kx + min(kw, 0) times it.
// (T = double, or an automatic-differentiation scalar in the fit.)
template <class T>
T bouc_wen_max_dwdx(const T& rho, const T& sigma) {
  return sigma > T(0.5) ? T(2.0) * sigma * rho : rho;
}

struct BoucWenParams {
  double kx = 1.0;
  double kw = 0.0;
  double rho = 1.0;
  double sigma = 0.5;
  double n = 1.0;
  Limits input_limits;
  UnitsMap units;
};

// Maxwell-slip: a spring k0 in parallel with elasto-slide elements (spring k_i in series
// with a slider that slips at deflection delta_i; Lampaert et al. 2002):
//   y = k0 x + sum_i k_i E_{delta_i}[x],   E_d[x] = x - F_d[x]  (stop = input - play)
// exactly a PI with q = k0 + sum k_i, r_i = delta_i, p_i = -k_i (canonical_structure).
// k_i >= 0, delta_i >= 0; invertible when k0 > 0.
struct MaxwellSlipParams {
  double k0 = 1.0;
  std::vector<double> k;
  std::vector<double> delta;
  Limits input_limits;
  UnitsMap units;
};

// Rate-dependent PI: plays whose thresholds grow with the filtered input rate
// (after Al Janaideh et al. 2009, with a causal rate):
//   r_i(k) = r_i (1 + c rate(k-1)),  rate(k) = rate(k-1) + dt / (tau + dt) (|x_k - x_{k-1}| / dt - rate(k-1))
//   y = q x + sum_i p_i F_{r_i(k)}[x]
// The thresholds of a sample are fixed before its input is known, so each sample is a
// PI step and the inverse is exact. dt [s] is the sample time the model runs at.
// c >= 0 [s per input unit], tau >= 0 [s], dt > 0, and c max(r_i) <= (tau + dt) / 2 (a
// threshold moves slower than the input). Invertible when q > 0 and p_i >= 0.
struct RatePiParams {
  double q = 1.0;
  std::vector<double> r;
  std::vector<double> p;
  double c = 0.0;
  double tau = 0.0;
  double dt = 1e-3;
  Limits input_limits;
  UnitsMap units;
};

using ModelParams = std::variant<PiParams, GpiParams, MpiDeadzoneParams, MpiAsymParams, PreisachParams, KpParams,
                                 BoucWenParams, MaxwellSlipParams, RatePiParams>;

// "pi", "gpi", "mpi-deadzone", "mpi-asym", "preisach", "kp", "bouc-wen", "maxwell-slip",
// "rate-pi".
std::string_view model_name(const ModelParams& params) noexcept;
// True for the kinds that reduce to Structure (pi, gpi, mpi-deadzone, mpi-asym,
// maxwell-slip); the others run on their own kernels.
bool has_pi_structure(const ModelParams& params) noexcept;
const Limits& input_limits(const ModelParams& params) noexcept;
const UnitsMap& units_map(const ModelParams& params) noexcept;
UnitsMap& units_map(ModelParams& params) noexcept;

// The same model with input_scale = +-1 and output_gain = +-1: the scales' magnitudes are
// absorbed into the kind's own parameters, so that they read in the user's units
//   identity envelope (pi, mpi-deadzone):  r -> a r,  q, p -> (b / a) q, p,  z -> b z
//   other envelopes (gpi, mpi-asym):       gamma(x) -> b gamma(x / a),  r -> b r,
//                                          alpha -> b alpha,  tau -> tau / b
// with a = |input_scale|, b = |output_gain| (an identity envelope of gpi/mpi-asym becomes
// affine); the signs stay (a mirrored model stays mirrored). input_origin and output_offset
// stay. Exact up to rounding.
ModelParams absorb_scales(const ModelParams& params);

// The canonical structure every model reduces to (see the top of this file),
// templated on the scalar so identification can differentiate through it.
// Thresholds are strictly increasing and positive: operators with r = 0 are
// folded into q, equal thresholds merged. Dead zones: z sorted increasing.
template <class T>
struct Structure {
  EnvelopeKind asc_kind = EnvelopeKind::identity;
  EnvelopeKind desc_kind = EnvelopeKind::identity;
  std::array<T, 4> asc_c{T(1), T(0), T(0), T(0)};
  std::array<T, 4> desc_c{T(1), T(0), T(0), T(0)};
  bool asymmetric = false;
  T q = T(0);
  std::vector<T> r;
  std::vector<T> p;
  bool has_dead_zones = false;
  T g0 = T(1);
  std::vector<T> z;
  std::vector<T> g;
  // Raw units <-> model coordinates (applied by Model, Inverse and Rls around the
  // structure; structure_step works in model coordinates). The per-sample steps
  // multiply by the reciprocals (set with `units` by canonical_structure; exact for
  // the identity map and for the +-1 gains fit() writes).
  UnitsMap units;
  double inv_input_scale = 1.0;  // 1 / units.input_scale
  double inv_output_gain = 1.0;  // 1 / units.output_gain
  double to_model(double x) const noexcept { return (x - units.input_origin) * inv_input_scale; }
  double model_output(double y) const noexcept { return (y - units.output_offset) * inv_output_gain; }
};

// Dead-zone output map  g0 v + sum_k g_k S_{z_k}(v).
template <class T>
inline T dead_zone_map(const Structure<T>& s, const T& v) {
  T out = s.g0 * v;
  for (std::size_t k = 0; k < s.z.size(); ++k) out += s.g[k] * ops::dead_zone<T>(v, s.z[k]);
  return out;
}

// sum_i p_i y_i with four partial sums: breaks the floating-point dependency
// chain (about 3x faster for n >= 8) and is still deterministic.
template <class T>
inline T weighted_sum(const T* p, const T* y, std::size_t n) {
  T s0(0), s1(0), s2(0), s3(0);
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += p[i] * y[i];
    s1 += p[i + 1] * y[i + 1];
    s2 += p[i + 2] * y[i + 2];
    s3 += p[i + 3] * y[i + 3];
  }
  for (; i < n; ++i) s0 += p[i] * y[i];
  return (s0 + s1) + (s2 + s3);
}

// One sample of the model: updates the operator outputs y[0..n) in place and
// returns the model output. Allocation-free; works for double and Jets.
// If u_out is given it receives gamma_a(x).
template <class T, class X>
inline T structure_step(const Structure<T>& s, const X& x, T* y, T* u_out = nullptr) {
  const T u_a = envelope_value<T>(s.asc_kind, s.asc_c.data(), x);
  if (u_out) *u_out = u_a;
  const std::size_t n = s.r.size();
  const T* r = s.r.data();
  T v;
  if (!s.asymmetric) {
    for (std::size_t i = 0; i < n; ++i) y[i] = ops::generalized_play<T>(u_a, r[i], y[i]);
    v = s.q * u_a;
  } else {
    const T u_d = envelope_value<T>(s.desc_kind, s.desc_c.data(), x);
    for (std::size_t i = 0; i < n; ++i) y[i] = ops::asymmetric_play<T>(u_a, u_d, r[i], y[i]);
    v = s.q * (u_a + u_d) * T(0.5);
  }
  v += weighted_sum<T>(s.p.data(), y, n);
  return s.has_dead_zones ? dead_zone_map(s, v) : v;
}

// Validates `params` and builds the canonical structure. Throws hysteron::Error
// with a message naming the offending key (e.g. "gpi: alpha must be > 0"), and for a
// kind without PI structure (has_pi_structure false).
Structure<double> canonical_structure(const ModelParams& params);

// Forward-model state: operator outputs y_i and the envelope value u = gamma(x)
// of the last input (0 in the virgin state; used to start an inverse).
struct ModelState {
  std::vector<double> y;
  double u = 0.0;
};

namespace detail {
class Kernel;  // per-sample kernel of a kind without PI structure (src/core/kernels.hpp)
struct KernelCopy {
  std::unique_ptr<Kernel> p;
  KernelCopy() = default;
  explicit KernelCopy(std::unique_ptr<Kernel> k) noexcept;
  KernelCopy(const KernelCopy& o);
  KernelCopy(KernelCopy&&) noexcept;
  KernelCopy& operator=(const KernelCopy& o);
  KernelCopy& operator=(KernelCopy&&) noexcept;
  ~KernelCopy();
  Kernel* get() const noexcept { return p.get(); }
  explicit operator bool() const noexcept { return static_cast<bool>(p); }
};
}  // namespace detail

// Validates any kind's parameters (canonical_structure for the PI family, the kernel's
// checks for the others). Throws hysteron::Error naming the key.
void validate_model(const ModelParams& params);

// A hysteresis model ready to run sample by sample.
class Model {
 public:
  explicit Model(ModelParams params);  // throws hysteron::Error on invalid params

  const ModelParams& params() const noexcept { return params_; }
  std::string_view name() const noexcept { return model_name(params_); }
  // The canonical structure (PI family; for the other kinds only `units` is set).
  const Structure<double>& structure() const noexcept { return s_; }
  std::size_t num_operators() const noexcept { return s_.r.size(); }

  // Virgin state y_i0 = 0 (Eq. 2 applies it at the first sample).
  void reset() noexcept;
  // Explicit initial state; throws hysteron::Error on a size mismatch or a non-finite value.
  void reset(const ModelState& state);
  // Initial state relaxed at (raw) input x0: y_i = gamma(x0), as if x0 had been held forever.
  // Returns false and changes nothing if step() would refuse x0 (!accepts(x0)).
  bool reset_relaxed(double x0) noexcept;

  // One sample. Never allocates, never throws. A non-finite input, or one so large that
  // the output could overflow (!accepts(x)), leaves the state unchanged, returns the
  // previous output and is counted in faults().
  double step(double x) noexcept;
  // Whether step(x) takes x: finite, and |x - input_origin| / input_scale <= input_bound().
  bool accepts(double x) const noexcept { return std::abs(s_.to_model(x)) <= x_max_; }
  // The largest |input| in model coordinates whose output (and every intermediate of the
  // step) stays within DBL_MAX / 16 for every reachable state: derived from the weights,
  // envelopes and units map (about DBL_MAX / 16 / (sum of |weights| |output_gain|)), far
  // beyond any physical input.
  double input_bound() const noexcept { return x_max_; }
  // The PI family: the bound on |u| and |y_i| (model coordinates) of a state from which no
  // step can overflow (the larger of what the accepted inputs reach and what the weights
  // can sum below DBL_MAX / 16); reset(ModelState) refuses a state beyond it.
  double state_bound() const noexcept;
  // Batch: y[k] = step(x[k]). Throws hysteron::Error on unequal sizes or an x[k] that
  // step() would refuse (non-finite or beyond input_bound()).
  void simulate(std::span<const double> x, std::span<double> y);
  std::vector<double> simulate(std::span<const double> x);

  // The state: operator outputs (PI family) or the kernel's state vector (the other
  // kinds: preisach the relays on per row, kp the ramp outputs, bouc-wen [x, w],
  // rate-pi [y_1..y_n, x, rate], all in model coordinates), and u.
  const ModelState& state() const noexcept;
  double output() const noexcept { return out_; }
  std::size_t faults() const noexcept { return faults_; }

  // Everything step() changes, as numbers: state().y, state().u, output() and faults().
  // restore(snapshot()) on a model of the same parameters steps exactly as this one from here
  // on, faults() included (a running model saved and loaded again, e.g. Python's pickle).
  // restore throws hysteron::Error, the model unchanged, on a snapshot of another size, a state
  // that reset(const ModelState&) refuses, a non-finite output or a fault count that is no count.
  std::vector<double> snapshot() const;
  void restore(std::span<const double> snapshot);

 private:
  double step_symmetric(double x, double* y) noexcept;

  ModelParams params_;
  Structure<double> s_;
  FastEnvelope env_;  // gamma of the symmetric models (all but mpi-asym)
  detail::KernelCopy kernel_;  // the kinds without PI structure
  mutable ModelState state_;
  double out_ = 0.0;
  std::size_t faults_ = 0;
  double x_max_ = 0.0;  // input_bound()
};

}  // namespace hysteron
