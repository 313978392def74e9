/* A loop from `hysteron experiment`'s result.json through the C ABI, from strict C99
 * (compiled with -std=c99 -pedantic -Wall -Wextra -Werror).
 *
 *   hysteron_c_loop_test RESULT.json MODEL.json
 *       reads runs of the fixture RESULT.json (tests/c_api/result.json: mpi-pwm-like, two
 *       references) with hysteron_loop_params_from_file / _from_json and checks every field
 *       against the fixture's numbers, creates the loop on MODEL.json and steps it, checks
 *       hysteron_loop_preview against the documented formula computed here, and checks the
 *       error paths (no such run, a variant with several references, malformed JSON, missing
 *       file, unknown loop, limits the structs cannot hold, NULL, sizes): status and message.
 * Exit status 0 if every check passed, 1 otherwise. (The whole way from an experiment's
 * directory to the run's commands is tests/test_c_api_loops.cpp.)
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hysteron/hysteron.h"

#include "c_check.h"

#define EQ(a, b) CHECK((a) == (b), "%s = %.17g, expected %.17g", #a, (double)(a), (double)(b))

/* The fixture's compensated triangle, field by field (tests/c_api/result.json). */
static void check_compensated_triangle(const hysteron_loop_params* p) {
  const hysteron_ff_pid_params* f = &p->ff_pid;
  EQ(p->kind, HYSTERON_LOOP_CASCADE_PWM);
  EQ(f->sample_time, 0.001);
  EQ(f->pressure_min, 0.01);
  EQ(f->pressure_max, 0.59);
  EQ(f->model_scale, 1000.0);
  EQ(f->lag_time_constant, 0.002);
  EQ(f->kp, 4.25);
  EQ(f->ki, 31.5);
  EQ(f->kd, 0.125);
  EQ(f->derivative_filter, 0.0075);
  EQ(f->tracking_time, 0.05);
  EQ(f->setpoint_weight_p, 0.875);
  EQ(f->setpoint_weight_d, 0.25);
  EQ(f->anti_windup, HYSTERON_ANTI_WINDUP_BACK_CALCULATION);
  EQ(p->pressure.kp, 6.5);
  EQ(p->pressure.ki, 120.0);
  EQ(p->pressure.kd, 0.0);
  EQ(p->pressure.out_min, -0.5);
  EQ(p->pressure.out_max, 0.75);
  EQ(p->pressure.anti_windup, HYSTERON_ANTI_WINDUP_NONE);
  EQ(p->pwm.gain, 1.5);
  EQ(p->pwm.deadband, 0.02);
  EQ(p->pwm.min_duty, 0.05);
  EQ(p->pwm.max_duty, 0.95);
  EQ(p->pwm.resolution, 0.01);
  EQ(p->feedforward_lead, 76);
  EQ(p->shaped, 1);
  EQ(p->shaper_a1, 0.955);
  EQ(p->shaper_a2, 0.045);
  EQ(p->shaper_delay, 172);
  EQ(p->shaper_advance, 8);
  EQ(p->has_learning, 0);
}

/* preview(k) = s(min(k + lead, n - 1)), s(j) = a1 r(j + adv) + a2 r(j + adv - delay), indices
 * clamped to [0, n) (hysteron.h), computed here independently of the library. */
