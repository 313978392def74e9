/*
 * hysteron C ABI: load a hysteresis model, run it forwards, run its exact inverse,
 * run the inverse-feedforward + PID, open-loop and switching-valve cascade controllers and
 * iterative learning control, from C, LabVIEW, Simulink,
 * ROS, Python ctypes or anything else that can call a C function.
 *
 * Plain C99; the library (libhysteron_c.so / libhysteron_c.a) is C++ inside.
 * Usage and examples: docs/deploy.md.
 *
 * Conventions
 * - Every function except hysteron_last_error(), hysteron_status_name() and
 *   hysteron_version_string() returns a hysteron_status; HYSTERON_OK (0) is success.
 *   No C++ exception ever leaves the library (std::bad_alloc included).
 * - On failure, hysteron_last_error() returns a message for the calling thread
 *   that names the function, the argument and, for model files, the file and key.
 *   Successful calls leave it unchanged.
 * - Objects are opaque handles created by *_create / hysteron_params_from_*, and
 *   released by the matching *_free (NULL is accepted and ignored). A handle may be
 *   used from any thread, but from one thread at a time; distinct handles are
 *   independent. Exception: a hysteron_params is never modified after it is loaded (every
 *   function takes it as const and only reads or copies it; there is no cache inside),
 *   so one hysteron_params may be shared by any number of threads at once, e.g. each
 *   creating its own model or inverse from it, as long as none frees it meanwhile.
 * - Out-pointers are written only on success, except that the per-sample step
 *   functions also write an output when an input is not finite: the held (previous) value
 *   for a model or an inverse, the command the loop computes without that input for a
 *   controller (as the library's controllers and the generated C; see hysteron_ff_pid_step).
 * - The per-sample functions (hysteron_model_step, hysteron_inverse_step,
 *   hysteron_ff_pid_step, hysteron_open_loop_step, hysteron_cascade_step,
 *   hysteron_ilc_correction, hysteron_ilc_step) never allocate
 *   memory, never block and take a bounded time: they are meant for a real-time loop.
 *   Loading and creating allocate. One exception, outside hysteron's control: where the
 *   library is loaded with dlopen (ctypes, MATLAB, LabVIEW), glibc allocates a thread's
 *   block of thread-local storage lazily, once, the first time that thread's error
 *   message is written (its first failing call, e.g. a NaN input); call
 *   hysteron_last_error() once in each real-time thread before its loop to take it there.
 *
 * Units: a model maps the actuator input x in the model file's input units
 * (e.g. MPa of pressure, V of a piezo amplifier) to the output y in its output
 * units (e.g. mm of contraction); see docs/model-files.md. The controller
 * (hysteron_ff_pid_*) works in metres and MPa, like the C++ FeedforwardPidController.
 * PID gains are magnitudes: on a model whose output decreases with its input (output_gain and
 * input_scale of opposite signs, e.g. a sensor that reads the muscle's length, not its contraction) every
 * controller's position PID acts on y - r instead of r - y, so the feedback stays negative.
 */
#ifndef HYSTERON_H
#define HYSTERON_H

#include <stddef.h>

#if defined(_WIN32) || defined(__CYGWIN__)
#  if defined(HYSTERON_C_BUILD)
#    define HYSTERON_C_API __declspec(dllexport)
#  elif defined(HYSTERON_C_STATIC)
#    define HYSTERON_C_API
#  else
#    define HYSTERON_C_API __declspec(dllimport)
#  endif
#elif defined(__GNUC__) || defined(__clang__)
#  define HYSTERON_C_API __attribute__((visibility("default")))
#else
#  define HYSTERON_C_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Version of this header's ABI: functions and structs only get added (major 1). */
#define HYSTERON_C_ABI_VERSION 1

/* ---- status codes --------------------------------------------------------- */
typedef enum hysteron_status {
  HYSTERON_OK = 0,
  HYSTERON_ERROR_NULL_POINTER = 1,     /* a required pointer argument is NULL */
  HYSTERON_ERROR_INVALID_ARGUMENT = 2, /* NaN or infinite number, wrong array size, bad option */
  HYSTERON_ERROR_PARSE = 3,            /* the model text is not valid JSON (line and column in the message) */
  HYSTERON_ERROR_MODEL = 4,            /* valid JSON, but not a valid or not an invertible model (key named) */
  HYSTERON_ERROR_IO = 5,               /* a file cannot be opened or read */
  HYSTERON_ERROR_OUT_OF_MEMORY = 6,    /* allocation failed */
  HYSTERON_ERROR_INTERNAL = 7          /* a bug: please report it with the message */
} hysteron_status;

/* Message of the last failed call in the calling thread ("" if none). The
 * pointer stays valid until the next failing call in the same thread. Never NULL. */
HYSTERON_C_API const char* hysteron_last_error(void);

/* Name of a status code, e.g. "HYSTERON_ERROR_PARSE" (static string, never NULL). */
HYSTERON_C_API const char* hysteron_status_name(hysteron_status status);

