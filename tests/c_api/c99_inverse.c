/* The C ABI from strict C99 (compiled with -std=c99 -pedantic -Wall -Wextra -Werror).
 *
 *   hysteron_c_test selftest MODEL.json
 *       loads the model file, runs the model and its inverse over a trajectory (virgin,
 *       relaxed, from a saved state; batch and per sample), runs the feedforward + PID
 *       controller and iterative learning control on a simulated loop, and checks the error
 *       paths (bad JSON, unknown key, missing file, NULL, NaN, wrong sizes, bad limits,
 *       controller and learning parameters): status and message.
 *   hysteron_c_test invert MODEL.json Y.txt X.txt
 *       inverts the desired outputs of Y.txt (one number per line) from the virgin state
 *       and writes the inputs to X.txt, one per line with 17 significant digits
 *       (compared with `hysteron invert` by tests/c_api/cli_equal.sh).
 * Exit status 0 if every check passed, 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hysteron/hysteron.h"

#include "c_check.h"

static double max_abs_diff(const double* a, const double* b, size_t n) {
  double m = 0.0;
  size_t k;
  for (k = 0; k < n; ++k) {
    const double d = fabs(a[k] - b[k]);
    if (d > m || d != d) m = d;
  }
  return m;
}

#define N 2000

static void check_errors(const hysteron_params* params, hysteron_model* model, hysteron_inverse* inverse) {
  hysteron_params* p = NULL;
  hysteron_model* m = NULL;
  hysteron_inverse* inv = NULL;
  hysteron_ff_pid* c = NULL;
  hysteron_ff_pid_params cp;
  double x[8] = {0.1, 0.2, 0.3, 0.4, 0.5, 0.4, 0.3, 0.2};
  double y[8], y_ref[8], state[64];
  double held = 0.0, v = 0.0, u = 0.0;
  int sat = -1;
  size_t n = 0;
  hysteron_status st;

  /* model loading */
  expect_error("bad JSON", hysteron_params_from_json("{\"model\": \"gpi\", ", &p), HYSTERON_ERROR_PARSE,
               "not valid JSON");
  CHECK(p == NULL, "no handle on failure");
  expect_error("repeated key", hysteron_params_from_json("{\"model\": \"gpi\", \"model\": \"pi\", \"r\": [0.1], "
                                                         "\"p\": [1]}", &p),
               HYSTERON_ERROR_PARSE, "appears twice");
  expect_error("unknown key", hysteron_params_from_json("{\"model\": \"pi\", \"r\": [0.1], \"p\": [1], \"gain\": 2}", &p),
               HYSTERON_ERROR_MODEL, "gain");
  expect_error("invalid value",
               hysteron_params_from_json("{\"model\": \"gpi\", \"c\": [1,1,0,0], \"n\": 3, \"rho\": 1, \"tau\": 1, "
                                         "\"alpha\": -1}", &p),
               HYSTERON_ERROR_MODEL, "alpha");
  expect_error("missing file", hysteron_params_from_file("/nonexistent/dir/m.json", &p), HYSTERON_ERROR_IO,
               "/nonexistent/dir/m.json");
  expect_error("NULL json", hysteron_params_from_json(NULL, &p), HYSTERON_ERROR_NULL_POINTER, "json");
  expect_error("NULL out", hysteron_params_from_json("{}", NULL), HYSTERON_ERROR_NULL_POINTER, "out");
  expect_error("NULL path", hysteron_params_from_file(NULL, &p), HYSTERON_ERROR_NULL_POINTER, "path");
  CHECK(p == NULL, "no handle on failure");
  OK(hysteron_params_free(NULL));

  /* an mpi-asym inverse needs finite limits */
  OK(hysteron_params_from_json("{\"model\": \"mpi-asym\", \"r\": [0.1], \"p\": [0.2], "
                               "\"ascending\": {\"envelope\": \"identity\"}, "
                               "\"descending\": {\"envelope\": \"affine\", \"c\": [1, 0.1]}}", &p));
  expect_error("mpi-asym without limits", hysteron_inverse_create(p, -HUGE_VAL, HUGE_VAL, &inv), HYSTERON_ERROR_MODEL,
               "limit");
  CHECK(inv == NULL, "no handle on failure");
  OK(hysteron_inverse_create(p, -1.0, 1.0, &inv));
  OK(hysteron_inverse_free(inv));
  inv = NULL;
  OK(hysteron_params_free(p));

  /* create */
  expect_error("model_create NULL params", hysteron_model_create(NULL, &m), HYSTERON_ERROR_NULL_POINTER, "params");
  expect_error("inverse NaN limit", hysteron_inverse_create(params, NAN, 1.0, &inv), HYSTERON_ERROR_INVALID_ARGUMENT,
               "lo = nan");
  expect_error("inverse lo > hi", hysteron_inverse_create(params, 1.0, 0.0, &inv), HYSTERON_ERROR_INVALID_ARGUMENT,
               "need lo < hi");
  CHECK(inv == NULL && m == NULL, "no handles on failure");

  /* per-sample steps: NULL and NaN */
  expect_error("model_step NULL model", hysteron_model_step(NULL, 0.1, &v), HYSTERON_ERROR_NULL_POINTER, "model");
  expect_error("model_step NULL y", hysteron_model_step(model, 0.1, NULL), HYSTERON_ERROR_NULL_POINTER, "y");
  expect_error("inverse_step NULL x", hysteron_inverse_step(inverse, 0.1, NULL, NULL), HYSTERON_ERROR_NULL_POINTER,
               "x is NULL");
  OK(hysteron_inverse_reset(inverse));
  OK(hysteron_inverse_step(inverse, 0.05, &held, &sat));
  CHECK(sat == 0 || sat == 1, "saturated flag %d", sat);
  v = -1.0;
  st = hysteron_inverse_step(inverse, NAN, &v, &sat);
  expect_error("inverse_step NaN", st, HYSTERON_ERROR_INVALID_ARGUMENT, "y_desired = nan");
  CHECK(v == held, "NaN holds the previous input: %.17g vs %.17g", v, held);
  st = hysteron_inverse_step(inverse, HUGE_VAL, &v, NULL);
  expect_error("inverse_step inf", st, HYSTERON_ERROR_INVALID_ARGUMENT, "y_desired = inf");
  OK(hysteron_model_reset(model));
  OK(hysteron_model_step(model, 0.3, &held));
  st = hysteron_model_step(model, NAN, &v);
  expect_error("model_step NaN", st, HYSTERON_ERROR_INVALID_ARGUMENT, "x = nan");
  CHECK(v == held, "NaN holds the previous output");

  /* batch: wrong sizes, NaN inside (nothing stepped), NULL arrays */
  expect_error("simulate sizes", hysteron_model_simulate(model, x, 8, y, 7), HYSTERON_ERROR_INVALID_ARGUMENT,
               "n_x = 8 and n_y = 7 differ");
  expect_error("invert sizes", hysteron_inverse_invert(inverse, x, 8, y, 9, NULL), HYSTERON_ERROR_INVALID_ARGUMENT,
               "n_y = 8 and n_x = 9 differ");
  expect_error("simulate NULL x", hysteron_model_simulate(model, NULL, 8, y, 8), HYSTERON_ERROR_NULL_POINTER, "x");
  OK(hysteron_model_simulate(model, NULL, 0, NULL, 0));
  OK(hysteron_model_reset(model));
  OK(hysteron_model_simulate(model, x, 8, y_ref, 8));
  OK(hysteron_model_reset(model));
  x[3] = NAN;
  expect_error("simulate NaN", hysteron_model_simulate(model, x, 8, y, 8), HYSTERON_ERROR_INVALID_ARGUMENT, "x[3] = nan");
  x[3] = 0.4;
  OK(hysteron_model_simulate(model, x, 8, y, 8)); /* the failed call stepped nothing */
  CHECK(max_abs_diff(y, y_ref, 8) == 0.0, "state unchanged by a failed batch");
  y[5] = -HUGE_VAL;
  expect_error("invert inf", hysteron_inverse_invert(inverse, y, 8, y, 8, &n), HYSTERON_ERROR_INVALID_ARGUMENT,
               "y[5] = -inf");

  /* states */
  OK(hysteron_params_num_operators(params, &n));
  CHECK(n < 64, "test buffer too small for %lu operators", (unsigned long)n);
  OK(hysteron_model_get_state(model, state, n, &u));
  expect_error("reset_state size", hysteron_model_reset_state(model, state, n + 1, u), HYSTERON_ERROR_INVALID_ARGUMENT,
               "operators");
  expect_error("get_state size", hysteron_inverse_get_state(inverse, state, n + 2, &u),
               HYSTERON_ERROR_INVALID_ARGUMENT, "operators");
  expect_error("reset_state NaN u", hysteron_inverse_reset_state(inverse, state, n, NAN),
               HYSTERON_ERROR_INVALID_ARGUMENT, "u = nan");
  if (n > 0) {
    state[0] = NAN;
    expect_error("reset_state NaN y", hysteron_model_reset_state(model, state, n, 0.0),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "y[0] = nan");
    expect_error("reset_state NULL y", hysteron_model_reset_state(model, NULL, n, 0.0), HYSTERON_ERROR_NULL_POINTER,
                 "y");
  }
  expect_error("reset_relaxed NaN", hysteron_inverse_reset_relaxed(inverse, NAN), HYSTERON_ERROR_INVALID_ARGUMENT,
               "x0 = nan");

  /* controller */
  OK(hysteron_ff_pid_default_params(&cp));
  cp.sample_time = 0.0;
  expect_error("ff_pid sample_time 0", hysteron_ff_pid_create(params, &cp, &c), HYSTERON_ERROR_INVALID_ARGUMENT,
               "sample_time");
  OK(hysteron_ff_pid_default_params(&cp));
  cp.anti_windup = 7;
  expect_error("ff_pid anti_windup 7", hysteron_ff_pid_create(params, &cp, &c), HYSTERON_ERROR_INVALID_ARGUMENT,
               "anti_windup = 7");
  OK(hysteron_ff_pid_default_params(&cp));
  cp.pressure_max = NAN;
  expect_error("ff_pid NaN limit", hysteron_ff_pid_create(params, &cp, &c), HYSTERON_ERROR_INVALID_ARGUMENT,
               "pressure_limits");
  CHECK(c == NULL, "no handle on failure");
  expect_error("ff_pid_step NULL", hysteron_ff_pid_step(NULL, 0, 0, 0, &v), HYSTERON_ERROR_NULL_POINTER, "controller");
}

