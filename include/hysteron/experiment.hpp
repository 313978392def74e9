#pragma once
// The three papers' experiments, end to end on the simulated rig: an
// identification run, the fit of the paper's model, validation on the minor
// loops, and tracking runs with
//   faithful    - the paper's scheme as published (its structure and gains),
//   compensated - hysteron's best variant of it, every gain and lead derived
//                 from the identification run of the rig at hand (docs/control.md),
//   learning    - the compensated loop plus iterative learning control across
//                 the periods of a periodic reference (docs/control.md),
//   adaptive    - the compensated loop with the inverse model's weights
//                 re-identified online by RLS with forgetting, kept invertible
//                 (AdaptiveInverse below, docs/control.md),
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
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/compensation.hpp"
#include "hysteron/control.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"  // LoopDesign, make_controller, feedforward_preview
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

// [s] The longest control period an experiment accepts (100 Hz). The identification run is
// logged at the control period, and the papers' fits need 10 samples per parameter of it:
// mpi-openloop's 29-parameter fit had too few above 0.0172 s (a demo at 0.02 s wrote gpi-pid and
// then failed); at 0.02 s the learning design's floor no longer fitted in gpi-pid's period.
inline constexpr double kMaxControlPeriod = 0.01;
// Refuses (hysteron::Error) a control period outside [dt, kMaxControlPeriod] or not a whole number
// of the rig's steps dt (control_steps): "<where>: control_period = ... s must be within [<rig> dt
// = ... s, 0.01 s]" or "<where>: <rig>: control_period = ... s is not a whole multiple ...". One
// check for the experiment's rig and tracking rig and a sweep's base and variant rigs.
void check_control_period(double control_period, double dt, std::string_view where, std::string_view rig);

// A reference of the user's own (ExperimentOptions::references; `hysteron experiment --reference
// SPEC`, Python run_experiment(references=[SPEC, ...]); docs/control.md, section 8).
// SPEC (contractions in mm, from the muscle at rest):
//   sine:amplitude=A,offset=O,frequency=F,periods=N      x(t) = O - A cos(2 pi F t): the papers'
//       sine (Eq. 18 as a contraction, gpi_sinusoid_reference), centre O, from its bottom O - A;
//   triangle:amplitude=A,offset=O,frequency=F,periods=N  from O - A up to O + A and back, N times;
//   file:PATH[,time=COL][,contraction=COL][,periodic][,periods=N]  a record (CSV or .mat, read
//       as fit reads one): the time column (default column 0) in s (or the unit its header
//       names: "t [ms]"), strictly increasing, and the contraction column (default column 1) in
//       mm (or the length unit its header names), each a header name or a 0-based index;
//       linearly interpolated at the control period from its first time stamp (shifted to 0).
//       Not periodic (no learning run) unless `periodic`: the record is then one period, its
//       last sample closing it (equal to its first within 1 % of its span), tracked N times.
// Every kind takes `name=NAME` (letters, digits, '-', '_'): the name in the CSV files, the
// table and result.json; default the kind, or refN (N its place among the references) where
// two share a kind. Each is preceded by the pre-roll of the papers' references (kPreRollS).
struct UserReference {
  enum class Kind { sine, triangle, file };
  Kind kind = Kind::sine;
  std::string name;    // unique among the references
  std::string origin;  // where it was given, for errors: "--reference 'sine:...'"
  double amplitude_mm = 0.0, offset_mm = 0.0, frequency_hz = 0.0;  // sine, triangle
  int periods = 1;     // sine, triangle; a periodic file
  std::string path;    // file: the record, its samples below (time from 0 [s], contraction [mm])
  std::vector<double> t_s, x_mm;
  bool periodic = true;  // a file: only with `periodic`
  // A file whose time column's unit nothing gave (no header unit, no time_unit=): its duration,
  // samples and "time read as s" (run_experiment adds it to the result's notes); else empty.
  std::string note;
};
// Parses the SPECs in order (default names as above); `option` names them in errors
// ("--reference"; Python "references"). Reads a file reference's record. Throws hysteron::Error
// naming the option, the spec and the key at fault (an unknown or missing key, a value that is
// not a finite number, frequency <= 0, periods < 1, amplitude < 0, a duplicate name).
std::vector<UserReference> parse_references(const std::vector<std::string>& specs,
                                            std::string_view option = "--reference");
