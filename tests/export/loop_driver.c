/* Test driver for a generated loop (hysteron export --loop; tests/test_export_loop.cpp,
 * tests/test_c_api_loops.cpp). Compile with a file exported with --prefix lp, either
 *   gcc -std=c99 ... -I DIR loop_driver.c DIR/loop.c -lm          (declarations in DIR/loop.h)
 *   gcc -std=c99 ... -I DIR -DLP_SINGLE loop_driver.c -lm         (#includes DIR/loop.c)
 * Reads commands from stdin and prints one line per result (C99 hex floats, exact):
 *   r                       reset                                  (no output)
 *   s REF PREV MEAS PRESS   one step of lp_loop_step               -> "S command duty"
 *   p N V0 .. VN-1          lp_loop_preview of N values            -> "P v0 .. vN-1"
 */
#include <stdio.h>
#include <stdlib.h>

#ifdef LP_SINGLE
#include "loop.c"
#else
#include "loop.h"
#endif

int main(void)
{
  lp_loop c;
  char op[8];
  double a[4];
  lp_loop_reset(&c);
  while (scanf("%7s", op) == 1) {
    switch (op[0]) {
      case 'r':
        lp_loop_reset(&c);
        break;
      case 's': {
        double duty = -2.0, u;
        if (scanf("%lf %lf %lf %lf", &a[0], &a[1], &a[2], &a[3]) != 4) return 2;
        u = lp_loop_step(&c, a[0], a[1], a[2], a[3], &duty);
        printf("S %a %a\n", u, duty);
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