/* Iterative learning on a simulated loop y_k = a y_{k-1} + (1 - a) u_{k-1} (a lag and one
 * sample of delay) tracking a sine of N_ILC samples per period: u = r + c, the correction learnt
 * with a phase lead of 2 samples. The RMS error of each period falls, to under 5 % of the
 * first period's within 15 periods; the error paths of the learning functions. */
#define N_ILC 200
static void check_ilc(void) {
  hysteron_ilc_params ip;
  hysteron_ilc* ilc = NULL;
  static double saved[N_ILC];
  double rms[15], y = 0.0, u = 0.0, c = 0.0, g = 0.0, warm = 0.0;
  size_t j, k, phase = 0, iteration = 0, faults = 0;
  int held = 1;
  const double a = 0.8, pi = 3.14159265358979323846;
  OK(hysteron_ilc_default_params(&ip));
  CHECK(ip.period == 0 && ip.gain == 0.5 && ip.max_gain == 0.0, "defaults: period %zu, gain %g", ip.period, ip.gain);
  expect_error("ilc period 0", hysteron_ilc_create(&ip, &ilc), HYSTERON_ERROR_INVALID_ARGUMENT, "period");
  CHECK(ilc == NULL, "no handle on failure");
  ip.period = (size_t)-1; /* SIZE_MAX: refused by its bound (it was an INTERNAL error) */
  expect_error("ilc period SIZE_MAX", hysteron_ilc_create(&ip, &ilc), HYSTERON_ERROR_INVALID_ARGUMENT,
               "must be <= 10000000 samples");
  CHECK(ilc == NULL, "no handle on failure");
  ip.period = N_ILC;
  ip.gain = 2.5;
  expect_error("ilc gain 2.5", hysteron_ilc_create(&ip, &ilc), HYSTERON_ERROR_INVALID_ARGUMENT, "gain = 2.5");
  ip.gain = 0.5;
  ip.lead = 2;
  ip.half_width = 2000; /* its summed taps, 2 x 287, beyond the period */
  expect_error("ilc window beyond the period", hysteron_ilc_create(&ip, &ilc), HYSTERON_ERROR_INVALID_ARGUMENT,
               "must be < period = 200");
  ip.half_width = 4;
  ip.lookahead = 3;
  expect_error("ilc create NULL", hysteron_ilc_create(NULL, &ilc), HYSTERON_ERROR_NULL_POINTER, "params");
  OK(hysteron_ilc_create(&ip, &ilc));
  if (ilc == NULL) return;
  for (j = 0; j < 15; ++j) {
    double s2 = 0.0;
    for (k = 0; k < N_ILC; ++k) {
      const double r = sin(2.0 * pi * (double)k / N_ILC);
      double e;
      y = a * y + (1.0 - a) * u; /* the plant answers the previous command */
      OK(hysteron_ilc_correction(ilc, 0, &c));
      if (j == 14) saved[k] = c; /* the last period's correction, for the warm start below */
      u = r + c;
      e = r - y;
      s2 += e * e;
      OK(hysteron_ilc_step(ilc, e));
    }
    rms[j] = sqrt(s2 / N_ILC);
    if (j > 0) CHECK(rms[j] <= rms[j - 1] * (1.0 + 1e-9), "period %zu: RMS %g above the period before, %g", j, rms[j], rms[j - 1]);
  }
  CHECK(rms[14] < 0.05 * rms[0], "learning: the last period's RMS %g is not below 5 %% of the first's, %g", rms[14], rms[0]);
  printf("ok   ilc: RMS of the first and the last of 15 periods %g, %g\n", rms[0], rms[14]);
  OK(hysteron_ilc_state(ilc, &phase, &iteration, &g, NULL, NULL, &held, &faults));
  CHECK(phase == 0 && iteration == 15 && g == 0.5 && held == 0 && faults == 0, "state: phase %zu, iteration %zu, L %g",
        phase, iteration, g);
  OK(hysteron_ilc_correction(ilc, 3, &c));
  expect_error("ilc correction beyond the lookahead", hysteron_ilc_correction(ilc, 4, &c),
               HYSTERON_ERROR_INVALID_ARGUMENT, "lookahead = 3");
  expect_error("ilc correction NULL", hysteron_ilc_correction(ilc, 0, NULL), HYSTERON_ERROR_NULL_POINTER,
               "correction");
  expect_error("ilc step NaN", hysteron_ilc_step(ilc, NAN), HYSTERON_ERROR_INVALID_ARGUMENT, "not finite");
  OK(hysteron_ilc_state(ilc, &phase, NULL, NULL, NULL, NULL, NULL, &faults));
  CHECK(phase == 1 && faults == 1, "a NaN error advances the sample (phase %zu) and is counted (%zu)", phase, faults);
  expect_error("ilc step NULL", hysteron_ilc_step(NULL, 0.0), HYSTERON_ERROR_NULL_POINTER, "ilc");
  OK(hysteron_ilc_reset(ilc));
  OK(hysteron_ilc_state(ilc, &phase, &iteration, NULL, NULL, NULL, NULL, NULL));
  OK(hysteron_ilc_correction(ilc, 0, &c));
  CHECK(phase == 0 && iteration == 0 && c == 0.0, "reset: phase %zu, iteration %zu, correction %g", phase, iteration, c);
  /* warm start: the plant at rest again, the first period applies the saved correction */
  expect_error("ilc reset_to short", hysteron_ilc_reset_to(ilc, saved, N_ILC - 1), HYSTERON_ERROR_INVALID_ARGUMENT,
               "has 199 values");
  expect_error("ilc reset_to NULL", hysteron_ilc_reset_to(ilc, NULL, N_ILC), HYSTERON_ERROR_NULL_POINTER, "correction");
  c = saved[7];
  saved[7] = NAN;
  expect_error("ilc reset_to NaN", hysteron_ilc_reset_to(ilc, saved, N_ILC), HYSTERON_ERROR_INVALID_ARGUMENT,
               "phase 7) is not finite");
  saved[7] = c;
  OK(hysteron_ilc_reset_to(ilc, saved, N_ILC));
  y = u = 0.0;
  {
    double s2 = 0.0;
    int same = 1;
    for (k = 0; k < N_ILC; ++k) {
      const double r = sin(2.0 * pi * (double)k / N_ILC);
      double e;
      y = a * y + (1.0 - a) * u;
      OK(hysteron_ilc_correction(ilc, 0, &c));
      same = same && c == saved[k];
      u = r + c;
      e = r - y;
      s2 += e * e;
      OK(hysteron_ilc_step(ilc, e));
    }
    warm = sqrt(s2 / N_ILC);
    CHECK(same, "warm start: the first period applies the saved correction");
  }
  CHECK(warm < 0.2 * rms[0], "warm start: the first period's RMS %g is not below 20 %% of a cold start's, %g", warm, rms[0]);
  printf("ok   ilc: warm start from the 15th period's correction, first period RMS %g (cold %g)\n", warm, rms[0]);
  /* finite errors of 1.7e308 (c + L e overflows from the third period on, c having grown by
   * L e each period): every correction stays finite, each overflowing update is reported by the
   * step that made it (INVALID_ARGUMENT, the sample advanced) and counted */
  OK(hysteron_ilc_reset(ilc));
  {
    size_t reported = 0, overflows = 0;
    int finite = 1;
    for (k = 0; k < 4 * N_ILC; ++k) {
      const hysteron_status st = hysteron_ilc_step(ilc, 1.7e308);
      OK(hysteron_ilc_correction(ilc, 0, &c));
      finite = finite && isfinite(c);
      if (st != HYSTERON_OK) {
        ++reported;
        expect_error("ilc step: overflowing update", st, HYSTERON_ERROR_INVALID_ARGUMENT, "overflowed");
      }
    }
    OK(hysteron_ilc_overflows(ilc, &overflows));
    OK(hysteron_ilc_state(ilc, &phase, &iteration, NULL, NULL, NULL, NULL, &faults));
    CHECK(finite, "ilc: a correction is not finite after errors of 1.7e308");
    CHECK(overflows > 0 && reported == overflows && faults == 0 && iteration == 4,
          "ilc: %zu overflows, %zu reported, %zu faults, %zu periods", overflows, reported, faults, iteration);
    expect_error("ilc overflows NULL", hysteron_ilc_overflows(ilc, NULL), HYSTERON_ERROR_NULL_POINTER, "overflows");
  }
  OK(hysteron_ilc_free(ilc));
  OK(hysteron_ilc_free(NULL));
}

