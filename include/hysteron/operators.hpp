#pragma once
// Elementary hysteresis operators, templated on the scalar type so that the
// same code runs with double and with automatic-differentiation types (Ceres Jet).
// Equation numbers refer to ../shared/papers/gpi-lm-feedforward-pid.txt unless noted.
//
// All functions are pure, allocation-free and noexcept for double.

namespace hysteron::ops {

// max/min written with operator< only, so that they work for any ordered scalar
// (std::max would need both arguments of one exact type; Jets compare by value).
template <class T>
inline T hmax(const T& a, const T& b) { return a < b ? b : a; }
template <class T>
inline T hmin(const T& a, const T& b) { return b < a ? b : a; }

// Linear play (backlash) operator, Eq. 1:
//   y(k) = max{ x(k) - r, min{ x(k) + r, y(k-1) } },  r >= 0.
// The initial condition of Eq. 2 is the same expression with y(k-1) = y_i0.
template <class T, class X>
inline T play(const X& x, const T& r, const T& y_prev) {
  return hmax<T>(T(x) - r, hmin<T>(T(x) + r, y_prev));
}

// Stop (elastic-plastic) operator, the dual of the play: s = x - play(x), i.e.
//   s(k) = min{ r, max{ -r, s(k-1) + x(k) - x(k-1) } }.
template <class T, class X>
inline T stop(const X& x, const X& x_prev, const T& r, const T& s_prev) {
  return hmin<T>(r, hmax<T>(-r, s_prev + T(x) - T(x_prev)));
}

// Generalized play on an envelope value u = gamma(x), Eq. 4:
//   y(k) = max{ gamma(x(k)) - r, min{ gamma(x(k)) + r, y(k-1) } }.
// The envelope is applied by the caller (it is shared by all operators of a model).
template <class T>
inline T generalized_play(const T& u, const T& r, const T& y_prev) {
  return hmax<T>(u - r, hmin<T>(u + r, y_prev));
}

// Asymmetric generalized play: the output follows the ascending envelope
// u_a = gamma_a(x) (minus r) while the input rises and the descending envelope
// u_d = gamma_d(x) (plus r) while it falls:
//   y(k) = max{ gamma_a(x(k)) - r, min{ gamma_d(x(k)) + r, y(k-1) } }.
// With gamma_a == gamma_d it is the generalized play.
template <class T>
inline T asymmetric_play(const T& u_a, const T& u_d, const T& r, const T& y_prev) {
  return hmax<T>(u_a - r, hmin<T>(u_d + r, y_prev));
}

// One-sided dead-zone operator (modified PI of Kuhnen, used in
// ../shared/papers/mpi-deadzone-switching-valves.txt):
//   S_z(v) = max{ v - z, 0 }  for z > 0,
//   S_z(v) = v                for z = 0,
//   S_z(v) = min{ v - z, 0 }  for z < 0.
template <class T>
inline T dead_zone(const T& v, const T& z) {
  if (T(0) < z) return hmax<T>(v - z, T(0));
  if (z < T(0)) return hmin<T>(v - z, T(0));
  return v;
}

}  // namespace hysteron::ops
