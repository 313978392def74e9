#pragma once
// Hysteresis-compensating controllers for the muscle rig, built from an exact
// inverse model (inverse.hpp) and the PID of control.hpp. Units at the
// interface: positions in metres, pressures in MPa gauge; the model maps
// pressure [MPa] to contraction in model units (model_scale per metre, 1000
// for models fitted in mm). Every step() is allocation-free, noexcept and
// deterministic; every pressure command is clamped to the pressure limits, which
// default to the model's input_limits (resolve_pressure_limits).
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "hysteron/control.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/models.hpp"

namespace hysteron {

// Inverse-model feedforward with optional compensation of a first-order lag
// (tau) of the pressure actuator: p_cmd = p + tau dp/dt, dp/dt by a backward
// difference at the sample time (the reference is smooth and known ahead, so
// the dead time is best handled by feeding a previewed reference).
struct FeedforwardParams {
  // [MPa], the command limits and the inverse's saturation limits. An infinite side (unset, the
  // default) is the model's input_limits on that side: a fitted model's training input range
  // (resolve_pressure_limits). Set your actuator's where the model was not fitted up to them.
  Limits pressure_limits;
  double model_scale = 1000.0;       // model output units per metre
  double lag_time_constant = 0.0;    // tau [s] to compensate, >= 0
  double sample_time = 1e-3;         // [s], > 0
  void validate() const;             // throws hysteron::Error
};

// The pressure limits [MPa] a controller on `model` clamps to: `given` (FeedforwardParams::
// pressure_limits), each infinite side replaced by the model's input_limits on that side (raw
// input units: MPa for these controllers). Throws hysteron::Error if a side is NaN, if a side is
// still infinite (the model has no finite input_limits there, e.g. a hand-written model file:
// pressure_limits must be given) or if the result is not lo < hi.
Limits resolve_pressure_limits(const ModelParams& model, const Limits& given);

class InverseFeedforward {
 public:
  // params.pressure_limits resolved on the model (resolve_pressure_limits; throws hysteron::Error).
  InverseFeedforward(const ModelParams& model, const FeedforwardParams& params);
  // Pressure [MPa] that makes the model reach desired_m [m] (within limits).
  double step(double desired_m) noexcept;
  void reset() noexcept;
  bool saturated() const noexcept { return inverse_.saturated(); }
  // The inverse's faults (non-finite desired outputs ignored) since construction or the last reset().
  std::size_t faults() const noexcept { return inverse_.faults(); }
  // The parameters with the resolved pressure limits (never infinite).
  const FeedforwardParams& params() const noexcept { return p_; }
  const Limits& pressure_limits() const noexcept { return p_.pressure_limits; }
  // +1 where the model's output increases with its input, -1 where it decreases (UnitsMap::
  // increasing(): a displacement sensor that reads length instead of contraction, a force read with
  // the other sign). The controllers feed their position PID sign * (r, y): PID gains are magnitudes,
  // and feedback on a decreasing model is negative feedback too.
  double feedback_sign() const noexcept { return sign_; }

