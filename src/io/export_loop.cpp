// The loop in generated C (export_loop.hpp). Every number is read from the controller
// make_controller builds (the PIDs as built, with their narrowed limits and discrete
// coefficients), so the C code steps exactly what step(Controller&, ...) steps.
#include "export_loop.hpp"

#include <fmt/format.h>

#include <cstddef>
#include <variant>

#include "export_c_text.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/control.hpp"
#include "hysteron/error.hpp"

namespace hysteron::io::detail {

namespace {

// A Pid as built, as a C initializer of $P_pid_gains (the field order of the struct below).
std::string pid_gains(const Pid& pid) {
  const PidParams& p = pid.params();
  const Pid::Coefficients k = pid.coefficients();
  const int aw = p.anti_windup == AntiWindup::none ? 0 : p.anti_windup == AntiWindup::conditional ? 1 : 2;
  // the state after a reset: the controller's PIDs are built reset and not yet stepped
  const PidState& s0 = pid.state();
  const PidGuard& g = p.guard;
  return fmt::format("{{{}, {}, {}, {}, {}, {},\n   {}, {}, {}, {}, {}, {}, {},\n   {}, {}, {}, {}, {}, {}, {}}}", num(p.kp),
                     num(p.ki), num(p.sample_time), num(p.setpoint_weight_p), num(p.setpoint_weight_d), num(k.a_d),
                     num(k.b_d), num(k.k_t), num(p.out_min), num(p.out_max), aw, num(s0.output), num(s0.integral),
                     num(g.period), num(g.amplitude), num(g.count), num(g.factor), num(g.min_scale),
                     num(k.guard_decay), num(k.guard_iae_limit));
}

std::string pid_comment(const char* name, const Pid& pid) {
  const PidParams& p = pid.params();
  return fmt::format(
      " *   {}: K_p = {}, K_i = {} 1/s, K_d = {} s, T_f = {} s, output in [{}, {}],\n"
      " *     anti-windup {}{}, setpoint weights b = {}, c = {}\n",
      name, num(p.kp), num(p.ki), num(p.kd), num(p.derivative_filter), num(p.out_min), num(p.out_max),
      anti_windup_name(p.anti_windup),
      p.anti_windup == AntiWindup::back_calculation ? fmt::format(" (T_s / T_t = {})", num(pid.coefficients().k_t))
                                                     : std::string(),
      num(p.setpoint_weight_p), num(p.setpoint_weight_d)) +
    (p.guard.enabled()
         ? fmt::format(" *     limit-cycle guard: T_u = {} s, amplitude {}, count {}, memory {} T_u, gains x{} per cut, "
                       "not below x{}\n",
                       num(p.guard.period), num(p.guard.amplitude), num(p.guard.count), num(p.guard.memory),
                       num(p.guard.factor), num(p.guard.min_scale))
         : std::string());
}

// With a feedforward into the position PID (not the open loop's: unused there, which -Wall refuses).
constexpr std::string_view kHeldCommand = R"(
/* The command of a sample the position PID held (hysteron::held_pid_command): this sample's
 * feedforward plus the PID's held correction (its held output minus the feedforward in it),
 * clamped to the PID's output limits; the held output itself where the feedforward is the one
 * it held, and where the sum is not finite. */
static double $P_held_command(double u_ff, double held_output, double held_ff, const $P_pid_gains *k)
{
  const double c = u_ff == held_ff ? held_output : u_ff + (held_output - held_ff);
  return $P_clamp($P_finite(c) ? c : held_output, k->out_min, k->out_max);
}
)";

constexpr std::string_view kPidStep = R"(
/* The limit-cycle guard (hysteron::Pid, PidGuard): half-cycles of e between its sign changes
 * (hysteresis amplitude / 4) no longer than T_u with an integral of |e| dt above a T_u / pi
 * count 1, or where the ring grows (three counted in a row, this one's integral at least that of the
 * one of its sign before) their severity (that integral over a T_u / pi, at most 2^1023 (no overflow on a
 * limit near DBL_MIN), added at most guard_count); the count decays by guard_decay per sample; at guard_count it
 * cuts the gains. Updates the candidate state s; 0 where the integral of |e| dt or the count overflows
 * (s then discarded: the sample is held). */
static int $P_pid_guard($P_pid_state *s, const $P_pid_gains *k, double e)
{
  const double h = 0.25 * k->guard_amplitude;
  const int sign = e > h ? 1 : (e < -h ? -1 : 0);
  s->guard_iae += fabs(e) * k->ts;
  if (!$P_finite(s->guard_iae)) return 0;  /* only an integral that overflows is held */
  if ((double)s->guard_samples * k->ts <= k->guard_period) ++s->guard_samples;  /* no wrap-around */
  if (sign != 0 && sign != s->guard_sign) {
    const double length = (double)s->guard_samples * k->ts;
    double severity = 0.0, add;
    if (s->guard_sign != 0 && length <= k->guard_period && s->guard_iae > k->guard_iae_limit)  /* at most 2^1023: */
      severity = s->guard_iae > 0x1p1023 * k->guard_iae_limit ? 0x1p1023 : s->guard_iae / k->guard_iae_limit;
    add = 1.0; /* a growing ring (three in a row, this one at least the one of its sign before): its severity */
    if (s->guard_last > 0.0 && s->guard_last2 > 0.0 && severity >= s->guard_last2) {
      add = severity < k->guard_count ? severity : k->guard_count;
      if (add < 1.0) add = 1.0;
    }
    if (severity > 0.0) s->guard_count += add;
    s->guard_last2 = s->guard_last;
    s->guard_last = severity;
    s->guard_sign = sign;
    s->guard_iae = 0.0;
    s->guard_samples = 0;
  }
  s->guard_count *= k->guard_decay;
  if (s->guard_count < 0x1p-1022) s->guard_count = 0.0;  /* below DBL_MIN: 0, no subnormal count */
  if (!$P_finite(s->guard_count)) return 0;
  if (s->guard_count >= k->guard_count) {
    double next = s->gain_scale * k->guard_factor;
    if (next < k->guard_min_scale) next = k->guard_min_scale;
    s->guard_count = 0.0;
    if (next < s->gain_scale) {
      s->gain_scale = next;
      ++s->guard_cuts;
    }
  }
  return 1;
}

/* Discrete PID (hysteron::Pid::step, control.hpp; Eq. 17 of gpi-lm-feedforward-pid.txt):
 *   P = s K_p (b r - y),  D = a_d D + s b_d (d - d_prev), d = c r - y,  v = P + I + D + ff,
 *   u = clamp(v, out_min, out_max),  I += s K_i T_s (r - y) by the anti-windup rule,
 * s the limit-cycle guard's scale (1 unless it cut the gains; docs/control.md, section 2).
 * A non-finite input or intermediate (r - y of r = 1e308, y = -1e308, the integral's increment,
 * the guard's) holds the last output and leaves the state as it was (counted in faults). */
static double $P_pid_step($P_pid_state *s, const $P_pid_gains *k, double r, double y, double ff)
{
  double e, scale, prop, d_err, prev_d_error, derivative, v, u, di, integral;
  $P_pid_state n;
  if (!$P_finite(r) || !$P_finite(y) || !$P_finite(ff)) {
    ++s->faults;
    return s->output;
  }
  e = r - y;
  scale = s->gain_scale;
  prop = scale * k->kp * (k->b * r - y);
  d_err = k->c * r - y;
  prev_d_error = s->initialized ? s->prev_d_error : d_err;  /* no derivative kick */
  derivative = k->a_d * s->derivative + scale * k->b_d * (d_err - prev_d_error);
  v = prop + s->integral + derivative + ff;
  u = $P_clamp(v, k->out_min, k->out_max);
  di = scale * k->ki * k->ts * e;
  integral = s->integral;
  if (k->anti_windup == 0) {
    integral += di;
  } else if (k->anti_windup == 1) {  /* conditional: not further into saturation */
    if (!((v > k->out_max && di > 0.0) || (v < k->out_min && di < 0.0))) integral += di;
  } else {                           /* back-calculation */
    integral += di + k->k_t * (u - v);
  }
  if (!$P_finite(e) || !$P_finite(d_err) || !$P_finite(di) || !$P_finite(v) || !$P_finite(derivative) ||
      !$P_finite(integral)) {
    ++s->faults;
    return s->output;
  }
  n = *s;  /* the candidate state */
  n.initialized = 1;
  n.derivative = fabs(derivative) < 0x1p-1022 ? 0.0 : derivative;  /* no subnormal state at rest */
  n.prev_d_error = d_err;
  n.integral = integral;
  n.saturated = u != v;
  n.output = u;
  if (k->guard_period > 0.0 && !$P_pid_guard(&n, k, e)) {
    ++s->faults;
    return s->output;
  }
  *s = n;
  return u;
}

/* Restarts the limit-cycle guard (hysteron::Pid::restart_guard): the gains as tuned, no half-cycles
 * counted; the rest of the state goes on. */
static void $P_pid_restart_guard($P_pid_state *s)
{
  s->gain_scale = 1.0;
  s->guard_cuts = 0;
  s->guard_sign = 0;
  s->guard_iae = 0.0;
  s->guard_samples = 0;
  s->guard_count = 0.0;
  s->guard_last = 0.0;
  s->guard_last2 = 0.0;
}

static void $P_pid_reset($P_pid_state *s, const $P_pid_gains *k)
{
  s->integral = k->reset_integral;
  s->derivative = 0.0;
  s->prev_d_error = 0.0;
  s->output = k->reset_output;
  s->initialized = 0;
  s->saturated = 0;
  s->faults = 0;
  $P_pid_restart_guard(s);
}

/* The inverse feedforward (hysteron::InverseFeedforward::step): the pressure [MPa] the model
 * needs for desired_m [m], plus the lag compensation tau dp/dt, within the pressure limits. */
static double $P_feedforward($P_loop *c, double desired_m)
{
  const double p = $P_inverse_step(&c->inverse, desired_m * $P_model_scale);
  double cmd = p;
  if (c->ff_started && $P_lag_time_constant > 0) cmd = p + $P_lag_time_constant * (p - c->ff_prev) / $P_sample_time;
  c->ff_prev = p;
  c->ff_started = 1;
  return $P_clamp(cmd, $P_pressure_lo, $P_pressure_hi);
}

/* j + plus - minus clamped to [0, n) (feedforward_preview's index arithmetic, no overflow). */
static size_t $P_clamped_index(size_t j, size_t plus, size_t minus, size_t n)
{
  if (plus >= minus) {
    const size_t up = plus - minus;
    return up >= n - 1 - j ? n - 1 : j + up;
  } else {
    const size_t down = minus - plus;
    return down >= j ? 0 : j - down;
  }
}
)";

}  // namespace