/* The open loop and the cascade (their C++ classes' formulas, hysteron.h), against the ff+pid
 * twin with the same feedforward and position PID: the open loop without a PID and k_p = 0 is
 * the feedforward; with k_p its command is clamp(p_d + k_p (p_d - p)); the cascade's p_d is the
 * ff+pid's command and its duty clamp(k_p,inner (p_d - p), -1, 1) (gain 1, no dead band). Then
 * the argument checks. y: a contraction trajectory [model units]; lo, hi: pressure limits. */
static void check_loops(const hysteron_params* params, const double* y, size_t n, double lo, double hi) {
  hysteron_ff_pid_params fp;
  hysteron_open_loop_params op;
  hysteron_cascade_params cp;
  hysteron_ff_pid* twin = NULL;
  hysteron_open_loop* ol = NULL;
  hysteron_cascade* cc = NULL;
  double worst_ff = 0.0, worst_pd = 0.0, worst_duty = 0.0, pressure = lo;
  size_t k;
  int saturated_duty = 0;
  OK(hysteron_ff_pid_default_params(&fp));
  fp.pressure_min = lo;
  fp.pressure_max = hi;
  OK(hysteron_open_loop_default_params(&op));
  CHECK(op.pressure_gain == 0.5, "default pressure_gain %g (the paper's 0.5)", op.pressure_gain);
  op.loop = fp;
  op.pressure_gain = 0.0;
  OK(hysteron_open_loop_create(params, &op, &ol));
  OK(hysteron_ff_pid_create(params, &fp, &twin));
  if (ol == NULL || twin == NULL) return;
  for (k = 0; k < n; ++k) {
    double a = 0.0, b = 0.0;
    OK(hysteron_ff_pid_step(twin, y[k] / 1000.0, y[k] / 1000.0, 0.0, &a));
    OK(hysteron_open_loop_step(ol, y[k] / 1000.0, y[k] / 1000.0, 0.0, 0.0, &b));
    if (fabs(a - b) > worst_ff) worst_ff = fabs(a - b);
  }
  printf("open loop without PID and pressure loop = the feedforward: %.3g\n", worst_ff);
  CHECK(worst_ff == 0.0, "open loop vs feedforward %.3g", worst_ff);
  OK(hysteron_open_loop_free(ol));
  ol = NULL;
  OK(hysteron_ff_pid_free(twin));
  twin = NULL;

  fp.kp = 5.0;
  fp.ki = 1.0;
  op.loop = fp;
  op.pressure_gain = 0.5;
  OK(hysteron_cascade_default_params(&cp));
  CHECK(cp.pressure.kp == 20.0 && cp.pwm.gain == 1.0 && cp.pwm.max_duty == 1.0, "cascade defaults");
  cp.outer = fp;
  OK(hysteron_open_loop_create(params, &op, &ol));
  OK(hysteron_cascade_create(params, &cp, &cc));
  OK(hysteron_ff_pid_create(params, &fp, &twin));
  if (ol == NULL || cc == NULL || twin == NULL) return;
  for (k = 0; k < n; ++k) {
    const double ref = y[k] / 1000.0, meas = 0.9 * ref, p_meas = pressure;
    double u_twin = 0.0, u_ol = 0.0, duty = 0.0, p_d = 0.0, expect_duty;
    OK(hysteron_ff_pid_step(twin, ref, ref, meas, &u_twin));
    OK(hysteron_open_loop_step(ol, ref, ref, meas, p_meas, &u_ol));
    OK(hysteron_cascade_step(cc, ref, ref, meas, p_meas, &duty, &p_d));
    if (fabs(p_d - u_twin) > worst_pd) worst_pd = fabs(p_d - u_twin);
    expect_duty = 20.0 * (p_d - p_meas);
    if (expect_duty > 1.0) expect_duty = 1.0;
    if (expect_duty < -1.0) expect_duty = -1.0;
    saturated_duty += fabs(expect_duty) == 1.0;
    if (fabs(duty - expect_duty) > worst_duty) worst_duty = fabs(duty - expect_duty);
    CHECK(u_ol >= lo && u_ol <= hi, "open-loop command %g outside [%g, %g]", u_ol, lo, hi);
    pressure = 0.7 * pressure + 0.3 * u_ol; /* a lagging actuator to feed back */
  }
  printf("cascade: |p_d - ff+pid| %.3g, |duty - 20 (p_d - p)| %.3g (%d samples at +-1)\n", worst_pd, worst_duty,
         saturated_duty);
  CHECK(worst_pd == 0.0, "cascade p_d vs ff+pid %.3g", worst_pd);
  CHECK(worst_duty <= 1e-15, "cascade duty %.3g", worst_duty);
  {
    /* the open loop's pressure loop on its feedforward, PID off: clamp(p_d + 0.5 (p_d - p)) */
    double worst = 0.0;
    hysteron_open_loop_params o2 = op;
    hysteron_open_loop* ol2 = NULL;
    o2.loop.kp = o2.loop.ki = 0.0;
    OK(hysteron_open_loop_create(params, &o2, &ol2));
    OK(hysteron_ff_pid_reset(twin));
    if (ol2 == NULL) return;
    {
      hysteron_ff_pid_params f0 = fp;
      hysteron_ff_pid* ff = NULL;
      f0.kp = f0.ki = 0.0;
      OK(hysteron_ff_pid_create(params, &f0, &ff));
      if (ff == NULL) return;
      for (k = 0; k < n; ++k) {
        const double ref = y[k] / 1000.0, p_meas = 0.5 * (lo + hi) + 0.1 * (hi - lo) * sin(0.05 * (double)k);
        double p_d = 0.0, u = 0.0, e;
        OK(hysteron_ff_pid_step(ff, ref, ref, ref, &p_d));
        OK(hysteron_open_loop_step(ol2, ref, ref, ref, p_meas, &u));
        e = p_d + 0.5 * (p_d - p_meas);
        if (e < lo) e = lo;
        if (e > hi) e = hi;
        if (fabs(u - e) > worst) worst = fabs(u - e);
      }
      OK(hysteron_ff_pid_free(ff));
    }
    printf("open loop's pressure loop: |u - clamp(p_d + 0.5 (p_d - p))| %.3g\n", worst);
    CHECK(worst <= 1e-15, "open-loop pressure loop %.3g", worst);
    OK(hysteron_open_loop_free(ol2));
  }

  /* a non-finite argument: error, the loop steps without it (as the library does; the C++ test
   * CApiLoops compares every later sample with the library's) */
  {
    double u = 0.0, u2 = -1.0, duty = 0.0, duty2 = 3.0, pd = 0.0, pd2 = -1.0;
    OK(hysteron_open_loop_step(ol, 0.01, 0.01, 0.01, lo, &u));
    expect_error("open_loop_step NaN pressure", hysteron_open_loop_step(ol, 0.01, 0.01, 0.01, NAN, &u2),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "pressure_mpa = nan");
    CHECK(isfinite(u2) && u2 >= lo && u2 <= hi, "NaN pressure: a command within the limits (%g)", u2);
    OK(hysteron_cascade_step(cc, 0.01, 0.01, 0.01, lo, &duty, &pd));
    expect_error("cascade_step inf", hysteron_cascade_step(cc, INFINITY, 0.01, 0.01, lo, &duty2, &pd2),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "reference_m = inf");
    CHECK(pd2 == pd, "an infinite reference holds the position PID's output, p_d (%g, %g)", pd2, pd);
    CHECK(duty2 >= -1.0 && duty2 <= 1.0, "the duty within [-1, 1] (%g)", duty2);
    expect_error("cascade_step NULL duty", hysteron_cascade_step(cc, 0, 0, 0, 0, NULL, NULL),
                 HYSTERON_ERROR_NULL_POINTER, "duty");
    OK(hysteron_cascade_step(cc, 0.01, 0.01, 0.01, lo, &duty2, NULL)); /* desired pressure may be NULL */
  }
  /* bad parameters name the field; nothing is created */
  {
    hysteron_open_loop_params bad = op;
    hysteron_cascade_params badc = cp;
    hysteron_open_loop* none = NULL;
    hysteron_cascade* nonec = NULL;
    bad.pressure_gain = -0.1;
    expect_error("open_loop_create pressure_gain", hysteron_open_loop_create(params, &bad, &none),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "pressure_gain");
    bad = op;
    bad.loop.pressure_max = bad.loop.pressure_min;
    expect_error("open_loop_create limits", hysteron_open_loop_create(params, &bad, &none),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "pressure");
    CHECK(none == NULL, "nothing created");
    badc.pwm.max_duty = 1.5;
    expect_error("cascade_create max_duty", hysteron_cascade_create(params, &badc, &nonec),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "pwm.max_duty");
    badc = cp;
    badc.pressure.anti_windup = 7;
    expect_error("cascade_create anti_windup", hysteron_cascade_create(params, &badc, &nonec),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "pressure.anti_windup = 7");
    badc = cp;
    badc.pressure.ki = NAN;
    expect_error("cascade_create ki", hysteron_cascade_create(params, &badc, &nonec),
                 HYSTERON_ERROR_INVALID_ARGUMENT, "pressure: pid.ki = nan");
    CHECK(nonec == NULL, "nothing created");
    expect_error("cascade_create NULL", hysteron_cascade_create(NULL, &cp, &nonec), HYSTERON_ERROR_NULL_POINTER,
                 "params");
  }
  OK(hysteron_open_loop_reset(ol));
  OK(hysteron_cascade_reset(cc));
  OK(hysteron_open_loop_free(ol));
  OK(hysteron_cascade_free(cc));
  OK(hysteron_ff_pid_free(twin));
  OK(hysteron_open_loop_free(NULL));
  OK(hysteron_cascade_free(NULL));
}

