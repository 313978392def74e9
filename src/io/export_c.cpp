// Generated C (docs/export.md): the per-sample arithmetic of Model::step and
// Inverse::step (src/core/models.cpp, inverse.cpp, play_kernel.hpp, envelope.hpp)
// transcribed into C99 operation by operation, with the model's constants baked in.
// Keep the two in step: tests/test_export.cpp compares them over 10^5 samples per kind.
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <numbers>
#include <string_view>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/version.hpp"
#include "export_c_text.hpp"
#include "export_loop.hpp"

namespace hysteron::io {

namespace {

using detail::comment_safe;
using detail::kInf;
using detail::num;
using detail::replace_all;

std::string array_init(const std::vector<double>& v) {
  if (v.empty()) return "{0.0}";
  std::string s = "{";
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (i) s += (i % 4 == 0) ? ",\n    " : ", ";
    s += num(v[i]);
  }
  return s + "}";
}

// Everything the inverse's constructor derives, recomputed with its arithmetic
// (src/core/inverse.cpp); the limits are checked against a real Inverse.
struct Baked {
  Structure<double> s;
  Envelope asc, desc;
  FastEnvelope fasc, fdesc;
  Limits lim;      // model coordinates
  Limits lim_raw;  // raw input units
  double u_lo = 0.0, u_hi = 0.0;
  double x_max = 0.0;   // Model::input_bound()
  double u_max = 0.0;   // Model::state_bound()
  Limits v_bounds;  // Inverse::output_bounds()
  double qi = 1.0;
  std::vector<double> ri, pi;
  std::vector<double> zp, dp, sp, zn, dn, sn;
};

Baked bake(const ModelParams& params, const Limits& user_limits) {
  // The library's own checks first (invertibility, limits), with its messages.
  const Inverse inverse(params, InverseOptions{user_limits});
  Baked b;
  b.x_max = Model(params).input_bound();
  b.u_max = Model(params).state_bound();
  b.v_bounds = inverse.output_bounds();
  b.s = canonical_structure(params);
  const Structure<double>& s = b.s;
  b.asc = Envelope{s.asc_kind, s.asc_c};
  b.desc = Envelope{s.desc_kind, s.desc_c};
  b.fasc = FastEnvelope(b.asc);
  b.fdesc = FastEnvelope(b.desc);
  const Limits& ml = input_limits(params);
  Limits lim{std::isinf(user_limits.lo) ? ml.lo : user_limits.lo, std::isinf(user_limits.hi) ? ml.hi : user_limits.hi};
  const UnitsMap& um = s.units;
  const Limits raw = lim;
  lim = um.to_model(lim);  // model coordinates (a mirrored input swaps lo and hi)
  const std::size_t n = s.r.size();
  if (!s.asymmetric) {
    b.qi = 1.0 / s.q;
    b.ri.resize(n);
    b.pi.resize(n);
    hysteron::detail::inverse_pi_parameters(s.q, s.r, s.p, b.ri.data(), b.pi.data());  // Eq. 11, as Inverse
    if (s.has_dead_zones) {
      b.zp = {0.0};
      b.dp = {0.0};
      b.sp = {s.g0};
      for (std::size_t k = 0; k < s.z.size(); ++k) {
        if (!(s.z[k] > 0)) continue;
        const double dz = s.z[k] - b.zp.back();
        b.dp.push_back(b.dp.back() + b.sp.back() * dz);
        b.zp.push_back(s.z[k]);
        b.sp.push_back(b.sp.back() + s.g[k]);
      }
      b.zn = {0.0};
      b.dn = {0.0};
      b.sn = {s.g0};
      for (std::size_t kk = s.z.size(); kk-- > 0;) {
        if (!(s.z[kk] < 0)) continue;
        const double dz = s.z[kk] - b.zn.back();
        b.dn.push_back(b.dn.back() + b.sn.back() * dz);
        b.zn.push_back(s.z[kk]);
        b.sn.push_back(b.sn.back() + s.g[kk]);
      }
    }
    const double span = b.asc.range_hi() - b.asc.range_lo();
    if (std::isinf(lim.lo) && std::isfinite(span)) lim.lo = b.asc.inverse(b.asc.range_lo() + 1e-9 * span);
    if (std::isinf(lim.hi) && std::isfinite(span)) lim.hi = b.asc.inverse(b.asc.range_hi() - 1e-9 * span);
    b.u_lo = std::isinf(lim.lo) ? -kInf : b.asc.value(lim.lo);
    b.u_hi = std::isinf(lim.hi) ? kInf : b.asc.value(lim.hi);
  }
  b.lim = lim;
  const Limits back = um.from_model(lim);
  b.lim_raw = Limits{std::isfinite(raw.lo) ? raw.lo : back.lo, std::isfinite(raw.hi) ? raw.hi : back.hi};
  if (!(b.lim_raw == inverse.limits()))
    throw std::logic_error(fmt::format("export: the inverse's limits [{}, {}] differ from the library's [{}, {}]",
                                       b.lim_raw.lo, b.lim_raw.hi, inverse.limits().lo, inverse.limits().hi));
  return b;
}

// ---- C text ---------------------------------------------------------------------

// gamma(x) of one envelope as a C expression in `x` (envelope_value / FastEnvelope::value).
std::string envelope_expr(const FastEnvelope& e, std::string_view x) {
  switch (e.kind) {
    case EnvelopeKind::identity: return std::string(x);
    case EnvelopeKind::affine: return fmt::format("{} * {} + {}", num(e.c0), x, num(e.c1));
    case EnvelopeKind::tanh: return fmt::format("{} * $P_tanh({} * {} + {}) + {}", num(e.c0), num(e.c1), x, num(e.c2), num(e.c3));
    case EnvelopeKind::atan: return fmt::format("{} * atan({} * {} + {}) + {}", num(e.c0), num(e.c1), x, num(e.c2), num(e.c3));
  }
  return std::string(x);
}

std::string envelope_formula(const Envelope& e) {
  switch (e.kind) {
    case EnvelopeKind::identity: return "x_m  (identity)";
    case EnvelopeKind::affine: return fmt::format("c0 x_m + c1  (affine),  c = [{}, {}]", num(e.c[0]), num(e.c[1]));
    case EnvelopeKind::tanh:
      return fmt::format("c0 tanh(c1 x_m + c2) + c3  (tanh, Eq. 5),  c = [{}, {}, {}, {}]", num(e.c[0]), num(e.c[1]),
                         num(e.c[2]), num(e.c[3]));
    case EnvelopeKind::atan:
      return fmt::format("c0 atan(c1 x_m + c2) + c3  (atan),  c = [{}, {}, {}, {}]", num(e.c[0]), num(e.c[1]),
                         num(e.c[2]), num(e.c[3]));
  }
  return "";
}

// e[iu] = gamma(x) and e[idu] = d gamma / dx as C statements, bit-identical to
// Envelope::value_and_derivative (a tanh envelope's tanh once for both).
std::string value_and_derivative_body(const Envelope& e, int iu, int idu) {
  const std::string c0 = num(e.c[0]), c1 = num(e.c[1]), c2 = num(e.c[2]), c3 = num(e.c[3]);
  switch (e.kind) {
    case EnvelopeKind::identity: return fmt::format("  e[{}] = x;\n  e[{}] = 1.0;\n", iu, idu);
    case EnvelopeKind::affine: return fmt::format("  e[{}] = {} * x + {};\n  e[{}] = {};\n", iu, c0, c1, idu, c0);
    case EnvelopeKind::tanh:
      return fmt::format("  {{\n    const double t = $P_tanh({} * x + {});\n    e[{}] = {} * t + {};\n"
                         "    e[{}] = {} * {} * (1.0 - t * t);\n  }}\n",
                         c1, c2, iu, c0, c3, idu, c0, c1);
    case EnvelopeKind::atan:
      return fmt::format("  {{\n    const double z = {} * x + {};\n    e[{}] = {} * atan(z) + {};\n"
                         "    e[{}] = {} * {} / (1.0 + z * z);\n  }}\n",
                         c1, c2, iu, c0, c3, idu, c0, c1);
  }
  return "";
}

// gamma^-1(u) of FastEnvelope::inverse (finite at the range's edges).
std::string inverse_body(const FastEnvelope& e) {
  switch (e.kind) {
    case EnvelopeKind::identity: return "  return u;\n";
    case EnvelopeKind::affine: return fmt::format("  return (u - {}) * {};\n", num(e.c1), num(e.inv_c0));
    case EnvelopeKind::tanh:
      return fmt::format("  return ($P_atanh_ratio(u - {}, {}) - {}) * {};\n", num(e.c3), num(e.c0), num(e.c2), num(e.inv_c1));
    case EnvelopeKind::atan:
      return fmt::format("  return (tan((u - {}) * {}) - {}) * {};\n", num(e.c3), num(e.inv_c0), num(e.c2), num(e.inv_c1));
  }
  return "  return u;\n";
}

// The arithmetic is the library's in IEEE binary64: a 32-bit double, or floating constants made
// float by -fsingle-precision-constant (no macro tells), would give wrong limits (0.6 becomes
// 0.60000002384185791 > 0.6) and overflow guards of inf. Both stop the compilation instead.
constexpr std::string_view kTargetCheck = R"(
/* The constants and kernels below are IEEE 754 binary64 doubles (docs/export.md, "Limits"). A
 * target whose double is narrower (e.g. avr-gcc's 32-bit default) stops here; so does a build
 * with -fsingle-precision-constant, which makes every floating constant a float (the limit 0.6
 * would be 0.60000002384185791 and the overflow guards 1e300 inf): the array size below is
 * negative when a constant like 0.5 is not a double. */
#if DBL_MANT_DIG != 53 || DBL_MAX_EXP != 1024
#error "this generated C needs IEEE 754 binary64 double, DBL_MANT_DIG == 53"
#endif
typedef char $P_floating_constants_are_double[(sizeof(0.5) == sizeof(double)) ? 1 : -1];
)";