/* Library version, e.g. "0.1.0" (static string). */
HYSTERON_C_API const char* hysteron_version_string(void);
/* Library version as numbers; any pointer may be NULL. */
HYSTERON_C_API hysteron_status hysteron_version(int* major, int* minor, int* patch);

/* ---- model parameters (a validated model file) --------------------------- */
typedef struct hysteron_params hysteron_params;

/* Parses a model from a NUL-terminated JSON text (schema: docs/model-files.md).
 * HYSTERON_ERROR_PARSE for a syntax error, HYSTERON_ERROR_MODEL for a missing,
 * unknown or invalid key. *out receives a new handle (free with hysteron_params_free). */
HYSTERON_C_API hysteron_status hysteron_params_from_json(const char* json, hysteron_params** out);
/* The same from a file; HYSTERON_ERROR_IO if it cannot be read. */
HYSTERON_C_API hysteron_status hysteron_params_from_file(const char* path, hysteron_params** out);
HYSTERON_C_API hysteron_status hysteron_params_free(hysteron_params* params);

/* Model kind, one of "pi", "gpi", "mpi-deadzone", "mpi-asym", "maxwell-slip", "preisach",
 * "kp", "bouc-wen", "rate-pi" (docs/model-files.md; valid as long as params). */
HYSTERON_C_API hysteron_status hysteron_params_kind(const hysteron_params* params, const char** kind);
/* Length n of a state vector (*_reset_state, *_get_state): the number of play operators of
 * the PI family (pi, gpi, mpi-deadzone, mpi-asym), the state entries of the other kinds (kp,
 * preisach, maxwell-slip, rate-pi, bouc-wen; before 2026-11-30 this was 0 for them, and their
 * states could not be set or read). */
HYSTERON_C_API hysteron_status hysteron_params_num_operators(const hysteron_params* params, size_t* n);
/* The model file's "input_limits" in input units; -HUGE_VAL / +HUGE_VAL for an unbounded side. */
HYSTERON_C_API hysteron_status hysteron_params_input_limits(const hysteron_params* params, double* lo, double* hi);

/* ---- forward model: input x -> output y ----------------------------------- */
typedef struct hysteron_model hysteron_model;

/* A model in its virgin state (all operator outputs 0). */
HYSTERON_C_API hysteron_status hysteron_model_create(const hysteron_params* params, hysteron_model** out);
HYSTERON_C_API hysteron_status hysteron_model_free(hysteron_model* model);

/* Virgin state: operator outputs 0 (the model at rest at its input_origin). */
HYSTERON_C_API hysteron_status hysteron_model_reset(hysteron_model* model);
/* At rest at input x0 [input units], as if x0 had been held forever. A non-finite x0, or one
 * that hysteron_model_step would refuse (beyond the input bound, below), is
 * HYSTERON_ERROR_INVALID_ARGUMENT and changes nothing. */
HYSTERON_C_API hysteron_status hysteron_model_reset_relaxed(hysteron_model* model, double x0);
/* Explicit state: n entries y[0..n) (n = hysteron_params_num_operators: the operator outputs
 * of the PI family, the kernel's entries of the other kinds) and the envelope value u of the
 * last input, all finite, in model coordinates (as returned by hysteron_model_get_state).
 * HYSTERON_ERROR_INVALID_ARGUMENT on a wrong n or a state no input reaches. */
HYSTERON_C_API hysteron_status hysteron_model_reset_state(hysteron_model* model, const double* y, size_t n, double u);
/* Copies the current state out (y: array of n; u may be NULL). */
HYSTERON_C_API hysteron_status hysteron_model_get_state(const hysteron_model* model, double* y, size_t n, double* u);

/* One sample: *y = model output [output units] for input x [input units]. A non-finite
 * x, or a finite x so large that the output could overflow (beyond the model's input bound,
 * about DBL_MAX / 16 / (sum of |weights| |output_gain|) in model coordinates: never a
 * physical input), returns HYSTERON_ERROR_INVALID_ARGUMENT, leaves the state unchanged and
 * writes the previous output to *y: never an inf or NaN output. Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_model_step(hysteron_model* model, double x, double* y);
/* Batch: y[k] = step(x[k]) for k < n_x; n_y must equal n_x. y may be x itself (in place:
 * x[k] is read before y[k] is written) or apart from it; a y that partly overlaps x (y = x + 1)
 * is HYSTERON_ERROR_INVALID_ARGUMENT (since 2026-12-01; before, wrong outputs with
 * HYSTERON_OK). Every x[k] is checked first: on one that step would refuse nothing is stepped
 * and the index is in the message. */
HYSTERON_C_API hysteron_status hysteron_model_simulate(hysteron_model* model, const double* x, size_t n_x, double* y,
                                                      size_t n_y);

/* ---- exact inverse: desired output y -> input x ---------------------------- */
typedef struct hysteron_inverse hysteron_inverse;