LoopC loop_c(const LoopDesign& d, const ModelParams& model) {
  const Controller ctl = make_controller(d, model);  // every check of the loop, with its messages
  const std::string lead = count_literal(d.feedforward_lead, "feedforward_lead");
  std::string advance = "0u", delay = "0u";
  if (d.shaper) {
    advance = count_literal(d.shaper->advance, "shaper.advance");
    delay = count_literal(d.shaper->delay, "shaper.delay");
  }
  FeedforwardParams ff = d.feedforward_params();
  ff.pressure_limits = pressure_limits(ctl);  // resolved: unset sides the model's
  LoopC out;
  out.pressure_limits = ff.pressure_limits;

  // ---- the comment: the loop's structure and its numbers
  std::string& cm = out.comment;
  cm += " *\n * The loop (docs/deploy.md; hysteron::make_controller and step(), loop_design.hpp), one step\n";
  cm += fmt::format(" * every T_s = {} s; contraction in m, pressure in MPa:\n", num(d.sample_time));
  cm += fmt::format(" *   u_ff = clamp(p + tau (p - p_prev) / T_s, {}, {}), p = inverse(model_scale y_preview),\n",
                    num(ff.pressure_limits.lo), num(ff.pressure_limits.hi));
  cm += fmt::format(" *     model_scale = {} per m, tau = {} s\n", num(ff.model_scale), num(ff.lag_time_constant));
  std::string kind_decl;
  switch (d.kind) {
    case LoopDesign::Kind::feedforward_pid: {
      const auto& c = std::get<FeedforwardPidController>(ctl);
      cm += " *   feedforward_pid (FeedforwardPidController): p_cmd = clamp(PID(r, y, u_ff), limits)\n";
      cm += " *     (a sample the PID holds: clamp(u_ff + its held correction), held_pid_command)\n";
      cm += pid_comment("position PID", c.pid());
      break;
    }
    case LoopDesign::Kind::open_loop: {
      const auto& c = std::get<OpenLoopController>(ctl);
      cm += " *   open_loop (OpenLoopController): p_d = u_ff";
      cm += c.uses_position() ? " + PID(r, y), clamped to the limits,\n" : " (no position loop),\n";
      cm += fmt::format(" *     p_cmd = clamp(p_d + k_p (p_d - p), limits), k_p = {} (p: measured pressure)\n",
                        num(c.params().pressure_gain));
      if (c.uses_position()) cm += pid_comment("position PID", c.position());
      break;
    }
    case LoopDesign::Kind::cascade_pwm: {
      const auto& c = std::get<CascadePwmController>(ctl);
      const PwmParams& w = c.params().pwm;
      cm += " *   cascade_pwm (CascadePwmController): p_d = clamp(PID(r, y, u_ff), limits),\n";
      cm += " *     duty = PWM(pressure PID(p_d, p)), in [-1, 1] (> 0 inlet, < 0 exhaust);\n";
      cm += " *     a non-finite p: duty 0 (valves closed), the position PID held\n";
      cm += pid_comment("position PID", c.position());
      cm += pid_comment("pressure PID", c.pressure());
      cm += fmt::format(" *   PWM: gain {}, deadband {}, duty in [{}, {}], resolution {}\n", num(w.gain), num(w.deadband),
                        num(w.min_duty), num(w.max_duty), num(w.resolution));
      break;
    }
  }
  if (d.shaper)
    cm += fmt::format(" *   preview(k) = a1 r(k + L + A) + a2 r(k + L + A - D): L = {}, A = {}, D = {} samples,\n"
                      " *     a1 = {}, a2 = {} (zero-vibration shaper, docs/control.md)\n",
                      d.feedforward_lead, d.shaper->advance, d.shaper->delay, num(d.shaper->a1), num(d.shaper->a2));
  else
    cm += fmt::format(" *   preview(k) = r(k + {}) (the feedforward's lead, samples)\n", d.feedforward_lead);

  // ---- declarations
  const bool cascade = d.kind == LoopDesign::Kind::cascade_pwm;
  std::string& dc = out.declarations;
  dc += fmt::format(R"(
/* ---- the loop ---- */

#include <stddef.h>

/* The sample time [s] the loop was designed for: call $P_loop_step at this period. */
#define $U_LOOP_SAMPLE_TIME_S {}

/* PID gains as the loop built them (hysteron::Pid: params() and coefficients()). */
typedef struct $P_pid_gains {{
  double kp, ki, ts, b, c;         /* K_p, K_i [1/s], T_s [s], setpoint weights */
  double a_d, b_d, k_t;            /* T_f/(T_f+T_s), K_d/(T_f+T_s), T_s/T_t */
  double out_min, out_max;         /* output limits */
  int anti_windup;                 /* 0 none, 1 conditional, 2 back-calculation */
  double reset_output, reset_integral;  /* the state after a reset */
  /* limit-cycle guard (guard_period = T_u [s]; 0: off): amplitude, count, factor per cut, least
     scale, the count's decay per sample, the half-cycles' limit of the integral of |e| dt */
  double guard_period, guard_amplitude, guard_count, guard_factor, guard_min_scale, guard_decay, guard_iae_limit;
}} $P_pid_gains;

/* PID state (hysteron::PidState). */
typedef struct $P_pid_state {{
  double integral;       /* I_k */
  double derivative;     /* D_k */
  double prev_d_error;   /* d_(k-1) */
  double output;         /* last output, held on a fault */
  int initialized;       /* 0 until the first finite sample (no derivative kick) */
  int saturated;         /* 1 if the last output was clamped */
  unsigned long faults;  /* samples held since the last reset: a non-finite input or intermediate */
  double gain_scale;     /* the limit-cycle guard's factor on the gains (1: as tuned) */
  unsigned long guard_cuts;     /* times the guard cut the gains */
  int guard_sign;               /* sign of the current half-cycle of e (0: none yet) */
  double guard_iae;             /* its integral of |e| dt */
  unsigned long guard_samples;  /* its length [samples] */
  double guard_count;           /* decaying count of half-cycles like a limit cycle */
  double guard_last;            /* the last half-cycle's severity (0: not like one) */
  double guard_last2;           /* the one before's */
}} $P_pid_state;

/* The loop's state. Set with $P_loop_reset before the first step. */
typedef struct $P_loop {{
  $P_inverse inverse;    /* the feedforward's inverse (inverse.saturated: the reference asks
                            for more than the pressure limits give) */
  double ff_prev;        /* last inverse output [MPa] (lag compensation) */
  int ff_started;
  $P_pid_state position; /* the position PID{} */
  double ff_held;        /* the feedforward in the position PID's last output [MPa]: a sample it holds
                            commands u_ff + (its output - ff_held) */
{}}} $P_loop;

#ifdef __cplusplus
extern "C" {{
#endif

/* Initial state, as a new loop (the inverse virgin, the PIDs at their reset output). */
void $P_loop_reset($P_loop *c);
/* Restarts the position PID's limit-cycle guard (docs/control.md, section 2; off where the loop
 * has none): the gains as tuned, no half-cycles counted, the rest of the state as it was. The
 * guard cuts the gains of a loop that rings; the start-up transient (the muscle filling from
 * rest) can look like a ring and cut them for good: call this once it has passed. Real-time safe. */
void $P_loop_restart_guard($P_loop *c);
/* One sample (step(Controller&, ...), loop_design.hpp): reference_m, the reference now [m];
 * preview_m, the feedforward's reference (preview[k] of $P_loop_preview); measured_m, the
 * contraction [m]; pressure_mpa, the measured gauge pressure [MPa]{}. Returns the pressure
 * command [MPa]{}, always finite and inside the pressure limits; writes the valves' PWM duty
 * in [-1, 1] to *duty if duty is not NULL ({}). A non-finite input is stepped without: a
 * reference or measurement holds the position PID's state and correction while the feedforward
 * goes on (the command: this sample's u_ff plus the PID's held output minus its ff_held), a
 * preview holds the inverse's state and output, a pressure the pressure loop's (the cascade: duty
 * 0, both valves closed, and the position PID held too); these, and errors whose PID terms
 * overflow (|r - y| near 1e308), are counted in the PIDs' and the inverse's faults (the C ABI
 * returns HYSTERON_ERROR_INVALID_ARGUMENT there, with the same command). */
double $P_loop_step($P_loop *c, double reference_m, double preview_m, double measured_m, double pressure_mpa,
                    double *duty);
/* The feedforward's reference for a recorded or planned reference (feedforward_preview):
 * preview[k] = {}, indices clamped to [0, n). preview must not overlap reference. The
 * loop needs the reference {} samples ahead. */
void $P_loop_preview(const double *reference, double *preview, size_t n);

#ifdef __cplusplus
}}
#endif
)",
                    num(d.sample_time), d.kind == LoopDesign::Kind::open_loop ? " (unused without gains)" : "",
                    cascade ? "  $P_pid_state pressure; /* the pressure PID (error in MPa -> duty) */\n"
                              "  double desired_pressure; /* p_d, the position loop's output [MPa] */\n"
                              "  double duty;            /* last PWM duty */\n"
                              "  unsigned long pwm_faults; /* non-finite pressure-PID outputs (duty held) */\n"
                            : "",
                    d.kind == LoopDesign::Kind::feedforward_pid ? " (not used by this loop)" : "",
                    cascade ? " (this loop: the desired pressure p_d of the valves' loop)" : "",
                    cascade ? "this loop's actuator command" : "0: this loop has no valves",
                    d.shaper ? "a1 r(k + L + A) + a2 r(k + L + A - D)" : "r(k + L)",
                    d.feedforward_lead + (d.shaper ? d.shaper->advance : 0));

  // ---- definitions
  std::string& df = out.definitions;
  df += "\n/* ---- the loop's constants ---- */\n";
  df += fmt::format("static const double $P_sample_time = {};  /* T_s [s] */\n", num(d.sample_time));
  df += fmt::format("static const double $P_model_scale = {};  /* model output units per m */\n", num(ff.model_scale));
  df += fmt::format("static const double $P_lag_time_constant = {};  /* tau [s] */\n", num(ff.lag_time_constant));
  df += fmt::format("static const double $P_pressure_lo = {}, $P_pressure_hi = {};  /* pressure limits [MPa] */\n",
                    num(ff.pressure_limits.lo), num(ff.pressure_limits.hi));
  df += fmt::format("static const size_t $P_lead = {};  /* the feedforward's lead [samples] */\n", lead);
  const double sign = std::visit([](const auto& c) { return c.feedforward().feedback_sign(); }, ctl);
  df += fmt::format(
      "static const double $P_feedback_sign = {};  /* -1: the model decreases, the position PID acts on y - r */\n",
      num(sign));
  if (d.shaper) {
    df += fmt::format("static const size_t $P_advance = {}, $P_delay = {};  /* shaper [samples] */\n", advance, delay);
    df += fmt::format("static const double $P_a1 = {}, $P_a2 = {};  /* shaper weights */\n", num(d.shaper->a1),
                      num(d.shaper->a2));
  }
  switch (d.kind) {
    case LoopDesign::Kind::feedforward_pid:
      df += fmt::format("static const $P_pid_gains $P_position_gains =\n  {};\n",
                        pid_gains(std::get<FeedforwardPidController>(ctl).pid()));
      break;
    case LoopDesign::Kind::open_loop: {
      const auto& c = std::get<OpenLoopController>(ctl);
      df += fmt::format("static const $P_pid_gains $P_position_gains =\n  {};\n", pid_gains(c.position()));
      df += fmt::format("static const int $P_use_position = {};  /* a position gain is non-zero */\n",
                        c.uses_position() ? 1 : 0);
      df += fmt::format("static const double $P_pressure_gain = {};  /* k_p */\n", num(c.params().pressure_gain));
      break;
    }
    case LoopDesign::Kind::cascade_pwm: {
      const auto& c = std::get<CascadePwmController>(ctl);
      const PwmParams& w = c.params().pwm;
      df += fmt::format("static const $P_pid_gains $P_position_gains =\n  {};\n", pid_gains(c.position()));
      df += fmt::format("static const $P_pid_gains $P_pressure_gains =\n  {};\n", pid_gains(c.pressure()));
      df += fmt::format(
          "static const double $P_pwm_gain = {}, $P_pwm_deadband = {}, $P_pwm_min_duty = {}, $P_pwm_max_duty = {},\n"
          "  $P_pwm_resolution = {};  /* PWM (hysteron::PwmParams) */\n",
          num(w.gain), num(w.deadband), num(w.min_duty), num(w.max_duty), num(w.resolution));
      break;
    }
  }
  df += R"(