static double clamped(const double* r, long n, long k) { return r[k < 0 ? 0 : (k >= n ? n - 1 : k)]; }
static void check_preview(hysteron_loop_params p) {
  enum { n = 40 };
  double r[n], pv[n];
  long k;
  double worst = 0.0;
  for (k = 0; k < n; ++k) r[k] = 0.001 * (double)(k * k) - 0.01 * (double)k;
  p.feedforward_lead = 3;
  p.shaped = 1;
  p.shaper_a1 = 0.75;
  p.shaper_a2 = 0.25;
  p.shaper_delay = 5;
  p.shaper_advance = 2;
  OK(hysteron_loop_preview(&p, r, n, pv, n));
  for (k = 0; k < n; ++k) {
    const long j = k + 3 < n - 1 ? k + 3 : n - 1;
    const double want = 0.75 * clamped(r, n, j + 2) + 0.25 * clamped(r, n, j + 2 - 5);
    worst = fmax(worst, fabs(pv[k] - want));
  }
  CHECK(worst == 0.0, "shaped preview differs from the formula by %g", worst);
  p.shaped = 0;
  OK(hysteron_loop_preview(&p, r, n, pv, n));
  for (k = 0, worst = 0.0; k < n; ++k) worst = fmax(worst, fabs(pv[k] - clamped(r, n, k + 3)));
  CHECK(worst == 0.0, "unshaped preview differs from r(k + lead) by %g", worst);
  printf("ok   hysteron_loop_preview: shaped and unshaped equal the formula over %d samples\n", n);
  /* counts as large as a size_t holds (a file may say so): clamped, no overflow */
  p.shaped = 1;
  p.feedforward_lead = (size_t)-1;
  p.shaper_advance = (size_t)-1;
  p.shaper_delay = (size_t)-1;
  OK(hysteron_loop_preview(&p, r, n, pv, n));
  for (k = 0, worst = 0.0; k < n; ++k) worst = fmax(worst, fabs(pv[k] - (0.75 * r[n - 1] + 0.25 * r[n - 1])));
  CHECK(worst == 0.0, "huge lead and advance = delay: differs from r(n - 1) by %g", worst);
  p.feedforward_lead = 0;
  p.shaper_advance = 0;
  OK(hysteron_loop_preview(&p, r, n, pv, n));
  for (k = 0, worst = 0.0; k < n; ++k)
    worst = fmax(worst, fabs(pv[k] - (0.75 * r[k] + 0.25 * r[0])));
  CHECK(worst == 0.0, "huge delay: differs from a1 r(k) + a2 r(0) by %g", worst);
  p.shaped = 0;
  p.feedforward_lead = 3;
  expect_error("preview: sizes", hysteron_loop_preview(&p, r, n, pv, n - 1), HYSTERON_ERROR_INVALID_ARGUMENT,
               "n_preview = 39");
  expect_error("preview: aliasing", hysteron_loop_preview(&p, r, n, r, n), HYSTERON_ERROR_INVALID_ARGUMENT,
               "overlaps");
  r[7] = NAN;
  expect_error("preview: NaN", hysteron_loop_preview(&p, r, n, pv, n), HYSTERON_ERROR_INVALID_ARGUMENT,
               "reference[7]");
  expect_error("preview: NULL", hysteron_loop_preview(NULL, r, n, pv, n), HYSTERON_ERROR_NULL_POINTER, "loop");
}

/* Each kind's struct creates its object on the model, and a few steps give finite commands
 * inside the pressure limits (duty inside [-1, 1]). */
static void check_create(const hysteron_loop_params* p, const hysteron_params* model) {
  int k;
  double u = NAN, duty = NAN, pd = NAN;
  if (p->kind == HYSTERON_LOOP_CASCADE_PWM) {
    const hysteron_cascade_params cp = {p->ff_pid, p->pressure, p->pwm};
    hysteron_cascade* c = NULL;
    OK(hysteron_cascade_create(model, &cp, &c));
    for (k = 0; c && k < 50; ++k) {
      OK(hysteron_cascade_step(c, 0.01, 0.012, 0.009, 0.2, &duty, &pd));
      CHECK(duty >= -1.0 && duty <= 1.0, "duty %g", duty);
      CHECK(pd >= p->ff_pid.pressure_min && pd <= p->ff_pid.pressure_max, "p_d %g", pd);
    }
    hysteron_cascade_free(c);
  } else if (p->kind == HYSTERON_LOOP_OPEN_LOOP) {
    const hysteron_open_loop_params op = {p->ff_pid, p->pressure_gain};
    hysteron_open_loop* c = NULL;
    OK(hysteron_open_loop_create(model, &op, &c));
    for (k = 0; c && k < 50; ++k) {
      OK(hysteron_open_loop_step(c, 0.01, 0.012, 0.009, 0.2, &u));
      CHECK(u >= p->ff_pid.pressure_min && u <= p->ff_pid.pressure_max, "command %g", u);
    }
    hysteron_open_loop_free(c);
  } else {
    hysteron_ff_pid* c = NULL;
    OK(hysteron_ff_pid_create(model, &p->ff_pid, &c));
    for (k = 0; c && k < 50; ++k) {
      OK(hysteron_ff_pid_step(c, 0.01, 0.012, 0.009, &u));
      CHECK(u >= p->ff_pid.pressure_min && u <= p->ff_pid.pressure_max, "command %g", u);
    }
    hysteron_ff_pid_free(c);
  }
}