 private:
  FeedforwardParams p_;
  Inverse inverse_;
  double sign_ = 1.0;
  double prev_ = 0.0;
  bool started_ = false;
};

// The command of a sample the position PID held (its step counted a fault: a non-finite reference
// or measurement, or an overflow) in a loop whose feedforward enters the PID as its feedforward term
// (FeedforwardPidController, CascadePwmController): this sample's feedforward u_ff plus the PID's
// held correction, its held output minus the feedforward that output held (held_ff), clamped to the
// PID's output limits [lo, hi] — the muscle keeps following the feedforward while the sensor is out,
// as the open loop's does (2026-12-01; before, the whole command was held: 40 mm error after a 1 s
// dropout of a 0.5 Hz sine). Exactly the held output where the feedforward is the one it held (a
// non-finite preview too: the inverse holds), and where the sum is not finite (not for finite
// inputs: both held values lie within [lo, hi]). After a reset held_ff is the PID's reset output
// (no correction yet). The generated C's loop (io::export_loop) computes the same.
inline double held_pid_command(double u_ff, double held_output, double held_ff, double lo, double hi) noexcept {
  const double c = u_ff == held_ff ? held_output : u_ff + (held_output - held_ff);
  return std::clamp(std::isfinite(c) ? c : held_output, lo, hi);
}

// GPI paper Fig. 10: p_cmd = clamp(FF(y_d) + PID(y_d - y)), with the PID's
// anti-windup aware of the total command (the feedforward enters the PID as
// its feedforward term, so the clamp and the integrator agree). On a decreasing model the PID
// acts on y - y_d (InverseFeedforward::feedback_sign), as do the other controllers' position PIDs.
// A sample the PID holds (a non-finite reference or measurement) commands held_pid_command: the
// feedforward of this sample (of its preview: where that is not finite either, the inverse holds
// too and the command is the previous one) plus the PID's held correction.
class FeedforwardPidController {
 public:
  // Throws hysteron::Error if pid.sample_time is not ff.sample_time (one sample time for the loop)
  // or the pressure limits cannot be resolved (resolve_pressure_limits).
  FeedforwardPidController(const ModelParams& model, const FeedforwardParams& ff, const PidParams& pid);
  // reference_m: y_d(t); preview_m: the reference fed to the inverse (y_d(t + lead)
  // for a known reference, else reference_m); measured_m: sensor. Returns MPa.
  double step(double reference_m, double preview_m, double measured_m) noexcept;
  // The same loop around a feedforward computed elsewhere (an inverse that adapts, a learned
  // correction added to it): u_ff [MPa] in place of this controller's inverse, which is not
  // stepped; the feedback sign, the limits and the hold are this controller's.
  double step_feedforward(double reference_m, double u_ff, double measured_m) noexcept;
  void reset() noexcept;
  // The PID as built (its output limits narrowed to the pressure limits).
  const Pid& pid() const noexcept { return pid_; }
  const InverseFeedforward& feedforward() const noexcept { return ff_; }
  // The resolved pressure limits [MPa] the command is clamped to.
  const Limits& pressure_limits() const noexcept { return ff_.pressure_limits(); }
  // Replaces the PID's limit-cycle guard (Pid::set_guard; throws Error). A setup call.
  void set_guard(const PidGuard& guard) { pid_.set_guard(guard); }
  // Restarts the PID's limit-cycle guard (Pid::restart_guard): real-time safe, for the end of the
  // start-up transient.
  void restart_guard() noexcept { pid_.restart_guard(); }

 private:
  InverseFeedforward ff_;
  Pid pid_;
  double ff_held_;  // the feedforward in the PID's last output [MPa] (held_pid_command); reset: its output
};

// Asymmetric-MPI paper (Fig. 6): open-loop inverse compensation with a
// proportional pressure loop, p_cmd = p_d + k_p (p_d - p_meas); optionally
// (hysteron's variant) a slow PI position correction added to p_d.
struct OpenLoopParams {
  FeedforwardParams feedforward;
  double pressure_gain = 0.5;        // k_p [-] of the pressure loop, >= 0
  PidParams position;                // kp = ki = 0: pure open loop (as published)
};

// The proportional pressure loop of OpenLoopController: p_d + k_p (p_d - p_meas) [MPa], or p_d
// where the measured pressure is not finite or k_p = 0 (not clamped). Never NaN for a finite
// p_d: a difference that overflows (p_d = 1e300, p_meas = -DBL_MAX) gives +-inf with k_p > 0,
// which the caller's clamp takes to a limit, and with k_p = 0 no term (0 * inf would be NaN).
// The generated C's loop (io::export_loop) computes the same, operation for operation.
inline double pressure_loop_command(double p_d, double pressure_mpa, double k_p) noexcept {
  return std::isfinite(pressure_mpa) && k_p != 0.0 ? p_d + k_p * (p_d - pressure_mpa) : p_d;
}

class OpenLoopController {
 public:
  // Throws hysteron::Error if the position PID is used (a gain non-zero) at another sample time than
  // feedforward.sample_time, or the pressure limits cannot be resolved (resolve_pressure_limits).
  OpenLoopController(const ModelParams& model, const OpenLoopParams& params);
  double step(double reference_m, double preview_m, double measured_m, double pressure_mpa) noexcept;
  // The same loop around a feedforward computed elsewhere (FeedforwardPidController::
  // step_feedforward): u_ff [MPa] in place of this controller's inverse, which is not stepped.
  double step_feedforward(double reference_m, double u_ff, double measured_m, double pressure_mpa) noexcept;
  void reset() noexcept;
  // The parameters with the resolved pressure limits.
  const OpenLoopParams& params() const noexcept { return p_; }
  const Limits& pressure_limits() const noexcept { return p_.feedforward.pressure_limits; }
  // The position PID as built (output limits narrowed to +-the pressure span) and whether
  // step() uses it (a gain is non-zero).
  const Pid& position() const noexcept { return position_; }
  bool uses_position() const noexcept { return use_position_; }
  const InverseFeedforward& feedforward() const noexcept { return ff_; }
  // Replaces the position PID's limit-cycle guard (Pid::set_guard; throws Error). A setup call.
  void set_guard(const PidGuard& guard) { position_.set_guard(guard); }
  // Restarts the position PID's limit-cycle guard (Pid::restart_guard): real-time safe.
  void restart_guard() noexcept { position_.restart_guard(); }

