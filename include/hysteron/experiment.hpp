#pragma once
// The three papers' experiments, end to end on the simulated rig: an
// identification run, the fit of the paper's model, validation on the minor
// loops, and tracking runs with
//   faithful    - the paper's scheme as published (its structure and gains),
//   compensated - hysteron's best variant of it, every gain and lead derived
//                 from the identification run of the rig at hand (docs/control.md),
//   learning    - the compensated loop plus iterative learning control across
//                 the periods of a periodic reference (docs/control.md),
//   baseline    - the same loop without hysteresis compensation (the inverse
//                 model replaced by a straight line fitted to the same data).
// Each experiment is a spec in its own file under src/experiment/, registered
// in one place (experiments() lists them with their variants).
//
//   gpi-pid      gpi-lm-feedforward-pid.txt: GPI (n = 10) fitted by LM on the
//                major loop of the Fig. 4 input; inverse feedforward + PID of
//                Table 3 (Fig. 10) tracking Eq. 18 / Table 4; published Table 5.
//   mpi-openloop mpi-asymmetric-openloop.txt: asymmetric MPI (20 operators)
//                on the 0.5..0.3 MPa input; open-loop inverse + proportional
//                pressure loop; triangle and sine references 40/35/30 mm;
//                published maximum errors 1.29 mm (triangle), 1.38 mm (sine).
//   mpi-pwm      mpi-deadzone-switching-valves.txt: dead-zone MPI by LM;
//                cascade with fast switching valves (outer position loop with
//                inverse feedforward, inner pressure loop driving PWM). The
//                paper's text is truncated before its results: no published figures.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/identify.hpp"
#include "hysteron/plant.hpp"

namespace hysteron {

// One registered experiment (names and descriptions for the CLI, Python and reports).
struct ExperimentInfo {
  std::string name;                   // e.g. "gpi-pid"
  std::string title;                  // one line
  std::string summary;                // a few sentences: model, loop, references
  std::vector<std::string> variants;  // e.g. faithful, compensated, learning, baseline
  std::string published_source;       // "" where the paper gives no figures
};
const std::vector<ExperimentInfo>& experiments();
std::vector<std::string> experiment_names();

struct ExperimentOptions {
  std::string name = "gpi-pid";  // one of experiment_names()
  PamRigParams rig{};            // the simulated rig (defaults: nominal, with sensor noise)
  std::uint64_t seed = 1;        // rig noise seed; a run is reproducible bit for bit
  double control_period = 1e-3;  // controller and logging period [s]
  int learning_periods = 10;     // periods of the learning variant (0: no learning runs), 0..1000
  void validate() const;         // throws hysteron::Error
};

// Dynamics of the rig from the commanded pressure to the measured contraction,
// identified on the identification run (first order plus dead time around the
// fitted hysteresis model M, which is rate-independent, so the shift commutes):
//   x(t) ~ lag_tau[ M(p_cmd) ](t - theta),   tau dz/dt = M(p_cmd) - z
struct RigDynamics {
  double dead_time_s = 0.0;    // theta
  double lag_s = 0.0;          // tau
  double gain_m_per_mpa = 0.0; // mean slope of the record: contraction span / pressure span
  double rms_mm = 0.0;         // RMS of the fit of this model to the record
  // Valve experiments: relay test of the pressure loop (duty +-h around 0.3 MPa):
  // ultimate gain K_u = 4 h / (pi sqrt(a^2 - eps^2)) [duty/MPa] and period T_u [s]; 0 if not run.
  double relay_gain = 0.0;
  double relay_period_s = 0.0;
  // Relay test of the position loop (pressure p0 +- 0.05 MPa switched on the measured
  // contraction around its level at p0): ultimate gain [MPa/m] and period [s]. It sees
  // the load's mode, which the slow identification run does not.
  double position_relay_gain = 0.0;
  double position_relay_period_s = 0.0;
  // The load's mode that puts the relay's point on the FOPDT: G = FOPDT * w_n^2 /
  // (s^2 + 2 zeta w_n s + w_n^2) with G(i w_u) = -1 / K_u (0: no mode fits).
  double mode_frequency_hz = 0.0;
  double mode_damping = 0.0;
};

struct TrackingErrors {
  double max_error_mm = 0.0;
  double mae_mm = 0.0;
  double rms_error_mm = 0.0;
};

// One tracking run, logged at the control period.
struct TrackingRun {
  std::string variant;    // faithful | compensated | baseline
  std::string reference;  // e.g. "sine", "triangle"
  std::string description;
  std::vector<double> t, reference_mm, measured_mm, actual_mm, pressure_command_mpa, pressure_mpa, duty;
  TrackingErrors errors;  // reference vs measured contraction (the last period of a learning run)
  std::vector<TrackingErrors> periods;  // learning runs: the errors of each period, in order
  std::size_t saturated = 0;  // control samples with the command at a pressure limit
};

// A paper's published tracking errors for one reference (NaN where it gives none).
struct PublishedErrors {
  std::string reference;  // "" when the experiment has a single reference
  double max_error_mm = std::numeric_limits<double>::quiet_NaN();
  double mae_mm = std::numeric_limits<double>::quiet_NaN();
  double rms_error_mm = std::numeric_limits<double>::quiet_NaN();
  bool operator==(const PublishedErrors&) const = default;
};

// The paper's figures; errors empty where the paper gives none.
struct PublishedFigures {
  std::string source;  // e.g. "gpi-lm-feedforward-pid.txt, Table 5"
  std::vector<PublishedErrors> errors;
  bool empty() const noexcept { return errors.empty(); }
  // The figures for `reference` (or the single reference's), nullptr if none.
  const PublishedErrors* find(const std::string& reference) const noexcept;
};

struct ExperimentResult {
  std::string name;
  std::string title;
  std::uint64_t seed = 0;
  // identification run (logged at the control period)
  std::vector<double> id_t, id_pressure_command_mpa, id_pressure_mpa, id_contraction_mm;
  std::size_t id_train_end = 0;   // samples [0, id_train_end) are the major loop
  FitReport fit;                  // the paper's model, fitted on the major loop
  FitMetrics validation;          // ... on the minor loops
  FitReport best_fit;             // hysteron's model for the compensated variant
  FitMetrics best_validation;     // on a second identification run (other seed)
  ModelParams baseline_model;     // the straight line of the baseline
  double lead_s = 0.0;            // preview of the compensated variants (identified)
  RigDynamics dynamics;           // identified from the identification run
  std::vector<std::string> messages;  // notes of the run (e.g. a candidate model skipped)
  std::vector<TrackingRun> runs;
  PublishedFigures published;     // the paper's figures (empty where it gives none)
  double wall_time_s = 0.0;

  // Summary as in the CLI's --json: compensated/faithful/baseline objects with
  // max_error_mm, mae_mm, rms_error_mm (keyed by reference where there are several).
  // The same as io::to_json(result) (hysteron/io/results.hpp, where it is defined).
  nlohmann::json to_json() const;
  // Writes identification.csv, tracking_<variant>_<reference>.csv, the models and
  // result.json into dir (created if needed), each file atomically.
  void write(const std::string& dir) const;
  // Human-readable table beside the paper's figures.
  std::string table() const;
};

// Throws hysteron::Error on invalid options or a diverging rig.
ExperimentResult run_experiment(const ExperimentOptions& options);

}  // namespace hysteron
