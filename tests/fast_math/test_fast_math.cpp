// The header-inline kernels of envelope.hpp (detail::tanh_fast, half_log1p, atanh_ratio and
// Envelope::value, which uses tanh_fast) compiled in a user's translation unit built with
// -ffast-math (this file is; tests/CMakeLists.txt). Compilers reassociate under it: the
// round-to-integer trick (y/ln2 + 1.5 2^52) - 1.5 2^52 folded to y/ln2 put tanh_fast off by up to
// 0.17, and s (..) + (s - 1) regrouped lost its relative precision below |z| = 1e-3. Reference:
// long double.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "hysteron/envelope.hpp"

#if !defined(__FAST_MATH__)
#error "tests/fast_math/test_fast_math.cpp must be compiled with -ffast-math (tests/CMakeLists.txt)"
#endif

namespace {

using hysteron::detail::atanh_ratio;
using hysteron::detail::half_log1p;
using hysteron::detail::tanh_fast;

// Arguments over [-25, 25] on a grid, and +-10^e for e = -300..300 (small: relative precision;
// large: saturation at +-1).
std::vector<double> tanh_arguments() {
  std::vector<double> z;
  for (int i = 0; i <= 200000; ++i) z.push_back(-25.0 + 50.0 * i / 200000.0);
  for (int e = -3000; e <= 3000; ++e) {
    const double v = std::pow(10.0, e / 10.0) * (1.0 + 0.37 * ((e + 3000) % 7) / 7.0);
    z.push_back(v);
    z.push_back(-v);
  }
  return z;
}

TEST(FastMath, TanhFastMatchesTanh) {
  double worst = 0.0, at = 0.0;
  for (const double z0 : tanh_arguments()) {
    volatile double zv = z0;  // no constant folding
    const double z = zv;
    const double t = tanh_fast(z);
    const long double ref = std::tanh(static_cast<long double>(z));
    if (ref == 0) {
      EXPECT_EQ(t, 0.0);
      continue;
    }
    // relative error (|tanh| <= 1, so it bounds the absolute error too)
    const double err = static_cast<double>(std::fabs(static_cast<long double>(t) - ref) / std::fabs(ref));
    if (err > worst) worst = err, at = z;
  }
  // at most 2.6 ulp (5.8e-16) at normal flags; measured 3.0e-16 under -ffast-math
  EXPECT_LE(worst, 1e-15) << "tanh_fast off by " << worst << " (relative) at z = " << at;
  std::printf("  tanh_fast under -ffast-math: max relative error %.3g (z = %.6g)\n", worst, at);
  EXPECT_EQ(tanh_fast(1e300), 1.0);
  EXPECT_EQ(tanh_fast(-25.0), -1.0);
}

TEST(FastMath, TanhEnvelopeMatchesTheFormula) {
  const hysteron::Envelope e = hysteron::Envelope::tanh(26.5, 5.4, -1.67, 21.4);  // gpi-pid's fitted scale
  double worst = 0.0;
  for (int i = 0; i <= 100000; ++i) {
    volatile double xv = -0.2 + 1.0 * i / 100000.0;
    const double x = xv;
    const long double ref = 26.5L * std::tanh(5.4L * x - 1.67L) + 21.4L;
    worst = std::max(worst, static_cast<double>(std::fabs(e.value(x) - ref) / 26.5L));
  }
  EXPECT_LE(worst, 1e-15);
  std::printf("  tanh envelope under -ffast-math: max error %.3g (relative to c0)\n", worst);
}

// half_log1p keeps its absolute accuracy under -ffast-math; below t = 1e-3 its relative precision
// is lost (the Fast2Sum of 1 + t is regrouped), harmless for the inverses (atanh_ratio feeds
// (atanh - c2) / c1, an absolute error).
TEST(FastMath, HalfLog1pAndAtanhRatioAbsoluteAccuracy) {
  double worst = 0.0, at = 0.0;
  for (int e = -3000; e <= 3000; ++e) {
    volatile double tv = std::pow(10.0, e / 10.0);
    const double t = tv;
    const long double ref = 0.5L * std::log1p(static_cast<long double>(t));
    const double err = static_cast<double>(std::fabs(half_log1p(t) - ref) / std::max(1.0L, std::fabs(ref)));
    if (err > worst) worst = err, at = t;
  }
  EXPECT_LE(worst, 1e-15) << "half_log1p at t = " << at;
  std::printf("  half_log1p under -ffast-math: max error %.3g (relative to max(1, |value|))\n", worst);
  worst = 0.0;
  for (int i = -100000; i <= 100000; ++i) {
    volatile double dv = 3.0 * i / 100000.0;
    const double d = dv;
    const long double w = d / 3.0L;
    if (std::fabs(w) >= 1) continue;
    const long double ref = std::atanh(w);
    const double err = static_cast<double>(std::fabs(atanh_ratio(d, 3.0) - ref) / std::max(1.0L, std::fabs(ref)));
    if (err > worst) worst = err, at = d;
  }
  EXPECT_LE(worst, 1e-14) << "atanh_ratio at d = " << at;
  std::printf("  atanh_ratio under -ffast-math: max error %.3g (relative to max(1, |value|))\n", worst);
}

}  // namespace
