#include "hysteron/models.hpp"

#include "format.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <type_traits>
#include <utility>

#include "hysteron/error.hpp"
#include "kernels.hpp"
#include "play_kernel.hpp"
#include "validate.hpp"

namespace hysteron {

namespace {

struct NameVisitor {
  std::string_view operator()(const PiParams&) const { return "pi"; }
  std::string_view operator()(const GpiParams&) const { return "gpi"; }
  std::string_view operator()(const MpiDeadzoneParams&) const { return "mpi-deadzone"; }
  std::string_view operator()(const MpiAsymParams&) const { return "mpi-asym"; }
  std::string_view operator()(const PreisachParams&) const { return "preisach"; }
  std::string_view operator()(const KpParams&) const { return "kp"; }
  std::string_view operator()(const BoucWenParams&) const { return "bouc-wen"; }
  std::string_view operator()(const MaxwellSlipParams&) const { return "maxwell-slip"; }
  std::string_view operator()(const RatePiParams&) const { return "rate-pi"; }
};

using detail::check_limits;
using detail::require_finite;

// Thresholds and weights of the operators: equal lengths, finite, r >= 0.
// Sorts by threshold, folds r = 0 into q and merges equal thresholds.
void add_operators(Structure<double>& s, const std::vector<double>& r, const std::vector<double>& p,
                   std::string_view model) {
  if (r.size() != p.size())
    throw Error(detail::format("{}: r has {} entries but p has {} (one weight per threshold)", model, r.size(), p.size()));
  if (r.size() > max_operators)
    throw Error(detail::format("{}: r has {} entries; at most {} operators are supported", model, r.size(), max_operators));
  std::vector<std::size_t> idx(r.size());
  std::iota(idx.begin(), idx.end(), 0);
  for (std::size_t i = 0; i < r.size(); ++i) {
    require_finite(r[i], model, detail::format("r[{}]", i));
    require_finite(p[i], model, detail::format("p[{}]", i));
    if (r[i] < 0) throw Error(detail::format("{}: r[{}] = {} must be >= 0 (play thresholds are half-widths)", model, i, r[i]));
  }
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return r[a] < r[b]; });
  for (std::size_t k : idx) {
    if (r[k] == 0.0) {
      s.q += p[k];  // a play with zero threshold is the identity
    } else if (!s.r.empty() && s.r.back() == r[k]) {
      s.p.back() += p[k];
    } else {
      s.r.push_back(r[k]);
      s.p.push_back(p[k]);
    }
  }
}

// The units map of `model` whose raw input_limits are `lim`: finite; the scale and gain that
// the map divides by normal with normal reciprocals; the offset and origin within DBL_MAX / 32
// (the outputs are kept within DBL_MAX / 16: an offset beyond leaves the model no input it
// accepts); and finite input_limits mapped to a finite range of model coordinates that is not
// one point (an origin of 1e308 maps [0, 0.6] onto one double). Since 2026-12-01; before, such a
// map loaded and broke every step.
void check_units(const UnitsMap& u, const Limits& lim, std::string_view model) {
  require_finite(u.input_origin, model, "input_origin");
  require_finite(u.output_offset, model, "output_offset");
  require_finite(u.input_scale, model, "input_scale");
  require_finite(u.output_gain, model, "output_gain");
  if (u.input_scale == 0.0)
    throw Error(detail::format("{}: input_scale must be != 0 (< 0 mirrors the input), got 0", model));
  if (u.output_gain == 0.0) throw Error(detail::format("{}: output_gain must be != 0 (the output would be constant)", model));
  constexpr double tiny = std::numeric_limits<double>::min();  // DBL_MIN
  constexpr double huge = 1.0 / tiny;                          // its reciprocal, 4.49e307
  constexpr double far = std::numeric_limits<double>::max() / 32;
  for (const auto& [key, v] : {std::pair<const char*, double>{"input_scale", u.input_scale}, {"output_gain", u.output_gain}})
    if (!(std::abs(v) >= tiny && std::abs(v) <= huge))
      throw Error(detail::format("{}: {} = {}: |{}| must be within [{}, {}] (DBL_MIN and 1 / DBL_MIN: the units map "
                                 "divides by it, and it and its reciprocal must be normal numbers)",
                                 model, key, v, key, tiny, huge));
  for (const auto& [key, v] :
       {std::pair<const char*, double>{"input_origin", u.input_origin}, {"output_offset", u.output_offset}})
    if (!(std::abs(v) <= far))
      throw Error(detail::format("{}: {} = {}: |{}| must be at most DBL_MAX / 32 = {} (the model's outputs, "
                                 "output_offset + output_gain M((x - input_origin) / input_scale), must stay finite)",
                                 model, key, v, key, far));
  const double a = u.to_model(lim.lo), b = u.to_model(lim.hi);  // of a finite side (an infinite one stays so)
  if ((std::isfinite(lim.lo) && !std::isfinite(a)) || (std::isfinite(lim.hi) && !std::isfinite(b)) ||
      (std::isfinite(lim.lo) && std::isfinite(lim.hi) && !(a != b))) {
    const Limits m = u.to_model(lim);
    throw Error(detail::format("{}: input_limits [{}, {}] map to [{}, {}] in model coordinates ((x - input_origin) / "
                               "input_scale, input_origin = {}, input_scale = {}): not a finite range of more than "
                               "one point; input_origin and input_scale must be of the limits' magnitude (an "
                               "unbounded side is null in a model file, not +-1e308)",
                               model, lim.lo, lim.hi, m.lo, m.hi, u.input_origin, u.input_scale));
  }
}

