#pragma once
// The three papers' experiments, end to end on the simulated rig: an
// identification run, the fit of the paper's model, validation on the minor
// loops, and tracking runs with
//   faithful    - the paper's scheme as published (its structure and gains),
//   compensated - hysteron's best variant of it,
//   baseline    - the same loop without hysteresis compensation (the inverse
//                 model replaced by a straight line fitted to the same data).
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

struct ExperimentOptions {
  std::string name = "gpi-pid";  // gpi-pid | mpi-openloop | mpi-pwm
  PamRigParams rig{};            // the simulated rig (defaults: nominal, with sensor noise)
  std::uint64_t seed = 1;        // rig noise seed; a run is reproducible bit for bit
  double control_period = 1e-3;  // controller and logging period [s]
  void validate() const;         // throws hysteron::Error
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
  TrackingErrors errors;  // reference vs measured contraction
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

std::vector<std::string> experiment_names();
// Throws hysteron::Error on invalid options or a diverging rig.
ExperimentResult run_experiment(const ExperimentOptions& options);

}  // namespace hysteron