 private:
  OpenLoopParams p_;
  InverseFeedforward ff_;
  Pid position_;
  bool use_position_;
};

// Dead-zone MPI paper: cascade with fast switching valves. Outer loop: desired
// pressure p_d = clamp(FF(y_d) + PID_x(y_d - y)); inner loop: a PI on the
// pressure error plus a duty feedforward, modulated to a PWM duty in [-1, 1].
// Faults: a non-finite pressure measurement commands duty 0 (both valves closed: the muscle's
// pressure holds; a held duty kept filling it up to the supply) and holds the position PID (no
// wind-up of p_d while the inner loop is blind), p_d = held_pid_command; the pressure PID counts the
// sample (pressure().faults()). A non-finite reference or measurement holds the position PID, p_d =
// held_pid_command (the feedforward goes on), and the inner loop tracks that p_d.
struct CascadeParams {
  FeedforwardParams feedforward;
  PidParams position;        // outer loop, output in MPa
  PidParams pressure;        // inner loop: error in MPa -> duty (limits [-1, 1])
  PwmParams pwm;             // duty shaping (dead band, minimum pulse)
};

class CascadePwmController {
 public:
  // Throws hysteron::Error if position.sample_time or pressure.sample_time is not
  // feedforward.sample_time (one sample time for the loop), or the pressure limits cannot be
  // resolved (resolve_pressure_limits).
  CascadePwmController(const ModelParams& model, const CascadeParams& params);
  // Returns the PWM duty in [-1, 1]; desired_pressure() is the outer loop's output.
  double step(double reference_m, double preview_m, double measured_m, double pressure_mpa) noexcept;
  // The same cascade around a feedforward computed elsewhere (FeedforwardPidController::
  // step_feedforward): u_ff [MPa] in place of this controller's inverse, which is not stepped.
  double step_feedforward(double reference_m, double u_ff, double measured_m, double pressure_mpa) noexcept;
  void reset() noexcept;  // every part, its fault counts and the guard's cuts included
  double desired_pressure() const noexcept { return p_d_; }
  // The parameters with the resolved pressure limits.
  const CascadeParams& params() const noexcept { return p_; }
  const Limits& pressure_limits() const noexcept { return p_.feedforward.pressure_limits; }
  // The PIDs as built: the position PID's output limits narrowed to the pressure limits, the
  // pressure PID's to [-1, 1].
  const Pid& position() const noexcept { return position_; }
  const Pid& pressure() const noexcept { return pressure_; }
  const PwmModulator& pwm() const noexcept { return pwm_; }
  const InverseFeedforward& feedforward() const noexcept { return ff_; }
  // Replaces the position PID's limit-cycle guard (Pid::set_guard; throws Error). A setup call.
  void set_guard(const PidGuard& guard) { position_.set_guard(guard); }
  // Restarts the position PID's limit-cycle guard (Pid::restart_guard): real-time safe.
  void restart_guard() noexcept { position_.restart_guard(); }

 private:
  CascadeParams p_;
  InverseFeedforward ff_;
  Pid position_;
  Pid pressure_;
  PwmModulator pwm_;
  double p_d_ = 0.0;
  double ff_held_;  // the feedforward in the position PID's last output [MPa] (held_pid_command); reset: its output
};

}  // namespace hysteron