void set_envelope(std::array<double, 4>& c, EnvelopeKind& kind, const Envelope& e) {
  kind = e.kind;
  c = e.c;
}

struct CanonicalVisitor {
  Structure<double> operator()(const PiParams& m) const {
    Structure<double> s;
    require_finite(m.q, "pi", "q");
    check_limits(m.input_limits, "pi");
    s.q = m.q;
    add_operators(s, m.r, m.p, "pi");
    if (s.r.empty() && s.q == 0.0) throw Error("pi: the model has no operator and q = 0 (output is constant)");
    return s;
  }
  Structure<double> operator()(const GpiParams& m) const {
    Structure<double> s;
    m.envelope.validate("gpi: c");
    check_limits(m.input_limits, "gpi");
    require_finite(m.q, "gpi", "q");
    if (!(m.q > 0)) throw Error(detail::format("gpi: q must be > 0 (Eq. 6), got {}", m.q));
    set_envelope(s.asc_c, s.asc_kind, m.envelope);
    set_envelope(s.desc_c, s.desc_kind, m.envelope);
    s.q = m.q;
    if (!m.r.empty() || !m.p.empty()) {
      add_operators(s, m.r, m.p, "gpi");
    } else {
      if (m.n < 0 || static_cast<std::size_t>(m.n) > max_operators)
        throw Error(detail::format("gpi: n must be in 0..{}, got {}", max_operators, m.n));
      require_finite(m.rho, "gpi", "rho");
      require_finite(m.tau, "gpi", "tau");
      require_finite(m.alpha, "gpi", "alpha");
      if (m.n > 0) {
        if (!(m.alpha > 0)) throw Error(detail::format("gpi: alpha must be > 0 (Eq. 7, r_i = alpha i), got {}", m.alpha));
        if (!(m.rho > 0)) throw Error(detail::format("gpi: rho must be > 0 (Eq. 8), got {}", m.rho));
        if (!(m.tau > 0)) throw Error(detail::format("gpi: tau must be > 0 (Eq. 8), got {}", m.tau));
      }
      for (int i = 1; i <= m.n; ++i) {
        const double ri = m.alpha * i;                  // Eq. 7
        s.r.push_back(ri);
        s.p.push_back(m.rho * std::exp(-m.tau * ri));  // Eq. 8
      }
    }
    return s;
  }
  Structure<double> operator()(const MpiDeadzoneParams& m) const {
    Structure<double> s;
    require_finite(m.q, "mpi-deadzone", "q");
    require_finite(m.g0, "mpi-deadzone", "g0");
    check_limits(m.input_limits, "mpi-deadzone");
    s.q = m.q;
    add_operators(s, m.r, m.p, "mpi-deadzone");
    if (m.z.size() > max_operators)
      throw Error(detail::format("mpi-deadzone: z has {} entries; at most {} dead zones are supported", m.z.size(), max_operators));
    if (m.z.size() != m.g.size())
      throw Error(detail::format("mpi-deadzone: z has {} entries but g has {} (one weight per dead zone)", m.z.size(), m.g.size()));
    s.has_dead_zones = true;
    s.g0 = m.g0;
    std::vector<std::size_t> idx(m.z.size());
    std::iota(idx.begin(), idx.end(), 0);
    for (std::size_t i = 0; i < m.z.size(); ++i) {
      require_finite(m.z[i], "mpi-deadzone", detail::format("z[{}]", i));
      require_finite(m.g[i], "mpi-deadzone", detail::format("g[{}]", i));
    }
    std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return m.z[a] < m.z[b]; });
    for (std::size_t k : idx) {
      if (m.z[k] == 0.0) {
        s.g0 += m.g[k];
      } else if (!s.z.empty() && s.z.back() == m.z[k]) {
        s.g.back() += m.g[k];
      } else {
        s.z.push_back(m.z[k]);
        s.g.push_back(m.g[k]);
      }
    }
    return s;
  }
  Structure<double> operator()(const MpiAsymParams& m) const {
    Structure<double> s;
    m.ascending.validate("mpi-asym: ascending");
    m.descending.validate("mpi-asym: descending");
    require_finite(m.q, "mpi-asym", "q");
    check_limits(m.input_limits, "mpi-asym");
    set_envelope(s.asc_c, s.asc_kind, m.ascending);
    set_envelope(s.desc_c, s.desc_kind, m.descending);
    s.asymmetric = !(m.ascending == m.descending);
    s.q = m.q;
    add_operators(s, m.r, m.p, "mpi-asym");
    return s;
  }
  // y = k0 x + sum k_i (x - F_{delta_i}[x]):  q = k0 + sum k_i, r_i = delta_i, p_i = -k_i.
  Structure<double> operator()(const MaxwellSlipParams& m) const {
    Structure<double> s;
    require_finite(m.k0, "maxwell-slip", "k0");
    check_limits(m.input_limits, "maxwell-slip");
    if (m.k.size() != m.delta.size())
      throw Error(detail::format("maxwell-slip: k has {} entries but delta has {} (one slip deflection per element)",
                                 m.k.size(), m.delta.size()));
    std::vector<double> p(m.k.size());
    s.q = m.k0;
    for (std::size_t i = 0; i < m.k.size(); ++i) {
      require_finite(m.k[i], "maxwell-slip", detail::format("k[{}]", i));
      if (m.k[i] < 0) throw Error(detail::format("maxwell-slip: k[{}] = {} must be >= 0 (a spring stiffness)", i, m.k[i]));
      s.q += m.k[i];
      p[i] = -m.k[i];
    }
    for (std::size_t i = 0; i < m.delta.size(); ++i)
      if (std::isfinite(m.delta[i]) && m.delta[i] < 0)
        throw Error(detail::format("maxwell-slip: delta[{}] = {} must be >= 0 (a slip deflection)", i, m.delta[i]));
    add_operators(s, m.delta, p, "maxwell-slip");
    if (s.r.empty() && s.q == 0.0) throw Error("maxwell-slip: the model has no element and k0 = 0 (output is constant)");
    return s;
  }
  template <class Other>
  Structure<double> operator()(const Other&) const {
    return {};  // kinds without PI structure: refused by canonical_structure
  }
};

}  // namespace

