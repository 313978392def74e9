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
#include <cmath>
#include <cstddef>
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
// tanh and atanh through expm1/log1p: 2-3 ulp, about twice as fast as glibc's
// tanh/atanh, and odd-symmetric so that small and negative arguments keep
// full relative precision.
inline double tanh_fast(double z) noexcept {
  const double a = std::abs(z);
  if (a > 19.1) return std::copysign(1.0, z);  // tanh = 1 to double precision
  const double e = std::expm1(2.0 * a);
  return std::copysign(e / (e + 2.0), z);
}
inline double atanh_fast(double w) noexcept {
  const double a = std::abs(w);
  return std::copysign(0.5 * std::log1p(2.0 * a / (1.0 - a)), w);
}
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

}  // namespace hysteron
