#pragma once
// Simulated test rig: a Festo DMSP-20-500 pneumatic muscle lifting a hanging
// mass, fed either by a proportional pressure regulator or by a pair of fast
// switching valves driven by PWM. All facts, equations and default values come
// from ../shared/reference/pam-plant.md; every default below carries its tag:
//   [F] stated in a public source, [D] derived from [F] values, [E] an estimate.
// docs/plant.md lists the equations (P1-P12 below) and measured behaviour.
//
// Model (SI units; x = shortening of the muscle [m], eps = x / L0):
//   P1  static force   F(P, eps) = F620 max(0, c0 (exp(-c1 e) - 1) + P* exp(-c2 e^2)),
//                      e = eps / eps620, P* = P_gauge / 620 kPa      (Festo fit)
//   P2  hysteresis     F_h = F(P - dP_h(P) z, eps),  dP_h(P) = dP_h0 + k_h P_gauge
//   P3  Bouc-Wen       dz/dt = (deps/dt / eps_z) [1 - |z|^n (beta sgn(z deps/dt) + 1 - beta)]
//                      bounded: |z| <= 1; z -> +1 while shortening (the braid
//                      friction then needs a higher pressure for the same force)
//   P4  creep          F_muscle = F_h - k_c (x - x_c),  dx_c/dt = (x - x_c) / tau_c
//   P5  load           m dv/dt = F_muscle - (m g + F_s0 + k_s x) - c v,  dx/dt = v (the weight
//                      and an optional return spring), hard stops at 0 <= x <= eps_max L0
//                      (velocity set to 0 at a stop)
//   P6  volume         V(eps) = pi r0^2 L0 (1 - eps)[1 - (1 - eps)^2 cos^2 theta0] / sin^2 theta0 + V_dead
//   P7  chamber        dP/dt = (R T / V)(k_in m_in - k_out m_out) - k P (dV/dt) / V
//   P8  ISO 6358       m = C rho0 p1 sqrt(T0/T1) phi(p2/p1), phi = 1 for r <= b,
//                      sqrt(1 - ((r - b)/(1 - b))^2) for b < r <= 0.999, linear to 0 at r = 1
//   P9  regulator      setpoint: dead time, then dp_set/dt = (u - p_set) / tau;
//                      valve stage: opening a = clamp((p_set - P_gauge) / p_band, -1, 1),
//                      a > 0 feeds from supply, a < 0 vents to exhaust, through P8
//   P10 switching      inlet (supply -> chamber) and exhaust (chamber -> atmosphere) valves;
//                      PWM period T = 1 / f_pwm, duty d in [-1, 1] latched at each period
//                      start; valve open on [kT + t_on, kT + |d| T + t_off)
//   P11 sensors        first-order lag, Gaussian noise, offset, quantisation, range clamp
//   P12 integration    classical RK4 with fixed step dt, split at every valve edge
//                      inside a step, sub-stepped if the linearised air dynamics need it
//
// Real time: storage is sized at construction; step() never allocates and never
// throws. A diverging simulation (non-finite state, pressure above supply,
// contraction outside the stroke) sets ok() = false and freezes the rig;
// check() (and run()) then throw hysteron::Error naming the time and the state.
// Random numbers: std::mt19937_64 seeded explicitly, turned into Gaussians by
// our own Box-Muller transform so a run is bit-for-bit reproducible across
// standard libraries.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hysteron/error.hpp"