std::string_view model_name(const ModelParams& params) noexcept { return std::visit(NameVisitor{}, params); }

const Limits& input_limits(const ModelParams& params) noexcept {
  return std::visit([](const auto& m) -> const Limits& { return m.input_limits; }, params);
}

const UnitsMap& units_map(const ModelParams& params) noexcept {
  return std::visit([](const auto& m) -> const UnitsMap& { return m.units; }, params);
}

UnitsMap& units_map(ModelParams& params) noexcept {
  return std::visit([](auto& m) -> UnitsMap& { return m.units; }, params);
}

namespace {

// gamma(x) -> b gamma(x / a)
Envelope scaled_envelope(const Envelope& e, double a, double b) {
  switch (e.kind) {
    case EnvelopeKind::identity: return Envelope::affine(b / a, 0.0);
    case EnvelopeKind::affine: return Envelope::affine(b * e.c[0] / a, b * e.c[1]);
    case EnvelopeKind::tanh: return Envelope::tanh(b * e.c[0], e.c[1] / a, e.c[2], b * e.c[3]);
    case EnvelopeKind::atan: return Envelope::atan(b * e.c[0], e.c[1] / a, e.c[2], b * e.c[3]);
  }
  return e;
}

void scale_all(std::vector<double>& v, double f) {
  for (double& x : v) x *= f;
}

struct AbsorbVisitor {
  double a, b;
  ModelParams operator()(PiParams m) const {
    m.q *= b / a;
    scale_all(m.p, b / a);
    scale_all(m.r, a);
    return m;
  }
  ModelParams operator()(MpiDeadzoneParams m) const {
    m.q *= b / a;
    scale_all(m.p, b / a);
    scale_all(m.r, a);
    scale_all(m.z, b);
    return m;
  }
  ModelParams operator()(GpiParams m) const {
    m.envelope = scaled_envelope(m.envelope, a, b);
    m.alpha *= b;
    m.tau /= b;
    scale_all(m.r, b);
    return m;
  }
  ModelParams operator()(MpiAsymParams m) const {
    m.ascending = scaled_envelope(m.ascending, a, b);
    m.descending = scaled_envelope(m.descending, a, b);
    scale_all(m.r, b);
    return m;
  }
  // y = q x + sum w R[x] on the grid t_k:  t -> a t,  q -> (b / a) q,  w -> b w.
  template <class G>
    requires std::is_base_of_v<PreisachGrid, G>
  ModelParams operator()(G m) const {
    m.q *= b / a;
    m.lo *= a;
    m.hi *= a;
    scale_all(m.w, b);
    return m;
  }
  // w is unitless: kx -> (b / a) kx, kw -> b kw, rho -> rho / a.
  ModelParams operator()(BoucWenParams m) const {
    m.kx *= b / a;
    m.kw *= b;
    m.rho /= a;
    return m;
  }
  ModelParams operator()(MaxwellSlipParams m) const {
    m.k0 *= b / a;
    scale_all(m.k, b / a);
    scale_all(m.delta, a);
    return m;
  }
  // the rate is in input units per second: c -> c / a.
  ModelParams operator()(RatePiParams m) const {
    m.q *= b / a;
    scale_all(m.p, b / a);
    scale_all(m.r, a);
    m.c /= a;
    return m;
  }
};

}  // namespace

