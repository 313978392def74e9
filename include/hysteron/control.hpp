#pragma once
// Feedback building blocks for the rig: a discrete PID (Eq. 17 of
// ../shared/papers/gpi-lm-feedforward-pid.txt) and a PWM modulator for the
// switching valves. Like the models: validated Params, a State, and a step()
// that never allocates, never throws and is deterministic.
#include <cstddef>
#include <limits>
#include <span>
#include <string_view>
#include <vector>

namespace hysteron {

enum class AntiWindup {
  none,                 // plain integration (for comparison only)
  conditional,          // integrate only if not saturated or the error drives out of saturation
  back_calculation,     // dI/dt += (u_sat - u) / T_t
};

// "none", "conditional", "back_calculation" (the Python binding's and result.json's names).
std::string_view anti_windup_name(AntiWindup a) noexcept;
// Throws hysteron::Error on an unknown name.
AntiWindup anti_windup_from_name(std::string_view name);

// Limit-cycle guard (docs/control.md, section 2, "The limit-cycle guard"): a loop that rings
// near its ultimate period T_u, e.g. on a rig that changed after its tuning, gets its gains cut.
// The error e = r - y is split into half-cycles at its sign changes, with a hysteresis of
// amplitude / 4 (noise around zero ends none). A half-cycle that lasts at most T_u and whose
// integral of |e| dt exceeds amplitude T_u / pi (a half-sine of that amplitude at period T_u)
// adds to a count that decays with time constant memory T_u: 1, or where the ring grows (three
// half-cycles in a row counted, this one's integral at least that of the one of its sign before)
// its severity, that integral over the limit (at most `count`; the severity itself at most 2^1023, so it is
// finite for every finite integral, also over a limit near DBL_MIN): a growing ring several times the
// amplitude is cut within a period instead of after 2.5, before it reaches the limits, and a
// step's decaying transient counts 1 per half-cycle as before (2026-11-30); when the count reaches `count`,
// K_p, K_i and K_d are multiplied by `factor` (not below min_scale times the tuned gains) and
// the count restarts. The cut gains stay until reset(). period = 0: off (the default).
struct PidGuard {
  double period = 0.0;     // T_u [s]: 0 (off) or >= 4 sample times
  double amplitude = 0.0;  // a [error units], > 0 where period > 0 (a T_u / pi finite and normal: >= DBL_MIN)
  double count = 5.0;      // half-cycles (decayed) that cut the gains, > 0 (2 count finite)
  double memory = 5.0;     // the count's decay time constant [T_u], > 0
  double factor = 0.63;    // in (0, 1)
  double min_scale = 0.25; // in (0, 1]
  bool enabled() const noexcept { return period > 0.0; }
};

// Eq. 17:  u = K_p e + K_i int e dt + K_d de/dt, discretised at sample time T_s:
//   P_k = K_p (b r_k - y_k)                                      setpoint weight b
//   D_k = T_f / (T_f + T_s) D_{k-1} + K_d / (T_f + T_s) (d_k - d_{k-1}),
//         d_k = c r_k - y_k  (backward Euler of K_d s / (T_f s + 1);  c = 0: on measurement)
//   v_k = P_k + I_k + D_k + u_ff,   u_k = clamp(v_k, u_min, u_max)
//   I_{k+1} = I_k + K_i T_s e_k  (+ T_s / T_t (u_k - v_k) with back-calculation)
// Units are the user's: Table 3 of the paper (K_p = 0.05, K_i = 0.01, K_d = 0) maps
// the error in mm to volts of the 0-10 V / 0-10 bar regulator (1 V = 0.1 MPa),
// i.e. K_p = 5 MPa/m, K_i = 1 MPa/(m s) with the error in m and u in MPa
// (gpi_paper_pid()).
struct PidParams {
  double kp = 0.0;                 // K_p
  double ki = 0.0;                 // K_i [1/s]
  double kd = 0.0;                 // K_d [s]
  double sample_time = 1e-3;       // T_s [s], > 0
  double derivative_filter = 0.0;  // T_f [s], >= 0 (0: unfiltered backward difference)
  double out_min = -std::numeric_limits<double>::infinity();
  double out_max = std::numeric_limits<double>::infinity();
  AntiWindup anti_windup = AntiWindup::conditional;
  double tracking_time = 0.0;      // T_t [s] for back-calculation; 0 selects sqrt(T_i T_d) or T_i
  double setpoint_weight_p = 1.0;  // b
  double setpoint_weight_d = 0.0;  // c (0: derivative on measurement, no setpoint kick)
  PidGuard guard = {};             // limit-cycle guard (off by default)
};

// Table 3 of the GPI paper in SI/MPa units (see above), output limited to
// [out_min, out_max] MPa.
PidParams gpi_paper_pid(double sample_time, double out_min = -0.6, double out_max = 0.6);

struct PidState {
  double integral = 0.0;     // I_k
  double derivative = 0.0;   // D_k
  double prev_d_error = 0.0; // d_{k-1}
  double output = 0.0;       // u_{k-1} (held on a fault)
  bool initialized = false;  // false until the first finite sample (no derivative kick)
  bool saturated = false;    // the last output was clamped
  // The limit-cycle guard (PidParams::guard): the factor on K_p, K_i, K_d in use, the times it
  // cut them, the sign (-1, 0, 1) of the current half-cycle of e, its integral of |e| dt and
  // length [samples], the decaying count of half-cycles that looked like a limit cycle, and the
  // severities of the last two half-cycles (0 where one did not look like one).
  double gain_scale = 1.0;
  std::size_t guard_cuts = 0;
  int guard_sign = 0;
  double guard_iae = 0.0;
  std::size_t guard_samples = 0;
  double guard_count = 0.0;
  double guard_last = 0.0, guard_last2 = 0.0;
};

class Pid {
 public:
  // Throws hysteron::Error naming the field ("pid.sample_time = 0: must be > 0"),
  // also for gains whose discrete coefficients overflow (kd / (T_f + T_s)).
  explicit Pid(const PidParams& params);