// The PATH of a file:PATH[,...] SPEC (trimmed), as parse_references reads it, without reading it;
// nullopt for a sine, a triangle or a spec parse_references refuses for its kind or an empty PATH.
std::optional<std::string> reference_file_path(std::string_view spec);
// [samples] The fewest control periods a user reference's period may span (a sine or triangle),
// and the most a file reference's record may deviate from its resampling at the control period
// [fraction of its span]: a trajectory finer than the loop's period is refused, not smoothed.
inline constexpr double kMinReferencePeriodSamples = 50.0;
inline constexpr double kReferenceResolution = 0.01;
// [s] The longest user reference (the runs log every control period).
inline constexpr double kMaxReferenceSeconds = 3600.0;
// [s] The longest learning run on a user reference: learning_periods x its period (the run logs
// every control period; ExperimentOptions::validate refuses more).
inline constexpr double kMaxLearningSeconds = 3600.0;

struct ExperimentOptions {
  std::string name = "gpi-pid";  // one of experiment_names()
  PamRigParams rig{};            // the simulated rig (defaults: nominal, with sensor noise)
  std::uint64_t seed = 1;        // rig noise seed; a run is reproducible bit for bit
  double control_period = 1e-3;  // controller and logging period [s], within [rig dt, kMaxControlPeriod]
  int learning_periods = 10;     // periods of the learning variant (0: no learning runs), 0..1000
  bool adaptive = true;          // run the adaptive variant (where the experiment has one)
  // The rig of the tracking runs if it differs from the identified one (a rig that changed
  // after its identification: wear, temperature, another load); unset: the same rig.
  std::optional<PamRigParams> tracking_rig;
  // The kind of hysteron's model, the one the compensated, learning and adaptive variants
  // invert (the faithful variant always uses the paper's model):
  //   FitModel::automatic (default): every kind of fit_model_kinds is fitted on the
  //     identification run; the one with the least RMS on a second identification run
  //     (other seed, other pressure sequence) is used. A kind that cannot be fitted or
  //     inverted is skipped with a note in ExperimentResult::messages.
  //   one kind of fit_model_kinds: only that one; run_experiment throws hysteron::Error
  //     naming the kind if it cannot be fitted or inverted.
  // The adaptive variant needs the PI family (AdaptiveInverse): for another kind it is
  // skipped with a note saying so.
  FitModel model = FitModel::automatic;
  // Keep every reference within the rig's reach, measured on its identification run: from
  // the contraction at rest to the contraction on its ascent at 95 % of the actuator's limit
  // (ExperimentResult::pressure_limit_mpa, 0.6 MPa on the nominal rig; 5 % kept as headroom for
  // the position loop). A reference that leaves it is
  // mapped affinely onto its intersection with the reach (only the end that leaves it
  // moves), and the result says so (ExperimentResult::reference_ranges, messages).
  // false: the papers' references as published, with a note where they are out of reach
  // (the error there is the actuator's limit, not the controller's). docs/control.md, 5.
  bool fit_references = true;
  // The gain trial (GainTrial) runs every candidate to its end. false: a candidate is stopped
  // once its squared error exceeds the best one's so far, the likeliest candidates first; the
  // choice is the same, the stopped candidates' RMS are lower bounds (GainTrial::early_stop).
  // hysteron sweep sets it: it reports the choice only.
  bool complete_gain_trials = true;
  // With FitModel::automatic and the adaptive variant, auto chooses among the PI family only,
  // and the other kinds are fitted for comparison (ExperimentResult::candidates). false: they
  // are not fitted (listed as such); the choice is the same. hysteron sweep sets it.
  bool fit_ineligible_candidates = true;
  // The references tracked instead of the experiment's own (the paper's) where not empty
  // (UserReference, parse_references). Every mechanism applies as to a paper's: the reach
  // mapping (fit_references), the model's identification range, the gain trial, learning
  // (periodic references only: a note for the others); no published figures (NaN).
  std::vector<UserReference> references;
  // Threads of each fit (FitOptions::num_threads; 0: one per usable CPU). The result does not
  // depend on it; hysteron sweep sets 1, its runs being its threads.
  int fit_threads = 0;
  // Optional: asked (thread-safe) between the runs on the rig, every few thousand samples of a
  // run and inside the fits (FitOptions::stop_requested). Once it returns true the experiment is
  // abandoned and run_experiment throws hysteron::Stopped: a stopped experiment has no result.
  std::function<bool()> stop_requested;
  void validate() const;         // throws hysteron::Error
};

