#pragma once
// Envelope functions gamma(x) of generalized play operators (Eq. 4-5 of
// gpi-lm-feedforward-pid.txt). Every family is strictly increasing, so it has an
// exact inverse on its range.
//
//   identity : gamma(x) = x                              (classical PI)
//   affine   : gamma(x) = c0 x + c1,               c0 > 0
//   tanh     : gamma(x) = c0 tanh(c1 x + c2) + c3, c0 > 0, c1 > 0   (Eq. 5)
//   atan     : gamma(x) = c0 atan(c1 x + c2) + c3, c0 > 0, c1 > 0
//
// tanh and atan saturate: their range is the open interval
// (c3 - c0, c3 + c0) resp. (c3 - c0 pi/2, c3 + c0 pi/2).
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>

namespace hysteron {

enum class EnvelopeKind { identity, affine, tanh, atan };

// Name used in model files ("identity", "affine", "tanh", "atan").
std::string_view envelope_name(EnvelopeKind kind) noexcept;
// Parses a name; throws hysteron::Error naming `where` on an unknown name.
EnvelopeKind envelope_kind_from_name(std::string_view name, std::string_view where);
// Number of coefficients c0.. used by a family (0, 2, 4, 4).
std::size_t envelope_num_coefficients(EnvelopeKind kind) noexcept;

namespace detail {
// tanh(z) without a library call, branch-free: expm1(2|z|) = 2^k (1 + expm1(r)) - 1
// with r = 2|z| - k ln2, |r| <= ln2/2, expm1(r) by a degree-12 polynomial
// (Chebyshev-economized Taylor series, truncation < 2e-18), then
// tanh = e / (e + 2). At most 2.6 ulp (tested against long double), odd, so
// small and negative arguments keep full relative precision.
inline double tanh_fast(double z) noexcept {
  double a = std::abs(z);
  a = a > 20.0 ? 20.0 : a;  // tanh = 1 to double precision beyond 19.1; NaN stays NaN
  const double y = a + a;
  constexpr double kShift = 0x1.8p52;  // adding it rounds to an integer
  constexpr double kInvLn2 = 0x1.71547652b82fep0;
  constexpr double kLn2Hi = 0x1.62e42fee00000p-1, kLn2Lo = 0x1.a39ef35793c76p-33;
  // k = round(y / ln2) read from the bits of the shifted sum, not as (sum - kShift): under
  // -ffast-math (-fassociative-math) compilers fold (y/ln2 + kShift) - kShift to y/ln2, and
  // r and 2^k stop matching (tanh off by up to 0.17). The same k, exact, under any flags
  // (tests/fast_math/test_fast_math.cpp).
  const std::uint64_t ki = std::bit_cast<std::uint64_t>(y * kInvLn2 + kShift) - std::bit_cast<std::uint64_t>(kShift);
  const double kd = static_cast<double>(static_cast<std::int64_t>(ki));
  const double r = (y - kd * kLn2Hi) - kd * kLn2Lo;  // k ln2_hi is exact
  const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  // P(r) = (expm1(r) - r) / r^2, Estrin's scheme
  const double q0 = 0x1.0000000000000p-1 + r * 0x1.5555555555557p-3;
  const double q1 = 0x1.5555555555557p-5 + r * 0x1.11111111100bbp-7;
  const double q2 = 0x1.6c16c16c15a45p-10 + r * 0x1.a01a01abf9e5bp-13;
  const double q3 = 0x1.a01a01a9f86bep-16 + r * 0x1.71de01f8ecf10p-19;
  const double q4 = 0x1.27e4d3f1bb8b0p-22 + r * 0x1.af4e5f2efa609p-26;
  const double P = (q0 + r2 * q1) + r4 * (q2 + r2 * q3) + r8 * (q4 + r2 * 0x1.1f7f70ba58a50p-29);
  const double s = std::bit_cast<double>((ki + 1023) << 52);  // 2^k, k = 0..58
  // s - 1 (rounded as the subtraction would be) from the integer 2^k - 1: written s - 1.0, it is
  // reassociated under -ffast-math into (s (r + r2 P) + s) - 1, and tanh of |z| < 1e-3 loses its
  // relative precision (tanh(1e-17) = 0).
  const double sm1 = static_cast<double>(static_cast<std::int64_t>((std::uint64_t{1} << (ki & 63)) - 1));
  const double e = s * (r + r2 * P) + sm1;  // expm1(2|z|)
  return std::copysign(e / (e + 2.0), z);
}

// 0.5 log1p(t) for t in [0, 1e300], branch-free: 1 + t = 2^k f (+ its exact
// rounding error), f in [sqrt(1/2), sqrt(2)), 0.5 log f = atanh(s) with
// s = (f - 1) / (f + 1), |s| <= 0.1716, by a degree-15 odd polynomial
// (Chebyshev-economized, truncation < 2e-16 s^2). At most 2.5 ulp.
inline double half_log1p(double t) noexcept {
  const double m = 1.0 + t;
  const double big = t < 1.0 ? 1.0 : t, small = t < 1.0 ? t : 1.0;
  const double err = small - (m - big);  // m + err = 1 + t exactly (Fast2Sum)
  const std::uint64_t im = std::bit_cast<std::uint64_t>(m) + (0x3ff0000000000000ULL - 0x3fe6a09e667f3bcdULL);
  const std::int64_t k = static_cast<std::int64_t>(im >> 52) - 0x3ff;
  const double f = std::bit_cast<double>((im & 0x000fffffffffffffULL) + 0x3fe6a09e667f3bcdULL);
  const double inv_2k = std::bit_cast<double>(static_cast<std::uint64_t>(0x3ff - k) << 52);
  const double s = ((f - 1.0) + err * inv_2k) / (f + 1.0);  // f - 1 is exact
  const double w = s * s, w2 = w * w, w4 = w2 * w2;
  const double Q = (0x1.5555555555558p-2 + w * 0x1.999999999520fp-3) +
                   w2 * (0x1.2492492e076bcp-3 + w * 0x1.c71c62ca876fdp-4) +
                   w4 * ((0x1.7462bc0eb06e4p-4 + w * 0x1.39fd72a12bd2ap-4) + w2 * 0x1.2b6374b474f69p-4);
  constexpr double kHalfLn2Hi = 0x1.62e42fee00000p-2, kHalfLn2Lo = 0x1.a39ef35793c76p-34;
  const double kd = static_cast<double>(k);
  return kd * kHalfLn2Hi + ((s + s * w * Q) + kd * kHalfLn2Lo);
}

// atanh(d / c0) = 0.5 log1p(2|d| / (c0 - |d|)) with the sign of d, for c0 > 0.
// |d| is clamped to c0; at |d| = c0 the result is +-345 (finite), not inf.
inline double atanh_ratio(double d, double c0) noexcept {
  double a = std::abs(d);
  a = a > c0 ? c0 : a;  // NaN stays NaN
  double t = (a + a) / (c0 - a);
  t = t > 1e300 ? 1e300 : t;
  return std::copysign(half_log1p(t), d);
}
inline double atanh_fast(double w) noexcept { return atanh_ratio(w, 1.0); }

template <class T>
inline T tanh_any(const T& z) {
  using std::tanh;
  if constexpr (std::is_same_v<T, double>) return tanh_fast(z); else return tanh(z);
}
}  // namespace detail

// gamma(x) for any scalar type (double or an autodiff Jet); c has 4 entries.
template <class T, class X>
inline T envelope_value(EnvelopeKind kind, const T* c, const X& x) {
  using std::atan;
  switch (kind) {
    case EnvelopeKind::identity: return T(x);
    case EnvelopeKind::affine: return c[0] * T(x) + c[1];
    case EnvelopeKind::tanh: return c[0] * detail::tanh_any<T>(c[1] * T(x) + c[2]) + c[3];
    case EnvelopeKind::atan: return c[0] * atan(c[1] * T(x) + c[2]) + c[3];
  }
  return T(x);
}

struct Envelope {
  EnvelopeKind kind = EnvelopeKind::identity;
  std::array<double, 4> c{1.0, 0.0, 0.0, 0.0};

