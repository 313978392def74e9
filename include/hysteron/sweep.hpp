#pragma once
// Plant variants: the papers' experiments run over a list of rigs that differ
// from a base rig (by default the nominal one of docs/plant.md) in named
// parameters, in parallel on all cores (docs/plant.md, "Plant variants").
//
// A variant is a set of overrides of PamRigParams fields by their dotted path in
// the rig's JSON form (rig_params_to_json), e.g. "load.mass=35",
// "hysteresis.pressure_band=25e3" or "muscle.force_620=-15%" (a change in percent
// of the base rig's value). Paths are checked against the JSON form: an unknown
// path is a hysteron::Error naming it and listing the closest names; the value
// must be a finite number, and the rig it gives is validated as a rig file is.
//
// Every (experiment, variant) pair is one run_experiment() call; the runs are
// independent and deterministic, so the result does not depend on the number of
// threads (bit for bit). An exception of a run is recorded as that run's failure
// (its message), not thrown.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/experiment.hpp"
#include "hysteron/plant.hpp"

namespace hysteron {

// One override of a rig parameter.
struct ParameterOverride {
  std::string path;      // dotted path in the rig's JSON form, e.g. "load.mass"
  double value = 0.0;    // the new value; with percent: the change in % of the base value
  bool percent = false;  // "-15%": value = -15, the parameter becomes base * (1 + value / 100)
  bool operator==(const ParameterOverride&) const = default;
};

// "load.mass=35", "muscle.force_620=+15%"; `where` prefixes the error messages
// (e.g. "--vary"). Throws hysteron::Error on an unknown path (with the closest
// names), a missing '=', a value that is not a finite number.
ParameterOverride parse_override(std::string_view text, std::string_view where);
// The text form of an override ("load.mass=35", "muscle.force_620=-15%").
std::string to_string(const ParameterOverride& o);

// The dotted paths of every rig parameter ("muscle.rest_length", ...).
std::vector<std::string> rig_parameter_paths();
// Throws hysteron::Error "WHERE: unknown rig parameter 'PATH' (did you mean ...?)"
// unless `path` is one of rig_parameter_paths().
void check_parameter_path(std::string_view path, std::string_view where);

struct PlantVariant {
  std::string name;                         // e.g. "load.mass=35"; unique within a sweep
  std::vector<ParameterOverride> overrides; // applied in order to the base rig
  // The parameter this variant varies one at a time (e.g. "load.mass", or
  // "regulator.time_constant/regulator.dead_time" for a pair varied together);
  // empty for a combination. The report plots the RMS error against it.
  std::string group;
  // Target of issue 11: the compensated RMS error at most this many times its value on
  // the base rig (1.5; 2 for the documented worst combination). Shown, never enforced.
  double rms_ratio_limit = 1.5;
};

// The base rig with the overrides applied (through the JSON form, so the result is
// validated as a rig file). Throws hysteron::Error prefixed with `where`.
PamRigParams apply_overrides(const PamRigParams& base, const std::vector<ParameterOverride>& overrides,
                             std::string_view where);

// --vary: "PATH=V1,V2,..." gives one variant per value (group PATH); several paths
// varied together: "P1/P2=A1/A2,B1/B2" (group "P1/P2"). Values as in parse_override.
std::vector<PlantVariant> parse_vary(std::string_view spec);

// A grid file (JSON):
//   {"variants": [{"name": "heavy", "set": {"load.mass": 35}},
//                 {"set": {"load.mass": 35, "muscle.force_620": "-15%"}, "rms_ratio_limit": 2}]}
// "name" (default: the overrides' text) and "rms_ratio_limit" (default 1.5) are optional;
// a variant setting one parameter is in that parameter's group. Unknown keys, repeated
// names, bad paths and values are hysteron::Error naming the file and the entry.
std::vector<PlantVariant> read_variant_grid(const std::string& path);
std::vector<PlantVariant> variant_grid_from_json(const nlohmann::json& j, std::string_view where);

// The documented set of issue 11 (docs/plant.md): load 10 and 35 kg; hysteresis band
// 10 and 25 kPa; force map (muscle.force_620) -15 % and +15 %; regulator time constant /
// dead time 30 ms / 5 ms and 100 ms / 12 ms; load damping 200 and 800 N s/m; and the
// worst combination (heaviest load 35 kg, widest band 25 kPa, weakest force map -15 %,
// slowest regulator 100 ms / 12 ms, lowest damping 200 N s/m; rms_ratio_limit 2).
// The nominal values (20 kg, 15 kPa, 50 ms / 7 ms, 400 N s/m) are the nominal rig.
std::vector<PlantVariant> documented_variants();
inline constexpr std::string_view documented_set_name = "documented";
// A built-in set by name (documented_set_name, the only one); any other name is a
// hysteron::Error "WHERE NAME: unknown set (the one built-in set is 'documented')".
std::vector<PlantVariant> variant_set(std::string_view name, std::string_view where);
// The experiments of a sweep from the names given: "all" is every registered experiment
// (experiment_names()), in place; the others as given (run_sweep checks them).
std::vector<std::string> sweep_experiments(const std::vector<std::string>& names);

// Progress of a sweep: called once per finished run, from one thread at a time.
struct SweepProgress {
  std::size_t done = 0, total = 0;
  std::string experiment, variant;
  bool ok = true;
  double wall_time_s = 0.0;
};

struct SweepOptions {
  std::vector<std::string> experiments;   // names from experiment_names()
  PamRigParams base{};                    // the nominal rig of the sweep
  std::vector<PlantVariant> variants;     // the base rig itself is always run first, as "nominal"
  std::uint64_t seed = 1;                 // rig noise seed of every run
  int learning_periods = ExperimentOptions{}.learning_periods;  // of every run (0: no learning runs)
  // ExperimentOptions::control_period of every run [s]: a whole number of every rig's dt
  double control_period = ExperimentOptions{}.control_period;
  // ExperimentOptions::model of every run: automatic (each run chooses among every kind on
  // its own rig; fits 9 kinds per run) or one kind pinned for every run.
  FitModel model = ExperimentOptions{}.model;
  bool fit_references = ExperimentOptions{}.fit_references;  // of every run
  // ExperimentOptions::references of every run (parse_references; empty: each experiment's own),
  // checked against control_period before anything runs
  std::vector<UserReference> references;
  // Every run identified and tuned on the base rig, its tracking runs on the variant's rig
  // (ExperimentOptions::tracking_rig): a rig that changed after its identification (another
  // load, a wider band, a slower regulator), the loops not re-tuned. false: each variant is
  // identified and tuned on its own rig.
  bool identify_on_base = false;
  unsigned jobs = 0;                      // threads; 0 = usable_cpus() (each run fits on one thread)
  std::function<void(const SweepProgress&)> progress;  // optional
  // Optional: asked (from the worker threads, so it must be thread-safe) before each run starts
  // and inside the runs (as their ExperimentOptions::stop_requested). Once it returns true no
  // further run starts, the runs under way are abandoned (hysteron::Stopped inside them), and
  // run_sweep throws hysteron::Error ("sweep stopped after K of N runs"): a stopped sweep has no
  // result (e.g. the Python module's Ctrl-C).
  std::function<bool()> stop_requested;
  // What runs one experiment: run_experiment when empty (a test may pass a cheaper one;
  // it is called from several threads at once).
  std::function<ExperimentResult(const ExperimentOptions&)> runner;
};

// One tracking run of one (experiment, variant): a reference and a variant kind
// (TrackingRun::variant: faithful, compensated, learning, baseline, ...).
struct SweepRunErrors {
  std::string reference;
  std::string kind;
  TrackingErrors errors;
  double min_command_mpa = 0.0, max_command_mpa = 0.0;  // NaN if the run logs no pressure command
  std::size_t saturated = 0;
  // The reference as tracked over the published one (ExperimentResult::reference_ranges):
  // the span's ratio (< 1: mapped into the rig's reach) and whether it lay within the reach.
  double reference_scale = 1.0;
  bool reachable = true;
  // compensated and adaptive runs: the gain trial's choice for the reference
  // (ExperimentResult::gain_trials): the scale of the PID gains and the shaped feedforward
  double gain_scale = 1.0;
  bool shaped = false;
  // What the position PID's limit-cycle guard did (LoopDesign::guard_cuts, guard_final_scale;
  // docs/control.md, section 2): 0 and 1 where it never acted or the loop has none.
  std::size_t guard_cuts = 0;
  double guard_final_scale = 1.0;
  // One of hysteron's loops (compensated, learning, adaptive) whose RMS error is not below the
  // baseline's on the same rig and reference: listed by the experiment's
  // ExperimentResult::not_below_baseline() (where `hysteron experiment` exits 3).
  bool not_below_baseline = false;
};

// One (experiment, variant) run.
struct SweepRun {
  std::string experiment;
  std::size_t variant = 0;  // index into SweepResult::variants
  bool ok = false;
  std::string error;        // the exception's message when !ok
  double wall_time_s = 0.0;
  std::vector<SweepRunErrors> runs;  // in the order of ExperimentResult::runs
  // The kind of hysteron's model the run used (ExperimentResult::best_fit), "" if it failed,
  // and ExperimentResult::model_reason.
  std::string model;
  std::string model_reason;
  // ExperimentResult::not_below_baseline() of the run ("variant (reference)"; empty if it failed):
  // the runs whose experiment would exit 3 (SweepRunErrors::not_below_baseline for each).
  std::vector<std::string> not_below_baseline;
  // The actuator's limit of the run [MPa] (ExperimentResult::pressure_limit_mpa: the rig's
  // muscle.max_pressure, and regulator.max_command for a regulator experiment): no pressure
  // command may leave 0..command_limit_mpa. NaN for an unknown experiment.
  double command_limit_mpa = 0.6;
};

struct SweepVariant {
  PlantVariant variant;          // variants[0]: "nominal", no overrides
  PamRigParams rig;              // the rig it ran on
  std::vector<double> values;    // the overridden parameters' values on that rig, in override order
};

struct SweepResult {
  std::vector<std::string> experiments;
  std::vector<SweepVariant> variants;
  std::vector<SweepRun> runs;     // experiment-major: runs[e * variants.size() + v]
  std::vector<std::string> notes; // e.g. a variant dropped because it is the nominal rig
  std::uint64_t seed = 1;
  unsigned jobs = 1;
  FitModel model = FitModel::automatic;  // SweepOptions::model
  bool fit_references = true;            // SweepOptions::fit_references
  bool identify_on_base = false;         // SweepOptions::identify_on_base
  double control_period = 1e-3;          // SweepOptions::control_period [s]
  double wall_time_s = 0.0;

