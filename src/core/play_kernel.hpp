#pragma once
// Per-sample kernel shared by Model::step and Inverse::step (double only):
// n generalized plays on one envelope value (Eq. 4) and their weighted sum
// (Eqs. 6, 9). SSE2 on x86-64 (two operators per instruction, branch-free
// minpd/maxpd); elsewhere a scalar loop with the same four partial sums, so
// every platform returns the same bits.
#include <cstddef>

#if defined(__SSE2__) || defined(_M_X64)
#include <emmintrin.h>
#define HYSTERON_PLAY_SSE2 1
#endif

namespace hysteron::detail {

// y_out[i] = max{u - r_i, min{u + r_i, y_in[i]}} (y_out may equal y_in);
// returns sum_i p_i y_out[i] accumulated as (s0 + s2) + (s1 + s3) with
// s_j = sum over i = j (mod 4), the odd tail in s0 or s2.
inline double play_weighted_sum(double u, const double* r, const double* p, const double* y_in, double* y_out,
                                std::size_t n) noexcept {
#ifdef HYSTERON_PLAY_SSE2
  const __m128d uu = _mm_set1_pd(u);
  __m128d a0 = _mm_setzero_pd(), a1 = _mm_setzero_pd();
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m128d r0 = _mm_loadu_pd(r + i), r1 = _mm_loadu_pd(r + i + 2);
    // min(y, u + r) then max(., u - r): the operand order of ops::hmin/hmax
    const __m128d y0 = _mm_max_pd(_mm_min_pd(_mm_loadu_pd(y_in + i), _mm_add_pd(uu, r0)), _mm_sub_pd(uu, r0));
    const __m128d y1 = _mm_max_pd(_mm_min_pd(_mm_loadu_pd(y_in + i + 2), _mm_add_pd(uu, r1)), _mm_sub_pd(uu, r1));
    _mm_storeu_pd(y_out + i, y0);
    _mm_storeu_pd(y_out + i + 2, y1);
    a0 = _mm_add_pd(a0, _mm_mul_pd(_mm_loadu_pd(p + i), y0));
    a1 = _mm_add_pd(a1, _mm_mul_pd(_mm_loadu_pd(p + i + 2), y1));
  }
  if (i + 2 <= n) {
    const __m128d r0 = _mm_loadu_pd(r + i);
    const __m128d y0 = _mm_max_pd(_mm_min_pd(_mm_loadu_pd(y_in + i), _mm_add_pd(uu, r0)), _mm_sub_pd(uu, r0));
    _mm_storeu_pd(y_out + i, y0);
    a0 = _mm_add_pd(a0, _mm_mul_pd(_mm_loadu_pd(p + i), y0));
    i += 2;
  }
  if (i < n) {
    const __m128d r0 = _mm_load_sd(r + i);
    const __m128d y0 = _mm_max_sd(_mm_min_sd(_mm_load_sd(y_in + i), _mm_add_sd(uu, r0)), _mm_sub_sd(uu, r0));
    _mm_store_sd(y_out + i, y0);
    a1 = _mm_add_sd(a1, _mm_mul_sd(_mm_load_sd(p + i), y0));
  }
  const __m128d s = _mm_add_pd(a0, a1);  // (s0 + s2, s1 + s3)
  return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
#else
  double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  auto play = [u](double ri, double yi) {
    const double hi = u + ri, lo = u - ri;
    const double m = yi < hi ? yi : hi;  // minpd(y, hi)
    return m > lo ? m : lo;              // maxpd(m, lo)
  };
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const double y0 = play(r[i], y_in[i]), y1 = play(r[i + 1], y_in[i + 1]);
    const double y2 = play(r[i + 2], y_in[i + 2]), y3 = play(r[i + 3], y_in[i + 3]);
    y_out[i] = y0; y_out[i + 1] = y1; y_out[i + 2] = y2; y_out[i + 3] = y3;
    s0 += p[i] * y0; s1 += p[i + 1] * y1; s2 += p[i + 2] * y2; s3 += p[i + 3] * y3;
  }
  if (i + 2 <= n) {
    const double y0 = play(r[i], y_in[i]), y1 = play(r[i + 1], y_in[i + 1]);
    y_out[i] = y0; y_out[i + 1] = y1;
    s0 += p[i] * y0; s1 += p[i + 1] * y1;
    i += 2;
  }
  if (i < n) {
    const double y0 = play(r[i], y_in[i]);
    y_out[i] = y0;
    s2 += p[i] * y0;
  }
  return (s0 + s2) + (s1 + s3);
#endif
}

}  // namespace hysteron::detail
