/* Time per sample of a generated compensator (not run by ctest):
 *   hysteron export --model M.json --out DIR/model.c --header DIR/model.h --prefix hm
 *   gcc -std=c99 -O2 -I DIR tests/export/bench.c DIR/model.c -o bench -lm && ./bench
 * Forward and inverse steps on 10^6 precomputed samples of a slow sine with minor loops
 * (amplitudes in model input / output units, arguments 1 and 2), three repetitions. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "model.h"

#define N 1000000
static double xs[N], ys[N];

static double now(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
  const double ax = argc > 1 ? atof(argv[1]) : 0.8, ay = argc > 2 ? atof(argv[2]) : 0.5;
  hm_model m;
  hm_inverse inv;
  double acc = 0.0, t0, t1, t2;
  long k;
  int rep;
  for (k = 0; k < N; ++k) {
    xs[k] = ax * (sin(1e-3 * (double)k) + 0.125 * sin(0.17 * (double)k));
    ys[k] = ay * (sin(1e-3 * (double)k) + 0.125 * sin(0.17 * (double)k));
  }
  for (rep = 0; rep < 3; ++rep) {
    hm_model_reset(&m);
    hm_inverse_reset(&inv);
    t0 = now();
    for (k = 0; k < N; ++k) acc += hm_model_step(&m, xs[k]);
    t1 = now();
    for (k = 0; k < N; ++k) acc += hm_inverse_step(&inv, ys[k]);
    t2 = now();
    printf("forward %.1f ns, inverse %.1f ns per sample (checksum %.17g)\n", (t1 - t0) / N * 1e9,
           (t2 - t1) / N * 1e9, acc);
  }
  return 0;
}