static double $P_clamp(double v, double lo, double hi)
{
  return v < lo ? lo : hi < v ? hi : v;  /* std::clamp */
}
)";
  df += kPidStep;
  if (d.kind != LoopDesign::Kind::open_loop) df += kHeldCommand;
  if (cascade)
    df += R"(
/* PWM modulator (hysteron::PwmModulator::step): the duty for a command u. */
static double $P_pwm_step($P_loop *c, double u)
{
  double mag, d = 0.0;
  if (!$P_finite(u)) {
    ++c->pwm_faults;
    return c->duty;
  }
  mag = fabs(u);
  if (mag > $P_pwm_deadband) {
    d = $P_pwm_min_duty + $P_pwm_gain * (mag - $P_pwm_deadband);
    if (!(d < $P_pwm_max_duty)) d = $P_pwm_max_duty;
    if ($P_pwm_resolution > 0.0) {
      d = round(d / $P_pwm_resolution) * $P_pwm_resolution;
      if (!(d < $P_pwm_max_duty)) d = $P_pwm_max_duty;
    }
    if (u < 0.0) d = -d;
  }
  c->duty = d;
  return d;
}
)";
  df += R"(
void $P_loop_reset($P_loop *c)
{
  $P_inverse_reset(&c->inverse);
  c->ff_prev = 0.0;
  c->ff_started = 0;
  $P_pid_reset(&c->position, &$P_position_gains);
  c->ff_held = $P_position_gains.reset_output;  /* no correction yet */
)";
  if (cascade)
    df += "  $P_pid_reset(&c->pressure, &$P_pressure_gains);\n  c->desired_pressure = 0.0;\n  c->duty = 0.0;\n"
          "  c->pwm_faults = 0;\n";
  df += "}\n";
  df += R"(
