#pragma once
// States that decay geometrically (the limit-cycle guard's count, the PID's filtered derivative,
// rate-pi's rate) reach the subnormal range after long enough at rest (708 time constants from 1),
// where every multiply-add takes tens of ns more on x86: Pid::step 27 -> 53 ns, rate-pi's model
// and inverse 80 -> 145 ns per sample. They are set to exactly 0 there instead.
#include <cmath>
#include <limits>

namespace hysteron::detail {

// x, or 0 where |x| < DBL_MIN (2.2e-308: only subnormals are flushed). Harmless for every state
// it is applied to: each is a term of a sum with numbers of the order of its units (mm, MPa, a
// count of half-cycles >= 1) or a factor 1 + c x, which a value below 2.2e-308 leaves unchanged
// (or changes by less than 2.2e-308 where every other term is 0).
inline double flush_subnormal(double x) noexcept {
  return std::abs(x) < std::numeric_limits<double>::min() ? 0.0 : x;
}

}  // namespace hysteron::detail