/* An inverse in the virgin state. lo, hi [input units]: limits to saturate at;
 * -HUGE_VAL / +HUGE_VAL (C99 <math.h>, or -INFINITY / INFINITY) take the model file's
 * input_limits, and for a saturating envelope with no limit at all the envelope's own
 * range (see docs/models.md). NaN, or lo >= hi, is HYSTERON_ERROR_INVALID_ARGUMENT; a
 * model that cannot be inverted (e.g. mpi-asym without finite limits), or limits that share
 * nothing with the model's finite input_limits (e.g. MPa on a model in kPa), is
 * HYSTERON_ERROR_MODEL. */
HYSTERON_C_API hysteron_status hysteron_inverse_create(const hysteron_params* params, double lo, double hi,
                                                      hysteron_inverse** out);
HYSTERON_C_API hysteron_status hysteron_inverse_free(hysteron_inverse* inverse);

/* The limits the inverse saturates at [input units] (possibly infinite). */
HYSTERON_C_API hysteron_status hysteron_inverse_limits(const hysteron_inverse* inverse, double* lo, double* hi);

/* Virgin state (matches hysteron_model_reset). */
HYSTERON_C_API hysteron_status hysteron_inverse_reset(hysteron_inverse* inverse);
/* Start as a forward model at rest at input x0 [input units] (hysteron_model_reset_relaxed;
 * the same refusals). x0 outside the inverse's limits is accepted on purpose (a muscle at
 * rest below the lowest pressure the loop commands): the memory is at rest at x0, the
 * inverse's last input (*x held on a refused step) is x0 clamped to the limits, and the next
 * step commands inside the limits as always. */
HYSTERON_C_API hysteron_status hysteron_inverse_reset_relaxed(hysteron_inverse* inverse, double x0);
/* Start from a forward model's state (y[0..n), u as from hysteron_model_get_state), so that
 * the inverse continues exactly where that model is. HYSTERON_ERROR_INVALID_ARGUMENT on a
 * wrong n, a non-finite value, or a state the model cannot reach. */
HYSTERON_C_API hysteron_status hysteron_inverse_reset_state(hysteron_inverse* inverse, const double* y, size_t n,
                                                           double u);
/* The equivalent forward-model state after the last step (y: array of n; u may be NULL). */
HYSTERON_C_API hysteron_status hysteron_inverse_get_state(const hysteron_inverse* inverse, double* y, size_t n,
                                                         double* u);

/* One sample: *x = the input [input units] that makes the model output y_desired
 * [output units], clamped to the limits. *saturated (may be NULL) = 1 if it was clamped,
 * else 0; a finite y_desired beyond what the model can output inside the limits, however
 * large (1e308), saturates at the limit in its direction. A non-finite y_desired (or, only
 * for an inverse with an unbounded limit, one whose input would overflow) returns
 * HYSTERON_ERROR_INVALID_ARGUMENT, leaves the state unchanged and writes the previous
 * input to *x. Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_inverse_step(hysteron_inverse* inverse, double y_desired, double* x,
                                                    int* saturated);
/* Batch: x[k] = step(y[k]) for k < n_y; n_x must equal n_y. x may be y itself (in place) or
 * apart from it; an x that partly overlaps y is HYSTERON_ERROR_INVALID_ARGUMENT (as
 * hysteron_model_simulate). *n_saturated (may be NULL) = number of clamped samples. Every y[k]
 * is checked first (nothing stepped on error). */
HYSTERON_C_API hysteron_status hysteron_inverse_invert(hysteron_inverse* inverse, const double* y, size_t n_y,
                                                      double* x, size_t n_x, size_t* n_saturated);

/* ---- inverse feedforward + PID (GPI paper, Fig. 10) ------------------------ */
/* pressure_cmd = clamp(FF(preview) + PID(reference - measured), pressure_min, pressure_max),
 * FF = the exact inverse of the model applied to preview * model_scale (optionally with
 * a first-order lag compensation), the PID (Eq. 17) with anti-windup that knows the total
 * command. Positions in metres, pressures in MPa (the C++ FeedforwardPidController). */
typedef enum hysteron_anti_windup {
  HYSTERON_ANTI_WINDUP_NONE = 0,
  HYSTERON_ANTI_WINDUP_CONDITIONAL = 1,     /* integrate only when it does not push further into the limit */
  HYSTERON_ANTI_WINDUP_BACK_CALCULATION = 2 /* dI/dt += (u_sat - u) / T_t */
} hysteron_anti_windup;