static int selftest(const char* path) {
  static double x[N], y[N], y2[N], xi[N], xi2[N];
  hysteron_params* params = NULL;
  hysteron_model* model = NULL;
  hysteron_inverse* inverse = NULL;
  hysteron_ff_pid* ctl = NULL;
  hysteron_ff_pid_params cp;
  const char* kind = NULL;
  double lo = 0, hi = 0, ilo = 0, ihi = 0, u = 0, err;
  double state[64];
  size_t n = 0, sat = 0, k;
  int major = -1, minor = -1, patch = -1;
  char version[64];

  OK(hysteron_version(&major, &minor, &patch));
  sprintf(version, "%d.%d.%d", major, minor, patch);
  CHECK(strcmp(version, hysteron_version_string()) == 0, "version %s vs %s", version, hysteron_version_string());
  printf("hysteron C ABI %s (header ABI %d)\n", hysteron_version_string(), HYSTERON_C_ABI_VERSION);

  if (hysteron_params_from_file(path, &params) != HYSTERON_OK) {
    fprintf(stderr, "FAIL loading %s: %s\n", path, hysteron_last_error());
    return 1;
  }
  OK(hysteron_params_kind(params, &kind));
  OK(hysteron_params_num_operators(params, &n));
  OK(hysteron_params_input_limits(params, &lo, &hi));
  printf("%s: %s, %lu operators, input limits [%g, %g]\n", path, kind, (unsigned long)n, lo, hi);
  CHECK(n < 64, "too many operators for the test");

  /* trajectory inside the limits: a decaying sine with minor loops (as tests/cli/simulate_invert.sh) */
  for (k = 0; k < N; ++k)
    x[k] = 0.8 * sin(0.013 * (double)k) * exp(-(double)k / 1500.0) + 0.15 * sin(0.17 * (double)k);

  OK(hysteron_model_create(params, &model));
  OK(hysteron_inverse_create(params, -HUGE_VAL, HUGE_VAL, &inverse));
  OK(hysteron_inverse_limits(inverse, &ilo, &ihi));
  printf("inverse limits [%g, %g]\n", ilo, ihi);

  /* forward: batch == per sample */
  OK(hysteron_model_simulate(model, x, N, y, N));
  OK(hysteron_model_reset(model));
  for (k = 0; k < N; ++k) OK(hysteron_model_step(model, x[k], &y2[k]));
  CHECK(max_abs_diff(y, y2, N) == 0.0, "batch and per-sample forward differ");

  /* inverse: round trip, batch == per sample, nothing saturated */
  OK(hysteron_inverse_invert(inverse, y, N, xi, N, &sat));
  err = max_abs_diff(x, xi, N);
  printf("virgin round trip: max |x - inverse(model(x))| = %.3g, %lu saturated\n", err, (unsigned long)sat);
  CHECK(err <= 1e-12, "round trip error %.3g", err);
  CHECK(sat == 0, "%lu samples saturated", (unsigned long)sat);
  OK(hysteron_inverse_reset(inverse));
  for (k = 0; k < N; ++k) {
    int s = -1;
    OK(hysteron_inverse_step(inverse, y[k], &xi2[k], &s));
    CHECK(s == 0, "sample %lu saturated", (unsigned long)k);
  }
  CHECK(max_abs_diff(xi, xi2, N) == 0.0, "batch and per-sample inverse differ");

  /* relaxed start at x[0] on both sides */
  OK(hysteron_model_reset_relaxed(model, x[0] + 0.1));
  OK(hysteron_model_simulate(model, x, N, y2, N));
  OK(hysteron_inverse_reset_relaxed(inverse, x[0] + 0.1));
  OK(hysteron_inverse_invert(inverse, y2, N, xi2, N, NULL));
  err = max_abs_diff(x, xi2, N);
  printf("relaxed round trip: %.3g\n", err);
  CHECK(err <= 1e-12, "relaxed round trip error %.3g", err);

  /* from a saved state: the forward model after N/2 samples -> the inverse goes on from there */
  OK(hysteron_model_reset(model));
  OK(hysteron_model_simulate(model, x, N / 2, y2, N / 2));
  OK(hysteron_model_get_state(model, state, n, &u));
  OK(hysteron_inverse_reset_state(inverse, state, n, u));
  OK(hysteron_inverse_invert(inverse, y + N / 2, N / 2, xi2, N / 2, NULL));
  err = max_abs_diff(x + N / 2, xi2, N / 2);
  printf("from a saved state: %.3g\n", err);
  CHECK(err <= 1e-12, "round trip from a saved state %.3g", err);
  /* and the inverse's own state round-trips into a model */
  OK(hysteron_inverse_get_state(inverse, state, n, &u));
  OK(hysteron_model_reset_state(model, state, n, u));

  /* feedforward + PID. Without gains the command is the inverse's output (the reference
   * in metres, the model in mm); with gains, on the model as plant, it tracks closely. */
  OK(hysteron_ff_pid_default_params(&cp));
  cp.pressure_min = ilo > -10 ? ilo : -1.0;
  cp.pressure_max = ihi < 10 ? ihi : 1.0;
  OK(hysteron_ff_pid_create(params, &cp, &ctl));
  if (ctl != NULL) {
    double p = 0.0;
    for (k = 0; k < N; ++k) OK(hysteron_ff_pid_step(ctl, y[k] / 1000.0, y[k] / 1000.0, y[k] / 1000.0, &xi2[k]));
    err = max_abs_diff(x, xi2, N);
    printf("ff+pid without gains = the inverse: %.3g\n", err);
    CHECK(err <= 1e-9, "ff+pid without gains vs the trajectory: %.3g", err);
    OK(hysteron_ff_pid_free(ctl));
    ctl = NULL;
    cp.kp = 5.0;
    cp.ki = 1.0;
    OK(hysteron_ff_pid_create(params, &cp, &ctl));
    if (ctl != NULL) {
      double measured = 0.0, worst = 0.0, span = 0.0;
      OK(hysteron_model_reset(model));
      for (k = 0; k < N; ++k) {
        const double ref = y[k] / 1000.0;
        OK(hysteron_ff_pid_step(ctl, ref, ref, measured, &p));
        CHECK(p >= cp.pressure_min && p <= cp.pressure_max, "command %g outside the limits", p);
        OK(hysteron_model_step(model, p, &measured));
        measured /= 1000.0;
        if (fabs(measured - ref) > worst) worst = fabs(measured - ref);
        if (fabs(ref) > span) span = fabs(ref);
      }
      printf("ff+pid on the model: max tracking error %.3g m (reference up to %.3g m)\n", worst, span);
      CHECK(worst < 0.01 * span, "tracking error %.3g m", worst);
      {
        double q = -1.0;
        /* a NaN reference (and preview: the inverse holds too) holds the PID's correction and the
           feedforward: the previous command */
        expect_error("ff_pid_step NaN", hysteron_ff_pid_step(ctl, NAN, NAN, 0, &q), HYSTERON_ERROR_INVALID_ARGUMENT,
                     "reference_m = nan");
        CHECK(q == p, "a NaN reference and preview hold the position PID's correction and the feedforward, the "
              "previous command");
      }
      OK(hysteron_ff_pid_reset(ctl));
    }
  }

  check_errors(params, model, inverse);
  check_ilc();
  check_loops(params, y, N, cp.pressure_min, cp.pressure_max);

  OK(hysteron_ff_pid_free(ctl));
  OK(hysteron_inverse_free(inverse));
  OK(hysteron_model_free(model));
  OK(hysteron_params_free(params));
  printf("%s: %d failure(s)\n", path, failures);
  return failures == 0 ? 0 : 1;
}

