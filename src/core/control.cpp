// PID and PWM modulator (control.hpp).
#include "hysteron/control.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "format.hpp"
#include "flush.hpp"
#include "validate.hpp"

#include "hysteron/error.hpp"

namespace hysteron {
namespace {
// The largest severity of a half-cycle of the limit-cycle guard (its integral of |e| dt over a T_u / pi): 2^1023.
constexpr double kGuardSeverityMax = 0x1p1023;

[[noreturn]] void bad(const char* key, double v, const char* expected) {
  throw Error(detail::format("{} = {}: must be {}", key, v, expected));
}
}  // namespace

std::string_view anti_windup_name(AntiWindup a) noexcept {
  switch (a) {
    case AntiWindup::none: return "none";
    case AntiWindup::conditional: return "conditional";
    case AntiWindup::back_calculation: return "back_calculation";
  }
  return "conditional";
}

AntiWindup anti_windup_from_name(std::string_view name) {
  for (AntiWindup a : {AntiWindup::none, AntiWindup::conditional, AntiWindup::back_calculation})
    if (name == anti_windup_name(a)) return a;
  throw Error(detail::format("anti_windup must be 'none', 'conditional' or 'back_calculation', got '{}'", name));
}

PidParams gpi_paper_pid(double sample_time, double out_min, double out_max) {
  PidParams p;
  // Table 3: K_p = 0.05 V/mm, K_i = 0.01 V/(mm s); 1 V = 0.1 MPa, 1 mm = 1e-3 m.
  p.kp = 0.05 * 0.1 / 1e-3;
  p.ki = 0.01 * 0.1 / 1e-3;
  p.kd = 0.0;
  p.sample_time = sample_time;
  p.out_min = out_min;
  p.out_max = out_max;
  return p;
}

Pid::Pid(const PidParams& p) : p_(p) {
  auto finite_nonneg = [](const char* key, double v) {
    if (!std::isfinite(v) || v < 0.0) bad(key, v, "a finite number >= 0");
  };
  finite_nonneg("pid.kp", p.kp);
  finite_nonneg("pid.ki", p.ki);
  finite_nonneg("pid.kd", p.kd);
  if (!std::isfinite(p.sample_time) || p.sample_time <= 0.0) bad("pid.sample_time", p.sample_time, "> 0");
  finite_nonneg("pid.derivative_filter", p.derivative_filter);
  finite_nonneg("pid.tracking_time", p.tracking_time);
  if (std::isnan(p.out_min) || std::isnan(p.out_max) || !(p.out_min < p.out_max))
    throw Error(detail::format("pid.out_min = {}, pid.out_max = {}: need out_min < out_max", p.out_min, p.out_max));
  if (!std::isfinite(p.setpoint_weight_p)) bad("pid.setpoint_weight_p", p.setpoint_weight_p, "finite");
  if (!std::isfinite(p.setpoint_weight_d)) bad("pid.setpoint_weight_d", p.setpoint_weight_d, "finite");
  if (p.anti_windup == AntiWindup::back_calculation && p.ki <= 0.0)
    bad("pid.ki", p.ki, "> 0 for back-calculation anti-windup");
  const double ts = p.sample_time;
  a_d_ = p.derivative_filter / (p.derivative_filter + ts);
  b_d_ = p.kd / (p.derivative_filter + ts);
  if (p.anti_windup == AntiWindup::back_calculation) {
    double tt = p.tracking_time;
    if (tt == 0.0) {  // Astrom & Hagglund: T_t = sqrt(T_i T_d), or T_i without D
      const double ti = p.kp > 0.0 ? p.kp / p.ki : 1.0 / p.ki;
      const double td = p.kp > 0.0 ? p.kd / p.kp : 0.0;
      tt = td > 0.0 ? std::sqrt(ti * td) : ti;
    }
    k_t_ = std::min(1.0, ts / tt);
  }
  // Gains that overflow once combined (kd = 1e308 with a small T_s) are refused
  // here rather than producing inf * 0 = NaN in step().
  if (!std::isfinite(b_d_)) bad("pid.kd", p.kd, "such that kd / (derivative_filter + sample_time) is finite");
  if (!std::isfinite(p.ki * ts)) bad("pid.ki", p.ki, "such that ki * sample_time is finite");
  if (!std::isfinite(k_t_)) bad("pid.tracking_time", p.tracking_time, "a time giving a finite tracking gain");
  set_guard(p.guard);
  reset();
}

void Pid::set_guard(const PidGuard& g) {
  if (!std::isfinite(g.period) || g.period < 0.0) bad("pid.guard.period", g.period, "a finite number >= 0");
  double decay = 0.0, limit = 0.0;
  if (g.enabled()) {
    // a half-cycle of at most T_u / 2 must span samples, or no ring is ever counted
    if (g.period < 4.0 * p_.sample_time)
      bad("pid.guard.period", g.period, detail::format("0 (off) or at least 4 sample times ({} s): a ring of a shorter "
                                                       "period cannot be seen at this sample time", 4.0 * p_.sample_time).c_str());
    if (!std::isfinite(g.amplitude) || g.amplitude <= 0.0) bad("pid.guard.amplitude", g.amplitude, "finite and > 0");
    if (!std::isfinite(g.count) || g.count <= 0.0) bad("pid.guard.count", g.count, "finite and > 0");
    // the count reaches at most count + max(1, count) before it is compared: no overflow in step()
    if (!std::isfinite(2.0 * g.count)) bad("pid.guard.count", g.count, "such that 2 count is finite");
    if (!std::isfinite(g.memory) || g.memory <= 0.0) bad("pid.guard.memory", g.memory, "finite and > 0");
    if (!(g.factor > 0.0 && g.factor < 1.0)) bad("pid.guard.factor", g.factor, "in (0, 1)");
    if (!(g.min_scale > 0.0 && g.min_scale <= 1.0)) bad("pid.guard.min_scale", g.min_scale, "in (0, 1]");
    decay = std::exp(-p_.sample_time / (g.memory * g.period));
    limit = g.amplitude * g.period / std::numbers::pi;
    // step() compares the integral of |e| dt with it and divides by it (0: every half-cycle counts; inf: none
    // ever does; subnormal: fewer than 53 significant bits, a T_u / pi not what was asked for)
    if (!std::isfinite(limit) || !(limit >= std::numeric_limits<double>::min()))
      bad("pid.guard.amplitude", g.amplitude,
          detail::format("such that amplitude * period / pi (period {} s) is finite and at least {} (not subnormal)",
                         g.period, std::numeric_limits<double>::min())
              .c_str());
  }
  p_.guard = g;
  guard_decay_ = decay;
  guard_iae_limit_ = limit;
  restart_guard();
}

void Pid::restart_guard() noexcept {
  // the guard restarts; the rest of the state goes on
  s_.gain_scale = 1.0;
  s_.guard_cuts = 0;
  s_.guard_sign = 0;
  s_.guard_iae = 0.0;
  s_.guard_samples = 0;
  s_.guard_count = 0.0;
  s_.guard_last = s_.guard_last2 = 0.0;
}

void Pid::reset(double u0) noexcept {
  s_ = PidState{};
  faults_ = 0;  // a fresh start: counts restart (as Model, Inverse, IterativeLearning and the generated C's pid_reset)
  if (std::isfinite(u0)) {
    u0 = std::clamp(u0, p_.out_min, p_.out_max);
    s_.integral = p_.ki > 0.0 ? u0 : 0.0;
    s_.output = u0;
  }
}

std::vector<double> Pid::snapshot() const {
  const PidState& s = s_;
  return {s.integral, s.derivative, s.prev_d_error, s.output, s.initialized ? 1.0 : 0.0, s.saturated ? 1.0 : 0.0,
          s.gain_scale, static_cast<double>(s.guard_cuts), static_cast<double>(s.guard_sign), s.guard_iae,
          static_cast<double>(s.guard_samples), s.guard_count, s.guard_last, s.guard_last2,
          static_cast<double>(faults_)};
}

void Pid::restore(std::span<const double> v) {
  const std::string_view what = "pid: snapshot";
  detail::check_snapshot_size(v, 15, what);
  for (double x : v) detail::snapshot_finite(x, what);
  PidState s;
  s.integral = v[0];
  s.derivative = v[1];
  s.prev_d_error = v[2];
  s.output = v[3];
  if (!(s.output >= p_.out_min && s.output <= p_.out_max))
    throw Error(detail::format("{}: output {} is outside [out_min, out_max] = [{}, {}]", what, s.output, p_.out_min,
                               p_.out_max));
  s.initialized = detail::snapshot_count(v[4], "pid: snapshot initialized", 1.0) == 1;
  s.saturated = detail::snapshot_count(v[5], "pid: snapshot saturated", 1.0) == 1;
  s.gain_scale = v[6];
  // the guard's scale lies within [min_scale, 1] (1 without the guard: nothing else ever sets it), its integrals
  // and severities are >= 0 and its count below the count that cuts (a scale of 1e-300 left the loop open for good)
  const double min_scale = p_.guard.enabled() ? p_.guard.min_scale : 1.0;
  if (!(s.gain_scale >= min_scale && s.gain_scale <= 1))
    throw Error(detail::format("{}: gain_scale {} must be in [{}, 1] (the guard's min_scale)", what, s.gain_scale,
                               min_scale));
  s.guard_cuts = detail::snapshot_count(v[7], "pid: snapshot guard_cuts");
  s.guard_sign = static_cast<int>(detail::snapshot_count(v[8] + 1.0, "pid: snapshot guard_sign + 1", 2.0)) - 1;
  s.guard_iae = v[9];
  s.guard_samples = detail::snapshot_count(v[10], "pid: snapshot guard_samples");
  s.guard_count = v[11];
  s.guard_last = v[12];
  s.guard_last2 = v[13];
  if (!(s.guard_iae >= 0 && s.guard_last >= 0 && s.guard_last2 >= 0 && s.guard_count >= 0 &&
        (!p_.guard.enabled() || s.guard_count < p_.guard.count)))
    throw Error(detail::format("{}: the guard's integral {}, severities {} and {} must be >= 0 and its count {} within "
                               "[0, {})",
                               what, s.guard_iae, s.guard_last, s.guard_last2, s.guard_count, p_.guard.count));
  faults_ = detail::snapshot_count(v[14], "pid: snapshot faults");
  s_ = s;
}

double Pid::step(double r, double y, double ff) noexcept {
  if (!std::isfinite(r) || !std::isfinite(y) || !std::isfinite(ff)) {
    ++faults_;
    return s_.output;
  }
  const double e = r - y;
  const double scale = s_.gain_scale;  // 1 unless the limit-cycle guard cut the gains
  const double prop = scale * p_.kp * (p_.setpoint_weight_p * r - y);
  const double d_err = p_.setpoint_weight_d * r - y;
  const double prev_d_error = s_.initialized ? s_.prev_d_error : d_err;  // no derivative kick
  // Candidate state; committed only if every intermediate is finite (large but
  // valid gains can still overflow on a large error, and e = r - y on extreme finite
  // inputs, r = 1e308, y = -1e308): otherwise the last output is held, the state is
  // left unchanged and the sample is counted as a fault. A non-finite b r - y makes
  // prop and so v non-finite, a non-finite c r - y or d_err - prev_d_error the
  // derivative (inf, or NaN with K_d = 0); e and di are checked themselves, as the
  // conditional rule may not add di and the guard takes e.
  const double derivative = a_d_ * s_.derivative + scale * b_d_ * (d_err - prev_d_error);
  const double v = prop + s_.integral + derivative + ff;
  const double u = std::clamp(v, p_.out_min, p_.out_max);
  const double di = scale * p_.ki * p_.sample_time * e;
  double integral = s_.integral;
  switch (p_.anti_windup) {
    case AntiWindup::none: integral += di; break;
    case AntiWindup::conditional:
      // Integrate unless saturated and the error pushes further into saturation.
      if (!((v > p_.out_max && di > 0.0) || (v < p_.out_min && di < 0.0))) integral += di;
      break;
    case AntiWindup::back_calculation: integral += di + k_t_ * (u - v); break;
  }
  if (!std::isfinite(e) || !std::isfinite(d_err) || !std::isfinite(di) || !std::isfinite(v) ||
      !std::isfinite(derivative) || !std::isfinite(integral)) {
    ++faults_;
    return s_.output;
  }
  PidState s = s_;
  s.initialized = true;
  s.derivative = detail::flush_subnormal(derivative);  // no subnormal state at rest (flush.hpp)
  s.prev_d_error = d_err;
  s.integral = integral;
  s.saturated = u != v;
  s.output = u;
  if (p_.guard.enabled() && !guard_step(s, e)) {
    ++faults_;
    return s_.output;
  }
  s_ = s;
  return u;
}

bool Pid::guard_step(PidState& s, double e) const noexcept {
  const PidGuard& g = p_.guard;
  s.guard_iae += std::abs(e) * p_.sample_time;
  // only an integral that overflows (errors near 1e308 for long) is held; the severity below is finite for any
  // finite integral
  if (!std::isfinite(s.guard_iae)) return false;
  // its length, counted until it is longer than T_u (which it then stays: no wrap-around)
  if (static_cast<double>(s.guard_samples) * p_.sample_time <= g.period) ++s.guard_samples;
  const double h = 0.25 * g.amplitude;
  const int sign = e > h ? 1 : (e < -h ? -1 : 0);
  if (sign != 0 && sign != s.guard_sign) {  // a half-cycle ended
    const double length = static_cast<double>(s.guard_samples) * p_.sample_time;
    // the severity, the integral over the limit, at most 2^1023: the quotient overflowed where a limit near
    // DBL_MIN (a = 1e-307) met an integral above about 4, and that sample and every later one were held. The
    // test compares the integral with 2^1023 limit (exact: a power of 2 times a normal double; inf where
    // the limit is >= 2, when the quotient is below 2^1023 anyway), so a quotient up to 2^1023 is as before.
    const double severity = s.guard_sign != 0 && length <= g.period && s.guard_iae > guard_iae_limit_
                                ? (s.guard_iae > kGuardSeverityMax * guard_iae_limit_ ? kGuardSeverityMax
                                                                                       : s.guard_iae / guard_iae_limit_)
                                : 0.0;
    // a ring that grows (three half-cycles in a row counted, this one at least the one of its sign
    // before) adds its severity; any other counted half-cycle 1 (a step's decaying transient)
    const bool growing = s.guard_last > 0.0 && s.guard_last2 > 0.0 && severity >= s.guard_last2;
    // at least 1, as any counted half-cycle (not std::clamp: count may be below 1)
    if (severity > 0.0) s.guard_count += growing ? std::max(1.0, std::min(severity, g.count)) : 1.0;
    s.guard_last2 = s.guard_last;
    s.guard_last = severity;
    s.guard_sign = sign;
    s.guard_iae = 0.0;
    s.guard_samples = 0;
  }
  s.guard_count = detail::flush_subnormal(s.guard_count * guard_decay_);  // a count < 2.2e-308 is 0 (flush.hpp)
  if (!std::isfinite(s.guard_count)) return false;  // not with a validated count (below 2 count); kept as a check
  if (s.guard_count >= g.count) {
    s.guard_count = 0.0;
    const double next = std::max(g.min_scale, s.gain_scale * g.factor);
    if (next < s.gain_scale) {
      s.gain_scale = next;
      ++s.guard_cuts;
    }
  }
  return true;
}

PwmModulator::PwmModulator(const PwmParams& p) : p_(p) {
  if (!std::isfinite(p.gain) || p.gain <= 0.0) bad("pwm.gain", p.gain, "> 0");
  if (!std::isfinite(p.deadband) || p.deadband < 0.0) bad("pwm.deadband", p.deadband, ">= 0");
  if (!std::isfinite(p.max_duty) || p.max_duty <= 0.0 || p.max_duty > 1.0) bad("pwm.max_duty", p.max_duty, "in (0, 1]");
  if (!std::isfinite(p.min_duty) || p.min_duty < 0.0 || p.min_duty > p.max_duty)
    bad("pwm.min_duty", p.min_duty, "in [0, max_duty]");
  if (!std::isfinite(p.resolution) || p.resolution < 0.0 || p.resolution > 1.0)
    bad("pwm.resolution", p.resolution, "in [0, 1]");
}

void PwmModulator::reset() noexcept {
  duty_ = 0.0;
  faults_ = 0;  // a fresh start, as Pid::reset
}

double PwmModulator::step(double u) noexcept {
  if (!std::isfinite(u)) {
    ++faults_;
    return duty_;
  }
  const double mag = std::abs(u);
  double d = 0.0;
  if (mag > p_.deadband) {
    d = std::min(p_.max_duty, p_.min_duty + p_.gain * (mag - p_.deadband));
    if (p_.resolution > 0.0) d = std::min(p_.max_duty, std::round(d / p_.resolution) * p_.resolution);
    if (u < 0.0) d = -d;
  }
  duty_ = d;
  return d;
}

}  // namespace hysteron