// Finiteness from the IEEE 754 bit pattern: isfinite()/isnan() are folded to constants under
// -ffast-math (-ffinite-math-only), and a target's build may use such flags.
constexpr std::string_view kFinite = R"(
/* x is finite (not NaN, not +-inf): its exponent bits are not all ones. Read from the bit
 * pattern, not with isfinite()/isnan(), which compilers fold to constants under -ffast-math
 * (-ffinite-math-only): the checks on the inputs hold whatever flags the target uses. */
typedef uint64_t $P_bits; /* double is IEEE 754 binary64 (checked after the #includes) */
#define $U_EXPONENT_BITS UINT64_C(0x7ff0000000000000)
#define $U_MAGNITUDE_BITS UINT64_C(0x7fffffffffffffff)

static int $P_finite(double x)
{
  $P_bits b;
  memcpy(&b, &x, sizeof b);
  return (b & $U_EXPONENT_BITS) != $U_EXPONENT_BITS;
}

/* x is a NaN: exponent bits all ones, fraction not zero (as $P_finite, not isnan()). */
static int $P_nan(double x)
{
  $P_bits b;
  memcpy(&b, &x, sizeof b);
  return (b & $U_MAGNITUDE_BITS) > $U_EXPONENT_BITS;
}
)";

constexpr std::string_view kTanh = R"(
/* tanh(z) as the library computes it (detail::tanh_fast, envelope.hpp): expm1(2|z|) =
 * 2^k (1 + expm1(r)) - 1 with |r| <= ln2/2, expm1(r) by a degree-12 polynomial, then
 * tanh = e / (e + 2). At most 2.6 ulp; bit-identical to the library. */
static double $P_tanh(double z)
{
  union { double d; uint64_t u; } kb, sb;
  double a = fabs(z);
  double y, kd, r, r2, r4, r8, q0, q1, q2, q3, q4, P, s, sm1, e;
  a = a > 20.0 ? 20.0 : a; /* tanh = 1 to double precision beyond 19.1 */
  y = a + a;
  kb.d = y * 0x1.71547652b82fep0 + 0x1.8p52; /* adding 1.5 2^52 rounds to an integer */
  /* k read from the bits of the sum, not as (sum - 1.5 2^52), which -ffast-math
   * (-fassociative-math) folds to y / ln2: the same k, exact, under any flags */
  kb.u -= UINT64_C(0x4338000000000000);
  kd = (double)(int64_t)kb.u;
  r = (y - kd * 0x1.62e42fee00000p-1) - kd * 0x1.a39ef35793c76p-33;
  r2 = r * r;
  r4 = r2 * r2;
  r8 = r4 * r4;
  q0 = 0x1.0000000000000p-1 + r * 0x1.5555555555557p-3;
  q1 = 0x1.5555555555557p-5 + r * 0x1.11111111100bbp-7;
  q2 = 0x1.6c16c16c15a45p-10 + r * 0x1.a01a01abf9e5bp-13;
  q3 = 0x1.a01a01a9f86bep-16 + r * 0x1.71de01f8ecf10p-19;
  q4 = 0x1.27e4d3f1bb8b0p-22 + r * 0x1.af4e5f2efa609p-26;
  P = (q0 + r2 * q1) + r4 * (q2 + r2 * q3) + r8 * (q4 + r2 * 0x1.1f7f70ba58a50p-29);
  sb.u = (kb.u + 1023u) << 52; /* 2^k, k = 0..58 */
  s = sb.d;
  /* s - 1 from the integer 2^k - 1, rounded as the subtraction: written s - 1.0, -ffast-math
   * reassociates e into (s (r + r2 P) + s) - 1 and tanh(1e-17) becomes 0 */
  sm1 = (double)(int64_t)((UINT64_C(1) << (kb.u & 63u)) - 1u);
  e = s * (r + r2 * P) + sm1; /* expm1(2|z|) */
  return copysign(e / (e + 2.0), z);
}
)";

constexpr std::string_view kAtanh = R"(
/* 0.5 log1p(t) for t in [0, 1e300] (detail::half_log1p, envelope.hpp): 1 + t = 2^k f,
 * 0.5 log f = atanh(s), s = (f - 1) / (f + 1), by a degree-15 odd polynomial. */
