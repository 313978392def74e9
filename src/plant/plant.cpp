// The simulated DMSP-20-500 rig (plant.hpp). Equation tags P1-P12 refer to the
// comment at the top of include/hysteron/plant.hpp.
#include "hysteron/plant.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <numbers>

#include <fmt/format.h>

namespace hysteron {

// ---- physics -------------------------------------------------------------------

double festo_force(const MuscleParams& m, double p_gauge, double eps) noexcept {  // P1
  const double e = eps / m.eps_620;
  const double ps = p_gauge / m.reference_pressure;
  const double f = m.c0 * (std::exp(-m.c1 * e) - 1.0) + ps * std::exp(-m.c2 * e * e);
  return m.force_620 * std::max(0.0, f);
}

namespace {
// P6 with its constants: V(eps) = scale u (1 - c2 u^2) + V_dead, u = 1 - eps,
// scale = pi r^2 L0 / sin^2(theta0), c2 = cos^2(theta0).
struct VolumeTerms {
  double scale, c2;
};
VolumeTerms volume_terms(const MuscleParams& m) noexcept {
  const double s = std::sin(m.rest_braid_angle);
  const double c = std::cos(m.rest_braid_angle);
  return {std::numbers::pi * m.effective_radius * m.effective_radius * m.rest_length / (s * s), c * c};
}
double volume_at(VolumeTerms v, double dead_volume, double eps) noexcept {
  const double u = 1.0 - eps;
  return v.scale * u * (1.0 - u * u * v.c2) + dead_volume;
}
double volume_slope(VolumeTerms v, double eps) noexcept {  // dV/d(eps)
  const double u = 1.0 - eps;
  return -v.scale * (1.0 - 3.0 * u * u * v.c2);
}
// |z|^n of P3; n = 1, 1.5 and 2 (the documented range's ends and default) without pow.
double bouc_wen_power(double a, double n) noexcept {
  if (n == 1.0) return a;
  if (n == 1.5) return a * std::sqrt(a);
  if (n == 2.0) return a * a;
  return std::pow(a, n);
}
}  // namespace

double muscle_volume(const MuscleParams& m, double eps) noexcept {  // P6
  return volume_at(volume_terms(m), m.dead_volume, eps);
}

double muscle_volume_derivative(const MuscleParams& m, double eps) noexcept {
  return volume_slope(volume_terms(m), eps);
}

namespace {
// P8 with sqrt(T0 / T_up) given (a rig's temperature is constant: computed once).
double iso6358_flow(double conductance, double b, double p_up, double p_down, double root_t,
                    const AirParams& air) noexcept {
  if (!(p_up > p_down) || p_up <= 0.0) return 0.0;
  const double r = p_down / p_up;
  const double choked = conductance * air.rho0 * p_up * root_t;
  if (r <= b) return choked;
  const double rl = air.linear_ratio;
  if (r <= rl) {
    const double q = (r - b) / (1.0 - b);
    return choked * std::sqrt(1.0 - q * q);
  }
  const double ql = (rl - b) / (1.0 - b);
  return choked * std::sqrt(1.0 - ql * ql) * (1.0 - r) / (1.0 - rl);
}
}  // namespace

double iso6358_mass_flow(double conductance, double b, double p_up, double p_down, double t_up,
                         const AirParams& air) noexcept {  // P8
  return iso6358_flow(conductance, b, p_up, p_down, std::sqrt(air.t0 / t_up), air);
}

double static_contraction(const PamRigParams& p, double p_gauge, double z) noexcept {
  const auto& m = p.muscle;
  const double band = p.hysteresis.pressure_band + p.hysteresis.pressure_band_slope * std::max(0.0, p_gauge);
  const double p_eff = p_gauge - band * z;
  // F(p, eps) - return_force(eps L0) is non-increasing in eps >= 0: bisection on [0, eps_max].
  const auto net = [&](double eps) { return festo_force(m, p_eff, eps) - return_force(p.load, eps * m.rest_length); };
  double lo = 0.0, hi = m.max_contraction;
  if (net(lo) <= 0.0) return 0.0;
  if (net(hi) >= 0.0) return hi * m.rest_length;
  for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
    const double mid = 0.5 * (lo + hi);
    (net(mid) > 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi) * m.rest_length;
}

// rig_statics and rig_unusable_reason live here, with the physics they call: plant_params.cpp is
// built alone into the rig-file fuzzer.
RigStatics rig_statics(const PamRigParams& p, std::string_view where) {
  validate(p, where);
  RigStatics s;
  const LoadParams& l = p.load;
  s.stroke_m = p.muscle.max_contraction * p.muscle.rest_length;
  s.weight_n = l.mass * l.gravity;
  s.return_force_rest_n = return_force(l, 0.0);
  s.return_force_stroke_n = return_force(l, s.stroke_m);
  const double inf = std::numeric_limits<double>::infinity();
  s.fall_speed_rest_m_s = l.damping > 0.0 ? s.return_force_rest_n / l.damping : inf;
  s.fall_speed_stroke_m_s = l.damping > 0.0 ? s.return_force_stroke_n / l.damping : inf;
  s.regulator_limit_pa = pressure_command_limit(p, Actuation::regulator);
  s.valves_limit_pa = pressure_command_limit(p, Actuation::switching_valves);
  const double supply = p.air.supply_pressure - p.air.atmospheric_pressure;  // [Pa gauge]
  // the rising branch contracts where F(P - dP_h, 0) exceeds the return force at rest: monotone in
  // P (dP_h's slope is below 1 or the effective pressure never grows), so bisection on [0, supply]
  const auto lifts = [&](double pa) { return static_contraction(p, pa, 1.0) > 0.0; };
  if (!lifts(supply)) {
    s.lift_off_pa = std::numeric_limits<double>::infinity();
  } else {
    double lo = 0.0, hi = supply;
    for (int i = 0; i < 100 && hi - lo > 1e-6; ++i) (lifts(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
    s.lift_off_pa = hi;
  }
  const double top = std::min(s.regulator_limit_pa, supply);
  for (int i = 0;; ++i) {
    const double pa = std::min(1e5 * i, top);
    s.pressure_pa.push_back(pa);
    s.rising_m.push_back(static_contraction(p, pa, 1.0));
    s.falling_m.push_back(static_contraction(p, pa, -1.0));
    if (pa >= top) break;
  }
  s.unusable = rig_unusable_reason(p, where);
  // the vented muscle held at the top longer than the creep time: F(dP_h(0), x) + k_c (top - x) = R(x),
  // the left side minus the right non-increasing in x, so bisection on [0, top]
  const double held = s.rising_m.back();
  const auto& m = p.muscle;
  const auto net = [&](double x) {
    return festo_force(m, p.hysteresis.pressure_band, x / m.rest_length) + p.hysteresis.creep_stiffness * (held - x) -
           return_force(l, x);
  };
  if (!(net(0.0) > 0.0)) {
    s.vented_stall_m = 0.0;
  } else if (net(held) >= 0.0) {
    s.vented_stall_m = held;
  } else {
    double lo = 0.0, hi = held;
    for (int i = 0; i < 200 && hi - lo > 1e-12; ++i) (net(0.5 * (lo + hi)) > 0.0 ? lo : hi) = 0.5 * (lo + hi);
    s.vented_stall_m = 0.5 * (lo + hi);
  }
  // infinite where nothing resists the fall (no damping, no creep stiffness), as the fall speeds
  const double resistance = l.damping + p.hysteresis.creep_stiffness * p.hysteresis.creep_time;  // [N s/m]
  s.creep_return_speed_m_s = resistance > 0.0 ? return_force(l, s.vented_stall_m) / resistance : inf;
  s.weak_return = rig_weak_return_reason(p, s, where);
  return s;
}

std::string rig_weak_return_reason(const PamRigParams& p, const RigStatics& s, std::string_view where) {
  if (!s.unusable.empty() || s.rising_m.empty() || s.falling_m.empty()) return {};
  const double top = s.rising_m.back(), rest = s.falling_m.front();
  if (!(top > rest)) return {};  // the muscle never lifts its load within the command limit
  // Half the reach: a muscle whose creep settled at the middle of its reach (under a reference
  // about it, a sine, held longer than the creep time) then stalls above its rest (docs/plant.md).
  const double fraction = (s.vented_stall_m - rest) / (top - rest);
  if (!(fraction >= 0.5)) return {};
  const HysteresisParams& h = p.hysteresis;
  return fmt::format(
      "the return force is weak against the creep element: held at the top of its reach ({1:.1f} mm at {2:.3f} MPa) "
      "for longer than {0}.hysteresis.creep_time = {3:g} s and vented, the muscle falls only to {4:.1f} mm ({5:.0f} % "
      "of its reach above its rest at {6:.1f} mm), where the creep element's pull, {0}.hysteresis.creep_stiffness = "
      "{7:g} N/m x ({1:.1f} mm - contraction), meets the return force ({8:.1f} N at rest: {0}.load.mass x "
      "{0}.load.gravity = {9:.1f} N, {0}.load.spring_preload = {10:g} N, {0}.load.spring_rate = {11:g} N/m); below "
      "that it returns only as the creep relaxes, at about {12:.1f} mm/s (the return force there / ({0}.load.damping + "
      "creep_stiffness x creep_time)), so the lower part of a reference cannot be tracked on its way down: a heavier "
      "load or a stronger return spring (docs/plant.md, \"A weak return force\")",
      where, top * 1e3, s.pressure_pa.back() * 1e-6, h.creep_time, s.vented_stall_m * 1e3, fraction * 100.0,
      rest * 1e3, h.creep_stiffness, s.return_force_rest_n, s.weight_n, p.load.spring_preload, p.load.spring_rate,
      s.creep_return_speed_m_s * 1e3);
}

std::string rig_unusable_reason(const PamRigParams& p, std::string_view where) {
  const LoadParams& l = p.load;
  if (!(return_force(l, 0.0) > 0.0) && !(l.spring_rate > 0.0))
    return fmt::format(
        "{0}.load.gravity = {1:g} with no return spring ({0}.load.spring_rate = {2:g} N/m, {0}.load.spring_preload = "
        "{3:g} N): nothing extends the muscle when it is vented (at 0 gauge pressure it pulls at most what its "
        "hysteresis band leaves, and the rig's return force is the load's weight, load.mass x load.gravity, plus the "
        "spring's), so after its first contraction it never returns and no reference can be tracked; a horizontal rig "
        "needs a return spring: set load.spring_rate and/or load.spring_preload (docs/plant.md, P5)",
        where, l.gravity, l.spring_rate, l.spring_preload);
  // the most pressure the muscle gets: its rating, or the supply where that is lower
  const double top = std::min(p.muscle.max_pressure, p.air.supply_pressure - p.air.atmospheric_pressure);
  if (static_contraction(p, top, 1.0) > 0.0) return {};
  const double band = p.hysteresis.pressure_band + p.hysteresis.pressure_band_slope * top;
  return fmt::format(
      "the muscle cannot lift its load: at {1:.3f} MPa, the most it gets ({0}.muscle.max_pressure = {2:g} Pa, "
      "{0}.air.supply_pressure = {3:g} Pa abs), it pulls {4:.1f} N at rest on its rising branch, less than the return "
      "force there, {5:.1f} N ({0}.load.mass x {0}.load.gravity = {6:.1f} N, {0}.load.spring_preload = {7:g} N); a "
      "lighter load, a weaker return spring, a stronger muscle or more pressure",
      where, top * 1e-6, p.muscle.max_pressure, p.air.supply_pressure, festo_force(p.muscle, top - band, 0.0),
      return_force(l, 0.0), l.mass * l.gravity, l.spring_preload);
}

// ---- rig -----------------------------------------------------------------------

struct PamRig::Deriv {
  double pressure, contraction, velocity, bouc_wen, creep;
};

namespace {
// Largest slope dm/d(p_up - p_down) [kg/(s Pa)] of P8 (its linear part).
double linear_slope(double conductance, double b, const AirParams& air) {
  const double q = (air.linear_ratio - b) / (1.0 - b);
  return conductance * air.rho0 * std::sqrt(air.t0 / air.temperature) * std::sqrt(1.0 - q * q) /
         (1.0 - air.linear_ratio);
}
}  // namespace

PamRig::PamRig(PamRigParams params, std::uint64_t seed) : p_(params), seed_(seed), rng_(seed) {
  validate(p_);
  const double dt = p_.simulation.dt;
  const auto n_delay = static_cast<std::size_t>(std::llround(p_.regulator.dead_time / dt));
  delay_.assign(n_delay, 0.0);
  reg_alpha_ = -std::expm1(-dt / p_.regulator.time_constant);
  sensor_alpha_ = p_.sensors.pressure_time_constant > 0.0
                      ? -std::expm1(-dt / p_.sensors.pressure_time_constant)
                      : 1.0;
  pwm_period_ = 1.0 / p_.valves.pwm_frequency;
  const VolumeTerms vt = volume_terms(p_.muscle);
  volume_scale_ = vt.scale;
  volume_c2_ = vt.c2;
  root_t_ = std::sqrt(p_.air.t0 / p_.air.temperature);
  lsb_pressure_ = p_.sensors.pressure_range / (std::ldexp(1.0, p_.sensors.pressure_bits) - 1.0);  // P11
  lsb_displacement_ = p_.sensors.displacement_range / (std::ldexp(1.0, p_.sensors.displacement_bits) - 1.0);

  // P12: the stiffest pneumatic mode, linearised at the smallest volume; RK4 is
  // run with h lambda <= 1 (its stability limit on the real axis is 2.78).
  const auto& a = p_.air;
  const double dm_reg = p_.regulator.sonic_conductance * a.rho0 * std::sqrt(a.t0 / a.temperature) *
                            a.supply_pressure / p_.regulator.proportional_band +
                        linear_slope(p_.regulator.sonic_conductance, p_.regulator.critical_ratio, a);
  const double dm_valves = 2.0 * linear_slope(p_.valves.sonic_conductance, p_.valves.critical_ratio, a);
  const double v_min = muscle_volume(p_.muscle, 0.0);
  const double lambda = std::max(a.k_in, a.k_out) * a.gas_constant * a.temperature / v_min *
                        std::max(dm_reg, dm_valves);
  // ... and the load's: its damping rate c / m (a light load on a heavily damped guide) and its
  // stiffest mode sqrt(k / m), k the force map's stiffness at rest, F620 c0 c1 / (eps620 L0),
  // plus the creep element's and the return spring's (without them a 0.5 kg load with 20 kN s/m
  // diverged at run time).
  const auto& mu = p_.muscle;
  const double k_max = mu.force_620 * mu.c0 * mu.c1 / (mu.eps_620 * mu.rest_length) +
                       p_.hysteresis.creep_stiffness + p_.load.spring_rate;
  const double lambda_load = p_.load.damping / p_.load.mass + std::sqrt(k_max / p_.load.mass);
  const double needed = std::ceil(dt * std::max(lambda, lambda_load) / 1.0);
  if (needed > p_.simulation.max_substeps) {
    if (lambda_load > lambda)
      throw Error(fmt::format(
          "rig: the load's dynamics (rate c / m + sqrt(k / m) = {:.4g} 1/s: load.damping c = {:.4g} N s/m, load.mass "
          "m = {:.4g} kg, stiffness k = {:.4g} N/m, the muscle's at rest plus hysteresis.creep_stiffness {:.4g} plus "
          "load.spring_rate {:.4g}) need {} sub-steps per dt = {} s, more than simulation.max_substeps = {}; a heavier "
          "load, less damping, a softer return spring or a smaller simulation.dt",
          lambda_load, p_.load.damping, p_.load.mass, k_max, p_.hysteresis.creep_stiffness, p_.load.spring_rate,
          needed, dt, p_.simulation.max_substeps));
    throw Error(fmt::format(
        "rig: the air dynamics (rate {:.4g} 1/s) need {} sub-steps per dt = {} s, more than "
        "simulation.max_substeps = {}; reduce simulation.dt or a valve conductance",
        lambda, needed, dt, p_.simulation.max_substeps));
  }
  substeps_ = std::max(1, static_cast<int>(needed));
  reset();
}

void PamRig::reset() noexcept {
  rng_.seed(seed_);
  has_spare_ = false;
  s_ = RigState{};
  s_.pressure = p_.air.atmospheric_pressure;
  n_ = 0;
  ok_ = true;
  fault_reason_ = "";
  input_faults_ = 0;
  last_in_ = RigInputs{};
  std::fill(delay_.begin(), delay_.end(), 0.0);
  delay_pos_ = 0;
  pwm_index_ = -1;
  duty_ = {};
  p_filtered_ = 0.0;
  out_ = RigOutputs{};
  measure();
}

void PamRig::reset_at_pressure(double p_gauge) noexcept {
  reset();
  if (!std::isfinite(p_gauge)) return;
  p_gauge = std::clamp(p_gauge, 0.0, p_.air.supply_pressure - p_.air.atmospheric_pressure);
  s_.pressure = p_.air.atmospheric_pressure + p_gauge;
  s_.contraction = static_contraction(p_, p_gauge, 0.0);
  s_.creep = s_.contraction;
  s_.regulator_setpoint = p_gauge;
  std::fill(delay_.begin(), delay_.end(), p_gauge);
  last_in_.pressure_command = p_gauge * 1e-6;
  p_filtered_ = p_gauge;
  out_ = RigOutputs{};
  measure();
}

void PamRig::derivative(const RigState& s, const Flow& f, double p_set, Deriv& d) const noexcept {
  const auto& m = p_.muscle;
  const auto& h = p_.hysteresis;
  const auto& a = p_.air;
  const double eps = s.contraction / m.rest_length;
  const double eps_dot = s.velocity / m.rest_length;
  const double p_gauge = s.pressure - a.atmospheric_pressure;

  // P2-P5: force on the effective pressure, creep, load.
  const double band = h.pressure_band + h.pressure_band_slope * std::max(0.0, p_gauge);
  const double force = festo_force(m, p_gauge - band * s.bouc_wen, eps) -
                       h.creep_stiffness * (s.contraction - s.creep);
  d.contraction = s.velocity;
  d.velocity = (force - return_force(p_.load, s.contraction) - p_.load.damping * s.velocity) / p_.load.mass;
  const double zn = bouc_wen_power(std::abs(s.bouc_wen), h.exponent);
  const double sgn = (s.bouc_wen * eps_dot > 0.0) ? 1.0 : -1.0;
  d.bouc_wen = eps_dot / h.transition_strain * (1.0 - zn * (h.beta * sgn + 1.0 - h.beta));
  d.creep = (s.contraction - s.creep) / h.creep_time;

  // P8-P10: valve mass flows.
  // Signed flow through an open orifice between a port at p_port and the chamber
  // (> 0 into the chamber): an open valve passes air both ways.
  auto port_flow = [&](double conductance, double b, double p_port) {
    return p_port >= s.pressure ? iso6358_flow(conductance, b, p_port, s.pressure, root_t_, a)
                                : -iso6358_flow(conductance, b, s.pressure, p_port, root_t_, a);
  };
  double m_net = 0.0;  // scaled so that inflow uses k_in and outflow k_out (P7)
  double m_in = 0.0, m_out = 0.0;
  if (f.regulator) {
    const auto& r = p_.regulator;
    const double opening = std::clamp((p_set - p_gauge) / r.proportional_band, -1.0, 1.0);
    if (opening > 0.0)
      m_net = opening * port_flow(r.sonic_conductance, r.critical_ratio, a.supply_pressure);
    else if (opening < 0.0)
      m_net = -opening * port_flow(r.sonic_conductance, r.critical_ratio, a.atmospheric_pressure);
    (m_net >= 0.0 ? m_in : m_out) += std::abs(m_net);
  } else {
    const auto& v = p_.valves;
    if (f.inlet) {
      const double q = port_flow(v.sonic_conductance, v.critical_ratio, a.supply_pressure);
      (q >= 0.0 ? m_in : m_out) += std::abs(q);
    }
    if (f.exhaust) {
      const double q = port_flow(v.sonic_conductance, v.critical_ratio, a.atmospheric_pressure);
      (q >= 0.0 ? m_in : m_out) += std::abs(q);
    }
  }
  // P6-P7: chamber.
  const VolumeTerms vt{volume_scale_, volume_c2_};
  const double vol = volume_at(vt, m.dead_volume, eps);
  const double vol_dot = volume_slope(vt, eps) * eps_dot;
  d.pressure = a.gas_constant * a.temperature / vol * (a.k_in * m_in - a.k_out * m_out) -
               a.k * s.pressure * vol_dot / vol;
}

void PamRig::integrate(double h, const Flow& f) noexcept {  // P12: classical RK4
  const double p_set = s_.regulator_setpoint;
  auto add = [](const RigState& s, const Deriv& d, double k) {
    RigState r = s;
    r.pressure += k * d.pressure;
    r.contraction += k * d.contraction;
    r.velocity += k * d.velocity;
    r.bouc_wen += k * d.bouc_wen;
    r.creep += k * d.creep;
    return r;
  };
  Deriv k1, k2, k3, k4;
  derivative(s_, f, p_set, k1);
  derivative(add(s_, k1, 0.5 * h), f, p_set, k2);
  derivative(add(s_, k2, 0.5 * h), f, p_set, k3);
  derivative(add(s_, k3, h), f, p_set, k4);
  const double w = h / 6.0;
  s_.pressure += w * (k1.pressure + 2.0 * k2.pressure + 2.0 * k3.pressure + k4.pressure);
  s_.contraction += w * (k1.contraction + 2.0 * k2.contraction + 2.0 * k3.contraction + k4.contraction);
  s_.velocity += w * (k1.velocity + 2.0 * k2.velocity + 2.0 * k3.velocity + k4.velocity);
  s_.bouc_wen += w * (k1.bouc_wen + 2.0 * k2.bouc_wen + 2.0 * k3.bouc_wen + k4.bouc_wen);
  s_.creep += w * (k1.creep + 2.0 * k2.creep + 2.0 * k3.creep + k4.creep);
  apply_stops();
}

void PamRig::apply_stops() noexcept {  // P5: hard end stops, |z| <= 1 (P3)
  const double top = p_.muscle.max_contraction * p_.muscle.rest_length;
  if (s_.contraction <= 0.0) {
    s_.contraction = 0.0;
    s_.velocity = std::max(0.0, s_.velocity);
  } else if (s_.contraction >= top) {
    s_.contraction = top;
    s_.velocity = std::min(0.0, s_.velocity);
  }
  s_.bouc_wen = std::clamp(s_.bouc_wen, -1.0, 1.0);
}

bool PamRig::valve_open(bool inlet, double t) const noexcept {  // P10
  const auto& v = p_.valves;
  const double period = pwm_period_;
  const auto j = static_cast<std::int64_t>(std::floor(t / period));
  // Only periods j and j - 1 can be active: the delays are shorter than a period.
  for (std::int64_t k = j - 1; k <= j; ++k) {
    if (k < 0 || k > pwm_index_ || k < pwm_index_ - 2) continue;
    const double d = duty_[static_cast<std::size_t>(k % 3)];
    const double width = (inlet ? d : -d) * period;  // command pulse length
    if (width <= v.min_pulse) continue;
    double start = static_cast<double>(k) * period + v.on_delay;
    // A valve held open through a period boundary (100 % duty) does not re-open.
    if (k >= 1 && k - 1 >= pwm_index_ - 2) {
      const double prev = duty_[static_cast<std::size_t>((k - 1) % 3)];
      if ((inlet ? prev : -prev) >= 1.0) start = static_cast<double>(k) * period;
    }
    const double end = static_cast<double>(k) * period + width + v.off_delay;
    if (t >= start && t < end) return true;
  }
  return false;
}

double PamRig::gaussian() noexcept {
  // Box-Muller on 53-bit uniforms: identical on every standard library.
  if (has_spare_) {
    has_spare_ = false;
    return spare_gauss_;
  }
  constexpr double scale = 1.0 / 9007199254740992.0;  // 2^-53
  const double u1 = (static_cast<double>(rng_() >> 11) + 1.0) * scale;  // (0, 1]
  const double u2 = static_cast<double>(rng_() >> 11) * scale;          // [0, 1)
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_gauss_ = r * std::sin(2.0 * std::numbers::pi * u2);
  has_spare_ = true;
  return r * std::cos(2.0 * std::numbers::pi * u2);
}

double PamRig::quantize(double v, double range, double lsb) const noexcept {
  return std::round(std::clamp(v, 0.0, range) / lsb) * lsb;
}

namespace {
// P11's first-order pressure-sensor lag, one rig step: returns the gauge pressure [Pa].
double filter_pressure(const RigState& s, const AirParams& air, double alpha, double& filtered) noexcept {
  const double p_gauge = s.pressure - air.atmospheric_pressure;
  filtered += alpha * (p_gauge - filtered);
  return p_gauge;
}
}  // namespace

void PamRig::measure() noexcept {  // P11
  const auto& se = p_.sensors;
  const double p_gauge = filter_pressure(s_, p_.air, sensor_alpha_, p_filtered_);
  const double np = gaussian();
  const double nx = gaussian();
  out_.time = time();
  out_.contraction = s_.contraction;
  out_.velocity = s_.velocity;
  out_.pressure = p_gauge;
  out_.pressure_measured =
      quantize(p_filtered_ + se.pressure_offset + se.pressure_noise * np, se.pressure_range, lsb_pressure_);
  out_.contraction_measured = quantize(s_.contraction + se.displacement_offset + se.displacement_noise * nx,
                                       se.displacement_range, lsb_displacement_);
  out_.ok = ok_;
}

void PamRig::detect_divergence() noexcept {
  const auto& sim = p_.simulation;
  const double top = p_.muscle.max_contraction * p_.muscle.rest_length;
  if (!std::isfinite(s_.pressure) || !std::isfinite(s_.contraction) || !std::isfinite(s_.velocity) ||
      !std::isfinite(s_.bouc_wen) || !std::isfinite(s_.creep) || !std::isfinite(s_.regulator_setpoint))
    fault_reason_ = "non-finite state";
  else if (s_.pressure > p_.air.supply_pressure * (1.0 + sim.pressure_tolerance))
    fault_reason_ = "pressure above the supply pressure";
  else if (s_.pressure <= 0.0)
    fault_reason_ = "non-positive absolute pressure";
  else if (s_.contraction < -sim.position_tolerance || s_.contraction > top + sim.position_tolerance)
    fault_reason_ = "contraction outside the stroke";
  else
    return;
  ok_ = false;
}

RigOutputs PamRig::step(const RigInputs& in) noexcept {
  if (!ok_) return out_;
  advance(in);
  measure();
  set_valve_flags();
  return out_;
}

void PamRig::step_unobserved(const RigInputs& in) noexcept {
  if (!ok_) return;
  advance(in);
  if (!ok_) {  // the outputs of a fault are kept as step() leaves them
    measure();
    set_valve_flags();
    return;
  }
  // measure() without its outputs: the sensor filter and the noise generator advance exactly
  // as there, so every later measure() reads the same as after step(). measure() takes one
  // pair of normal deviates (two draws) per call, so none is left over between calls.
  filter_pressure(s_, p_.air, sensor_alpha_, p_filtered_);
  rng_.discard(2);
}

void PamRig::set_valve_flags() noexcept {
  const bool switching = last_in_.mode == Actuation::switching_valves;
  const double tol = 1e-6 * p_.simulation.dt;
  const double t1 = time();
  out_.inlet_open = switching && valve_open(true, t1 - tol);
  out_.exhaust_open = switching && valve_open(false, t1 - tol);
}

void PamRig::advance(const RigInputs& in_raw) noexcept {
  // Inputs: non-finite values are faults; hold the previous input.
  RigInputs in = in_raw;
  if (!std::isfinite(in.pressure_command)) {
    in.pressure_command = last_in_.pressure_command;
    ++input_faults_;
  }
  if (!std::isfinite(in.pwm_duty)) {
    in.pwm_duty = last_in_.pwm_duty;
    ++input_faults_;
  }
  in.pwm_duty = std::clamp(in.pwm_duty, -1.0, 1.0);
  last_in_ = in;

  const double dt = p_.simulation.dt;
  const double t0 = time();
  const double t1 = static_cast<double>(n_ + 1) * dt;
  const double h_max = dt / substeps_;
  // Switching valves: latch the duty at every PWM period start within [t0, t1).
  const double tol = 1e-6 * dt;
  const bool switching = in.mode == Actuation::switching_valves;
  while (static_cast<double>(pwm_index_ + 1) * pwm_period_ < t1 - tol) {
    ++pwm_index_;
    duty_[static_cast<std::size_t>(pwm_index_ % 3)] = switching ? in.pwm_duty : 0.0;
  }

  // P9: regulator dead time, then the first-order lag (exact for a held input).
  const double command = std::clamp(in.pressure_command * 1e6, 0.0, p_.regulator.max_command);
  double delayed = command;
  if (!delay_.empty()) {
    delayed = delay_[delay_pos_];
    delay_[delay_pos_] = command;
    if (++delay_pos_ == delay_.size()) delay_pos_ = 0;
  }
  s_.regulator_setpoint += reg_alpha_ * (delayed - s_.regulator_setpoint);

  Flow flow;
  flow.regulator = !switching;
  if (!switching) {
    const int n = substeps_;
    for (int i = 0; i < n; ++i) integrate(h_max, flow);
  } else {
    // Split the step at every valve edge inside (t0, t1) (P12).
    std::array<double, 12> edges{};
    std::size_t ne = 0;
    edges[ne++] = t0;
    const auto& v = p_.valves;
    for (std::int64_t k = pwm_index_ - 1; k <= pwm_index_; ++k) {
      if (k < 0) continue;
      const double d = std::abs(duty_[static_cast<std::size_t>(k % 3)]);
      const double base = static_cast<double>(k) * pwm_period_;
      for (double e : {base, base + v.on_delay, base + d * pwm_period_ + v.off_delay})
        if (e > t0 + tol && e < t1 - tol && ne < edges.size() - 1) edges[ne++] = e;
    }
    std::sort(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(ne));
    edges[ne++] = t1;
    for (std::size_t i = 0; i + 1 < ne; ++i) {
      const double a = edges[i], b = edges[i + 1];
      if (b - a <= 0.0) continue;
      const double mid = 0.5 * (a + b);
      flow.inlet = valve_open(true, mid);
      flow.exhaust = valve_open(false, mid);
      const int n = std::max(1, static_cast<int>(std::ceil((b - a) / h_max - 1e-9)));
      for (int k = 0; k < n; ++k) integrate((b - a) / n, flow);
    }
  }
  ++n_;
  detect_divergence();
}

std::int64_t control_steps(double control_period, double dt, std::string_view where) {
  const double ratio = control_period / dt;
  const bool usable = control_period > 0 && dt > 0 && std::isfinite(ratio);
  const double n = usable ? std::round(ratio) : 0.0;
  if (usable && n >= 1 && n <= 1e12 && std::abs(ratio - n) <= 1e-9 * ratio) return static_cast<std::int64_t>(n);
  if (!usable || ratio > 1e12)
    throw Error(fmt::format("{}: control_period = {} s must be a whole multiple (1..1e12) of the rig's simulation.dt "
                            "= {} s",
                            where, control_period, dt));
  // the dt nearest the given one that divides the period: period / floor(ratio) or period / ceil(ratio)
  const double lo = std::max(1.0, std::floor(ratio)), hi = std::max(1.0, std::ceil(ratio));
  const double near = std::abs(control_period / lo - dt) <= std::abs(control_period / hi - dt) ? lo : hi;
  throw Error(fmt::format("{}: control_period = {} s is not a whole multiple of the rig's simulation.dt = {} s "
                          "({:.6g} steps; the loop would run every {:.6g} s); the nearest dt that divides it is {} "
                          "s ({:.0f} steps)",
                          where, control_period, dt, ratio, std::max(1.0, n) * dt, control_period / near, near));
}

void PamRig::check() const {
  if (ok_) return;
  throw Error(fmt::format(
      "PamRig diverged at t = {:.6f} s ({}): pressure = {:.6g} Pa abs (supply {:.6g}), "
      "contraction = {:.6g} m (stroke 0..{:.6g}), velocity = {:.6g} m/s, bouc_wen z = {:.6g}, "
      "creep = {:.6g} m; check the parameters and dt",
      time(), fault_reason_, s_.pressure, p_.air.supply_pressure, s_.contraction,
      p_.muscle.max_contraction * p_.muscle.rest_length, s_.velocity, s_.bouc_wen, s_.creep));
}

}  // namespace hysteron
