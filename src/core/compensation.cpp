#include "hysteron/compensation.hpp"

#include "format.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hysteron/error.hpp"

namespace hysteron {

namespace {
// The given pressure limits: numbers, an infinite side only the unset one (-inf below, +inf above),
// lo < hi where both are finite.
void check_given_limits(const Limits& l) {
  const double inf = std::numeric_limits<double>::infinity();
  if (std::isnan(l.lo) || std::isnan(l.hi) || l.lo == inf || l.hi == -inf ||
      (std::isfinite(l.lo) && std::isfinite(l.hi) && !(l.lo < l.hi)))
    throw Error(detail::format("feedforward: pressure_limits must be numbers with lo < hi (an infinite side, -inf "
                               "below or +inf above: the model's input_limits), got [{}, {}]",
                               l.lo, l.hi));
}
}  // namespace

void FeedforwardParams::validate() const {
  check_given_limits(pressure_limits);
  if (!(model_scale > 0) || !std::isfinite(model_scale))
    throw Error(detail::format("feedforward: model_scale must be > 0, got {}", model_scale));
  if (!(lag_time_constant >= 0) || !std::isfinite(lag_time_constant))
    throw Error(detail::format("feedforward: lag_time_constant must be >= 0, got {}", lag_time_constant));
  if (!(sample_time > 0) || !std::isfinite(sample_time))
    throw Error(detail::format("feedforward: sample_time must be > 0, got {}", sample_time));
}

Limits resolve_pressure_limits(const ModelParams& model, const Limits& given) {
  check_given_limits(given);
  const Limits& ml = input_limits(model);
  const Limits r{std::isinf(given.lo) ? ml.lo : given.lo, std::isinf(given.hi) ? ml.hi : given.hi};
  if (!std::isfinite(r.lo) || !std::isfinite(r.hi))
    throw Error(detail::format("feedforward: pressure_limits must be given (your actuator's [lo, hi] in MPa): the "
                               "model ({}) has no finite input_limits to take them from (its input_limits [{}, {}]; "
                               "a fitted model has its training input range)",
                               model_name(model), ml.lo, ml.hi));
  if (!(r.lo < r.hi))
    throw Error(detail::format("feedforward: pressure_limits [{}, {}] (given [{}, {}], an infinite side the model's "
                               "input_limits [{}, {}]) must satisfy lo < hi",
                               r.lo, r.hi, given.lo, given.hi, ml.lo, ml.hi));
  return r;
}

namespace {
// p validated, its pressure limits resolved on the model.
FeedforwardParams resolved(const ModelParams& model, FeedforwardParams p) {
  p.validate();
  p.pressure_limits = resolve_pressure_limits(model, p.pressure_limits);
  return p;
}
InverseOptions inverse_options(const FeedforwardParams& p) {
  InverseOptions o;
  o.input_limits = p.pressure_limits;
  return o;
}
// A loop runs at one sample time: a PID at another would integrate and differentiate with the wrong
// T_s without a word (a Pid left at its default 1e-3 s in a 10 ms loop: its integral 10 times too weak).
void check_sample_time(const PidParams& pid, const FeedforwardParams& ff, const char* where, const char* which) {
  if (std::abs(pid.sample_time - ff.sample_time) <= 1e-9 * std::abs(ff.sample_time)) return;
  throw Error(detail::format("{}: {}.sample_time = {} s differs from the loop's sample_time = {} s (one sample time "
                             "for the loop: set the PID's to {} s)",
                             where, which, pid.sample_time, ff.sample_time, ff.sample_time));
}
}  // namespace

InverseFeedforward::InverseFeedforward(const ModelParams& model, const FeedforwardParams& params)
    : p_(resolved(model, params)),
      inverse_(model, inverse_options(p_)),
      sign_(units_map(model).increasing() ? 1.0 : -1.0) {}

void InverseFeedforward::reset() noexcept {
  inverse_.reset();
  started_ = false;
  prev_ = 0.0;
}

double InverseFeedforward::step(double desired_m) noexcept {
  const double p = inverse_.step(desired_m * p_.model_scale);
  double cmd = p;
  if (started_ && p_.lag_time_constant > 0) cmd = p + p_.lag_time_constant * (p - prev_) / p_.sample_time;
  prev_ = p;
  started_ = true;
  return std::clamp(cmd, p_.pressure_limits.lo, p_.pressure_limits.hi);
}

FeedforwardPidController::FeedforwardPidController(const ModelParams& model, const FeedforwardParams& ff,
                                                   const PidParams& pid)
    : ff_(model, ff), pid_([&] {
        PidParams q = pid;
        q.out_min = std::max(q.out_min, ff_.pressure_limits().lo);
        q.out_max = std::min(q.out_max, ff_.pressure_limits().hi);
        return q;
      }()),
      ff_held_(pid_.output()) {
  check_sample_time(pid, ff, "feedforward-PID controller", "pid");
}

void FeedforwardPidController::reset() noexcept {
  ff_.reset();
  pid_.reset();
  ff_held_ = pid_.output();  // no correction yet
}

double FeedforwardPidController::step(double reference_m, double preview_m, double measured_m) noexcept {
  return step_feedforward(reference_m, ff_.step(preview_m), measured_m);
}

double FeedforwardPidController::step_feedforward(double reference_m, double u_ff, double measured_m) noexcept {
  const double s = ff_.feedback_sign();
  const std::size_t faults = pid_.faults();
  const double u = pid_.step(s * reference_m, s * measured_m, u_ff);
  const Limits& lim = ff_.pressure_limits();
  if (pid_.faults() == faults) {
    ff_held_ = u_ff;
    return std::clamp(std::isfinite(u) ? u : u_ff, lim.lo, lim.hi);
  }
  // held: the feedforward goes on with the PID's held correction
  const PidParams& q = pid_.params();
  return std::clamp(held_pid_command(u_ff, u, ff_held_, q.out_min, q.out_max), lim.lo, lim.hi);
}

OpenLoopController::OpenLoopController(const ModelParams& model, const OpenLoopParams& params)
    : p_(params), ff_(model, params.feedforward), position_([&] {
        PidParams q = params.position;
        const double span = ff_.pressure_limits().hi - ff_.pressure_limits().lo;
        q.out_min = std::max(q.out_min, -span);
        q.out_max = std::min(q.out_max, span);
        return q;
      }()),
      use_position_(params.position.kp != 0.0 || params.position.ki != 0.0 || params.position.kd != 0.0) {
  p_.feedforward = ff_.params();  // the resolved pressure limits
  if (!(params.pressure_gain >= 0) || !std::isfinite(params.pressure_gain))
    throw Error(detail::format("open-loop controller: pressure_gain must be >= 0, got {}", params.pressure_gain));
  if (use_position_) check_sample_time(params.position, params.feedforward, "open-loop controller", "position");
}

void OpenLoopController::reset() noexcept {
  ff_.reset();
  position_.reset();
}

double OpenLoopController::step(double reference_m, double preview_m, double measured_m,
                                double pressure_mpa) noexcept {
  return step_feedforward(reference_m, ff_.step(preview_m), measured_m, pressure_mpa);
}

double OpenLoopController::step_feedforward(double reference_m, double u_ff, double measured_m,
                                            double pressure_mpa) noexcept {
  const Limits& lim = p_.feedforward.pressure_limits;
  double p_d = u_ff;
  const double s = ff_.feedback_sign();
  if (use_position_) p_d = std::clamp(p_d + position_.step(s * reference_m, s * measured_m), lim.lo, lim.hi);
  return std::clamp(pressure_loop_command(p_d, pressure_mpa, p_.pressure_gain), lim.lo, lim.hi);
}

CascadePwmController::CascadePwmController(const ModelParams& model, const CascadeParams& params)
    : p_(params), ff_(model, params.feedforward), position_([&] {
        PidParams q = params.position;
        q.out_min = std::max(q.out_min, ff_.pressure_limits().lo);
        q.out_max = std::min(q.out_max, ff_.pressure_limits().hi);
        return q;
      }()),
      pressure_([&] {
        PidParams q = params.pressure;
        q.out_min = std::max(q.out_min, -1.0);
        q.out_max = std::min(q.out_max, 1.0);
        return q;
      }()),
      pwm_(params.pwm),
      ff_held_(position_.output()) {
  p_.feedforward = ff_.params();  // the resolved pressure limits
  check_sample_time(params.position, params.feedforward, "cascade PWM controller", "position");
  check_sample_time(params.pressure, params.feedforward, "cascade PWM controller", "pressure");
}

void CascadePwmController::reset() noexcept {
  ff_.reset();
  position_.reset();
  pressure_.reset();
  pwm_.reset();
  p_d_ = 0.0;
  ff_held_ = position_.output();  // no correction yet
}

double CascadePwmController::step(double reference_m, double preview_m, double measured_m,
                                  double pressure_mpa) noexcept {
  return step_feedforward(reference_m, ff_.step(preview_m), measured_m, pressure_mpa);
}

double CascadePwmController::step_feedforward(double reference_m, double u_ff, double measured_m,
                                              double pressure_mpa) noexcept {
  const Limits& lim = p_.feedforward.pressure_limits;
  const double s = ff_.feedback_sign();
  const PidParams& q = position_.params();
  if (!std::isfinite(pressure_mpa)) {
    // the inner loop is blind: the position PID held (its integral would wind p_d up), p_d the feedforward
    // with its held correction; the pressure PID counts the fault; both valves closed, the pressure holds
    p_d_ = std::clamp(held_pid_command(u_ff, position_.output(), ff_held_, q.out_min, q.out_max), lim.lo, lim.hi);
    pressure_.step(p_d_, pressure_mpa);
    return pwm_.step(0.0);
  }
  const std::size_t faults = position_.faults();
  const double u_x = position_.step(s * reference_m, s * measured_m, u_ff);
  if (position_.faults() == faults) {
    ff_held_ = u_ff;
    p_d_ = std::clamp(u_x, lim.lo, lim.hi);
  } else {  // held: the feedforward goes on with the PID's held correction
    p_d_ = std::clamp(held_pid_command(u_ff, u_x, ff_held_, q.out_min, q.out_max), lim.lo, lim.hi);
  }
  const double u = pressure_.step(p_d_, pressure_mpa);
  return std::clamp(pwm_.step(u), -1.0, 1.0);
}

}  // namespace hysteron