static double $P_half_log1p(double t)
{
  union { double d; uint64_t u; } mb, fb, ib;
  const double m = 1.0 + t;
  const double big = t < 1.0 ? 1.0 : t, small = t < 1.0 ? t : 1.0;
  const double err = small - (m - big); /* m + err = 1 + t exactly */
  uint64_t im;
  int64_t k;
  double f, inv_2k, s, w, w2, w4, Q, kd;
  mb.d = m;
  im = mb.u + (UINT64_C(0x3ff0000000000000) - UINT64_C(0x3fe6a09e667f3bcd));
  k = (int64_t)(im >> 52) - 0x3ff;
  fb.u = (im & UINT64_C(0x000fffffffffffff)) + UINT64_C(0x3fe6a09e667f3bcd);
  f = fb.d;
  ib.u = (uint64_t)(0x3ff - k) << 52;
  inv_2k = ib.d;
  s = ((f - 1.0) + err * inv_2k) / (f + 1.0);
  w = s * s;
  w2 = w * w;
  w4 = w2 * w2;
  Q = (0x1.5555555555558p-2 + w * 0x1.999999999520fp-3) +
      w2 * (0x1.2492492e076bcp-3 + w * 0x1.c71c62ca876fdp-4) +
      w4 * ((0x1.7462bc0eb06e4p-4 + w * 0x1.39fd72a12bd2ap-4) + w2 * 0x1.2b6374b474f69p-4);
  kd = (double)k;
  return kd * 0x1.62e42fee00000p-2 + ((s + s * w * Q) + kd * 0x1.a39ef35793c76p-34);
}

/* atanh(d / c0) = 0.5 log1p(2|d| / (c0 - |d|)) with the sign of d (detail::atanh_ratio);
 * |d| is clamped to c0, so the result stays finite (+-345) at the asymptote. */
static double $P_atanh_ratio(double d, double c0)
{
  double a = fabs(d), t;
  a = a > c0 ? c0 : a;
  t = (a + a) / (c0 - a);
  t = t > 1e300 ? 1e300 : t;
  return copysign($P_half_log1p(t), d);
}
)";

constexpr std::string_view kPlaySum = R"(
/* n generalized plays on one envelope value u (Eq. 4) and their weighted sum (Eqs. 6, 9):
 *   y_out[i] = max{ u - r_i, min{ u + r_i, y_in[i] } },   returns sum_i p_i y_out[i]
 * accumulated in four partial sums as the library does (play_kernel.hpp). */
static double $P_play_sum(double u, const double *r, const double *p, const double *y_in, double *y_out, int n)
{
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0, m;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    int j;
    for (j = 0; j < 4; ++j) {
      m = y_in[i + j] < u + r[i + j] ? y_in[i + j] : u + r[i + j];
      y_out[i + j] = m > u - r[i + j] ? m : u - r[i + j];
    }
    s0 += p[i] * y_out[i];
    s1 += p[i + 1] * y_out[i + 1];
    s2 += p[i + 2] * y_out[i + 2];
    s3 += p[i + 3] * y_out[i + 3];
  }
  if (i + 2 <= n) {
    int j;
    for (j = 0; j < 2; ++j) {
      m = y_in[i + j] < u + r[i + j] ? y_in[i + j] : u + r[i + j];
      y_out[i + j] = m > u - r[i + j] ? m : u - r[i + j];
    }
    s0 += p[i] * y_out[i];
    s1 += p[i + 1] * y_out[i + 1];
    i += 2;
  }
  if (i < n) {
    m = y_in[i] < u + r[i] ? y_in[i] : u + r[i];
    y_out[i] = m > u - r[i] ? m : u - r[i];
    s2 += p[i] * y_out[i];
  }
  return (s0 + s2) + (s1 + s3);
}
)";

constexpr std::string_view kMapDeviations = R"(
/* Deviation map between the PI's operators and the inverse PI's (docs/models.md,
 * "Starting the inverse from a forward state"): for play deviations d_i = u - y_i,
 *   d'_i = q d_i + sum_{j<i} p_j (d_i - d_j);
 * the same map with (q', p') takes d' back to d. */
static void $P_map_deviations(double q, const double *p, const double *d, double *out, int n)
{
  double psum = 0.0, pdsum = 0.0;
  int i;
  for (i = 0; i < n; ++i) {
    out[i] = q * d[i] + psum * d[i] - pdsum;
    psum += p[i];
    pdsum += p[i] * d[i];
  }
}
)";

struct Gen {
  const ModelParams& params;
  const ExportOptions& o;
  const Baked& b;
  const detail::LoopC* loop;  // the loop's text, or null (ExportOptions::loop)
  std::size_t n = 0;
  std::string size;  // array size (n, at least 1)

  bool uses_tanh() const { return b.s.asc_kind == EnvelopeKind::tanh || (b.s.asymmetric && b.s.desc_kind == EnvelopeKind::tanh); }
  bool uses_atanh() const { return b.s.asc_kind == EnvelopeKind::tanh; }

  std::string model_comment() const {
    const Structure<double>& s = b.s;
    const std::string_view kind = model_name(params);
    std::string t;
    t += " * Model (docs/models.md; equation numbers of gpi-lm-feedforward-pid.txt), per sample:\n";
    t += " *   x_m = (x - input_origin) / input_scale             units map (docs/model-files.md)\n";
    if (!s.asymmetric) {
      t += fmt::format(" *   u   = gamma(x_m) = {}\n", envelope_formula(b.asc));
      t += " *   y_i = max{ u - r_i, min{ u + r_i, y_i } }           operators (Eqs. 1, 4)\n";
      t += " *   v   = q u + sum_i p_i y_i                           superposition (Eqs. 3, 6)\n";
    } else {
      t += fmt::format(" *   u_a = gamma_a(x_m) = {}\n", envelope_formula(b.asc));
      t += fmt::format(" *   u_d = gamma_d(x_m) = {}\n", envelope_formula(b.desc));
      t += " *   y_i = max{ u_a - r_i, min{ u_d + r_i, y_i } }       asymmetric play (models.hpp)\n";
      t += " *   v   = q (u_a + u_d) / 2 + sum_i p_i y_i             superposition (Eqs. 3, 6)\n";
    }
    if (s.has_dead_zones) {
      t += " *   m   = g0 v + sum_k g_k S_{z_k}(v)                   one-sided dead zones (Kuhnen)\n";
      t += " *         S_z(v) = max{v - z, 0} (z > 0), min{v - z, 0} (z < 0)\n";
      t += " *   y   = output_offset + output_gain m                 units map\n";
    } else {
      t += " *   y   = output_offset + output_gain v                 units map\n";
    }
    if (kind == "gpi" && std::get<GpiParams>(params).r.empty())
      t += " * with r_i = alpha i (Eq. 7), p_i = rho exp(-tau r_i) (Eq. 8), evaluated below.\n";
    t += " * Operators with r = 0 are folded into q, equal thresholds merged, r sorted increasing\n";
    t += " * (canonical_structure); the constants below are that canonical form.\n";
    t += " *\n";
    if (!s.asymmetric) {
      t += " * Inverse (exact, analytical; docs/models.md \"Inverses\"), per sample:\n";
      t += " *   y_m = (y - output_offset) / output_gain\n";
      if (s.has_dead_zones) t += " *   v   = dead-zone inverse of y_m (piecewise linear, memoryless)\n";
      else t += " *   v   = y_m\n";
      t += " *   u   = q' v + sum_i p'_i x'_i,  x'_i = max{ v - r'_i, min{ v + r'_i, x'_i } }   (Eqs. 9-10)\n";
      t += " *   q' = 1/q,  r'_i = q r_i + sum_{j<i} p_j (r_i - r_j),\n";
      t += " *   p'_i = -p_i / ((q + sum_{j<=i} p_j)(q + sum_{j<i} p_j))                        (Eq. 11)\n";
      t += " *   x_m = gamma^-1(u),  x = input_origin + input_scale x_m\n";
      t += " * If u is beyond gamma(limits), x is the nearest limit and the inverse's state follows\n";
      t += " * the forward model driven by that limit (saturation, as hysteron::Inverse).\n";
    } else {
      t += " * Inverse (exact, numerical; docs/models.md \"mpi-asym\"): for the current operator state\n";
      t += " * f(x_m) = q u_m(x_m) + sum_i p_i clamp(y_i; u_a - r_i, u_d + r_i) is continuous and strictly\n";
      t += " * increasing; each sample solves f(x_m) = y_m by Newton steps safeguarded by bisection\n";
      t += " * inside the limits until the bracket is a few ulps wide. Beyond f(limits): the limit.\n";
    }
    return t;
  }