namespace hysteron {

// Muscle geometry and static force map (P1, P6).
struct MuscleParams {
  double rest_length = 0.5;             // L0 [m]                         [F] DMSP-20-500
  double max_contraction = 0.25;        // eps_max [-]                    [F]
  double rest_braid_angle = 0.49916;    // theta0 [rad] = 28.6 deg        [F]
  double effective_radius = 10.9e-3;    // r0 [m]                         [F]
  double dead_volume = 20e-6;           // V_dead [m^3] (tube, fittings)  [E] 10-30 cm^3
  double force_620 = 1326.0;            // F620 [N] for L0 = 0.5 m        [F]/[D]
  double eps_620 = 0.255;               // eps620 [-]                     [F]
  double c0 = 0.2579;                   // Festo fit c0 [-]               [F]
  double c1 = 6.477;                    // Festo fit c1 [-]               [F]
  double c2 = 1.321;                    // Festo fit c2 [-]               [F]
  double reference_pressure = 620e3;    // pressure of the fit's P* = 1 [Pa gauge] [F]
  // Rated maximum operating pressure [Pa gauge]: the experiments never command more
  // (pressure_command_limit). Not enforced by the simulation.  [F] DMSP-20 datasheet: 6 bar
  double max_pressure = 600e3;
};

// Length/pressure hysteresis (P2, P3) and creep (P4).
struct HysteresisParams {
  double pressure_band = 15e3;          // dP_h0 [Pa]                     [E] Hunt et al.: +-15.6 kPa
  double pressure_band_slope = 0.0;     // k_h [-], dP_h grows with P      [E]
  double transition_strain = 0.0075;    // eps_z [-] (0.75 % strain)      [E] 0.5-1 %
  double exponent = 1.5;                // n [-]                          [E] 1-2
  double beta = 0.5;                    // beta [-] in [0, 1]: 0.5 = linear unloading [E]
  double creep_stiffness = 150.0;       // k_c [N/m]                      [E] 1-3 % of stroke
  double creep_time = 4.0;              // tau_c [s]; creep visible over ~10 s [E]
};

// Air, chamber heat-transfer coefficients and pressures (P7, P8).
struct AirParams {
  double gas_constant = 287.0;          // R [J/(kg K)]                   [F]
  double temperature = 293.15;          // T [K] (chamber and supply)     [F]
  double k_in = 1.4;                    // polytropic coefficient, inflow [F]
  double k_out = 1.0;                   // polytropic coefficient, outflow [F]
  double k = 1.2;                       // polytropic coefficient, volume change [F]
  double rho0 = 1.185;                  // ISO 6358 reference density [kg/m^3] [F]
  double t0 = 293.15;                   // ISO 6358 reference temperature [K] [F]
  double supply_pressure = 7e5;         // [Pa abs]                       [F]
  double atmospheric_pressure = 1e5;    // exhaust [Pa abs]               [F]
  double linear_ratio = 0.999;          // p2/p1 above which P8 is linear [F]
};

// Proportional pressure regulator, VPPM class (P9).
struct RegulatorParams {
  double time_constant = 0.05;          // tau [s]                        [E] 30-100 ms
  double dead_time = 0.007;             // [s]                            [E] 5-10 ms
  double max_command = 1.0e6;           // command range 0..10 bar [Pa gauge] [F] VPPM-6L-...-0L10H
  double sonic_conductance = 1.5e-8;    // C [m^3/(s Pa)] of the valve stage [E]
  double critical_ratio = 0.3;          // b [-]                          [E]
  double proportional_band = 20e3;      // p_band [Pa] of full opening    [E]
};

// Fast switching valve pair, MHJ10 class, driven by PWM (P10).
struct SwitchingValveParams {
  double sonic_conductance = 4e-9;      // C [m^3/(s Pa)] of each valve   [F]
  double critical_ratio = 0.38;         // b [-]                          [F]
  double pwm_frequency = 200.0;         // [Hz]                           [E] 100-500 Hz for MHJ
  double on_delay = 1e-3;               // command-to-open delay [s]      [E] ~1 ms
  double off_delay = 1e-3;              // command-to-close delay [s]     [E] ~1 ms
  double min_pulse = 0.0;               // pulses of |d| T <= min_pulse are dropped [s] [E]
};

// Hanging load (P5), with an optional return spring in parallel with its weight.
struct LoadParams {
  // 20 kg: the GPI paper's sinusoid (5..95 mm contraction) is reachable within
  // 0..0.6 MPa (static contraction ~104 mm at 0.6 MPa, 0 at 0 MPa; see docs/plant.md). [E]
  double mass = 20.0;                   // m [kg]                         [E] literature 0-30 kg
  // 400 N s/m: damping ratio ~0.6 at 3 bar. With ~0.15 (100 N s/m) the
  // GPI paper's own PID gains (Table 3) make the simulated load ring at 3 Hz,
  // which that paper's rig did not: real muscles add rubber and braid damping.
  double damping = 400.0;               // c [N s/m]                      [E]
  double gravity = 9.81;                // g [m/s^2]                      [F]
  // A return spring pulling the load back toward the muscle's rest length, as on a
  // horizontal rig (gravity 0) or a spring-loaded one: F_s = spring_preload + spring_rate x,
  // x the contraction. 0 and 0: no spring (the papers' hanging load).
  double spring_rate = 0.0;             // k_s [N/m]                      [E]
  double spring_preload = 0.0;          // F_s0 [N] at x = 0              [E]
};

// P5: the force pulling the load back, its weight plus the return spring's, at contraction x [m].
inline double return_force(const LoadParams& l, double x) noexcept {
  return l.mass * l.gravity + l.spring_preload + l.spring_rate * x;
}

// Sensors (P11). Noise values are standard deviations.
struct SensorParams {
  double pressure_noise = 500.0;        // [Pa]                           [E] 0.3 % FS repeatability
  double pressure_offset = 0.0;         // [Pa]                           [E] within +-2 % FS
  double pressure_range = 1e6;          // full scale 0..10 bar [Pa gauge] [F] SDE1-D10
  int pressure_bits = 12;               // ADC resolution                 [F]
  double pressure_time_constant = 1.4e-3;  // [s]; 3 ms 10-90 % rise     [D]
  double displacement_noise = 1e-5;     // [m] (0.01 mm)                  [F] TEX-0150 repeatability
  double displacement_offset = 0.0;     // [m]                            [E]
  double displacement_range = 0.15;     // [m]                            [F] TEX-0150
  int displacement_bits = 16;           // ADC resolution (PCI-6230)      [F]
};

// Integration (P12).
struct SimulationParams {
  double dt = 1e-4;                     // fixed rig step [s], <= 1e-4    [F] pam-plant.md
  int max_substeps = 64;                // cap on automatic sub-steps     [E]
  // Divergence thresholds: pressure above supply by this fraction, contraction
  // outside [0, eps_max L0] by this distance [m].
  double pressure_tolerance = 0.05;
  double position_tolerance = 1e-3;
};

struct PamRigParams {
  MuscleParams muscle;
  HysteresisParams hysteresis;
  AirParams air;
  RegulatorParams regulator;
  SwitchingValveParams valves;
  LoadParams load;
  SensorParams sensors;
  SimulationParams simulation;
};

// Throws hysteron::Error naming the first offending field (e.g.
// "rig.load.mass = -1: must be > 0") prefixed by `where`.
void validate(const PamRigParams& params, std::string_view where = "rig");

// Rig steps of `dt` in one control period: control_period / dt, which must be a whole number
// within 1..1e12 (to 1e-9 relative) - a period rounded to whole steps would run the loop at
// another rate than the one its controllers are discretised for. Throws hysteron::Error
// "<where>: control_period = ... s is not a whole multiple of the rig's simulation.dt = ... s
// (... steps); the nearest dt that divides it is ... s".
std::int64_t control_steps(double control_period, double dt, std::string_view where);

// JSON: an object with optional sections "muscle", "hysteresis", "air",
// "regulator", "valves", "load", "sensors", "simulation", each an object with
// the field names above. Missing keys keep their default; an unknown key, a
// wrong type, a non-finite or impossible value throws hysteron::Error naming
// `where` and the key path.
PamRigParams rig_params_from_json(const nlohmann::json& j, std::string_view where);
nlohmann::json rig_params_to_json(const PamRigParams& params);
// Every parameter in the order of the JSON form: its path ("load.mass"), value, SI unit ("-":
// dimensionless) and what it must be ("a finite number > 0"). The one table behind validate
// and the JSON form.
struct RigParameter {
  std::string path;
  double value = 0.0;
  std::string unit, rule;
};
std::vector<RigParameter> rig_parameters(const PamRigParams& params);
PamRigParams load_rig_params(const std::filesystem::path& file);
void save_rig_params(const PamRigParams& params, const std::filesystem::path& file);

// ---- physics as free functions (used by the rig, tests and feedforward) ------

// P1: static muscle force [N] at gauge pressure p [Pa] and contraction eps [-].
double festo_force(const MuscleParams& m, double p_gauge, double eps) noexcept;
// P6: chamber volume including the dead volume [m^3], and dV/deps [m^3].
double muscle_volume(const MuscleParams& m, double eps) noexcept;
double muscle_volume_derivative(const MuscleParams& m, double eps) noexcept;
// P8: ISO 6358 mass flow [kg/s] from p_up to p_down [Pa abs] (0 if p_down >= p_up).
double iso6358_mass_flow(double conductance, double critical_ratio, double p_up, double p_down,
                         double t_up, const AirParams& air) noexcept;
// Static equilibrium: contraction [m] where F(p - dP_h z, eps) = return_force(eps L0), clamped to
// the stroke (0 if the muscle cannot lift the load; creep relaxed).
double static_contraction(const PamRigParams& params, double p_gauge, double z = 0.0) noexcept;

// What a rig's parameters imply at rest (`hysteron rig`; P1-P5 with the creep relaxed): the
// static map on the rising (z = +1) and falling (z = -1) branches at 0, 0.1, 0.2 ... MPa up to
// the regulator path's command limit (and at the limit), capped by the supply.
struct RigStatics {
  double stroke_m = 0.0;                // eps_max L0: the hard stop
  double weight_n = 0.0;                // m g
  double return_force_rest_n = 0.0;     // P5 at x = 0 (weight + spring preload)
  double return_force_stroke_n = 0.0;   // P5 at the stroke end
  // The vented load's terminal speed under its return force against the damping, return force /
  // load.damping, at rest and at the stroke end (inf without damping): with the muscle pulling
  // nothing it falls at about these; the creep element's pull (up to creep_stiffness x) and the
  // load's momentum where the spring's force drops add to it for a while.
  double fall_speed_rest_m_s = 0.0;
  double fall_speed_stroke_m_s = 0.0;
  double lift_off_pa = 0.0;             // the least gauge pressure at which the rising branch
                                        // contracts (inf: not within the supply)
  double regulator_limit_pa = 0.0;      // pressure_command_limit(regulator)
  double valves_limit_pa = 0.0;         // pressure_command_limit(switching_valves)
  std::vector<double> pressure_pa, rising_m, falling_m;
  std::string unusable;                 // rig_unusable_reason(params, where): "" if the experiments run
  // The vented muscle after a hold at the top of its reach (rising_m.back()) longer than the creep
  // time (P4: x_c at the top): where its fall stops on the load's time scale, the falling branch at
  // 0 gauge (P2, z = -1) plus the creep element's pull k_c (top - x) against the return force (P5);
  // near falling_m[0] (its rest) where the return force exceeds that pull. Below it the muscle only
  // follows the creep's relaxation, at about creep_return_speed_m_s = the return force at the stall /
  // (load.damping + creep_stiffness x creep_time) (P4 is a spring k_c in series with a dashpot
  // k_c tau_c, in parallel with the load's damping; slower below where a spring's force drops).
  double vented_stall_m = 0.0;
  double creep_return_speed_m_s = 0.0;  // inf without damping and creep stiffness (null in JSON)
  // rig_weak_return_reason(params, *this, where): "" unless the stall lies in the upper half of the
  // reach (docs/plant.md, "A weak return force"); `hysteron rig` warns with it, the experiments note it.
  std::string weak_return;
};
// Keys in `unusable` and `weak_return` (and validate's errors) are named with the prefix `where`
// ("tracking rig": "tracking rig.load.mass").
RigStatics rig_statics(const PamRigParams& params, std::string_view where = "rig");
// The one JSON form of RigStatics (`hysteron rig --json`, Python's rig_statics): its fields by
// name, the static map as three arrays, an infinite speed or lift-off as null.
nlohmann::json rig_statics_to_json(const RigStatics& statics);
// Every parameter's SI unit by its path ("load.mass": "kg"; "-": dimensionless).
nlohmann::json rig_units_to_json();
// Why no reference can be tracked on this rig, empty if one can (the experiments refuse such a
// rig with it; `hysteron rig` warns): nothing extends the vented muscle (no weight and no return
// spring), or the muscle cannot lift its load even at the most pressure it is rated for and
// supplied with. Keys are named with the prefix `where` ("rig": "rig.load.gravity").
std::string rig_unusable_reason(const PamRigParams& params, std::string_view where);
// Why the vented muscle cannot return through its reach at the load's pace, empty if it can: after a
// hold at the top of its reach its fall stalls (RigStatics::vented_stall_m) at half the reach above
// its rest or higher, where the creep element's pull balances the return force; keys are named with
// the prefix `where`. Empty where rig_unusable_reason is not, or the muscle never lifts its load.
std::string rig_weak_return_reason(const PamRigParams& params, const RigStatics& statics, std::string_view where);

// ---- the rig -------------------------------------------------------------------

enum class Actuation { regulator, switching_valves };

// `p` with the parameters that a rig driven only by `mode` never reads replaced by those of
// `other`. Under switching_valves: the regulator's time constant, dead time and command limit
// (P9 acts only on the regulator's setpoint, which no valve flow reads). Under regulator: the
// valves' PWM frequency, switching delays and minimum pulse (P10). The conductances and critical
// ratios of both stages are read under either mode: they set the sub-steps (P12). Two rigs
// that are equal after this give the same outputs, bit for bit, under that mode (test_plant.cpp
// checks it), so a sweep runs such a variant once (sweep.cpp). muscle.max_pressure, which the
// rig never reads, is kept: the experiments read it (pressure_command_limit).
PamRigParams with_unread_parameters_of(PamRigParams p, Actuation mode, const PamRigParams& other);

// The most pressure a controller may command on the rig under `mode` [Pa gauge]: the muscle's
// rated maximum (muscle.max_pressure), and under regulator also the end of the regulator's
// command range (regulator.max_command); the switching valves have no command range.
double pressure_command_limit(const PamRigParams& p, Actuation mode) noexcept;

struct RigInputs {
  double pressure_command = 0.0;  // regulator setpoint [MPa gauge] (regulator mode)
  double pwm_duty = 0.0;          // [-1, 1]; > 0 inlet, < 0 exhaust (switching mode)
  Actuation mode = Actuation::regulator;
};

struct RigOutputs {
  double time = 0.0;                  // at the end of the step [s]
  double contraction = 0.0;           // true shortening x [m]
  double contraction_measured = 0.0;  // sensor reading [m]
  double velocity = 0.0;              // dx/dt [m/s]
  double pressure = 0.0;              // true chamber pressure [Pa gauge]
  double pressure_measured = 0.0;     // sensor reading [Pa gauge]
  bool inlet_open = false;            // switching valves at the end of the step
  bool exhaust_open = false;
  bool ok = true;                     // false once the simulation diverged
};

// The full continuous state (for initial conditions, inspection and fault injection).
struct RigState {
  double pressure = 1e5;       // chamber [Pa abs]
  double contraction = 0.0;    // x [m]
  double velocity = 0.0;       // v [m/s]
  double bouc_wen = 0.0;       // z [-]
  double creep = 0.0;          // x_c [m]
  double regulator_setpoint = 0.0;  // lagged regulator setpoint [Pa gauge]
};

class PamRig {
 public:
  // Validates the parameters (throws hysteron::Error) and sizes all storage.
  PamRig(PamRigParams params, std::uint64_t seed);