static int invert_file(const char* model_path, const char* in_path, const char* out_path) {
  hysteron_params* params = NULL;
  hysteron_inverse* inverse = NULL;
  double* y = NULL;
  double* x = NULL;
  size_t n = 0, cap = 0, sat = 0, k;
  double v;
  FILE* in;
  FILE* out;
  hysteron_status st;

  if (hysteron_params_from_file(model_path, &params) != HYSTERON_OK ||
      hysteron_inverse_create(params, -HUGE_VAL, HUGE_VAL, &inverse) != HYSTERON_OK) {
    fprintf(stderr, "%s\n", hysteron_last_error());
    return 1;
  }
  in = fopen(in_path, "r");
  if (!in) {
    fprintf(stderr, "%s: cannot open\n", in_path);
    return 1;
  }
  while (fscanf(in, "%lf", &v) == 1) {
    if (n == cap) {
      double* grown;
      cap = cap ? 2 * cap : 1024;
      grown = (double*)realloc(y, cap * sizeof *y);
      if (!grown) return 1;
      y = grown;
    }
    y[n++] = v;
  }
  fclose(in);
  x = (double*)malloc((n ? n : 1) * sizeof *x);
  if (!x) return 1;
  st = hysteron_inverse_invert(inverse, y, n, x, n, &sat);
  if (st != HYSTERON_OK) {
    fprintf(stderr, "%s: %s\n", hysteron_status_name(st), hysteron_last_error());
    return 1;
  }
  out = fopen(out_path, "w");
  if (!out) return 1;
  for (k = 0; k < n; ++k) fprintf(out, "%.17g\n", x[k]);
  if (fclose(out) != 0) return 1;
  printf("inverted %lu samples of %s (%lu saturated)\n", (unsigned long)n, in_path, (unsigned long)sat);
  free(x);
  free(y);
  hysteron_inverse_free(inverse);
  hysteron_params_free(params);
  return 0;
}

int main(int argc, char** argv) {
  if (argc == 3 && strcmp(argv[1], "selftest") == 0) return selftest(argv[2]);
  if (argc == 5 && strcmp(argv[1], "invert") == 0) return invert_file(argv[2], argv[3], argv[4]);
  fprintf(stderr, "usage: %s selftest MODEL.json | invert MODEL.json Y.txt X.txt\n", argv[0]);
  return 2;
}