/* A bare "controller" object (run NULL) of the given loop, PID limits and pressure gain. */
static hysteron_status bare(const char* loop, const char* pid_limits, const char* extra, hysteron_loop_params* out) {
  char text[2048];
  snprintf(text, sizeof text,
           "{\"loop\": \"%s\", \"feedforward\": {\"pressure_min_mpa\": 0, \"pressure_max_mpa\": 0.6,"
           " \"model_scale_per_m\": 1000, \"lag_time_constant_s\": 0},"
           " \"pid\": {\"kp_mpa_per_m\": 8, \"ki_mpa_per_m_s\": 40, \"kd_mpa_s_per_m\": 0.2, \"sample_time_s\": 0.001,"
           " \"derivative_filter_s\": 0, %s, \"anti_windup\": \"conditional\", \"tracking_time_s\": 0,"
           " \"setpoint_weight_p\": 1, \"setpoint_weight_d\": 0},"
           " \"sample_time_s\": 0.001, \"feedforward_lead_samples\": 0%s}",
           loop, pid_limits, extra);
  return hysteron_loop_params_from_json(text, NULL, out);
}

/* A feedforward_pid controller whose PID has K_p and sample time given as JSON text. */
static hysteron_status with_pid(const char* kp, const char* sample_time, hysteron_loop_params* out) {
  char text[2048];
  snprintf(text, sizeof text,
           "{\"loop\": \"feedforward_pid\", \"feedforward\": {\"pressure_min_mpa\": 0, \"pressure_max_mpa\": 0.6,"
           " \"model_scale_per_m\": 1000, \"lag_time_constant_s\": 0},"
           " \"pid\": {\"kp_mpa_per_m\": %s, \"ki_mpa_per_m_s\": 40, \"kd_mpa_s_per_m\": 0.2, \"sample_time_s\": %s,"
           " \"derivative_filter_s\": 0, \"out_min_mpa\": null, \"out_max_mpa\": null, \"anti_windup\": \"none\","
           " \"tracking_time_s\": 0, \"setpoint_weight_p\": 1, \"setpoint_weight_d\": 0},"
           " \"sample_time_s\": 0.001, \"feedforward_lead_samples\": 0}",
           kp, sample_time);
  return hysteron_loop_params_from_json(text, NULL, out);
}