  // Vented muscle at rest at full length, t = 0, sensors and RNG re-seeded.
  void reset() noexcept;
  // As reset(), then at static equilibrium at gauge pressure p [Pa] (regulator
  // setpoint and dead-time buffer filled with p, z = 0, creep relaxed).
  void reset_at_pressure(double p_gauge) noexcept;

  // One rig step of dt. Never allocates or throws. A non-finite input is
  // replaced by the previous one and counted in input_faults().
  RigOutputs step(const RigInputs& in) noexcept;

  // Calls controller(const RigOutputs& last) -> RigInputs every `control_period`
  // seconds (a whole multiple of dt, see control_steps; else throws), holds its
  // inputs in between, and observer(const RigInputs&, const RigOutputs&) after
  // every rig step, for `duration` seconds. Throws hysteron::Error (via check())
  // if the simulation diverges. Returns the last outputs.
  template <class Controller, class Observer>
  RigOutputs run(double duration, double control_period, Controller&& controller,
                 Observer&& observer);
  // As above without an observer: the steps between control samples skip the sensors'
  // outputs (their filter and noise stream advance as in step()), so the controller and the
  // returned outputs see exactly what they would see with an observer.
  template <class Controller>
  RigOutputs run(double duration, double control_period, Controller&& controller) {
    return run(duration, control_period, controller, Unobserved{});
  }