void $P_loop_restart_guard($P_loop *c)
{
  $P_pid_restart_guard(&c->position);
}
)";
  df += R"(
double $P_loop_step($P_loop *c, double reference_m, double preview_m, double measured_m, double pressure_mpa,
                    double *duty)
{
)";
  switch (d.kind) {
    case LoopDesign::Kind::feedforward_pid:
      df += R"(  const double u_ff = $P_feedforward(c, preview_m);
  const unsigned long faults = c->position.faults;
  const double u = $P_pid_step(&c->position, &$P_position_gains, $P_feedback_sign * reference_m,
                               $P_feedback_sign * measured_m, u_ff);
  (void)pressure_mpa;
  if (duty) *duty = 0.0;
  if (c->position.faults == faults) {
    c->ff_held = u_ff;
    return $P_clamp($P_finite(u) ? u : u_ff, $P_pressure_lo, $P_pressure_hi);
  }
  /* held: the feedforward goes on with the PID's held correction */
  return $P_clamp($P_held_command(u_ff, u, c->ff_held, &$P_position_gains), $P_pressure_lo, $P_pressure_hi);
}
)";
      break;
    case LoopDesign::Kind::open_loop:
      df += R"(  double p_d = $P_feedforward(c, preview_m), cmd;
  if ($P_use_position)
    p_d = $P_clamp(p_d + $P_pid_step(&c->position, &$P_position_gains, $P_feedback_sign * reference_m,
                                     $P_feedback_sign * measured_m, 0.0),
                   $P_pressure_lo, $P_pressure_hi);
  /* the pressure loop (pressure_loop_command): without a finite measurement or a gain, p_d itself
     (0 * an overflowing difference would be NaN) */
  cmd = $P_finite(pressure_mpa) && $P_pressure_gain != 0.0 ? p_d + $P_pressure_gain * (p_d - pressure_mpa) : p_d;
  if (duty) *duty = 0.0;
  return $P_clamp(cmd, $P_pressure_lo, $P_pressure_hi);
}
)";
      break;
    case LoopDesign::Kind::cascade_pwm:
      df += R"(  const double u_ff = $P_feedforward(c, preview_m);
  unsigned long faults;
  double u_x, u, d;
  if (!$P_finite(pressure_mpa)) {
    /* the pressure loop is blind: the position PID held (no wind-up of p_d), p_d the feedforward with its
       held correction; the pressure PID counts the fault; both valves closed, the pressure holds */
    c->desired_pressure = $P_clamp($P_held_command(u_ff, c->position.output, c->ff_held, &$P_position_gains),
                                   $P_pressure_lo, $P_pressure_hi);
    (void)$P_pid_step(&c->pressure, &$P_pressure_gains, c->desired_pressure, pressure_mpa, 0.0);
    d = $P_pwm_step(c, 0.0);
    if (duty) *duty = d;
    return c->desired_pressure;
  }
  faults = c->position.faults;
  u_x = $P_pid_step(&c->position, &$P_position_gains, $P_feedback_sign * reference_m, $P_feedback_sign * measured_m,
                    u_ff);
  if (c->position.faults == faults) {
    c->ff_held = u_ff;
    c->desired_pressure = $P_clamp(u_x, $P_pressure_lo, $P_pressure_hi);
  } else {  /* held: the feedforward goes on with the PID's held correction */
    c->desired_pressure = $P_clamp($P_held_command(u_ff, u_x, c->ff_held, &$P_position_gains), $P_pressure_lo,
                                   $P_pressure_hi);
  }
  u = $P_pid_step(&c->pressure, &$P_pressure_gains, c->desired_pressure, pressure_mpa, 0.0);
  d = $P_clamp($P_pwm_step(c, u), -1.0, 1.0);
  if (duty) *duty = d;
  return c->desired_pressure;
}
)";
      break;
  }
  df += R"(
void $P_loop_preview(const double *reference, double *preview, size_t n)
{
  size_t k;
  for (k = 0; k < n; ++k) {
    const size_t j = $P_clamped_index(k, $P_lead, 0u, n);  /* s(k + lead), held at the end */
)";
  df += d.shaper ? R"(    preview[k] = $P_a1 * reference[$P_clamped_index(j, $P_advance, 0u, n)] +
                 $P_a2 * reference[$P_clamped_index(j, $P_advance, $P_delay, n)];
)"
                 : R"(    preview[k] = reference[j];
)";
  df += "  }\n}\n";
  if (d.learning) append_learning_c(d, out);
  return out;
}

}  // namespace hysteron::io::detail