// A reference as the paper defines it and as it was tracked on this rig [mm].
struct ReferenceRange {
  std::string reference;
  double paper_min_mm = 0.0, paper_max_mm = 0.0;  // as published (a user reference: as given)
  double min_mm = 0.0, max_mm = 0.0;              // as tracked (the paper's unless scaled)
  bool scaled = false;        // mapped into the rig's reach (ExperimentOptions::fit_references)
  bool reachable = true;      // the tracked reference lies within the reach (with its margin)
  bool operator==(const ReferenceRange&) const = default;
};

// Dynamics of the rig from the commanded pressure to the measured contraction,
// identified on the identification run (first order plus dead time around the
// fitted hysteresis model M, which is rate-independent, so the shift commutes):
//   x(t) ~ lag_tau[ M(p_cmd) ](t - theta),   tau dz/dt = M(p_cmd) - z
struct RigDynamics {
  // theta and tau as fitted; where the fit has more phase lag at the position relay's frequency
  // than the relay measured and no mode explains it, split again, their sum kept, to reach
  // -180 degrees there (a note says so).
  double dead_time_s = 0.0;    // theta
  double lag_s = 0.0;          // tau
  double gain_m_per_mpa = 0.0; // mean slope of the record: contraction span / pressure span
  double rms_mm = 0.0;         // RMS of the fit of this model to the record
  // Valve experiments: relay test of the pressure loop (duty +-h around relay_level_mpa):
  // ultimate gain K_u = 4 h / (pi sqrt(a^2 - eps^2)) [duty/MPa] and period T_u [s]; 0 if not run.
  double relay_gain = 0.0;
  double relay_period_s = 0.0;
  // Relay test of the position loop (pressure p0 +- h switched on the measured contraction
  // around its level at p0; h = 0.05 MPa, doubled while the muscle does not oscillate):
  // ultimate gain [MPa/m], period [s] and the amplitude h used [MPa]. It sees the load's
  // mode, which the slow identification run does not.
  double position_relay_gain = 0.0;
  double position_relay_period_s = 0.0;
  double position_relay_amplitude_mpa = 0.0;
  // The relay's hysteresis eps [m]: 3 sigma of the contraction sensor's noise, sigma from the
  // first differences of the reading at p0 (so the load still settling does not count).
  double position_relay_hysteresis_m = 0.0;
  // The load's mode that puts the relay's point on the FOPDT: G = FOPDT * w_n^2 /
  // (s^2 + 2 zeta w_n s + w_n^2) with G(i w_u) = -1 / K_u (0: no mode fits).
  double mode_frequency_hz = 0.0;
  double mode_damping = 0.0;
  // The pressures the relays switched around [MPa] (position, and the valves' pressure relay;
  // 0 if not run): 0.3, the middle of the actuator's 0..0.6 MPa (half the run's limit where that
  // is below 0.6 MPa, ExperimentResult::pressure_limit_mpa), or half the top the rig
  // reaches where its supply caps it below that (docs/control.md, section 1).
  double position_relay_level_mpa = 0.0;
  double relay_level_mpa = 0.0;
  // The valves' relay amplitude h [duty]: 0.5, or 1 where the valves did not open at 0.5 (a
  // minimum pulse or opening delay longer than half the PWM period); 0 if not run.
  double relay_duty = 0.0;
  bool operator==(const RigDynamics&) const = default;
};