  static Envelope identity() { return {}; }
  static Envelope affine(double a, double b) { return {EnvelopeKind::affine, {a, b, 0.0, 0.0}}; }
  static Envelope tanh(double c0, double c1, double c2, double c3) {
    return {EnvelopeKind::tanh, {c0, c1, c2, c3}};
  }
  static Envelope atan(double c0, double c1, double c2, double c3) {
    return {EnvelopeKind::atan, {c0, c1, c2, c3}};
  }

  // Throws hysteron::Error (message starts with `where`) if a coefficient is
  // not finite or breaks strict monotonicity (c0 > 0, c1 > 0).
  void validate(std::string_view where) const;

  double value(double x) const noexcept { return envelope_value<double>(kind, c.data(), x); }
  // d gamma / dx.
  double derivative(double x) const noexcept;
  // value(x) and derivative(x), bit-identical to them, with a tanh envelope's tanh
  // computed once for both (the numerical inverse's Newton step needs both).
  void value_and_derivative(double x, double& u, double& du) const noexcept {
    if (kind == EnvelopeKind::tanh) {
      const double t = detail::tanh_fast(c[1] * x + c[2]);
      u = c[0] * t + c[3];
      du = c[0] * c[1] * (1.0 - t * t);
    } else {
      u = value(x);
      du = derivative(x);
    }
  }
  // Open range (lo, hi) of gamma; infinite for identity and affine.
  double range_lo() const noexcept;
  double range_hi() const noexcept;
  bool in_range(double u) const noexcept { return u > range_lo() && u < range_hi(); }
  // Exact inverse gamma^-1(u). For u outside the open range it returns -inf/+inf
  // (never NaN); use inverse_checked for a throwing variant.
  double inverse(double u) const noexcept;
  // As inverse(), but throws hysteron::Error naming `where` outside the range.
  double inverse_checked(double u, std::string_view where) const;

