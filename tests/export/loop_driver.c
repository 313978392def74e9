/* Test driver for a generated loop (hysteron export --loop; tests/test_export_loop.cpp,
 * tests/test_c_api_loops.cpp). Compile with a file exported with --prefix lp, either
 *   gcc -std=c99 ... -I DIR loop_driver.c DIR/loop.c -lm          (declarations in DIR/loop.h)
 *   gcc -std=c99 ... -I DIR -DLP_SINGLE loop_driver.c -lm         (#includes DIR/loop.c)
 * Reads commands from stdin and prints one line per result (C99 hex floats, exact):
 *   r                       reset                                  (no output)
 *   g                       lp_loop_restart_guard                  (no output)
 *   s REF PREV MEAS PRESS   one step of lp_loop_step               -> "S command duty" and the counts
 *                           after it: the position PID's faults, guard_cuts, gain_scale, the inverse's
 *                           faults; with -DLP_CASCADE (a cascade_pwm loop) also the pressure PID's
 *                           faults, guard_cuts, gain_scale and pwm_faults
 *   p N V0 .. VN-1          lp_loop_preview of N values            -> "P v0 .. vN-1"
 * With -DLP_LEARNING (a loop exported with its learning), also
 *   l REF PREV MEAS PRESS   one step of lp_loop_learning_step      -> "L command duty c0"
 *                           (c0 = lp_learning_correction(0) before the step)
 *   w N V0 .. VN-1          lp_learning_warm_start                 -> "W status"
 * and r resets the learning too.
 */
#include <stdio.h>
#include <stdlib.h>

#ifdef LP_SINGLE
#include "loop.c"
#else
#include "loop.h"
#endif

#ifdef LP_LEARNING
static lp_learning l; /* large: not on the stack */
#endif

int main(void)
{
  lp_loop c;
  char op[8];
  double a[4];
  lp_loop_reset(&c);
#ifdef LP_LEARNING
  lp_learning_reset(&l);
#endif
  while (scanf("%7s", op) == 1) {
    switch (op[0]) {
      case 'g':
        lp_loop_restart_guard(&c);
        break;
      case 'r':
        lp_loop_reset(&c);
#ifdef LP_LEARNING
        lp_learning_reset(&l);
#endif
        break;
#ifdef LP_LEARNING
      case 'l': {
        double duty = -2.0, u, c0;
        if (scanf("%lf %lf %lf %lf", &a[0], &a[1], &a[2], &a[3]) != 4) return 2;
        c0 = lp_learning_correction(&l, 0u);
        u = lp_loop_learning_step(&c, &l, a[0], a[1], a[2], a[3], &duty);
        printf("L %a %a %a\n", u, duty, c0);
        break;
      }
      case 'w': {
        unsigned long n, k;
        double *v;
        if (scanf("%lu", &n) != 1 || n == 0) return 2;
        v = (double *)malloc(n * sizeof *v);
        if (!v) return 3;
        for (k = 0; k < n; ++k)
          if (scanf("%lf", &v[k]) != 1) return 2;
        printf("W %d\n", lp_learning_warm_start(&l, v, (size_t)n));
        free(v);
        break;
      }
#endif
      case 's': {
        double duty = -2.0, u;
        if (scanf("%lf %lf %lf %lf", &a[0], &a[1], &a[2], &a[3]) != 4) return 2;
        u = lp_loop_step(&c, a[0], a[1], a[2], a[3], &duty);
        printf("S %a %a %lu %lu %a %lu", u, duty, c.position.faults, c.position.guard_cuts, c.position.gain_scale,
               c.inverse.faults);
#ifdef LP_CASCADE
        printf(" %lu %lu %a %lu", c.pressure.faults, c.pressure.guard_cuts, c.pressure.gain_scale, c.pwm_faults);
#endif
        printf("\n");
        break;
      }
      case 'p': {
        unsigned long n, k;
        double *ref, *pre;
        if (scanf("%lu", &n) != 1 || n == 0) return 2;
        ref = (double *)malloc(n * sizeof *ref);
        pre = (double *)malloc(n * sizeof *pre);
        if (!ref || !pre) return 3;
        for (k = 0; k < n; ++k)
          if (scanf("%lf", &ref[k]) != 1) return 2;
        lp_loop_preview(ref, pre, (size_t)n);
        printf("P");
        for (k = 0; k < n; ++k) printf(" %a", pre[k]);
        printf("\n");
        free(ref);
        free(pre);
        break;
      }
      default:
        return 2;
    }
  }
  return 0;
}