struct TrackingErrors {
  double max_error_mm = 0.0;
  double mae_mm = 0.0;
  double rms_error_mm = 0.0;
};

// One identification run, logged at the control period, through the actuator of the
// experiment's hysteron variants (the regulator, with mpi-openloop's pressure loop, or
// mpi-pwm's valves behind their pressure PI). Written as identification.csv and
// model_identification.csv, with these names as columns.
struct IdentificationRun {
  std::vector<double> t;                     // [s]
  std::vector<double> pressure_command_mpa;  // the desired pressure [MPa]
  std::vector<double> pressure_mpa;          // measured [MPa]
  std::vector<double> contraction_mm;        // measured [mm]
  bool empty() const noexcept { return t.empty(); }
  std::size_t size() const noexcept { return t.size(); }
  bool operator==(const IdentificationRun&) const = default;
};

// One tracking run, logged at the control period.
struct TrackingRun {
  std::string variant;    // faithful | compensated | baseline
  std::string reference;  // e.g. "sine", "triangle"
  std::string description;
  LoopDesign controller;  // the loop's numbers (result.json "controller")
  // learning runs: the correction [mm] added to the reference at every sample (empty otherwise)
  std::vector<double> correction_mm;
  std::vector<double> t, reference_mm, measured_mm, actual_mm, pressure_command_mpa, pressure_mpa, duty;
  // The pressure sensor's reading the loop was given [MPa gauge] (pressure_mpa is the true
  // pressure): with reference_mm and measured_mm, what a loop rebuilt from `controller` is fed.
  // Empty when read from a directory written before it was recorded.
  std::vector<double> pressure_measured_mpa;
  TrackingErrors errors;  // reference vs measured contraction (the last period of a learning run)
  std::vector<TrackingErrors> periods;  // learning runs: the errors of each period, in order
  // scored control samples (those `errors` is over) with the command at a pressure limit: 0 or the
  // run's limit (before 2026-12-01, twenty-seventh session: every sample of the run, the pre-roll,
  // warm-up and a learning run's earlier periods included)
  std::size_t saturated = 0;
  // time [s] of the first scored sample: after a warm-up period or a pre-roll (the rig starts
  // vented, docs/control.md section 5); a learning run: the start of its last period
  double scored_from_s = 0.0;
};

// A paper's published tracking errors for one reference (NaN where it gives none).
struct PublishedErrors {
  std::string reference;  // "" when the experiment has a single reference
  double max_error_mm = std::numeric_limits<double>::quiet_NaN();
  double mae_mm = std::numeric_limits<double>::quiet_NaN();
  double rms_error_mm = std::numeric_limits<double>::quiet_NaN();
  bool operator==(const PublishedErrors&) const = default;
};

// The source of the published figures of a run on the user's references (--reference): none.
inline constexpr std::string_view kUserReferencesSource =
    "none: the user's references (--reference), which no paper tracked";

// The paper's figures; errors empty where the paper gives none.
struct PublishedFigures {
  std::string source;  // e.g. "gpi-lm-feedforward-pid.txt, Table 5"; kUserReferencesSource
  std::vector<PublishedErrors> errors;
  bool empty() const noexcept { return errors.empty(); }
  // The references were the user's (--reference), tracked in no paper (read back from result.json too).
  bool of_user_references() const noexcept { return source == kUserReferencesSource; }
  // The figures for `reference` (or the single reference's), nullptr if none.
  const PublishedErrors* find(const std::string& reference) const noexcept;
};