  std::string banner(bool header) const {
    std::string t = "/*\n";
    t += fmt::format(" * {} generated by hysteron {} (hysteron export): a hysteresis model and its exact inverse.\n",
                     header ? "C99 declarations" : "C99 source", version);
    t += fmt::format(" * Model kind: {}{}.\n", model_name(params),
                     o.source_name.empty() ? std::string() : fmt::format(", from the model file \"{}\"", comment_safe(o.source_name)));
    if (!o.input_unit.empty() || !o.output_unit.empty())
      t += fmt::format(" * Units (the model file's \"units\"): input {}, output {}.\n",
                       o.input_unit.empty() ? std::string("not given") : comment_safe(o.input_unit),
                       o.output_unit.empty() ? std::string("not given") : comment_safe(o.output_unit));
    if (loop)
      t += fmt::format(" * With the compensating loop around its inverse{}.\n",
                       o.loop_source.empty() ? std::string() : fmt::format(", from {}", comment_safe(o.loop_source)));
    if (!o.command_line.empty()) t += fmt::format(" * Regenerate with: {}\n", comment_safe(o.command_line));
    t += loop ? " * Do not edit by hand: every constant is the model's or the loop's, read back exactly.\n"
              : " * Do not edit by hand: every constant is the model's, read back exactly.\n";
    t += " *\n";
    return t;
  }

  std::string parameters_comment() const {
    std::string t = " * The model file's parameters (hysteron::io::model_to_json):\n";
    const nlohmann::json j = model_to_json(params);
    for (const auto& [key, value] : j.items()) {
      std::string line = fmt::format(" *   {}: {}", key, value.dump());
      t += comment_safe(line) + "\n";
    }
    const Limits& l = b.lim_raw;
    t += fmt::format(" * The inverse saturates at the input limits [{}, {}] (raw input units){}.\n",
                     std::isinf(l.lo) ? std::string("-inf") : num(l.lo), std::isinf(l.hi) ? std::string("inf") : num(l.hi),
                     loop ? " (the loop's pressure limits)"
                     : (std::isinf(o.inverse_limits.lo) && std::isinf(o.inverse_limits.hi)) ? ""
                                                                                          : " (from --limits)");
    return t;
  }