  bool operator==(const Envelope&) const = default;
};

// Double-only envelope for the per-sample paths of Model and Inverse, with
// precomputed reciprocals. value() is bit-identical to Envelope::value();
// inverse() is Envelope::inverse() inside the open range and stays finite at
// its edges (the caller clamps to input limits).
struct FastEnvelope {
  EnvelopeKind kind = EnvelopeKind::identity;
  double c0 = 1.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;
  double inv_c0 = 1.0, inv_c1 = 1.0;

  FastEnvelope() = default;
  explicit FastEnvelope(const Envelope& e) noexcept
      : kind(e.kind), c0(e.c[0]), c1(e.c[1]), c2(e.c[2]), c3(e.c[3]), inv_c0(e.c[0] != 0 ? 1.0 / e.c[0] : 0.0),
        inv_c1(e.c[1] != 0 ? 1.0 / e.c[1] : 0.0) {}

  double value(double x) const noexcept {
    switch (kind) {
      case EnvelopeKind::identity: return x;
      case EnvelopeKind::affine: return c0 * x + c1;
      case EnvelopeKind::tanh: return c0 * detail::tanh_fast(c1 * x + c2) + c3;  // Eq. 5
      case EnvelopeKind::atan: return c0 * std::atan(c1 * x + c2) + c3;
    }
    return x;
  }
  double inverse(double u) const noexcept {
    switch (kind) {
      case EnvelopeKind::identity: return u;
      case EnvelopeKind::affine: return (u - c1) * inv_c0;
      case EnvelopeKind::tanh: return (detail::atanh_ratio(u - c3, c0) - c2) * inv_c1;
      case EnvelopeKind::atan: return (std::tan((u - c3) * inv_c0) - c2) * inv_c1;
    }
    return u;
  }
};

}  // namespace hysteron