// One candidate for hysteron's model (ExperimentResult::candidates).
struct ModelCandidate {
  FitModel kind = FitModel::gpi;
  bool ok = false;          // fitted, invertible and scored on the second identification run
  FitStatus status = FitStatus::not_run;  // of its fit
  std::string message;      // why it was skipped (!ok), else the fit's message
  FitMetrics validation;    // on the second identification run (ok only)
  double fit_time_s = 0.0;  // wall time of its fit
  bool chosen = false;      // it is best_fit
};

// The gain trial of one reference (docs/control.md, section 2): the compensated loop, with
// its position PID's Ziegler-Nichols gains (K_p, K_i, K_d) scaled by each of `scales`, tracks
// a trapezoid over the reference's range at its largest speed on the rig; the scale with the
// least RMS error (measured contraction) is used by the compensated and adaptive variants.
// Where a load mode was identified, each scale is also tried with the feedforward's preview
// passed through a zero-vibration shaper at that mode (docs/control.md, section 2).
struct GainTrial {
  std::string reference;
  std::vector<double> scales;         // tried, ascending
  std::vector<double> rms_mm;         // RMS error of each on the trapezoid (+inf: the rig diverged)
  std::vector<double> rms_shaped_mm;  // ... with the shaped feedforward (empty: no shaper)
  double scale = 1.0;                 // the chosen scale
  bool shaped = false;                // the chosen loop shapes its feedforward
  // Candidates worse than the best were stopped early (ExperimentOptions::complete_gain_trials
  // = false): their RMS are lower bounds, from the samples before the stop.
  bool early_stop = false;
  bool operator==(const GainTrial&) const = default;
};

// Whether a run's variant is one of hysteron's own loops (compensated, learning, adaptive): those
// ExperimentResult::not_below_baseline() holds against the baseline (a sweep's records mark them).
bool is_hysterons_loop(std::string_view variant) noexcept;

struct ExperimentResult {
  std::string name;
  std::string title;
  std::uint64_t seed = 0;
  // The controller's period of every run [s] (ExperimentOptions::control_period); results written
  // before it was recorded read it from their runs' "controller" (sample_time_s), else 1 ms.
  double control_period_s = 1e-3;
  IdentificationRun identification;  // the paper's identification input, run on this rig
  std::size_t id_train_end = 0;   // samples [0, id_train_end) are the major loop
  FitReport fit;                  // the paper's model, fitted on the major loop
  FitMetrics validation;          // ... on the minor loops
  FitReport best_fit;             // hysteron's model for the compensated variant
  FitMetrics best_validation;     // on a second identification run (other seed)
  // How best_fit was chosen: ExperimentOptions::model of the run (automatic or the kind
  // asked for), every candidate tried (in the order fitted; in auto mode the chosen one has
  // the least validation RMS among those ok), and one line saying which and why.
  FitModel model_choice = FitModel::automatic;
  std::vector<ModelCandidate> candidates;
  std::string model_reason;
  ModelParams baseline_model;     // the straight line of the baseline
  double lead_s = 0.0;            // preview of the compensated variants (identified)
  // The top of the pressure inputs hysteron's model was identified on [MPa]: 0 where they are
  // the paper's, else the pressure the references need plus headroom (docs/control.md,
  // section 0), below the paper's input's maximum.
  double model_id_top_mpa = 0.0;
  // The actuator's limit of every run [MPa]: no pressure command left 0..pressure_limit_mpa.
  // pressure_command_limit of the rig (and of the tracking rig, the less) under the
  // experiment's actuation: 0.6 on the nominal rig (the DMSP-20's rating, the papers' range).
  double pressure_limit_mpa = 0.6;
  // The identification run hysteron's model (best_fit) was fitted on, where it is not the
  // paper's run above (model_id_top_mpa > 0: the paper's input scaled to the references'
  // pressures, or extended to the actuator's top); empty where it is the paper's run. write()
  // puts it into model_identification.csv.
  IdentificationRun model_identification;
  RigDynamics dynamics;           // identified from the identification run
  // The contraction the rig reached in the identification run (min and max of an 11 ms
  // moving mean of the measurement: 11 samples at 1 ms) [mm]; NaN in results written before it existed.
  double reach_min_mm = std::numeric_limits<double>::quiet_NaN();
  double reach_max_mm = std::numeric_limits<double>::quiet_NaN();
  // The top of the reach: the least contraction at or above reach_top_pressure_mpa on the
  // identification run (NaN if the run never got there) [mm], that pressure (95 % of the
  // actuator's top pressure: pressure_limit_mpa, or the most the measured pressure reached where the
  // supply caps it below) [MPa], and the most the measured pressure reached (11 ms mean)
  // [MPa]; NaN in results written before them.
  double reach_top_mm = std::numeric_limits<double>::quiet_NaN();
  double reach_top_pressure_mpa = std::numeric_limits<double>::quiet_NaN();
  double reach_pressure_max_mpa = std::numeric_limits<double>::quiet_NaN();
  std::vector<ReferenceRange> reference_ranges;  // one per reference, in the order run
  std::vector<GainTrial> gain_trials;            // one per reference with a compensated loop
  std::vector<std::string> messages;  // notes of the run (e.g. a candidate model skipped)
  std::vector<TrackingRun> runs;
  PublishedFigures published;     // the paper's figures (empty where it gives none)
  double wall_time_s = 0.0;