  std::string api_comment() const {
    return R"( *
 * Use (docs/export.md): one $P_model / $P_inverse per channel, no allocation, no globals:
 *   $P_inverse inv;  $P_inverse_reset(&inv);              at start-up (virgin state)
 *   x = $P_inverse_step(&inv, y_desired);                 every sample (feedforward)
 *   $P_model m;  $P_model_reset(&m);  y = $P_model_step(&m, x);   the model itself
 * Start both from rest at x0: $P_model_reset_relaxed(&m, x0);
 *   $P_inverse_reset_state(&inv, m.y, m.u);
 * Numbers: shortest decimals that read back to the same doubles (exact).
 */
)";
  }

  std::string declarations() const {
    const bool sym = !b.s.asymmetric;
    std::string t = fmt::format(R"(
/* Number of operators (canonical form). */
#define $U_NUM_OPERATORS {}

/* Forward model state (hysteron::Model). Set with a reset function before the first step. */
typedef struct $P_model {{
  double y[{}];          /* operator outputs y_i (Eqs. 1, 4), model units */
  double u;              /* envelope value of the last input ({}) */
  double out;            /* last output (raw units); returned for a non-finite input */
  unsigned long faults;  /* non-finite inputs ignored since the last reset */
}} $P_model;

/* Inverse state (hysteron::Inverse). Set with a reset function before the first step. */
typedef struct $P_inverse {{
{}  double x;              /* last input, model coordinates x_m */
  int saturated;         /* 1 if the last step saturated at an input limit */
  unsigned long faults;  /* non-finite desired outputs ignored since the last reset */
}} $P_inverse;

#ifdef __cplusplus
extern "C" {{
#endif

/* The input limits the inverse saturates at (raw input units; +-HUGE_VAL if none). */
void $P_input_limits(double *lo, double *hi);

/* Virgin state: operator outputs 0, at rest at x = input_origin (Model::reset()). */
void $P_model_reset($P_model *m);
/* At rest at the raw input x0, as if x0 had been held forever (Model::reset_relaxed);
 * returns 0, or -1 if x0 is not finite or beyond the input bound (then the virgin
 * state of $P_model_reset: never an uninitialised one). */
int $P_model_reset_relaxed($P_model *m, double x0);
/* Explicit state: y[0..$U_NUM_OPERATORS) and u (Model::reset(ModelState));
 * returns 0, or -1 (then the virgin state) if a value is not finite or so large that the
 * output could overflow (|u| or |y_i| above $P_u_max). */
int $P_model_reset_state($P_model *m, const double *y, double u);
/* One sample: raw input x -> raw output (Model::step). A non-finite x, or one whose
 * output could overflow (|x - input_origin| / |input_scale| > $P_x_max), is ignored
 * (counted in faults) and the last output returned. */
double $P_model_step($P_model *m, double x);

/* Virgin state, matching $P_model_reset (Inverse::reset()). */
void $P_inverse_reset($P_inverse *inv);
/* Start from a forward state y, u (e.g. a $P_model's m.y, m.u), so that the inverse
 * continues where the model is (Inverse::reset(ModelState)). Returns 0, or -1 (then the
 * virgin state of $P_inverse_reset) if a value is not finite, above $P_u_max{}. */
int $P_inverse_reset_state($P_inverse *inv, const double *y, double u);
/* One sample: desired raw output -> the raw input that produces it (Inverse::step),
 * inside the input limits; beyond what the model can output there, however large, the
 * limit in its direction (saturated = 1). A non-finite y_desired is ignored (counted in
 * faults) and the last input returned. */
double $P_inverse_step($P_inverse *inv, double y_desired);

#ifdef __cplusplus
}}
#endif
)",
                                n, size, b.s.asymmetric ? "u_a, ascending" : "gamma(x_m)",
                                sym ? fmt::format("  double xi[{}];         /* inverse-PI operator outputs x'_i (Eqs. 9-10) */\n"
                                                  "  double v_prev;         /* last PI output v */\n",
                                                  size)
                                    : fmt::format("  double y[{}];          /* forward operator outputs driven by the inverse's input */\n", size),
                                sym ? " or not reachable by the model (|d_i - d_j| <= r_j - r_i\n * broken for the deviations d_i = u - y_i)"
                                    : " or not reachable by the model (necessary conditions:\n * y_1 >= u - r_1 off the virgin state, |y_i - y_j| <= r_j - r_i)");
    return t;
  }

  std::string constants() const {
    const Structure<double>& s = b.s;
    const UnitsMap& um = s.units;
    std::string t = "\n/* ---- constants ---- */\n";
    t += fmt::format("static const double $P_input_origin = {};  /* units map */\n", num(um.input_origin));
    t += fmt::format("static const double $P_input_scale = {};\n", num(um.input_scale));
    t += fmt::format("static const double $P_inv_input_scale = {};  /* 1 / input_scale */\n", num(s.inv_input_scale));
    t += fmt::format("static const double $P_output_offset = {};\n", num(um.output_offset));
    t += fmt::format("static const double $P_output_gain = {};\n", num(um.output_gain));
    t += fmt::format("static const double $P_inv_output_gain = {};  /* 1 / output_gain */\n", num(s.inv_output_gain));
    t += fmt::format("static const double $P_q = {};  /* direct weight q (with r = 0 operators) */\n", num(s.q));
    t += fmt::format("static const double $P_r[{}] = {};  /* thresholds r_i */\n", size, array_init(s.r));
    t += fmt::format("static const double $P_p[{}] = {};  /* weights p_i */\n", size, array_init(s.p));
    if (s.has_dead_zones) {
      t += fmt::format("static const double $P_g0 = {};  /* dead zones: linear weight g0 */\n", num(s.g0));
      if (!s.z.empty()) {
        t += fmt::format("static const double $P_z[{}] = {};  /* dead-zone thresholds z_k */\n", s.z.size(), array_init(s.z));
        t += fmt::format("static const double $P_g[{}] = {};  /* dead-zone weights g_k */\n", s.z.size(), array_init(s.g));
      }
      t += "/* Dead-zone inverse: breakpoints zp/zn of v, their images dp/dn, slopes sp/sn after them. */\n";
      t += fmt::format("static const double $P_zp[{}] = {};\n", b.zp.size(), array_init(b.zp));
      t += fmt::format("static const double $P_dp[{}] = {};\n", b.dp.size(), array_init(b.dp));
      t += fmt::format("static const double $P_sp[{}] = {};\n", b.sp.size(), array_init(b.sp));
      t += fmt::format("static const double $P_zn[{}] = {};\n", b.zn.size(), array_init(b.zn));
      t += fmt::format("static const double $P_dn[{}] = {};\n", b.dn.size(), array_init(b.dn));
      t += fmt::format("static const double $P_sn[{}] = {};\n", b.sn.size(), array_init(b.sn));
    }
    t += fmt::format("static const double $P_lim_lo = {}, $P_lim_hi = {};  /* input limits, model coordinates */\n",
                     num(b.lim.lo), num(b.lim.hi));
    t += fmt::format("static const double $P_lim_raw_lo = {}, $P_lim_raw_hi = {};  /* input limits, raw units */\n",
                     num(b.lim_raw.lo), num(b.lim_raw.hi));
    t += fmt::format("static const double $P_x_max = {};  /* |x_m| above: the output could overflow (input_bound) */\n",
                     num(b.x_max));
    t += fmt::format("static const double $P_u_max = {};  /* |u|, |y_i| of a state: no overflow below (state_bound) */\n",
                     num(b.u_max));
    if (s.asymmetric) {
      // Both envelopes and their slopes at the two limits, as Inverse keeps them (constant).
      auto at = [&](double x) {
        std::array<double, 4> e{};
        b.asc.value_and_derivative(x, e[0], e[2]);
        b.desc.value_and_derivative(x, e[1], e[3]);
        return fmt::format("{{{}, {}, {}, {}}}", num(e[0]), num(e[1]), num(e[2]), num(e[3]));
      };
      t += fmt::format("static const double $P_env_lo[4] = {}, $P_env_hi[4] = {};  /* u_a, u_d, du_a/dx_m, du_d/dx_m at the limits */\n",
                       at(b.lim.lo), at(b.lim.hi));
    }
    if (!s.asymmetric) {
      t += fmt::format("static const double $P_qi = {};  /* q' = 1/q (Eq. 11) */\n", num(b.qi));
      t += fmt::format("static const double $P_ri[{}] = {};  /* r'_i (Eq. 11) */\n", size, array_init(b.ri));
      t += fmt::format("static const double $P_pi[{}] = {};  /* p'_i (Eq. 11) */\n", size, array_init(b.pi));
      t += fmt::format("static const double $P_u_lo = {}, $P_u_hi = {};  /* gamma(limits) */\n", num(b.u_lo), num(b.u_hi));
      if (std::isfinite(b.v_bounds.lo))
        t += fmt::format("static const double $P_v_lo = {};  /* v below it: unreachable inside the limits */\n",
                         num(b.v_bounds.lo));
      if (std::isfinite(b.v_bounds.hi))
        t += fmt::format("static const double $P_v_hi = {};  /* v above it: unreachable inside the limits */\n",
                         num(b.v_bounds.hi));
    }
    return t;
  }

  std::string helpers() const {
    const Structure<double>& s = b.s;
    std::string t(kFinite);
    if (uses_tanh()) t += kTanh;
    if (uses_atanh()) t += kAtanh;
    t += fmt::format(R"(
/* gamma{}(x_m): {} */
static double $P_gamma(double x)
{{
  return {};
}}
)",
                     s.asymmetric ? "_a" : "", envelope_formula(b.asc), envelope_expr(b.fasc, "x"));
    t += fmt::format(R"(
/* gamma{}^-1(u), finite at the edges of gamma's range (FastEnvelope::inverse). */
static double $P_gamma_inverse(double u)
{{
{}}}

/* gamma{}^-1(u); -+HUGE_VAL at or beyond the edges of gamma's range (Envelope::inverse). */
static double $P_gamma_inverse_checked(double u)
{{
  if ($P_nan(u)) return u;
  if (u <= {}) return -HUGE_VAL;
  if (u >= {}) return HUGE_VAL;
  return $P_gamma_inverse(u);
}}
)",
                     s.asymmetric ? "_a" : "", inverse_body(b.fasc), s.asymmetric ? "_a" : "", num(b.asc.range_lo()),
                     num(b.asc.range_hi()));
    if (s.asymmetric) {
      t += fmt::format(R"(
/* gamma_d(x_m): {} */
static double $P_gamma_d(double x)
{{
  return {};
}}

/* sum_i p_i y_i in four partial sums, as the library (weighted_sum, models.hpp). */
static double $P_weighted_sum(const double *y)
{{
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int i = 0;
  for (; i + 4 <= $U_NUM_OPERATORS; i += 4) {{
    s0 += $P_p[i] * y[i];
    s1 += $P_p[i + 1] * y[i + 1];
    s2 += $P_p[i + 2] * y[i + 2];
    s3 += $P_p[i + 3] * y[i + 3];
  }}
  for (; i < $U_NUM_OPERATORS; ++i) s0 += $P_p[i] * y[i];
  return (s0 + s1) + (s2 + s3);
}}

/* The asymmetric plays committed at the envelopes e = {{u_a, u_d, ...}} of the input:
 * y_i = max{{ u_a - r_i, min{{ u_d + r_i, y_i }} }} (Inverse::step_numerical, Model::step). */
static void $P_asym_commit(const double *e, double *y)
{{
  double lo, m;
  int i;
  for (i = 0; i < $U_NUM_OPERATORS; ++i) {{
    lo = e[0] - $P_r[i];
    m = y[i] < e[1] + $P_r[i] ? y[i] : e[1] + $P_r[i];
    y[i] = lo < m ? m : lo;
  }}
}}

/* The asymmetric plays driven by x_m; returns v = q (u_a + u_d) / 2 + sum_i p_i y_i and u_a. */
static double $P_asym_step(double x, double *y, double *u_a)
{{
  const double e[2] = {{$P_gamma(x), $P_gamma_d(x)}};
  $P_asym_commit(e, y);
  *u_a = e[0];
  return $P_q * (e[0] + e[1]) * 0.5 + $P_weighted_sum(y);
}}

/* e = {{u_a, u_d, du_a/dx_m, du_d/dx_m}} at x_m, a tanh computed once per envelope
 * (Inverse::envelopes_at). */
static void $P_envelopes(double x, double *e)
{{
{}{}}}

/* f(x_m) for the inverse's operator state, without committing it, and df/dx_m, from the
 * envelopes e at x_m (Inverse::forward_tentative). */
static double $P_forward_tentative(const double *y, const double *e, double *dfdx)
{{
  const double ua = e[0], ud = e[1], da = e[2], dd = e[3];
  double f = $P_q * 0.5 * (ua + ud);
  double df = $P_q * 0.5 * (da + dd);
  double lo, hi, m;
  int i;
  for (i = 0; i < $U_NUM_OPERATORS; ++i) {{
    lo = ua - $P_r[i];
    hi = ud + $P_r[i];
    m = y[i] < hi ? y[i] : hi;
    if (lo > m) {{
      f += $P_p[i] * lo;
      df += $P_p[i] * da;
    }} else {{
      f += $P_p[i] * m;
      if (hi < y[i]) df += $P_p[i] * dd;
    }}
  }}
  *dfdx = df;
  return f;
}}
)",
                       envelope_formula(b.desc), envelope_expr(b.fdesc, "x"), value_and_derivative_body(b.asc, 0, 2),
                       value_and_derivative_body(b.desc, 1, 3));
    } else {
      t += kPlaySum;
      t += kMapDeviations;
    }
    if (s.has_dead_zones) {
      std::string terms;
      if (!s.z.empty())
        terms = R"(  int k;
  for (k = 0; k < )" + std::to_string(s.z.size()) + R"(; ++k) {
    const double d = v - $P_z[k];
    if ($P_z[k] > 0.0) out += $P_g[k] * (d < 0.0 ? 0.0 : d);  /* max{v - z, 0} */
    else out += $P_g[k] * (0.0 < d ? 0.0 : d);                /* min{v - z, 0} */
  }
)";
      t += fmt::format(R"(
/* Dead zones: g0 v + sum_k g_k S_{{z_k}}(v) (dead_zone_map). */
static double $P_dead_zone_map(double v)
{{
  double out = $P_g0 * v;
{}  return out;
}}

/* Their exact inverse: piecewise linear between the breakpoints (Inverse::dead_zone_inverse). */
static double $P_dead_zone_inverse(double y)
{{
  int k = 0;
  if (y >= 0) {{
    while (k + 1 < {} && $P_dp[k + 1] <= y) ++k;
    return $P_zp[k] + (y - $P_dp[k]) / $P_sp[k];
  }}
  while (k + 1 < {} && $P_dn[k + 1] >= y) ++k;
  return $P_zn[k] + (y - $P_dn[k]) / $P_sn[k];
}}
)",
                       terms, b.dp.size(), b.dn.size());
    }
    return t;
  }

  std::string functions() const {
    const Structure<double>& s = b.s;
    const bool sym = !s.asymmetric;
    std::string t = R"(
/* ---- public functions ---- */

void $P_input_limits(double *lo, double *hi)
{
  *lo = $P_lim_raw_lo;
  *hi = $P_lim_raw_hi;
}

void $P_model_reset($P_model *m)
{
  int i;
  for (i = 0; i < $U_NUM_OPERATORS; ++i) m->y[i] = 0.0;
  m->u = 0.0;
  m->out = 0.0;
  m->faults = 0;
}

/* A refused reset leaves the virgin state, never an uninitialised one. */
static int $P_model_refuse($P_model *m)
{
  $P_model_reset(m);
  return -1;
}

int $P_model_reset_relaxed($P_model *m, double x0)
{
  const double u = $P_gamma((x0 - $P_input_origin) / $P_input_scale);
  int i;
  if (!(fabs((x0 - $P_input_origin) * $P_inv_input_scale) <= $P_x_max)) return $P_model_refuse(m);
  if (!$P_finite(u)) return $P_model_refuse(m);
  for (i = 0; i < $U_NUM_OPERATORS; ++i) m->y[i] = u;
  m->u = u;
  m->faults = 0;
  m->out = 0.0;
  return 0;
}

int $P_model_reset_state($P_model *m, const double *y, double u)
{
  int i;
  for (i = 0; i < $U_NUM_OPERATORS; ++i)
    if (!$P_finite(y[i]) || !(fabs(y[i]) <= $P_u_max)) return $P_model_refuse(m);  /* its step could overflow */
  if (!$P_finite(u) || !(fabs(u) <= $P_u_max)) return $P_model_refuse(m);
  for (i = 0; i < $U_NUM_OPERATORS; ++i) m->y[i] = y[i];
  m->u = u;
  m->out = 0.0;
  m->faults = 0;
  return 0;
}

double $P_model_step($P_model *m, double x)
{
  double xm, v;
  if (!$P_finite(x)) {
    ++m->faults;
    return m->out;
  }
  xm = (x - $P_input_origin) * $P_inv_input_scale;  /* units map */
  if (!(fabs(xm) <= $P_x_max)) {  /* the output could overflow: ignored as a non-finite x */
    ++m->faults;
    return m->out;
  }
)";
    if (sym) {
      t += R"(  m->u = $P_gamma(xm);                                  /* envelope (Eq. 5) */
  v = $P_q * m->u + $P_play_sum(m->u, $P_r, $P_p, m->y, m->y, $U_NUM_OPERATORS);  /* Eqs. 4, 6 */
)";
    } else {
      t += "  v = $P_asym_step(xm, m->y, &m->u);\n";
    }
    if (s.has_dead_zones) t += "  v = $P_dead_zone_map(v);                              /* dead zones */\n";
    t += R"(  m->out = $P_output_offset + $P_output_gain * v;         /* units map */
  return m->out;
}

