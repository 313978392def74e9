/* Time per sample of a generated loop (hysteron export --loop; not run by ctest):
 *   hysteron experiment gpi-pid --out run
 *   hysteron export --model run/best_model.json --loop run/result.json --run compensated \
 *       --out DIR/loop.c --header DIR/loop.h --prefix lp
 *   gcc -std=c99 -O2 -I DIR tests/export/bench_loop.c DIR/loop.c -o bench_loop -lm && ./bench_loop
 * lp_loop_step over 10^6 precomputed samples: a 0.5 Hz sine reference of amplitude A m around
 * A m (argument 1, default 0.012), its preview (lp_loop_preview), a measurement 10 samples
 * behind with a ripple, a pressure reading; three repetitions. Prints ns per sample and a
 * checksum of the commands. For a learning run's loop (--run learning.sine), compile with
 * -DLP_LEARNING: each repetition then also times lp_loop_learning_step (the loop and its
 * iterative learning) over the first 3 periods, and lp_loop_step right after on the same
 * samples. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "loop.h"

#define N 1000000
static double ref[N], pre[N], meas[N], pres[N];

static double now(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
  const double a = argc > 1 ? atof(argv[1]) : 0.012;
  lp_loop c;
  double acc = 0.0, duty = 0.0, t0, t1;
  long k;
  int rep;
  for (k = 0; k < N; ++k) {
    const double t = 1e-3 * (double)k;
    ref[k] = a + a * sin(2 * 3.141592653589793 * 0.5 * t);
    meas[k] = a + a * sin(2 * 3.141592653589793 * 0.5 * (t - 0.01)) + 1e-4 * sin(0.37 * (double)k);
    pres[k] = 0.3 + 0.25 * sin(2 * 3.141592653589793 * 0.5 * t - 0.3);
  }
  lp_loop_preview(ref, pre, N);
  for (rep = 0; rep < 3; ++rep) {
    lp_loop_reset(&c);
    t0 = now();
    for (k = 0; k < N; ++k) acc += lp_loop_step(&c, ref[k], pre[k], meas[k], pres[k], &duty) + duty;
    t1 = now();
    printf("loop step: %.1f ns per sample\n", 1e9 * (t1 - t0) / N);
#ifdef LP_LEARNING
    {
      /* the first 3 periods (the supervisor cannot hold the correction before 4: every sample
       * updates it), then the loop alone on the same samples */
      static lp_learning l;
      const long n = 3L * (long)LP_LEARNING_PERIOD < N ? 3L * (long)LP_LEARNING_PERIOD : N;
      double t2;
      lp_loop_reset(&c);
      lp_learning_reset(&l);
      t0 = now();
      for (k = 0; k < n; ++k) acc += lp_loop_learning_step(&c, &l, ref[k], pre[k], meas[k], pres[k], &duty) + duty;
      t1 = now();
      lp_loop_reset(&c);
      for (k = 0; k < n; ++k) acc += lp_loop_step(&c, ref[k], pre[k], meas[k], pres[k], &duty) + duty;
      t2 = now();
      printf("first %ld samples: loop + learning %.1f ns, loop alone %.1f ns per sample (%lu periods, held %d)\n", n,
             1e9 * (t1 - t0) / (double)n, 1e9 * (t2 - t1) / (double)n, (unsigned long)l.j, l.held);
    }
#endif
  }
  printf("checksum %.17g\n", acc);
  return 0;
}