  // Summary as in the CLI's --json: compensated/faithful/baseline objects with
  // max_error_mm, mae_mm, rms_error_mm (keyed by reference where there are several).
  // The same as io::to_json(result) (hysteron/io/results.hpp, where it is defined).
  nlohmann::json to_json() const;
  // Writes identification.csv, model_identification.csv (where model_identification is not empty),
  // tracking_<variant>_<reference>.csv, the models and result.json into dir (created if
  // needed), each file atomically (io::write_file_atomically) and all together
  // (io::FileBatch): every file is complete before the first is replaced, so
  // on an error (Error names the file) nothing in dir has changed. Where dir held an earlier
  // run (its result.json), that run's files this one does not have (tracking CSVs of variants
  // it did not run, report.html, which described it) are removed afterwards; other files in
  // dir are left alone.
  void write(const std::string& dir) const;
  // Several runs written as write() writes one, results[i] into dirs[i], but in one io::FileBatch:
  // every file of every run is complete before the first is replaced, so an error, or a signal
  // (Ctrl-C) the CLI handles, before the end leaves every directory as it was (`hysteron demo`).
  // also(i, dir), if given, writes further files of run i into its dir inside the batch and
  // returns their names (report.html), which are then not removed as stale.
  static void write_all(const std::vector<const ExperimentResult*>& results, const std::vector<std::string>& dirs,
                        const std::function<std::vector<std::string>(std::size_t, const std::string&)>& also = {});
  // True for the names of the files write() and `hysteron experiment` put into an output
  // directory: identification.csv, model_identification.csv, model.json, best_model.json,
  // result.json, report.html and tracking_*.csv.
  static bool is_output_file(const std::string& filename);
  // The files of the run's inputs (its file references' records, ExperimentOptions::references):
  // write() refuses (hysteron::Error, nothing written) where one of them lies in dir under an
  // output file's name (is_output_file), which it would replace or remove as stale.
  std::vector<std::string> input_files;
  // Throws hysteron::Error naming both where one of `inputs` (option, path) is, through links,
  // a file an experiment writing into `dir` would replace or remove: the output files there
  // (is_output_file) and those it always writes. `hysteron experiment` checks its --plant,
  // --tracking-plant and --reference files so before it runs.
  static void check_inputs_not_outputs(const std::string& dir, const std::vector<std::pair<std::string, std::string>>& inputs);
  // Human-readable table beside the paper's figures.
  std::string table() const;
  // The runs of hysteron's own loops (compensated, learning, adaptive) whose RMS error is not
  // below the baseline's on the same reference (NaN counts as not below), as "variant
  // (reference)"; empty where each beats it or no baseline ran. A compensation that does no
  // better than a straight line for the hysteresis must not look like one: `hysteron
  // experiment` and `demo` exit 3 where this is not empty (README, Exit codes), and to_json()
  // gives it with a status. Derived from runs (not stored).
  std::vector<std::string> not_below_baseline() const;
  // Whether `run` is one of them (a run of hysteron's loops whose RMS error is not below the
  // baseline's on its reference): the rule not_below_baseline() lists by.
  bool not_below_baseline(const TrackingRun& run) const;
};