void $P_inverse_reset($P_inverse *inv)
{
  int i;
)";
    if (sym) t += "  for (i = 0; i < $U_NUM_OPERATORS; ++i) inv->xi[i] = 0.0;\n  inv->v_prev = 0.0;\n";
    else t += "  for (i = 0; i < $U_NUM_OPERATORS; ++i) inv->y[i] = 0.0;\n";
    t += R"(  inv->x = 0.0 < $P_lim_lo ? $P_lim_lo : $P_lim_hi < 0.0 ? $P_lim_hi : 0.0;
  inv->saturated = 0;
  inv->faults = 0;
}

/* A refused reset leaves the virgin state, never an uninitialised one. */
static int $P_inverse_refuse($P_inverse *inv)
{
  $P_inverse_reset(inv);
  return -1;
}
)";
    if (sym) {
      t += R"(
int $P_inverse_reset_state($P_inverse *inv, const double *y, double u)
{
  double dev[$U_STATE_SIZE], sc[$U_STATE_SIZE];
  double scale = fabs(u), tol, d_prev = 0.0, r_prev = 0.0, v, x;
  int i;
  if (!$P_finite(u) || !(fabs(u) <= $P_u_max)) return $P_inverse_refuse(inv);
  for (i = 0; i < $U_NUM_OPERATORS; ++i)
    if (!$P_finite(y[i]) || !(fabs(y[i]) <= $P_u_max)) return $P_inverse_refuse(inv);
  /* Reachability: |d_1| <= r_1, |d_i - d_{i-1}| <= r_i - r_{i-1} (1-Lipschitz memory curve). */
  for (i = 0; i < $U_NUM_OPERATORS; ++i) scale = scale < fabs(y[i]) ? fabs(y[i]) : scale;
  tol = 1e-9 * (1.0 < scale ? scale : 1.0);
  for (i = 0; i < $U_NUM_OPERATORS; ++i) {
    dev[i] = u - y[i];
    if (fabs(dev[i] - d_prev) > $P_r[i] - r_prev + tol) return $P_inverse_refuse(inv);
    d_prev = dev[i];
    r_prev = $P_r[i];
  }
  v = $P_q * u;
  for (i = 0; i < $U_NUM_OPERATORS; ++i) v += $P_p[i] * y[i];
  $P_map_deviations($P_q, $P_p, dev, sc, $U_NUM_OPERATORS);
  for (i = 0; i < $U_NUM_OPERATORS; ++i) inv->xi[i] = v - sc[i];  /* x'_i = v - d'_i */
  inv->v_prev = v;
  x = $P_gamma_inverse_checked(u);
  x = $P_finite(x) ? x : 0.0;
  inv->x = x < $P_lim_lo ? $P_lim_lo : $P_lim_hi < x ? $P_lim_hi : x;
  inv->saturated = 0;
  inv->faults = 0;
  return 0;
}

double $P_inverse_step($P_inverse *inv, double y_desired)
{
  double sc[$U_STATE_SIZE], d[$U_STATE_SIZE];
  double ym, v, u, xm, x;
  int i;
  if (!$P_finite(y_desired)) {
    ++inv->faults;
    x = $P_input_origin + $P_input_scale * inv->x;
    return x < $P_lim_raw_lo ? $P_lim_raw_lo : $P_lim_raw_hi < x ? $P_lim_raw_hi : x;
  }
  ym = (y_desired - $P_output_offset) * $P_inv_output_gain;  /* units map */
)";
      t += s.has_dead_zones ? "  v = $P_dead_zone_inverse(ym);\n" : "  v = ym;\n";
      // unreachable inside the limits: still saturates, and u is never inf - inf (Inverse::step_analytical)
      if (std::isfinite(b.v_bounds.lo)) t += "  v = v < $P_v_lo ? $P_v_lo : v;\n";
      if (std::isfinite(b.v_bounds.hi)) t += "  v = $P_v_hi < v ? $P_v_hi : v;\n";
      t += R"(  /* Eqs. 9-10 on a tentative state */
  u = $P_qi * v + $P_play_sum(v, $P_ri, $P_pi, inv->xi, sc, $U_NUM_OPERATORS);
)";
      // an unbounded side: a u beyond a double there is held (step_analytical); +-inf toward a
      // bounded limit saturates there below
      if (!std::isfinite(b.v_bounds.lo) || !std::isfinite(b.v_bounds.hi))
        t += R"(  if ($P_nan(u) || )" + std::string(!std::isfinite(b.v_bounds.hi) ? "(u > 0.0 && !$P_finite(u))" : "0") +
             " || " + std::string(!std::isfinite(b.v_bounds.lo) ? "(u < 0.0 && !$P_finite(u))" : "0") + R"() {
    ++inv->faults;
    x = $P_input_origin + $P_input_scale * inv->x;
    return x < $P_lim_raw_lo ? $P_lim_raw_lo : $P_lim_raw_hi < x ? $P_lim_raw_hi : x;
  }
)";
      t += R"(  if (u >= $P_u_lo && u <= $P_u_hi) {
    for (i = 0; i < $U_NUM_OPERATORS; ++i) inv->xi[i] = sc[i];
    inv->v_prev = v;
    inv->saturated = 0;
    xm = $P_gamma_inverse(u);
    inv->x = xm < $P_lim_lo ? $P_lim_lo : $P_lim_hi < xm ? $P_lim_hi : xm;
  } else {
    /* Saturated: drive the forward model with the limit and re-derive the inverse state. */
    const int high = u > $P_u_hi;
    const double uc = high ? $P_u_hi : $P_u_lo;
    double u_prev = $P_qi * inv->v_prev, vc, yi, m;
    for (i = 0; i < $U_NUM_OPERATORS; ++i) {
      d[i] = inv->v_prev - inv->xi[i];
      u_prev += $P_pi[i] * inv->xi[i];
    }
    $P_map_deviations($P_qi, $P_pi, d, sc, $U_NUM_OPERATORS);  /* forward deviations */
    vc = $P_q * uc;
    for (i = 0; i < $U_NUM_OPERATORS; ++i) {
      m = u_prev - sc[i] < uc + $P_r[i] ? u_prev - sc[i] : uc + $P_r[i];
      yi = uc - $P_r[i] < m ? m : uc - $P_r[i];
      vc += $P_p[i] * yi;
      d[i] = uc - yi;
    }
    $P_map_deviations($P_q, $P_p, d, sc, $U_NUM_OPERATORS);
    for (i = 0; i < $U_NUM_OPERATORS; ++i) inv->xi[i] = vc - sc[i];
    inv->v_prev = vc;
    inv->saturated = 1;
    inv->x = high ? $P_lim_hi : $P_lim_lo;
  }
  x = $P_input_origin + $P_input_scale * inv->x;  /* units map */
  return x < $P_lim_raw_lo ? $P_lim_raw_lo : $P_lim_raw_hi < x ? $P_lim_raw_hi : x;
}
)";
    } else {
      t += R"(
int $P_inverse_reset_state($P_inverse *inv, const double *y, double u)
{
  double x, scale = fabs(u), tol;
  int i, virgin = 1;
  if (!$P_finite(u) || !(fabs(u) <= $P_u_max)) return $P_inverse_refuse(inv);
  for (i = 0; i < $U_NUM_OPERATORS; ++i)
    if (!$P_finite(y[i]) || !(fabs(y[i]) <= $P_u_max)) return $P_inverse_refuse(inv);
  /* Reachability, necessary conditions (Inverse::reset(ModelState), docs/models.md): y_1 >= u - r_1 (not on the
     virgin operators, all 0) and |y_i - y_{i-1}| <= r_i - r_{i-1}. */
  for (i = 0; i < $U_NUM_OPERATORS; ++i) {
    scale = scale < fabs(y[i]) ? fabs(y[i]) : scale;
    virgin = virgin && y[i] == 0.0;
  }
  tol = 1e-9 * (1.0 < scale ? scale : 1.0);
  if ($U_NUM_OPERATORS > 0 && !virgin && y[0] < u - $P_r[0] - tol) return $P_inverse_refuse(inv);
  for (i = 1; i < $U_NUM_OPERATORS; ++i)
    if (fabs(y[i] - y[i - 1]) > $P_r[i] - $P_r[i - 1] + tol) return $P_inverse_refuse(inv);
  for (i = 0; i < $U_NUM_OPERATORS; ++i) inv->y[i] = y[i];
  x = $P_gamma_inverse_checked(u);
  x = $P_finite(x) ? x : 0.0;
  inv->x = x < $P_lim_lo ? $P_lim_lo : $P_lim_hi < x ? $P_lim_hi : x;
  inv->saturated = 0;
  inv->faults = 0;
  return 0;
}

double $P_inverse_step($P_inverse *inv, double y_desired)
{
  double ym, a = $P_lim_lo, b = $P_lim_hi, fa, fb, df = 0.0, x, e[4];
  const double *ex = 0; /* the envelopes at x, once x has been evaluated */
  if (!$P_finite(y_desired)) {
    ++inv->faults;
    x = $P_input_origin + $P_input_scale * inv->x;
    return x < $P_lim_raw_lo ? $P_lim_raw_lo : $P_lim_raw_hi < x ? $P_lim_raw_hi : x;
  }
  ym = (y_desired - $P_output_offset) * $P_inv_output_gain;  /* units map */
  fa = $P_forward_tentative(inv->y, $P_env_lo, &df);
  fb = $P_forward_tentative(inv->y, $P_env_hi, &df);
  if (ym >= fb) {
    x = b;
    inv->saturated = ym > fb;
    ex = $P_env_hi;
  } else if (ym <= fa) {
    x = a;
    inv->saturated = ym < fa;
    ex = $P_env_lo;
  } else {
    int it;
    inv->saturated = 0;
    /* Safeguarded Newton inside the bracket [a, b] with f(a) < y_m < f(b). */
    x = inv->x < a ? a : b < inv->x ? b : inv->x;
    for (it = 0; it < 200; ++it) {
      double fx, xn, wa, wb;
      $P_envelopes(x, e);
      ex = e;
      fx = $P_forward_tentative(inv->y, e, &df);
      if (fx == ym) break;
      if (fx < ym) a = x; else b = x;
      xn = x - (fx - ym) / df;
      if (!(df > 0) || !(xn > a && xn < b)) xn = 0.5 * (a + b);
      wa = fabs(a);
      wb = fabs(b);
      if (b - a <= 0x1p-50 * (wa < wb ? wb : wa) || xn == x) {  /* 4 eps max(|a|, |b|) */
        if (xn != x) ex = 0;
        x = xn;
        break;
      }
      x = xn;
      ex = 0;
    }
  }
  if (!ex) {
    $P_envelopes(x, e);
    ex = e;
  }
  $P_asym_commit(ex, inv->y);  /* commit: the forward operators driven by x */
  inv->x = x;
  x = $P_input_origin + $P_input_scale * x;  /* units map */
  return x < $P_lim_raw_lo ? $P_lim_raw_lo : $P_lim_raw_hi < x ? $P_lim_raw_hi : x;
}
)";
    }
    return t;
  }

  std::string finish(std::string text) const {
    std::string upper = o.prefix;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    replace_all(text, "$U_STATE_SIZE", size);
    replace_all(text, "$U", upper);
    replace_all(text, "$P", o.prefix);
    return text;
  }

  GeneratedC run() const {
    std::string upper = o.prefix;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    GeneratedC out;
    std::string src = banner(false) + model_comment() + " *\n" + parameters_comment();
    if (loop) src += loop->comment;
    src += api_comment();
    src += "\n#ifndef $U_C_INCLUDED\n#define $U_C_INCLUDED\n\n#include <float.h>\n#include <math.h>\n#include <stdint.h>\n#include <string.h>\n";
    src += kTargetCheck;
    if (o.header_name.empty()) {
      src += declarations();
      if (loop) src += loop->declarations;
    } else {
      src += fmt::format("\n#include \"{}\"\n", o.header_name);
      std::string h = banner(true) + " * The definitions are in the generated .c file (docs/export.md).\n */\n";
      h += "\n#ifndef $U_H_INCLUDED\n#define $U_H_INCLUDED\n";
      h += declarations();
      if (loop) h += loop->declarations;
      h += "\n#endif /* $U_H_INCLUDED */\n";
      out.header = finish(std::move(h));
    }
    src += constants();
    src += helpers();
    src += functions();
    if (loop) src += loop->definitions;
    src += "\n#endif /* $U_C_INCLUDED */\n";
    out.source = finish(std::move(src));
    return out;
  }
};

}  // namespace