  // Zero state; optionally start bumplessly at output u0 (integral = clamp(u0)). The gains are
  // the tuned ones again (the guard's scale 1, no cuts) and faults() is 0 (as the generated C's pid_reset).
  void reset(double u0 = 0.0) noexcept;
  // Replaces the limit-cycle guard (params().guard) and restarts it: the gains as tuned, no
  // half-cycles counted. Throws hysteron::Error naming the field ("pid.guard.factor = 1: ...").
  // Not for the real-time loop's step: a setup call.
  void set_guard(const PidGuard& guard);
  // Restarts the limit-cycle guard without changing it: the gains as tuned (gain_scale 1, guard_cuts 0), no
  // half-cycles counted; the rest of the state (integral, output, faults) goes on. Real-time safe (noexcept,
  // no allocation): call it once a start-up transient (the muscle filling from rest) has passed, which the
  // guard may take for a ring and cut the gains on for good.
  void restart_guard() noexcept;
  // One sample. A non-finite setpoint, measurement or feedforward, or a
  // non-finite intermediate (an overflow of large gains on a large error, or of
  // extreme finite inputs: the error r - y of r = 1e308, y = -1e308, the weighted
  // errors, the integral's increment, the derivative, the limit-cycle guard's
  // integral of |e| dt, its count), holds the last output, leaves
  // the state unchanged and is counted in faults(): the output is always finite and
  // inside [out_min, out_max], the state always finite (restore(snapshot()) takes it).
  double step(double setpoint, double measurement, double feedforward = 0.0) noexcept;

  const PidParams& params() const noexcept { return p_; }
  const PidState& state() const noexcept { return s_; }
  // The discrete coefficients step() uses (derived from params() in the constructor):
  // a_d = T_f / (T_f + T_s), b_d = K_d / (T_f + T_s), k_t = min(1, T_s / T_t) (0 without
  // back-calculation); the limit-cycle guard's per-sample decay of its count,
  // exp(-T_s / (memory T_u)), and its half-cycles' limit a T_u / pi (both 0 without the guard).
  // hysteron export bakes them into generated C.
  struct Coefficients {
    double a_d, b_d, k_t, guard_decay, guard_iae_limit;
  };
  Coefficients coefficients() const noexcept { return {a_d_, b_d_, k_t_, guard_decay_, guard_iae_limit_}; }
  double output() const noexcept { return s_.output; }
  // Samples held since construction or the last reset().
  std::size_t faults() const noexcept { return faults_; }

  // Everything step() changes, as numbers: the PidState fields in their order (the flags 0/1)
  // and faults(). restore(snapshot()) on a Pid of the same parameters steps exactly as this one
  // from here on (a running PID saved and loaded again, e.g. Python's pickle). restore throws
  // hysteron::Error, the PID unchanged, on a snapshot of another size or a value out of range.
  std::vector<double> snapshot() const;
  void restore(std::span<const double> snapshot);

 private:
  PidParams p_;
  PidState s_;
  double a_d_ = 0.0, b_d_ = 0.0;  // derivative filter coefficients
  double k_t_ = 0.0;              // T_s / T_t
  double guard_decay_ = 0.0;      // exp(-T_s / (memory T_u))
  double guard_iae_limit_ = 0.0;  // a T_u / pi
  std::size_t faults_ = 0;
  // The guard's update of the candidate state s for the error e; false where one of its quantities overflows
  // (s is then to be discarded).
  bool guard_step(PidState& s, double e) const noexcept;
};

// Turns a continuous command u (e.g. a PID output) into the PWM duty of the
// valve pair of PamRig (> 0 inlet, < 0 exhaust):
//   d = 0                                 if |u| <= deadband
//   d = sgn(u) min(max_duty, min_duty + gain (|u| - deadband))  otherwise,
// then rounded to the timer resolution. min_duty compensates the valves'
// opening delay; the deadband avoids chattering around zero.
struct PwmParams {
  double gain = 1.0;        // duty per unit of u, > 0
  double deadband = 0.0;    // >= 0, in units of u
  double min_duty = 0.0;    // [0, max_duty]
  double max_duty = 1.0;    // (0, 1]
  double resolution = 0.0;  // duty quantum, 0 = continuous, else in (0, 1]
};

class PwmModulator {
 public:
  explicit PwmModulator(const PwmParams& params);  // throws hysteron::Error
  // Duty in [-max_duty, max_duty]; a non-finite u holds the last duty (counted in faults()).
  double step(double u) noexcept;
  // Duty 0 and faults() 0 (as the generated C's loop_reset: pwm_faults = 0).
  void reset() noexcept;
  const PwmParams& params() const noexcept { return p_; }
  double duty() const noexcept { return duty_; }
  std::size_t faults() const noexcept { return faults_; }

 private:
  PwmParams p_;
  double duty_ = 0.0;
  std::size_t faults_ = 0;
};

}  // namespace hysteron