/* Fill with hysteron_ff_pid_default_params(), then change what you need. */
typedef struct hysteron_ff_pid_params {
  double sample_time;       /* T_s [s], > 0 (default 1e-3) */
  /* pressure_min, pressure_max: the command limits [MPa], min < max, also the inverse's saturation
   * limits. An infinite side, -HUGE_VAL / +HUGE_VAL (the default, as hysteron_inverse_create), is
   * the model file's input_limits on that side: a fitted model's training input range. A model
   * without finite ones there: *_create is HYSTERON_ERROR_INVALID_ARGUMENT (set your actuator's). */
  double pressure_min;
  double pressure_max;
  double model_scale;       /* model output units per metre (default 1000: model in mm); where the
                               model file's "units" give its output a length unit (m, mm, um, ...),
                               one that contradicts it is HYSTERON_ERROR_INVALID_ARGUMENT (a model
                               in m needs 1) */
  double lag_time_constant; /* tau [s] >= 0 of the actuator lag to compensate (default 0) */
  double kp;                /* K_p [MPa/m] (default 0) */
  double ki;                /* K_i [MPa/(m s)] (default 0) */
  double kd;                /* K_d [MPa s/m] (default 0) */
  double derivative_filter; /* T_f [s] >= 0 of the derivative's first-order filter (default 0) */
  double tracking_time;     /* T_t [s] for back-calculation; 0 selects one from T_i, T_d (default 0) */
  double setpoint_weight_p; /* b: P acts on b r - y (default 1) */
  double setpoint_weight_d; /* c: D acts on c r - y (default 0: on the measurement) */
  int anti_windup;          /* a hysteron_anti_windup (default CONDITIONAL) */
} hysteron_ff_pid_params;

typedef struct hysteron_ff_pid hysteron_ff_pid;

HYSTERON_C_API hysteron_status hysteron_ff_pid_default_params(hysteron_ff_pid_params* params);
/* A controller for the model `params` (copied: params may be freed afterwards). Invalid
 * controller parameters are HYSTERON_ERROR_INVALID_ARGUMENT (the field is named), and so are
 * unset pressure limits that the model's input_limits cannot give. A model file whose "units"
 * give its input a pressure unit other than MPa ("kPa", "bar", "Pa", "psi", ...) is
 * HYSTERON_ERROR_MODEL naming the file and the unit (since 2026-12-01; the controller's
 * pressures are in MPa and its inverse would saturate): refit the model with its pressure in
 * MPa. A model without an input unit (hand-written) or with one that is no pressure is taken
 * as in MPa. The same holds for hysteron_open_loop_create and hysteron_cascade_create. */
HYSTERON_C_API hysteron_status hysteron_ff_pid_create(const hysteron_params* params,
                                                     const hysteron_ff_pid_params* controller,
                                                     hysteron_ff_pid** out);
HYSTERON_C_API hysteron_status hysteron_ff_pid_free(hysteron_ff_pid* controller);
/* Zero PID state, virgin inverse. */
HYSTERON_C_API hysteron_status hysteron_ff_pid_reset(hysteron_ff_pid* controller);
/* One sample. reference_m: y_d(t) [m]; preview_m: the reference fed to the inverse [m]
 * (y_d(t + lead) for a known reference, else reference_m); measured_m: sensor [m].
 * *pressure_mpa: the command [MPa]. A non-finite argument returns
 * HYSTERON_ERROR_INVALID_ARGUMENT and the loop steps without it, as the C++ controller, Python
 * and the generated C do (so they agree on every later sample): a non-finite reference_m or
 * measured_m holds the position PID's state (no integration) and its correction, and the
 * feedforward goes on: the command is the inverse's pressure for this sample's preview plus the
 * PID's held correction (its previous output minus the feedforward in it), clamped to the
 * limits, so a muscle whose position sensor drops out keeps following the reference open loop
 * (before 2026-12-01 the previous command was held, the muscle stood still); with a non-finite
 * preview_m as well the inverse holds too and the command is the previous one. A non-finite
 * preview_m alone holds the inverse's state and output, and the PID steps on. In
 * hysteron_open_loop_step a non-finite pressure_mpa skips the pressure loop for that sample (p_d
 * is commanded); in hysteron_cascade_step it commands duty 0 (both valves closed: the muscle's
 * pressure holds; a held duty filled it up to the supply), holds the position PID (no wind-up
 * of p_d while the pressure loop is blind; p_d is the feedforward plus its held correction) and
 * holds the pressure PID's state. The command is always finite and within the limits. Finite
 * arguments whose error or PID terms overflow (reference_m = 1e308, measured_m = -1e308) return
 * HYSTERON_ERROR_INVALID_ARGUMENT too: the PID's state is unchanged and the command as for a
 * non-finite measurement (never a NaN into the integrator). The same holds for
 * hysteron_open_loop_step and hysteron_cascade_step. Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_ff_pid_step(hysteron_ff_pid* controller, double reference_m, double preview_m,
                                                   double measured_m, double* pressure_mpa);

/* ---- open-loop inverse compensation + pressure loop (asymmetric-MPI paper, Fig. 6) ---- */
/* p_d = FF(preview) (+ PID(reference - measured) if any of kp, ki, kd is nonzero, the sum
 * clamped to the pressure limits), then the proportional pressure loop
 *   pressure_cmd = clamp(p_d + pressure_gain (p_d - pressure), pressure_min, pressure_max)
 * around a proportional regulator (p_d itself where pressure_gain = 0: never NaN, also where
 * p_d - pressure overflows). The C++ OpenLoopController; `hysteron experiment
 * mpi-openloop`'s loops (result.json "controller", "loop": "open_loop"; docs/deploy.md). */