ModelParams absorb_scales(const ModelParams& params) {
  const UnitsMap u = units_map(params);
  const double a = std::abs(u.input_scale), b = std::abs(u.output_gain);
  if (a == 1.0 && b == 1.0) return params;
  ModelParams out = std::visit(AbsorbVisitor{a, b}, params);
  units_map(out).input_scale = u.input_scale < 0 ? -1.0 : 1.0;
  units_map(out).output_gain = u.output_gain < 0 ? -1.0 : 1.0;
  return out;
}

bool has_pi_structure(const ModelParams& params) noexcept { return !detail::has_kernel(params); }

Structure<double> canonical_structure(const ModelParams& params) {
  if (!has_pi_structure(params))
    throw Error(detail::format(
        "{}: {}; this operation supports pi, gpi, mpi-deadzone, mpi-asym and maxwell-slip", model_name(params),
        std::holds_alternative<RatePiParams>(params)
            ? "rate-dependent (its plays' thresholds move with the input's rate, through its dt): not supported, "
              "the fixed play structure of the Prandtl-Ishlinskii family it needs does not hold"
            : "not a model of the Prandtl-Ishlinskii family (it has no play structure)"));
  Structure<double> s = std::visit(CanonicalVisitor{}, params);
  check_units(units_map(params), input_limits(params), model_name(params));
  s.units = units_map(params);
  s.inv_input_scale = 1.0 / s.units.input_scale;
  s.inv_output_gain = 1.0 / s.units.output_gain;
  return s;
}

