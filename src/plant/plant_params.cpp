// Parameter validation and JSON I/O of the simulated rig (plant.hpp).
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hysteron/io/files.hpp"
#include "hysteron/io/names.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/plant.hpp"

namespace hysteron {
namespace {

// What a field must satisfy.
enum class Rule { finite, positive, nonnegative, unit_closed, unit_open, acute_angle, braid_angle, bits };

const char* describe(Rule r) {
  switch (r) {
    case Rule::finite: return "a finite number";
    case Rule::positive: return "a finite number > 0";
    case Rule::nonnegative: return "a finite number >= 0";
    case Rule::unit_closed: return "a number in [0, 1]";
    case Rule::unit_open: return "a number in (0, 1)";
    case Rule::acute_angle: return "an angle in (0, pi/2) rad";
    case Rule::braid_angle:
      return "an angle in (0, 0.9553) rad: below the braid's neutral angle atan(sqrt(2)) = 54.74 deg, above which "
             "the muscle's volume shrinks as it contracts (it would lengthen under pressure)";
    case Rule::bits: return "an integer in [1, 31]";
  }
  return "";
}

bool satisfies(Rule r, double v) {
  if (!std::isfinite(v)) return false;
  switch (r) {
    case Rule::finite: return true;
    case Rule::positive: return v > 0.0;
    case Rule::nonnegative: return v >= 0.0;
    case Rule::unit_closed: return v >= 0.0 && v <= 1.0;
    case Rule::unit_open: return v > 0.0 && v < 1.0;
    case Rule::acute_angle: return v > 0.0 && v < std::numbers::pi / 2.0;
    case Rule::braid_angle: return v > 0.0 && v < std::atan(std::sqrt(2.0));
    case Rule::bits: return v >= 1.0 && v <= 31.0 && v == std::floor(v);
  }
  return false;
}

// Calls f(section, name, field&, rule, unit) for every parameter; field is double& or int&, unit
// its SI unit ("-": dimensionless).
// The one table used by validation, JSON reading and JSON writing.
template <class P, class F>
void for_each_field(P& p, F&& f) {
  auto& m = p.muscle;
  f("muscle", "rest_length", m.rest_length, Rule::positive, "m");
  f("muscle", "max_contraction", m.max_contraction, Rule::unit_open, "-");
  f("muscle", "rest_braid_angle", m.rest_braid_angle, Rule::braid_angle, "rad");
  f("muscle", "effective_radius", m.effective_radius, Rule::positive, "m");
  f("muscle", "dead_volume", m.dead_volume, Rule::nonnegative, "m^3");
  f("muscle", "force_620", m.force_620, Rule::positive, "N");
  f("muscle", "eps_620", m.eps_620, Rule::unit_open, "-");
  f("muscle", "c0", m.c0, Rule::nonnegative, "-");
  f("muscle", "c1", m.c1, Rule::nonnegative, "-");
  f("muscle", "c2", m.c2, Rule::nonnegative, "-");
  f("muscle", "reference_pressure", m.reference_pressure, Rule::positive, "Pa");
  f("muscle", "max_pressure", m.max_pressure, Rule::positive, "Pa");
  auto& h = p.hysteresis;
  f("hysteresis", "pressure_band", h.pressure_band, Rule::nonnegative, "Pa");
  f("hysteresis", "pressure_band_slope", h.pressure_band_slope, Rule::unit_closed, "-");
  f("hysteresis", "transition_strain", h.transition_strain, Rule::positive, "-");
  f("hysteresis", "exponent", h.exponent, Rule::positive, "-");
  f("hysteresis", "beta", h.beta, Rule::unit_closed, "-");
  f("hysteresis", "creep_stiffness", h.creep_stiffness, Rule::nonnegative, "N/m");
  f("hysteresis", "creep_time", h.creep_time, Rule::positive, "s");
  auto& a = p.air;
  f("air", "gas_constant", a.gas_constant, Rule::positive, "J/(kg K)");
  f("air", "temperature", a.temperature, Rule::positive, "K");
  f("air", "k_in", a.k_in, Rule::positive, "-");
  f("air", "k_out", a.k_out, Rule::positive, "-");
  f("air", "k", a.k, Rule::positive, "-");
  f("air", "rho0", a.rho0, Rule::positive, "kg/m^3");
  f("air", "t0", a.t0, Rule::positive, "K");
  f("air", "supply_pressure", a.supply_pressure, Rule::positive, "Pa");
  f("air", "atmospheric_pressure", a.atmospheric_pressure, Rule::positive, "Pa");
  f("air", "linear_ratio", a.linear_ratio, Rule::unit_open, "-");
  auto& r = p.regulator;
  f("regulator", "time_constant", r.time_constant, Rule::positive, "s");
  f("regulator", "dead_time", r.dead_time, Rule::nonnegative, "s");
  f("regulator", "max_command", r.max_command, Rule::positive, "Pa");
  f("regulator", "sonic_conductance", r.sonic_conductance, Rule::positive, "m^3/(s Pa)");
  f("regulator", "critical_ratio", r.critical_ratio, Rule::unit_open, "-");
  f("regulator", "proportional_band", r.proportional_band, Rule::positive, "Pa");
  auto& v = p.valves;
  f("valves", "sonic_conductance", v.sonic_conductance, Rule::positive, "m^3/(s Pa)");
  f("valves", "critical_ratio", v.critical_ratio, Rule::unit_open, "-");
  f("valves", "pwm_frequency", v.pwm_frequency, Rule::positive, "Hz");
  f("valves", "on_delay", v.on_delay, Rule::nonnegative, "s");
  f("valves", "off_delay", v.off_delay, Rule::nonnegative, "s");
  f("valves", "min_pulse", v.min_pulse, Rule::nonnegative, "s");
  auto& l = p.load;
  f("load", "mass", l.mass, Rule::positive, "kg");
  f("load", "damping", l.damping, Rule::nonnegative, "N s/m");
  f("load", "gravity", l.gravity, Rule::nonnegative, "m/s^2");
  f("load", "spring_rate", l.spring_rate, Rule::nonnegative, "N/m");
  f("load", "spring_preload", l.spring_preload, Rule::nonnegative, "N");
  auto& s = p.sensors;
  f("sensors", "pressure_noise", s.pressure_noise, Rule::nonnegative, "Pa");
  f("sensors", "pressure_offset", s.pressure_offset, Rule::finite, "Pa");
  f("sensors", "pressure_range", s.pressure_range, Rule::positive, "Pa");
  f("sensors", "pressure_bits", s.pressure_bits, Rule::bits, "bits");
  f("sensors", "pressure_time_constant", s.pressure_time_constant, Rule::nonnegative, "s");
  f("sensors", "displacement_noise", s.displacement_noise, Rule::nonnegative, "m");
  f("sensors", "displacement_offset", s.displacement_offset, Rule::finite, "m");
  f("sensors", "displacement_range", s.displacement_range, Rule::positive, "m");
  f("sensors", "displacement_bits", s.displacement_bits, Rule::bits, "bits");
  auto& sim = p.simulation;
  f("simulation", "dt", sim.dt, Rule::positive, "s");
  f("simulation", "max_substeps", sim.max_substeps, Rule::positive, "-");
  f("simulation", "pressure_tolerance", sim.pressure_tolerance, Rule::positive, "-");
  f("simulation", "position_tolerance", sim.position_tolerance, Rule::positive, "m");
}

constexpr const char* kSections[] = {"muscle", "regulator", "hysteresis", "air",
                                     "valves", "load", "sensors", "simulation"};

[[noreturn]] void fail(std::string_view where, std::string_view key, double value,
                       std::string_view expected) {
  throw Error(fmt::format("{}.{} = {}: must be {}", where, key, value, expected));
}

}  // namespace

void validate(const PamRigParams& p, std::string_view where) {
  for_each_field(p, [&](const char* section, const char* name, const auto& value, Rule rule, const char*) {
    const double v = static_cast<double>(value);
    if (!satisfies(rule, v)) fail(where, fmt::format("{}.{}", section, name), v, describe(rule));
  });
  // Relations between fields.
  if (p.air.supply_pressure <= p.air.atmospheric_pressure)
    fail(where, "air.supply_pressure", p.air.supply_pressure,
         fmt::format("> air.atmospheric_pressure = {}", p.air.atmospheric_pressure));
  // The ambient air of a rig on Earth (30-110 kPa from a mountain top to sea level) and a supply
  // within what pneumatic components are built for (at most 16-25 bar): 1 Pa or 1e9 Pa were
  // accepted and simulated as an ideal gas.
  if (p.air.atmospheric_pressure < 10e3 || p.air.atmospheric_pressure > 200e3)
    fail(where, "air.atmospheric_pressure", p.air.atmospheric_pressure,
         "within 10e3 .. 200e3 Pa abs (the ambient air: about 1e5 Pa at sea level)");
  if (p.air.supply_pressure > 5e6)
    fail(where, "air.supply_pressure", p.air.supply_pressure,
         "<= 5e6 Pa abs (50 bar; pneumatic muscles and valves are rated for at most 6-25 bar)");
  if (p.air.linear_ratio <= p.regulator.critical_ratio || p.air.linear_ratio <= p.valves.critical_ratio)
    fail(where, "air.linear_ratio", p.air.linear_ratio,
         "> regulator.critical_ratio and > valves.critical_ratio");
  if (p.simulation.dt > 1e-4 * (1.0 + 1e-12))
    fail(where, "simulation.dt", p.simulation.dt, "<= 1e-4 s (pam-plant.md)");
  // the dead time's delay line holds dead_time / dt samples (1e6 s asked for 8e10 bytes)
  if (p.regulator.dead_time > 10.0)
    fail(where, "regulator.dead_time", p.regulator.dead_time, "<= 10 s (a proportional regulator's is 5-10 ms)");
  if (p.regulator.dead_time > 1e7 * p.simulation.dt)
    fail(where, "regulator.dead_time", p.regulator.dead_time,
         fmt::format("<= 1e7 simulation steps of dt = {} s (its delay line)", p.simulation.dt));
  const double period = 1.0 / p.valves.pwm_frequency;
  if (p.valves.on_delay >= period)
    fail(where, "valves.on_delay", p.valves.on_delay, fmt::format("< the PWM period {} s", period));
  if (p.valves.off_delay >= period)
    fail(where, "valves.off_delay", p.valves.off_delay, fmt::format("< the PWM period {} s", period));
  // P10 drops a pulse |d| T <= min_pulse, |d| <= 1: from the period on every pulse was dropped, the
  // valves never opened, and mpi-pwm's relay test stopped the experiment
  if (p.valves.min_pulse >= period)
    fail(where, "valves.min_pulse", p.valves.min_pulse,
         fmt::format("< the PWM period {} s (a pulse no longer than it is dropped: the valves would never open)",
                     period));
  // A regulator's command range (P9; proportional regulators span 0-2 .. 0-10 bar): 1e12 Pa was
  // accepted; the bound is the supply's
  if (p.regulator.max_command > 5e6)
    fail(where, "regulator.max_command", p.regulator.max_command,
         "<= 5e6 Pa (50 bar, the supply's bound; proportional regulators span 0-2 .. 0-10 bar)");
  // Air as the ideal gas P8 and the chamber's equation treat it: it liquefies near 80 K, and a
  // muscle's rubber is rated for about -10 .. +60 C (1 K was accepted and simulated)
  if (p.air.temperature < 150.0 || p.air.temperature > 600.0)
    fail(where, "air.temperature", p.air.temperature,
         "within 150 .. 600 K (the air's temperature; 293.15 K is 20 C; air liquefies near 80 K)");
  // The divergence check (docs/plant.md, Safety): a rig fed from the supply cannot reach twice its
  // pressure, nor contract by more than the muscle's length; 1e9 disabled the check
  if (p.simulation.pressure_tolerance > 1.0)
    fail(where, "simulation.pressure_tolerance", p.simulation.pressure_tolerance,
         "<= 1 (the pressure above the supply, relative, at which the rig is held diverged; 0.05 nominal)");
  if (p.simulation.position_tolerance > p.muscle.rest_length)
    fail(where, "simulation.position_tolerance", p.simulation.position_tolerance,
         fmt::format("<= muscle.rest_length = {} m (the contraction outside the stroke at which the rig is held "
                     "diverged; 1e-3 m nominal)",
                     p.muscle.rest_length));
  if (p.simulation.dt > 0.5 * period)
    fail(where, "simulation.dt", p.simulation.dt, fmt::format("<= half the PWM period {} s", period));
  if (p.muscle.max_contraction * p.muscle.rest_length > p.sensors.displacement_range)
    fail(where, "sensors.displacement_range", p.sensors.displacement_range,
         fmt::format(">= the stroke {} m (muscle.max_contraction x muscle.rest_length; a longer "
                     "muscle needs a longer displacement sensor)",
                     p.muscle.max_contraction * p.muscle.rest_length));
}

PamRigParams with_unread_parameters_of(PamRigParams p, Actuation mode, const PamRigParams& other) {
  if (mode == Actuation::switching_valves) {
    p.regulator.time_constant = other.regulator.time_constant;
    p.regulator.dead_time = other.regulator.dead_time;
    p.regulator.max_command = other.regulator.max_command;
  } else {
    p.valves.pwm_frequency = other.valves.pwm_frequency;
    p.valves.on_delay = other.valves.on_delay;
    p.valves.off_delay = other.valves.off_delay;
    p.valves.min_pulse = other.valves.min_pulse;
  }
  return p;
}

double pressure_command_limit(const PamRigParams& p, Actuation mode) noexcept {
  return mode == Actuation::regulator ? std::min(p.muscle.max_pressure, p.regulator.max_command)
                                      : p.muscle.max_pressure;
}

PamRigParams rig_params_from_json(const nlohmann::json& j, std::string_view where) {
  if (!j.is_object()) throw Error(fmt::format("{}: expected a JSON object, got {}", where, j.type_name()));
  PamRigParams p;
  // iterators, not structured bindings: clang 14 (the fuzz build) cannot capture bindings in lambdas
  for (auto sec_it = j.begin(); sec_it != j.end(); ++sec_it) {
    const std::string& section = sec_it.key();
    const nlohmann::json& body = sec_it.value();
    bool known = false;
    for (const char* s : kSections) known = known || section == s;
    if (!known)
      throw Error(fmt::format("{}: unknown key '{}' (expected one of muscle, hysteresis, air, "
                              "regulator, valves, load, sensors, simulation)",
                              where, section));
    if (!body.is_object())
      throw Error(fmt::format("{}.{}: expected a JSON object, got {}", where, section, body.type_name()));
    for (auto key_it = body.begin(); key_it != body.end(); ++key_it) {
      const std::string& key = key_it.key();
      const nlohmann::json& value = key_it.value();
      bool found = false;
      for_each_field(p, [&](const char* sec, const char* name, auto& field, Rule rule, const char*) {
        if (found || section != sec || key != name) return;
        found = true;
        const std::string path = fmt::format("{}.{}.{}", where, sec, name);
        using F = std::remove_reference_t<decltype(field)>;
        if constexpr (std::is_same_v<F, int>) {
          if (!value.is_number_integer())
            throw Error(fmt::format("{}: expected {}, got {}", path, describe(rule),
                                    value.is_number() ? value.dump() : value.type_name()));
          // outside int: refused, not wrapped (2^32 + 12 bits would read as 12)
          if (value.is_number_unsigned() ? value.get<std::uint64_t>() > std::uint64_t{INT_MAX}
                                         : (value.get<std::int64_t>() > INT_MAX || value.get<std::int64_t>() < INT_MIN))
            throw Error(fmt::format("{} = {}: must be {}", path, value.dump(), describe(rule)));
          field = static_cast<int>(value.get<std::int64_t>());
        } else {
          if (!value.is_number())
            throw Error(fmt::format("{}: expected {}, got {}", path, describe(rule), value.type_name()));
          field = value.get<double>();
        }
        if (!satisfies(rule, static_cast<double>(field)))
          throw Error(fmt::format("{} = {}: must be {}", path, value.dump(), describe(rule)));
      });
      if (!found) {
        // the section's keys, and the closest of them when the key looks like a typo of it
        std::string keys;
        std::vector<std::string_view> names;
        for_each_field(p, [&](const char* sec, const char* name, auto&, Rule, const char*) {
          if (section != sec) return;
          keys += (keys.empty() ? "" : ", ") + std::string(name);
          names.emplace_back(name);
        });
        const std::string_view hint = io::closest_name(key, names);
        throw Error(fmt::format("{}.{}: unknown key '{}'{} (the keys of {}: {})", where, section, key,
                                hint.empty() ? "" : fmt::format(", did you mean '{}'?", hint), section, keys));
      }
    }
  }
  validate(p, where);
  return p;
}

nlohmann::json rig_params_to_json(const PamRigParams& params) {
  nlohmann::json j = nlohmann::json::object();
  for_each_field(params, [&](const char* section, const char* name, const auto& value, Rule, const char*) {
    j[section][name] = value;
  });
  return j;
}

std::vector<RigParameter> rig_parameters(const PamRigParams& params) {
  std::vector<RigParameter> out;
  for_each_field(params, [&](const char* section, const char* name, const auto& value, Rule rule, const char* unit) {
    out.push_back({fmt::format("{}.{}", section, name), static_cast<double>(value), unit, describe(rule)});
  });
  return out;
}

nlohmann::json rig_statics_to_json(const RigStatics& s) {
  const auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"stroke_m", s.stroke_m},
          {"weight_n", s.weight_n},
          {"return_force_rest_n", s.return_force_rest_n},
          {"return_force_stroke_n", s.return_force_stroke_n},
          {"fall_speed_rest_m_s", finite_or_null(s.fall_speed_rest_m_s)},
          {"fall_speed_stroke_m_s", finite_or_null(s.fall_speed_stroke_m_s)},
          {"lift_off_pa", finite_or_null(s.lift_off_pa)},
          {"regulator_limit_pa", s.regulator_limit_pa},
          {"valves_limit_pa", s.valves_limit_pa},
          {"pressure_pa", s.pressure_pa},
          {"rising_m", s.rising_m},
          {"falling_m", s.falling_m},
          {"unusable", s.unusable},
          {"vented_stall_m", s.vented_stall_m},
          {"creep_return_speed_m_s", finite_or_null(s.creep_return_speed_m_s)},
          {"weak_return", s.weak_return}};
}

nlohmann::json rig_units_to_json() {
  nlohmann::json j = nlohmann::json::object();
  for (const RigParameter& r : rig_parameters(PamRigParams{})) j[r.path] = r.unit;
  return j;
}

PamRigParams load_rig_params(const std::filesystem::path& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw Error(fmt::format("{}: is a directory, not a rig parameter file (JSON)", file.string()));
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open for reading", file.string()));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(fmt::format("{}: read error", file.string()));
  const nlohmann::json j = io::parse_json(text.str(), file.string());
  return rig_params_from_json(j, file.string());
}

void save_rig_params(const PamRigParams& params, const std::filesystem::path& file) {
  validate(params, file.string());
  // atomic, mode and links kept, devices written in place, "-" = stdout (io/files.hpp)
  io::write_text_file(file.string(), rig_params_to_json(params).dump(2) + "\n");
}

}  // namespace hysteron