int main(int argc, char** argv) {
  hysteron_loop_params p, q;
  hysteron_params* model = NULL;
  const char* result;
  if (argc != 3) {
    fprintf(stderr, "usage: %s RESULT.json MODEL.json\n", argv[0]);
    return 2;
  }
  result = argv[1];
  OK(hysteron_params_from_file(argv[2], &model));

  /* a variant keyed by reference */
  OK(hysteron_loop_params_from_file(result, "compensated.triangle", &p));
  check_compensated_triangle(&p);
  printf("ok   compensated.triangle: every field equals the fixture's\n");
  check_create(&p, model);
  check_preview(p);

  OK(hysteron_loop_params_from_file(result, "compensated.sine", &p));
  EQ(p.kind, HYSTERON_LOOP_CASCADE_PWM);
  EQ(p.ff_pid.kp, 3.5);
  EQ(p.feedforward_lead, 60);
  EQ(p.shaped, 0);
  EQ(p.shaper_a1, 1.0);
  EQ(p.shaper_a2, 0.0);

  /* the faithful loop: unbounded PID limits (null) are representable */
  OK(hysteron_loop_params_from_file(result, "faithful.triangle", &p));
  EQ(p.ff_pid.kp, 10.0);
  EQ(p.pressure.kp, 20.0);
  check_create(&p, model);

  /* the learning run's ILC */
  OK(hysteron_loop_params_from_file(result, "learning.triangle", &p));
  EQ(p.has_learning, 1);
  EQ(p.learning.period, 5000);
  EQ(p.learning.gain, 0.25);
  EQ(p.learning.lead, 38);
  EQ(p.learning.half_width, 2011);
  EQ(p.learning.lookahead, 76);
  CHECK(isinf(p.learning.max_correction) && p.learning.max_correction > 0, "max_correction %g (null: +inf)",
        p.learning.max_correction);
  EQ(p.learning.rise_tolerance, 0.05);
  EQ(p.learning.hold_after_cuts, 3);
  EQ(p.learning.max_gain, 0.5);
  {
    hysteron_ilc* ilc = NULL;
    OK(hysteron_ilc_create(&p.learning, &ilc));
    hysteron_ilc_free(ilc);
  }

  /* the other two kinds, from a bare controller object */
  OK(bare("feedforward_pid", "\"out_min_mpa\": -0.6, \"out_max_mpa\": 0.6", "", &q));
  EQ(q.kind, HYSTERON_LOOP_FEEDFORWARD_PID);
  EQ(q.ff_pid.kp, 8.0);
  EQ(q.ff_pid.ki, 40.0);
  EQ(q.ff_pid.kd, 0.2);
  check_create(&q, model);
  OK(bare("open_loop", "\"out_min_mpa\": -0.6, \"out_max_mpa\": 0.6", ", \"pressure_gain\": 0.5", &q));
  EQ(q.kind, HYSTERON_LOOP_OPEN_LOOP);
  EQ(q.pressure_gain, 0.5);
  EQ(q.ff_pid.kp, 8.0);
  check_create(&q, model);

  /* errors; *out is left as it was */
  memcpy(&q, &p, sizeof q);
  expect_error("variant with several references",
               hysteron_loop_params_from_file(result, "compensated", &p), HYSTERON_ERROR_MODEL,
               "result.json.compensated: one run per reference (sine, triangle): name one, e.g. \"compensated.sine\"");
  expect_error("no such variant", hysteron_loop_params_from_file(result, "baseline.sine", &p), HYSTERON_ERROR_MODEL,
               "no run \"baseline\" (variants: adaptive, compensated, faithful, learning)");
  expect_error("an adaptive run", hysteron_loop_params_from_file(result, "adaptive.sine", &p), HYSTERON_ERROR_MODEL,
               "result.json.adaptive.sine.controller: its inverse is adapted online (\"adaptation\": RLS with "
               "forgetting, lambda = 0.9998; an adaptive run)");
  expect_error("no such reference", hysteron_loop_params_from_file(result, "faithful.sine", &p),
               HYSTERON_ERROR_MODEL, "no reference \"sine\" (references: triangle)");
  expect_error("no run named", hysteron_loop_params_from_file(result, NULL, &p), HYSTERON_ERROR_MODEL,
               "name a run");
  CHECK(memcmp(&q, &p, sizeof q) == 0, "out written on an error");
  expect_error("missing file", hysteron_loop_params_from_file("/nonexistent/result.json", "compensated", &p),
               HYSTERON_ERROR_IO, "/nonexistent/result.json");
  expect_error("malformed JSON", hysteron_loop_params_from_json("{\"compensated\": {", "compensated", &p),
               HYSTERON_ERROR_PARSE, "result.json");
  expect_error("unknown loop", bare("bang_bang", "\"out_min_mpa\": -0.6, \"out_max_mpa\": 0.6", "", &p),
               HYSTERON_ERROR_MODEL, "unknown loop \"bang_bang\"");
  expect_error("narrower PID limits", bare("feedforward_pid", "\"out_min_mpa\": 0.1, \"out_max_mpa\": 0.6", "", &p),
               HYSTERON_ERROR_MODEL, "result.json.pid: output limits [0.1, 0.6] are narrower");
  expect_error("open loop: PID limits inside +-span",
               bare("open_loop", "\"out_min_mpa\": -0.3, \"out_max_mpa\": 0.6", "", &p), HYSTERON_ERROR_MODEL,
               "[-0.6, 0.6] the C controller applies");
  expect_error("PID at another sample time", with_pid("8", "0.002", &p), HYSTERON_ERROR_MODEL,
               "pid.sample_time_s = 0.002 differs from the loop's sample_time_s = 0.001");
  expect_error("null gain", with_pid("null", "0.001", &p), HYSTERON_ERROR_MODEL, "pid.kp = nan");
  expect_error("negative pressure gain",
               bare("open_loop", "\"out_min_mpa\": null, \"out_max_mpa\": null", ", \"pressure_gain\": -0.5", &p),
               HYSTERON_ERROR_MODEL, "pressure_gain = -0.5: expected a finite value >= 0");
  expect_error("missing key", hysteron_loop_params_from_json("{\"loop\": \"feedforward_pid\", \"sample_time_s\": 0.001}",
                                                            NULL, &p),
               HYSTERON_ERROR_MODEL, "feedforward_lead_samples");
  expect_error("NULL out", hysteron_loop_params_from_file(result, "compensated.sine", NULL),
               HYSTERON_ERROR_NULL_POINTER, "out");
  CHECK(memcmp(&q, &p, sizeof q) == 0, "out written on an error");

  hysteron_params_free(model);
  if (failures) fprintf(stderr, "%d failure(s)\n", failures);
  else printf("all checks passed\n");
  return failures ? 1 : 0;
}