namespace detail {
KernelCopy::KernelCopy(std::unique_ptr<Kernel> k) noexcept : p(std::move(k)) {}
KernelCopy::KernelCopy(const KernelCopy& o) : p(o.p ? o.p->clone() : nullptr) {}
KernelCopy::KernelCopy(KernelCopy&&) noexcept = default;
KernelCopy& KernelCopy::operator=(const KernelCopy& o) {
  if (this != &o) p = o.p ? o.p->clone() : nullptr;
  return *this;
}
KernelCopy& KernelCopy::operator=(KernelCopy&&) noexcept = default;
KernelCopy::~KernelCopy() = default;
}  // namespace detail

Structure<double> detail::structure_of(const ModelParams& params) {
  if (has_pi_structure(params)) return canonical_structure(params);
  check_units(units_map(params), input_limits(params), model_name(params));
  Structure<double> s;
  s.units = units_map(params);
  s.inv_input_scale = 1.0 / s.units.input_scale;
  s.inv_output_gain = 1.0 / s.units.output_gain;
  return s;
}

namespace detail {

namespace {
// |gamma(x)| <= a |x| + b.
void envelope_bound(EnvelopeKind kind, const std::array<double, 4>& c, double& a, double& b) {
  const Envelope e{kind, c};
  const double lo = e.range_lo(), hi = e.range_hi();
  if (std::isfinite(lo) && std::isfinite(hi)) {
    a = 0.0, b = std::max(std::abs(lo), std::abs(hi));
  } else if (kind == EnvelopeKind::affine) {
    a = std::abs(c[0]), b = std::abs(c[1]);
  } else {
    a = 1.0, b = 0.0;
  }
}

// |u| <= ea |x_m| + eb for the envelope value u of any input x_m (both envelopes of mpi-asym).
void envelopes_bound(const Structure<double>& s, double& ea, double& eb) {
  envelope_bound(s.asc_kind, s.asc_c, ea, eb);
  if (s.asymmetric) {
    double da = 0.0, db = 0.0;
    envelope_bound(s.desc_kind, s.desc_c, da, db);
    ea = std::max(ea, da), eb = std::max(eb, db);
  }
}
}  // namespace

double state_bound(const Structure<double>& s, double x_max) noexcept {
  double ea = 0.0, eb = 0.0;  // what the accepted inputs reach: |u| <= ea x_max + eb
  envelopes_bound(s, ea, eb);
  const double reach = ea == 0 ? eb : std::min(ea * x_max + eb, std::numeric_limits<double>::max());
  // |output| <= |offset| + gain g (w Y + sum |g_k z_k|) for |u|, |y_i| <= Y: within DBL_MAX / 16
  constexpr double big = std::numeric_limits<double>::max() / 16;
  double w = std::abs(s.q), g = 1.0, gz = 0.0;
  for (double p : s.p) w += std::abs(p);
  if (s.has_dead_zones) {
    g = std::abs(s.g0);
    for (std::size_t k = 0; k < s.g.size(); ++k) g += std::abs(s.g[k]), gz += std::abs(s.g[k] * s.z[k]);
  }
  const double gain = std::max(1.0, std::abs(s.units.output_gain));
  const double safe = ((big - std::abs(s.units.output_offset)) / gain / std::max(g, 1.0) - gz) / std::max(w, 1.0);
  return std::max(reach, safe > 0 ? safe : 0.0);
}

void check_state_bound(std::string_view what, const Structure<double>& s, double x_max, const ModelState& state) {
  const double bound = state_bound(s, x_max);
  if (!(std::abs(state.u) <= bound))
    throw Error(detail::format("{} u = {} is so large that the model's output could overflow (|u| <= {})", what, state.u,
                               bound));
  for (std::size_t i = 0; i < state.y.size(); ++i)
    if (!(std::abs(state.y[i]) <= bound))
      throw Error(detail::format("{} y[{}] = {} is so large that the model's output could overflow (|y_i| <= {})", what,
                                 i, state.y[i], bound));
}

double input_bound(const Structure<double>& s, const Kernel* kernel) noexcept {
  double a = 0.0, b = 0.0;  // |model output| and every intermediate <= a X + b for |x_m| <= X
  if (kernel) {
    a = b = kernel->amplification();
  } else {
    double ea = 0.0, eb = 0.0;
    envelopes_bound(s, ea, eb);
    double w = std::abs(s.q), rw = 0.0;  // plays: |y_i| <= |u| + r_i
    for (std::size_t i = 0; i < s.p.size(); ++i) w += std::abs(s.p[i]), rw += std::abs(s.p[i]) * s.r[i];
    a = w * ea, b = w * eb + rw;
    if (s.has_dead_zones) {  // |g0 v + sum g_k S(v)| <= (|g0| + sum |g_k|) |v| + sum |g_k z_k|
      double g = std::abs(s.g0), gz = 0.0;
      for (std::size_t k = 0; k < s.g.size(); ++k) g += std::abs(s.g[k]), gz += std::abs(s.g[k] * s.z[k]);
      a *= g, b = g * b + gz;
    }
    a = std::max(a, ea), b = std::max(b, eb);  // the envelope value itself
  }
  constexpr double big = std::numeric_limits<double>::max() / 16;
  const double gain = std::max(1.0, std::abs(s.units.output_gain));
  const double room = (big - std::abs(s.units.output_offset)) / gain - b;
  if (!(room > 0) || !(a >= 0)) return 0.0;
  if (!kernel && a == 0) return std::numeric_limits<double>::max();  // bounded envelopes: any finite x_m
  return std::min(room / std::max(a, 1.0), std::numeric_limits<double>::max());  // |x_m| itself too
}

}  // namespace detail