// Throws hysteron::Error on invalid options or a diverging rig.
ExperimentResult run_experiment(const ExperimentOptions& options);

// The adaptive variant's inverse model (docs/control.md, "Adaptive inverse"): the weights
// theta = (q, p_1..p_n) of a fitted PI-family model (pi, gpi, mpi-deadzone's PI part,
// mpi-asym; thresholds, envelopes, dead zones and units map fixed) re-identified online from
// measured (input, output) pairs by recursive least squares with forgetting,
//   e = t - theta^T phi,  K = P phi / (lambda + phi^T P phi),  theta += K e,
//   P = (P - K phi^T P) / lambda,  trace(P) <= trace(P_0)
// (phi: the direct term and the operator outputs driven by the measured input; t: the
// measured output in model coordinates, through the inverse of the dead zones), projected
// after every update onto the invertibility constraints with a margin m > 0
//   symmetric PI family: every cumulative slope q + p_1 + ... + p_i clipped at >= m,
//   mpi-asym:            q >= m and p_i >= 0,
// and handed to an exact inverse updated in place (Inverse::set_weights, no allocation).
// Guard: the a-priori prediction errors of the adapted and of the fitted weights are
// averaged with the same forgetting; while the adapted weights predict worse, the inverse
// uses the fitted ones.
struct AdaptiveInverseParams {
  double lambda = 0.9998;  // forgetting factor in (0, 1]: memory about 1 / (1 - lambda) samples
  // Margin m of the constraints in model units (cumulative slope dv/du); 0: derived from the
  // prior record by the fit's rule, FitOptions::min_slope x span(v) / span(u), lowered to the
  // fitted weights' own smallest cumulative slope (mpi-asym: q) so that they are feasible.
  double margin = 0.0;
  // Samples by which the output lags the input in the pairs (x_(k-delay), y_k) the RLS learns
  // from (and in the prior record): the rig's response delay, so that the estimate does not
  // widen the hysteresis to absorb a lag that the loop's preview compensates already.
  std::size_t delay = 0;  // at most 100000
  Limits input_limits;    // the inverse's (unset: the model's)
  bool frozen = false;    // no update at all: the fitted model's inverse (for comparisons)
  // Hand the weights to the inverse after every update (commit()); false: only when the
  // caller calls commit() (the experiments: at the bottom of each loop of the reference).
  bool commit_every_update = true;
  void validate() const;  // throws hysteron::Error
};

class AdaptiveInverse {
 public:
  // prior_x, prior_y: the identification record (raw units, from rest) the model was fitted
  // on. The covariance starts as that of an RLS with the same forgetting run over it,
  // P_0 = (sum_k lambda^(N-1-k) phi_k phi_k^T + delta I)^-1, the weights at the fitted ones.
  // Throws hysteron::Error for a model outside the PI family, a non-invertible model,
  // an empty or non-finite prior record or invalid params.
  AdaptiveInverse(const ModelParams& model, std::span<const double> prior_x, std::span<const double> prior_y,
                  const AdaptiveInverseParams& params);