  bool ok() const noexcept { return ok_; }
  // Throws hysteron::Error "PamRig diverged at t = ... s: <reason>; state: ..." if !ok().
  void check() const;

  const PamRigParams& params() const noexcept { return p_; }
  double time() const noexcept { return static_cast<double>(n_) * p_.simulation.dt; }
  double dt() const noexcept { return p_.simulation.dt; }
  std::uint64_t seed() const noexcept { return seed_; }
  const RigState& state() const noexcept { return s_; }
  // Overwrites the state without validation; a non-physical state is caught
  // by the divergence check of the next step.
  void set_state(const RigState& s) noexcept { s_ = s; }
  const RigOutputs& last_outputs() const noexcept { return out_; }
  std::size_t input_faults() const noexcept { return input_faults_; }
  // Pneumatic sub-steps per step (1 with the defaults).
  int substeps() const noexcept { return substeps_; }

 private:
  struct Deriv;
  struct Flow {  // conductance-scaled flow commands for one sub-interval
    double reg_opening = 0.0;  // regulator mode: set from the state
    bool regulator = false;
    bool inlet = false;
    bool exhaust = false;
  };
  struct Unobserved {
    void operator()(const RigInputs&, const RigOutputs&) const noexcept {}
  };
  void advance(const RigInputs& in) noexcept;          // step() without its outputs
  void step_unobserved(const RigInputs& in) noexcept;  // step() whose outputs nobody reads
  void set_valve_flags() noexcept;
  void derivative(const RigState& s, const Flow& f, double p_set, Deriv& d) const noexcept;
  void integrate(double h, const Flow& f) noexcept;
  void apply_stops() noexcept;
  bool valve_open(bool inlet, double t) const noexcept;
  double gaussian() noexcept;
  double quantize(double v, double range, double lsb) const noexcept;
  void detect_divergence() noexcept;
  void measure() noexcept;