void validate_model(const ModelParams& params) {
  (void)detail::structure_of(params);
  (void)detail::make_kernel(params);
}

Model::Model(ModelParams params)
    : params_(std::move(params)), s_(detail::structure_of(params_)), env_(Envelope{s_.asc_kind, s_.asc_c}),
      kernel_(detail::make_kernel(params_)) {
  state_.y.assign(kernel_ ? kernel_.get()->state_size() : s_.r.size(), 0.0);
  x_max_ = detail::input_bound(s_, kernel_.get());
}

const ModelState& Model::state() const noexcept {
  if (kernel_) kernel_.get()->get_state(state_.y.data());
  return state_;
}

void Model::reset() noexcept {
  std::fill(state_.y.begin(), state_.y.end(), 0.0);
  if (kernel_) kernel_.get()->reset();
  state_.u = 0.0;
  out_ = 0.0;
  faults_ = 0;
}

void Model::reset(const ModelState& state) {
  const std::size_t n = state_.y.size();
  if (state.y.size() != n)
    throw Error(detail::format("{}: initial state has {} {}, the model has {}", name(), state.y.size(),
                               kernel_ ? "entries" : "operator outputs", n));
  for (std::size_t i = 0; i < state.y.size(); ++i)
    if (!std::isfinite(state.y[i])) throw Error(detail::format("{}: initial state y[{}] is not finite", name(), i));
  if (!std::isfinite(state.u)) throw Error(detail::format("{}: initial state u is not finite", name()));
  if (kernel_) kernel_.get()->set_state(state.y.data(), x_max_);
  else
    detail::check_state_bound(detail::format("{}: initial state", name()), s_, x_max_, state);
  std::copy(state.y.begin(), state.y.end(), state_.y.begin());
  state_.u = state.u;
  out_ = 0.0;
  faults_ = 0;
}

std::vector<double> Model::snapshot() const {
  std::vector<double> s = state().y;
  s.insert(s.end(), {state_.u, out_, static_cast<double>(faults_)});
  return s;
}