std::string c_prefix_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > 40) return fmt::format("it has {} characters, at most 40 are allowed", name.size());
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_') || static_cast<unsigned char>(c) >= 0x80)
      return "it is not a C identifier (letters, digits and '_' only)";
  if (std::isdigit(static_cast<unsigned char>(name.front()))) return "it starts with a digit";
  if (name.front() == '_') return "it starts with '_' (such names are reserved in C)";
  if (name.back() == '_') return "it ends with '_' (the names would contain \"__\", reserved in C++)";
  if (name.find("__") != std::string::npos) return "it contains \"__\" (reserved in C++)";
  std::string lower = name;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower == "hysteron" || lower.starts_with("hysteron_"))
    return "hysteron and hysteron_* are the C ABI's names (include/hysteron/hysteron.h, e.g. "
           "hysteron_params_input_limits, HYSTERON_OK)";
  return {};
}

bool valid_c_prefix(const std::string& name) noexcept {
  try {
    return c_prefix_problem(name).empty();
  } catch (...) {
    return false;
  }
}

GeneratedC generate_c(const ModelParams& params, const ExportOptions& options) {
  if (const std::string why = c_prefix_problem(options.prefix); !why.empty())
    throw Error(fmt::format("export: prefix \"{}\" is not usable: {}", options.prefix, why));
  if (options.header_name.find_first_of("\"\\\n\r") != std::string::npos)
    throw Error(fmt::format("export: header name \"{}\" cannot be #included (it contains a quote, backslash or newline)",
                            options.header_name));
  Limits inverse_limits = options.inverse_limits;
  std::optional<detail::LoopC> loop;
  if (options.loop) {
    try {
      loop = detail::loop_c(*options.loop, params);
    } catch (const Error& e) {
      throw Error(fmt::format("the loop{}: {}",
                              options.loop_source.empty() ? std::string() : " of " + options.loop_source, e.what()));
    }
    if (const std::string why = input_unit_mismatch(options.input_unit); !why.empty())
      throw Error(fmt::format("the loop{}: {}", options.loop_source.empty() ? std::string() : " of " + options.loop_source,
                              why));
    if (const std::string why = model_scale_mismatch(options.loop->feedforward.model_scale, options.output_unit);
        !why.empty())
      throw Error(fmt::format("the loop{}: {}: this loop was designed for a model in another length unit",
                              options.loop_source.empty() ? std::string() : " of " + options.loop_source, why));
    // the loop's inverse saturates at its pressure limits (InverseFeedforward), resolved on the model
    const Limits& pl = loop->pressure_limits;
    const bool unset = std::isinf(inverse_limits.lo) && std::isinf(inverse_limits.hi);
    if (!unset && !(inverse_limits == pl))
      throw Error(fmt::format("the limits [{}, {}] differ from the loop's pressure limits [{}, {}], at which "
                              "its inverse saturates: leave the limits out",
                              inverse_limits.lo, inverse_limits.hi, pl.lo, pl.hi));
    inverse_limits = pl;
  }
  const Baked b = bake(params, inverse_limits);
  const std::size_t n = b.s.r.size();
  const Gen g{params, options, b, loop ? &*loop : nullptr, n, std::to_string(std::max<std::size_t>(n, 1))};
  return g.run();
}

}  // namespace hysteron::io