typedef struct hysteron_open_loop_params {
  /* The feedforward (sample_time, pressure limits, model_scale, lag_time_constant) and the
   * position PID (kp = ki = kd = 0, the default: the paper's pure open loop), as in
   * hysteron_ff_pid_params; the PID's output is limited to +-(pressure_max - pressure_min). */
  hysteron_ff_pid_params loop;
  double pressure_gain; /* k_p >= 0 of the pressure loop (default 0.5, the paper's; 0: none) */
} hysteron_open_loop_params;

typedef struct hysteron_open_loop hysteron_open_loop;

HYSTERON_C_API hysteron_status hysteron_open_loop_default_params(hysteron_open_loop_params* params);
/* As hysteron_ff_pid_create (the model is copied; invalid parameters are
 * HYSTERON_ERROR_INVALID_ARGUMENT naming the field). */
HYSTERON_C_API hysteron_status hysteron_open_loop_create(const hysteron_params* params,
                                                        const hysteron_open_loop_params* controller,
                                                        hysteron_open_loop** out);
HYSTERON_C_API hysteron_status hysteron_open_loop_free(hysteron_open_loop* controller);
/* Zero PID state, virgin inverse. */
HYSTERON_C_API hysteron_status hysteron_open_loop_reset(hysteron_open_loop* controller);
/* One sample: reference_m, preview_m, measured_m as in hysteron_ff_pid_step; pressure_mpa the
 * measured gauge pressure [MPa]; *command_mpa the regulator's command [MPa]. A non-finite
 * argument returns HYSTERON_ERROR_INVALID_ARGUMENT and the loop steps without it (see
 * hysteron_ff_pid_step). Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_open_loop_step(hysteron_open_loop* controller, double reference_m,
                                                      double preview_m, double measured_m, double pressure_mpa,
                                                      double* command_mpa);

/* ---- cascade with fast switching valves (dead-zone MPI paper) ------------------------ */
/* Outer loop: p_d = clamp(FF(preview) + PID_x(reference - measured), pressure_min, pressure_max);
 * inner loop: u = PID_p(p_d - pressure) [duty], limited to [-1, 1]; then the PWM modulator:
 *   duty = 0 if |u| <= deadband, else sgn(u) min(max_duty, min_duty + gain (|u| - deadband)),
 * rounded to `resolution` (0: continuous); duty > 0 opens the inlet valve, < 0 the exhaust.
 * The C++ CascadePwmController; `hysteron experiment mpi-pwm`'s loops ("loop": "cascade_pwm"). */
typedef struct hysteron_pid_params {
  double kp, ki, kd;        /* K_p, K_i [1/s], K_d [s] in the loop's units (default 0) */
  double derivative_filter; /* T_f [s] >= 0 (default 0) */
  double tracking_time;     /* T_t [s] for back-calculation (default 0) */
  double setpoint_weight_p; /* b (default 1) */
  double setpoint_weight_d; /* c (default 0) */
  double out_min, out_max;  /* output limits, out_min < out_max (default -1, 1; the inner loop's
                               output is also limited to [-1, 1]) */
  int anti_windup;          /* a hysteron_anti_windup (default CONDITIONAL) */
} hysteron_pid_params;

typedef struct hysteron_pwm_params {
  double gain;       /* duty per unit of u, > 0 (default 1) */
  double deadband;   /* >= 0 (default 0) */
  double min_duty;   /* in [0, max_duty] (default 0) */
  double max_duty;   /* in (0, 1] (default 1) */
  double resolution; /* duty quantum in [0, 1], 0: continuous (default 0) */
} hysteron_pwm_params;

typedef struct hysteron_cascade_params {
  hysteron_ff_pid_params outer; /* feedforward + position PID [MPa/m], as hysteron_ff_pid_params */
  hysteron_pid_params pressure; /* inner loop: pressure error [MPa] -> duty (default: P, kp = 20, the paper's) */
  hysteron_pwm_params pwm;
} hysteron_cascade_params;

typedef struct hysteron_cascade hysteron_cascade;

HYSTERON_C_API hysteron_status hysteron_cascade_default_params(hysteron_cascade_params* params);
HYSTERON_C_API hysteron_status hysteron_cascade_create(const hysteron_params* params,
                                                      const hysteron_cascade_params* controller,
                                                      hysteron_cascade** out);