  // One measured pair (raw units): a-priori errors of both weight sets, the RLS update, the
  // projection, and (commit_every_update) commit(). Never allocates, never throws; a
  // non-finite pair is ignored and counted in faults(). The covariance is bounded by the
  // prior's trace (directional forgetting at the bound, counters().bounded) and reset to the
  // prior where it is no longer positive definite (counters().resets, also in faults()).
  void update(double x, double y) noexcept;
  // The guard, then the chosen weights (the projected estimate, or the fitted ones while the
  // estimate predicts worse) into the inverse, in place. Never allocates, never throws.
  void commit() noexcept;
  // The inverse (raw units): the input that makes the model in use output y_desired.
  double step(double y_desired) noexcept { return inverse_.step(y_desired); }

  const Inverse& inverse() const noexcept { return inverse_; }
  double margin() const noexcept { return margin_; }
  double lambda() const noexcept { return p_.lambda; }
  std::size_t delay() const noexcept { return p_.delay; }
  // (q, p_1..p_n): the projected estimate, and the weights the inverse uses now.
  std::span<const double> estimate() const noexcept { return theta_; }
  std::span<const double> weights_in_use() const noexcept { return adapted_ ? theta_ : theta_fixed_; }
  std::span<const double> fitted_weights() const noexcept { return theta_fixed_; }
  // The smallest constraint value of the estimate: min_i (q + p_1 + ... + p_i), or for
  // mpi-asym min(q, min_i p_i + m); >= margin() after every update.
  double min_constraint() const noexcept;
  bool adapted_in_use() const noexcept { return adapted_; }
  // Forgetting sums sum_k lambda^(K-k) e_k^2 of the a-priori prediction errors (raw output units).
  double adapted_error() const noexcept { return j_adapted_; }
  double fitted_error() const noexcept { return j_fixed_; }
  struct Counters {
    std::size_t updates = 0;    // pairs learned from
    std::size_t projected = 0;  // updates whose estimate the projection changed
    std::size_t fallback = 0;   // updates after which the fitted weights were in use
    std::size_t commits = 0;    // commit() calls
    std::size_t switches = 0;   // changes between adapted and fitted weights
    std::size_t rejected = 0;   // weights the inverse refused (0 unless the projection fails)
    std::size_t bounded = 0;    // updates at the covariance bound (directional forgetting)
    std::size_t resets = 0;     // covariance resets to the prior (no longer positive definite)
  };
  const Counters& counters() const noexcept { return n_; }
  // Pairs not learned from (non-finite) plus covariance resets.
  std::size_t faults() const noexcept { return faults_; }

 private:
  double regressor(double x) noexcept;  // fills phi_ (operators driven by x); returns 0
  double dz(double v) const noexcept;          // dead-zone map (identity without)
  double dz_inverse(double y) const noexcept;  // its inverse
  void project() noexcept;
  double distance(const std::vector<double>& theta) noexcept;
  static constexpr int kSweeps = 4;  // coordinate sweeps of the projection per sample

  AdaptiveInverseParams p_;
  Structure<double> s_;
  Inverse inverse_;
  std::vector<double> y_;                    // operator outputs
  // theta_: projected estimate (in use unless the guard says otherwise); theta_hat_: the
  // unconstrained RLS estimate; P_, R_ = P_^-1: m x m, row-major.
  std::vector<double> theta_, theta_hat_, theta_fixed_, clip_, w_, phi_, pphi_, P_, R_;
  std::vector<double> P0_, R0_;  // the prior's P_ and R_
  std::vector<double> zb_, zv_;              // dead-zone map: breakpoints and values there
  std::vector<double> xs_;                   // the last delay + 1 inputs (ring)
  std::size_t xi_ = 0, xn_ = 0;              // next slot, inputs held
  double lo_slope_ = 1.0, hi_slope_ = 1.0;   // its slopes beyond the first / last breakpoint
  double margin_ = 0.0, trace0_ = 0.0;
  double j_adapted_ = 0.0, j_fixed_ = 0.0;
  bool adapted_ = true;
  Counters n_;
  std::size_t faults_ = 0;
};

}  // namespace hysteron