  PamRigParams p_;
  std::uint64_t seed_;
  std::mt19937_64 rng_;
  double spare_gauss_ = 0.0;
  bool has_spare_ = false;

  RigState s_;
  std::int64_t n_ = 0;  // steps taken
  RigOutputs out_;
  RigInputs last_in_;
  bool ok_ = true;
  std::size_t input_faults_ = 0;
  std::string_view fault_reason_ = "";

  // regulator dead time: ring buffer of past commands [Pa gauge]
  std::vector<double> delay_;
  std::size_t delay_pos_ = 0;
  double reg_alpha_ = 0.0;  // 1 - exp(-dt / tau)
  double volume_scale_ = 0.0, volume_c2_ = 0.0;  // P6's constants, computed once
  double root_t_ = 1.0;                          // sqrt(T0 / T) of P8
  double lsb_pressure_ = 0.0, lsb_displacement_ = 0.0;  // P11's quantisation steps

  // PWM: duty latched for the last three periods, indexed by period mod 3
  double pwm_period_ = 0.0;
  std::int64_t pwm_index_ = -1;  // latest latched period
  std::array<double, 3> duty_{};

  // sensor filter
  double p_filtered_ = 0.0;
  double sensor_alpha_ = 1.0;
  int substeps_ = 1;
};

template <class Controller, class Observer>
RigOutputs PamRig::run(double duration, double control_period, Controller&& controller,
                       Observer&& observer) {
  check();
  const double h = p_.simulation.dt;
  const auto steps = static_cast<std::int64_t>(duration / h + 0.5);
  const std::int64_t every = control_steps(control_period, h, "PamRig::run");
  RigInputs in = last_in_;
  constexpr bool observed = !std::is_same_v<std::remove_cvref_t<Observer>, Unobserved>;
  for (std::int64_t k = 0; k < steps; ++k) {
    if (k % every == 0) in = controller(static_cast<const RigOutputs&>(out_));
    if (observed || (k + 1) % every == 0 || k + 1 == steps) {
      const RigOutputs& y = step(in);
      observer(static_cast<const RigInputs&>(in), y);
    } else {
      step_unobserved(in);
    }
    if (!ok_) check();
  }
  return out_;
}

}  // namespace hysteron