HYSTERON_C_API hysteron_status hysteron_cascade_free(hysteron_cascade* controller);
/* Zero PID states and duty, virgin inverse. */
HYSTERON_C_API hysteron_status hysteron_cascade_reset(hysteron_cascade* controller);
/* One sample (arguments as hysteron_open_loop_step): *duty the PWM duty in [-1, 1] for the next
 * valve period; *desired_pressure_mpa (may be NULL) the outer loop's p_d. A non-finite argument
 * returns HYSTERON_ERROR_INVALID_ARGUMENT and the loop steps without it (see
 * hysteron_ff_pid_step). Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_cascade_step(hysteron_cascade* controller, double reference_m,
                                                    double preview_m, double measured_m, double pressure_mpa,
                                                    double* duty, double* desired_pressure_mpa);

/* ---- the position PID's limit-cycle guard (docs/control.md, section 2) ------------------ */
/* A loop that rings near its ultimate period T_u (e.g. on a rig that changed after its tuning)
 * gets its position PID's gains cut: half-cycles of the error r - y (between its sign changes,
 * with a hysteresis of amplitude / 4) no longer than T_u whose integral of |e| dt exceeds
 * amplitude T_u / pi add 1 to a count that decays with time constant memory T_u; at `count`
 * the gains K_p, K_i, K_d are multiplied by `factor`, not below min_scale times the tuned
 * ones. The cut gains stay until the controller's reset or hysteron_*_restart_guard.
 * `hysteron experiment`'s tuned loops (compensated, learning, adaptive) have one;
 * hysteron_loop_guard_from_file reads it. Off by default (period 0), and in the faithful and
 * baseline loops. The start-up transient of a loop (the muscle filling from rest, a first
 * large error) can look like a ring to the guard and cut the gains for good (+23 % RMS error on
 * the rig after): call hysteron_*_restart_guard once it has passed (the experiments restart the
 * guard after their pre-roll). */
typedef struct hysteron_pid_guard {
  double period;    /* T_u [s]: 0 (off, the default) or >= 4 sample times */
  double amplitude; /* [m] > 0 where period > 0 (default 0) */
  double count;     /* > 0 (default 5) */
  double memory;    /* the count's decay time constant [T_u] > 0 (default 5) */
  double factor;    /* on the gains per cut, in (0, 1) (default 0.63) */
  double min_scale; /* in (0, 1] (default 0.25) */
} hysteron_pid_guard;

HYSTERON_C_API hysteron_status hysteron_pid_guard_default(hysteron_pid_guard* guard);
/* Sets the position PID's guard of a controller and restarts it (the gains as tuned). Invalid
 * numbers are HYSTERON_ERROR_INVALID_ARGUMENT naming the field; the controller is then
 * unchanged. A setup call, not for the real-time loop. */
HYSTERON_C_API hysteron_status hysteron_ff_pid_set_guard(hysteron_ff_pid* controller, const hysteron_pid_guard* guard);
HYSTERON_C_API hysteron_status hysteron_open_loop_set_guard(hysteron_open_loop* controller,
                                                           const hysteron_pid_guard* guard);
HYSTERON_C_API hysteron_status hysteron_cascade_set_guard(hysteron_cascade* controller, const hysteron_pid_guard* guard);
/* Restarts the position PID's guard without changing it: the gains as tuned (gain_scale 1, no
 * cuts), no half-cycles counted; the rest of the loop's state goes on. Call it once the loop's
 * start-up transient has passed (e.g. after the first period of the reference, or once |r - y|
 * has settled). Real-time safe (no allocation, no lock): may be called between two steps. */
HYSTERON_C_API hysteron_status hysteron_ff_pid_restart_guard(hysteron_ff_pid* controller);
HYSTERON_C_API hysteron_status hysteron_open_loop_restart_guard(hysteron_open_loop* controller);
HYSTERON_C_API hysteron_status hysteron_cascade_restart_guard(hysteron_cascade* controller);
/* What the guard did: the factor on the position PID's gains now (1: as tuned) and how often
 * it cut them since the last reset. Either out-pointer may be NULL. Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_ff_pid_guard_state(const hysteron_ff_pid* controller, double* gain_scale,
                                                          size_t* cuts);
HYSTERON_C_API hysteron_status hysteron_open_loop_guard_state(const hysteron_open_loop* controller, double* gain_scale,
                                                             size_t* cuts);
HYSTERON_C_API hysteron_status hysteron_cascade_guard_state(const hysteron_cascade* controller, double* gain_scale,
                                                           size_t* cuts);

/* ---- iterative learning control (docs/control.md, section 3) ------------------ */
/* For a periodic reference with N samples per period: a correction c is added to the
 * reference (and to the feedforward's preview) of a closed loop, and learnt from the
 * tracking error e = r - y over the periods (the C++ IterativeLearning):
 *   c_{j+1}(k) = sum_{m=-h..h} q_m [ c_j(k+m) + L e_j(k+m+d) ]   (indices mod N),
 * q the binomial Q-filter, |Q(w)| = cos^(2h)(w / 2). Each sample: read the correction(s),
 * run the loop on r + c, then step with the error of that sample. `hysteron experiment`
 * prints the L, d and h it designed for the rig at hand (the learning run's description). */
