/* Test driver for generated C (tests/test_export.cpp, tests/cli/export_c.sh).
 * Compile with a model exported with --prefix hm, either
 *   gcc -std=c99 ... -I DIR driver.c DIR/model.c -lm              (declarations in DIR/model.h)
 *   gcc -std=c99 ... -I DIR -DHM_SINGLE driver.c -lm              (#includes DIR/model.c)
 * Reads commands from stdin, one per line, and prints one line per result
 * (numbers as C99 hex floats, exact):
 *   v              virgin reset of the model and the inverse          (no output)
 *   r X0           model relaxed at X0, inverse started from its state -> "R rc"
 *   n X0           the same over garbage structs, with a refused X0    -> "N rc_relaxed rc_state"
 *                  (then both in the virgin state)
 *   s U Y0..Yn-1   model and inverse started from the state (y, u)     -> "S rc_model rc_inverse"
 *   f X            forward step                                        -> "F out faults"
 *   i Y            inverse step                                        -> "I x saturated faults"
 *   l              input limits                                        -> "L lo hi"
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef HM_SINGLE
#include "model.c"
#else
#include "model.h"
#endif

int main(void)
{
  hm_model m;
  hm_inverse inv;
  char op[8];
  double a, y[HM_NUM_OPERATORS + 1];
  int i;
  hm_model_reset(&m);
  hm_inverse_reset(&inv);
  while (scanf("%7s", op) == 1) {
    switch (op[0]) {
      case 'v':
        hm_model_reset(&m);
        hm_inverse_reset(&inv);
        break;
      case 'r':
        if (scanf("%lf", &a) != 1) return 2;
        hm_model_reset_relaxed(&m, a);
        printf("R %d\n", hm_inverse_reset_state(&inv, m.y, m.u));
        break;
      case 'n': {
        int rm, ri;
        if (scanf("%lf", &a) != 1) return 2;
        memset(&m, 0xA5, sizeof m); /* as uninitialised stack memory */
        memset(&inv, 0xA5, sizeof inv);
        rm = hm_model_reset_relaxed(&m, a);
        ri = rm == 0 ? hm_inverse_reset_state(&inv, m.y, m.u) : hm_inverse_reset_state(&inv, m.y, NAN);
        printf("N %d %d\n", rm, ri);
        break;
      }
      case 's': {
        int rm, ri;
        if (scanf("%lf", &a) != 1) return 2;
        for (i = 0; i < HM_NUM_OPERATORS; ++i)
          if (scanf("%lf", &y[i]) != 1) return 2;
        rm = hm_model_reset_state(&m, y, a);
        ri = hm_inverse_reset_state(&inv, y, a);
        printf("S %d %d\n", rm, ri);
        break;
      }
      case 'f':
        if (scanf("%lf", &a) != 1) return 2;
        a = hm_model_step(&m, a);
        printf("F %a %lu\n", a, m.faults);
        break;
      case 'i':
        if (scanf("%lf", &a) != 1) return 2;
        a = hm_inverse_step(&inv, a);
        printf("I %a %d %lu\n", a, inv.saturated, inv.faults);
        break;
      case 'l': {
        double lo, hi;
        hm_input_limits(&lo, &hi);
        printf("L %a %a\n", lo, hi);
        break;
      }
      default:
        fprintf(stderr, "driver: unknown command \"%s\"\n", op);
        return 2;
    }
  }
  return 0;
}