void Model::restore(std::span<const double> s) {
  const std::string what = detail::format("{}: snapshot", name());
  const std::size_t n = state_.y.size();
  detail::check_snapshot_size(s, n + 3, what);
  const double out = detail::snapshot_finite(s[n + 1], what + " output");
  const std::size_t faults = detail::snapshot_count(s[n + 2], what + " faults");
  reset(ModelState{{s.begin(), s.begin() + static_cast<std::ptrdiff_t>(n)}, s[n]});  // checks the state
  out_ = out;
  faults_ = faults;
}

double Model::state_bound() const noexcept { return detail::state_bound(s_, x_max_); }

bool Model::reset_relaxed(double x0) noexcept {
  if (!accepts(x0)) return false;
  if (kernel_) {
    const double xm = s_.units.to_model(x0);
    kernel_.get()->reset_relaxed(xm);
    state_.u = xm;
    faults_ = 0;
    out_ = 0.0;
    return true;
  }
  const double u = envelope_value<double>(s_.asc_kind, s_.asc_c.data(), s_.units.to_model(x0));
  if (!std::isfinite(u)) return false;
  std::fill(state_.y.begin(), state_.y.end(), u);
  state_.u = u;
  faults_ = 0;
  out_ = 0.0;
  return true;
}

// structure_step<double> for one shared envelope (pi, gpi, mpi-deadzone), with
// the plays and their weighted sum in one vectorised pass (Eqs. 4, 6).
inline double Model::step_symmetric(double x, double* y) noexcept {
  const double u = env_.value(x);
  state_.u = u;
  const double v = s_.q * u + detail::play_weighted_sum(u, s_.r.data(), s_.p.data(), y, y, s_.r.size());
  return s_.has_dead_zones ? dead_zone_map(s_, v) : v;
}

double Model::step(double x) noexcept {
  const double xm = s_.to_model(x);
  if (!(std::abs(xm) <= x_max_)) {  // non-finite, or the output could overflow (accepts)
    ++faults_;
    return out_;
  }
  if (kernel_) {
    state_.u = xm;
    out_ = s_.units.output(kernel_.get()->step(xm));
    return out_;
  }
  const double m = s_.asymmetric ? structure_step<double>(s_, xm, state_.y.data(), &state_.u) : step_symmetric(xm, state_.y.data());
  out_ = s_.units.output(m);
  return out_;
}

void Model::simulate(std::span<const double> x, std::span<double> y) {
  if (x.size() != y.size())
    throw Error(detail::format("{}: simulate: input has {} samples but output has room for {}", name(), x.size(), y.size()));
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) throw Error(detail::format("{}: simulate: input sample {} is not finite ({})", name(), k, x[k]));
    if (!accepts(x[k]))
      throw Error(detail::format("{}: simulate: input sample {} = {} is beyond the model's input bound (|x_m| <= {} in "
                                 "model coordinates; the output would overflow)", name(), k, x[k], x_max_));
  }
  double* yi = state_.y.data();
  const UnitsMap& um = s_.units;
  if (kernel_) {
    detail::Kernel& k = *kernel_.get();
    for (std::size_t i = 0; i < x.size(); ++i) y[i] = um.output(k.step(s_.to_model(x[i])));
    if (!x.empty()) state_.u = s_.to_model(x.back());
  } else if (s_.asymmetric) {
    for (std::size_t k = 0; k < x.size(); ++k) y[k] = um.output(structure_step<double>(s_, s_.to_model(x[k]), yi));
    if (!x.empty()) state_.u = envelope_value<double>(s_.asc_kind, s_.asc_c.data(), s_.to_model(x.back()));
  } else {
    for (std::size_t k = 0; k < x.size(); ++k) y[k] = um.output(step_symmetric(s_.to_model(x[k]), yi));
  }
  if (!x.empty()) out_ = y.back();
}

std::vector<double> Model::simulate(std::span<const double> x) {
  std::vector<double> y(x.size());
  simulate(x, y);
  return y;
}

}  // namespace hysteron