typedef struct hysteron_ilc_params {
  size_t period;          /* N [samples] per period, 2..10^7 (default 0: must be set) */
  double gain;            /* L, in (0, 2) (default 0.5) */
  size_t lead;            /* d [samples] (default 0) */
  size_t half_width;      /* h of the Q-filter (default 0: no filter; at most 10^7) */
  size_t lookahead;       /* largest `ahead` of hysteron_ilc_correction (default 0);
                             lead + 2 r + lookahead < period, r the filter's summed taps
                             each side (r = h up to h = 31, about 6.4 sqrt(h) beyond) */
  double max_correction;  /* |c| limit, > 0 (default: infinity) */
  double rise_tolerance;  /* supervision: a period whose RMS error rises above the least
                             before it by more than this fraction restores the best
                             correction and halves L, >= 0 (default: infinity, none) */
  size_t hold_after_cuts; /* after this many halvings the best correction is held; at most 10
                             (L's floor, kMaxLearningCuts): 0 or a larger count holds after 10.
                             A held correction is never re-checked (until a reset) */
  double max_gain;        /* L doubles after every new best period up to this, until the first
                             halving (0: never; else in [gain, 2); needs rise_tolerance) */
} hysteron_ilc_params;

typedef struct hysteron_ilc hysteron_ilc;

HYSTERON_C_API hysteron_status hysteron_ilc_default_params(hysteron_ilc_params* params);
/* Allocates O(N). Invalid parameters are HYSTERON_ERROR_INVALID_ARGUMENT (the field is named). */
HYSTERON_C_API hysteron_status hysteron_ilc_create(const hysteron_ilc_params* params, hysteron_ilc** out);
HYSTERON_C_API hysteron_status hysteron_ilc_free(hysteron_ilc* ilc);
/* Zero corrections, back to phase 0 of period 0, L back to params.gain. */
HYSTERON_C_API hysteron_status hysteron_ilc_reset(hysteron_ilc* ilc);
/* As hysteron_ilc_reset, but period 0 applies `correction` (n = params.period values, clipped to
 * +-params.max_correction) instead of zeros, and learning goes on from it: a warm start from a
 * correction learnt before (recorded with hysteron_ilc_correction(ilc, 0, ...) over a period of an
 * earlier session, or the correction_mm column of `hysteron experiment`'s learning run, converted
 * to the loop's units). n != period or a non-finite value is HYSTERON_ERROR_INVALID_ARGUMENT and
 * changes nothing. Does not allocate. */
HYSTERON_C_API hysteron_status hysteron_ilc_reset_to(hysteron_ilc* ilc, const double* correction, size_t n);
/* The correction to add to the reference `ahead` samples after the current one (0: the
 * current sample; the feedforward's preview takes its lead). ahead > params.lookahead is
 * HYSTERON_ERROR_INVALID_ARGUMENT. Call before hysteron_ilc_step for the current sample.
 * Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_ilc_correction(const hysteron_ilc* ilc, size_t ahead, double* correction);
/* Records the error r - y [the loop's units] of the current sample and advances one sample.
 * A non-finite error is learnt as 0 and counted (the sample still advances, so the phase
 * stays with the reference), and the call returns HYSTERON_ERROR_INVALID_ARGUMENT. A finite
 * but huge error (of the order of 1e308) can overflow the update of the correction, which runs
 * learning_update_delay = lead + h samples behind the errors: that phase then keeps its
 * correction of the period before (never inf or NaN), the overflow is counted
 * (hysteron_ilc_overflows) and the call that made the update returns
 * HYSTERON_ERROR_INVALID_ARGUMENT (the sample still advances). Feed 0 where the actuator is at
 * a limit (the error there cannot be reduced). Real-time safe. */
HYSTERON_C_API hysteron_status hysteron_ilc_step(hysteron_ilc* ilc, double error);
/* Updates of the correction that overflowed since the last reset (see hysteron_ilc_step). */
HYSTERON_C_API hysteron_status hysteron_ilc_overflows(const hysteron_ilc* ilc, size_t* overflows);
/* Where it is: the phase in the period, completed periods, the L in use, how often the
 * supervisor halved and doubled L, whether it holds the best correction, non-finite errors
 * seen. Any out-pointer may be NULL. */
HYSTERON_C_API hysteron_status hysteron_ilc_state(const hysteron_ilc* ilc, size_t* phase, size_t* iteration,
                                                 double* gain, size_t* gain_cuts, size_t* gain_raises, int* held,
                                                 size_t* faults);

/* ---- a loop from `hysteron experiment`'s result.json (docs/deploy.md) ---------------- */
/* Every tracking run of `hysteron experiment NAME --out DIR` records its loop in DIR/result.json
 * ("controller"): which controller, its gains, the feedforward's preview and the learning.
 * hysteron_loop_params_from_file reads one run's loop into the structs above, so a C program
 * deploys what the experiment found without parsing JSON itself:
 *
 *   hysteron_loop_params loop;
 *   hysteron_loop_params_from_file("out/result.json", "compensated.sine", &loop);
 *   hysteron_params_from_file("out/best_model.json", &model);   (faithful: model.json)
 *   if (loop.kind == HYSTERON_LOOP_CASCADE_PWM) {
 *     hysteron_cascade_params cp = {loop.ff_pid, loop.pressure, loop.pwm};
 *     hysteron_cascade_create(model, &cp, &c);
 *   }
 *   hysteron_loop_guard_from_file("out/result.json", "compensated.sine", &guard);
 *   hysteron_cascade_set_guard(c, &guard);   (the position PID's limit-cycle guard, below)
 *
 * The numbers are the file's exactly; they are checked when read, as the *_create functions
 * would check them. */