  std::size_t failures() const noexcept;
  const SweepRun& run(std::size_t experiment, std::size_t variant) const { return runs.at(experiment * variants.size() + variant); }
  // The errors of (experiment, variant, reference, kind); nullptr if absent or failed.
  const SweepRunErrors* find(std::size_t experiment, std::size_t variant, std::string_view reference,
                             std::string_view kind) const noexcept;
  // The table (one row per tracking run, one per failed run), as CSV text; columns:
  // experiment, variant, overrides, reference, kind, max_mm, mae_mm, rms_mm,
  // rms_vs_nominal, rms_vs_baseline, min_command_mpa, max_command_mpa, saturated,
  // reference_scale, status (ok | failed), error, wall_time_s, guard_cuts, guard_final_scale
  // (what the position PID's limit-cycle guard did; 0 and 1 where it has none),
  // command_limit_mpa (SweepRun::command_limit_mpa), control_period_s (every run's controller
  // period, SweepOptions::control_period), not_below_baseline (1 | 0 for hysteron's loops,
  // SweepRunErrors::not_below_baseline; empty for the other kinds and a failed run). Numbers
  // with %.17g (exact), NaN as "".
  std::string csv() const;
  // A human-readable table (RMS per kind), failures and target misses.
  std::string text() const;
  // Every figure of the table as one JSON document.
  nlohmann::json to_json() const;
  // The misses of issue 11's targets for the variant kind "compensated": RMS above
  // rms_ratio_limit x nominal, not below the baseline's, a command outside 0..the run's
  // limit (SweepRun::command_limit_mpa),
  // a reference out of the rig's reach (SweepOptions::fit_references false), and every
  // failed run. One line each.
  std::vector<std::string> target_misses() const;
  // The learning runs whose RMS error is not below the compensated run's on the same rig and
  // reference (a tie or a non-finite error too): the periods of learning did not pay for
  // themselves there (docs/control.md, section 3; where it is above, the experiment's own note
  // says why). One line each, with both errors.
  std::vector<std::string> learning_not_below_compensated() const;
  // Every run of hysteron's loops (compensated, learning, adaptive) not below the baseline's RMS
  // error on the same rig and reference (SweepRunErrors::not_below_baseline: what makes
  // `hysteron experiment` exit 3 on that rig), one line each with both errors. The compensated
  // ones are also target misses; the sweep's exit status does not change (docs/plant.md).
  std::vector<std::string> not_below_baseline() const;
  // The runs whose position PID's limit-cycle guard cut its gains (they rang near the relay's
  // period; docs/control.md, section 2): how often and to which scale. One line each.
  std::vector<std::string> guard_acted() const;
  // How the runs were identified, where not each on its own rig (identify_on_base): one
  // sentence for the text, the page and the JSON ("" by default).
  std::string identification_note() const;
};

// Runs every (experiment, variant) pair (the base rig first, as "nominal"), `jobs`
// at a time. Throws hysteron::Error before running anything on invalid options (unknown
// experiment, bad override, repeated variant names, a variant rig that is not valid);
// a run that throws is recorded as failed.
SweepResult run_sweep(const SweepOptions& options);

namespace report {
// The HTML page of a sweep (hysteron::report, src/report/sweep_html.cpp): errors of
// every variant and kind, target misses, and the RMS against each varied parameter
// (inline SVG through gnuplot). Throws hysteron::Error (e.g. gnuplot missing).
std::string sweep_report_html(const SweepResult& result, const std::string& command_line);
// The same page written atomically to html_path.
void write_sweep_report(const SweepResult& result, const std::string& html_path, const std::string& command_line);
}  // namespace report

}  // namespace hysteron