typedef enum hysteron_loop_kind {
  HYSTERON_LOOP_FEEDFORWARD_PID = 0, /* hysteron_ff_pid_create(model, &loop.ff_pid, ...) (gpi-pid) */
  HYSTERON_LOOP_OPEN_LOOP = 1,       /* hysteron_open_loop_params {loop.ff_pid, loop.pressure_gain} (mpi-openloop) */
  HYSTERON_LOOP_CASCADE_PWM = 2      /* hysteron_cascade_params {loop.ff_pid, loop.pressure, loop.pwm} (mpi-pwm) */
} hysteron_loop_kind;
typedef struct hysteron_loop_params {
  int kind; /* a hysteron_loop_kind: the object to create */
  /* The feedforward and the position PID (every kind; a run without a position PID, the
   * faithful open loop, has kp = ki = kd = 0), then the parts of the pressure loop its kind
   * has; the parts it does not have are the *_default_params values. */
  hysteron_ff_pid_params ff_pid;
  double pressure_gain;         /* HYSTERON_LOOP_OPEN_LOOP: k_p of the pressure loop */
  hysteron_pid_params pressure; /* HYSTERON_LOOP_CASCADE_PWM: the valves' inner loop */
  hysteron_pwm_params pwm;      /* HYSTERON_LOOP_CASCADE_PWM: the modulator */
  /* The feedforward's preview of a known reference r (hysteron_loop_preview):
   * preview(k) = s(k + feedforward_lead), s = r unshaped, else
   * s(k) = shaper_a1 r(k + shaper_advance) + shaper_a2 r(k + shaper_advance - shaper_delay). */
  size_t feedforward_lead; /* [samples] */
  int shaped;              /* 1: through the shaper; 0: a1 = 1, a2 = 0, delay = advance = 0 */
  double shaper_a1, shaper_a2;
  size_t shaper_delay, shaper_advance; /* [samples] */
  /* The learning run's iterative learning (hysteron_ilc_create(&loop.learning, ...)); else
   * has_learning = 0 and hysteron_ilc_default_params. */
  int has_learning;
  hysteron_ilc_params learning;
} hysteron_loop_params;
/* One run's loop from a result.json text. `run` is "VARIANT" for an experiment with one
 * reference (e.g. "compensated", "learning") or "VARIANT.REFERENCE" (e.g. "compensated.sine",
 * "learning.triangle"); NULL or "" takes `json` as a "controller" object itself. Errors:
 * HYSTERON_ERROR_PARSE (not JSON: line and column), HYSTERON_ERROR_MODEL (no such run, a
 * missing key, a value the loop's objects would refuse such as a null or negative gain, or a
 * loop these structs cannot hold exactly, e.g. a position PID whose output limits are narrower
 * than the ones the controller applies; the message names the runs there are, or the key).
 * *out is written only on success. */
HYSTERON_C_API hysteron_status hysteron_loop_params_from_json(const char* json, const char* run,
                                                             hysteron_loop_params* out);
/* The same from a file (e.g. "out/result.json"); HYSTERON_ERROR_IO if it cannot be read. */
HYSTERON_C_API hysteron_status hysteron_loop_params_from_file(const char* path, const char* run,
                                                             hysteron_loop_params* out);
/* The position PID's limit-cycle guard of the same run (hysteron_loop_params holds the loop
 * without it): pass it to hysteron_ff_pid_set_guard, hysteron_open_loop_set_guard or
 * hysteron_cascade_set_guard after creating the loop, so that the loop is the run's. A run
 * without one (or written before it) gives period = 0, off. Errors as hysteron_loop_params_from_json;
 * *out is written only on success. */
HYSTERON_C_API hysteron_status hysteron_loop_guard_from_json(const char* json, const char* run,
                                                            hysteron_pid_guard* out);
HYSTERON_C_API hysteron_status hysteron_loop_guard_from_file(const char* path, const char* run,
                                                            hysteron_pid_guard* out);
/* The preview the loop's feedforward is fed for a recorded or planned reference r[0..n) (any
 * units, e.g. m), by the formula above with indices clamped to [0, n): what the experiment's
 * run fed its feedforward. n_preview must equal n_reference; preview may not alias reference.
 * Not for the real-time loop: a batch over the whole reference (it does not allocate). */
HYSTERON_C_API hysteron_status hysteron_loop_preview(const hysteron_loop_params* loop, const double* reference,
                                                    size_t n_reference, double* preview, size_t n_preview);

#ifdef __cplusplus
}
#endif

#endif /* HYSTERON_H */
