#pragma once
// The hysteron CLI is one executable with subcommands; each lives in its own
// apps/cmd_*.cpp and registers itself here. An action returns the exit code;
// user errors are thrown as hysteron::Error and reported by main() (exit 1).
#include <CLI/CLI.hpp>

#include <cstdint>
#include <limits>

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <optional>

#include "hysteron/identify.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/models.hpp"
#include "hysteron/report.hpp"

namespace hysteron::cli {

using Action = std::function<int()>;

void add_simulate_invert(CLI::App& app, Action& action);  // cmd_simulate.cpp: simulate, invert
void add_fit(CLI::App& app, Action& action);              // cmd_fit.cpp: fit
void add_experiment(CLI::App& app, Action& action);       // cmd_experiment.cpp: experiment, demo
void add_report(CLI::App& app, Action& action);           // cmd_report.cpp: report
void add_evaluate(CLI::App& app, Action& action);         // cmd_evaluate.cpp: evaluate
void add_export(CLI::App& app, Action& action);           // cmd_export.cpp: export (generated C)
void add_sweep(CLI::App& app, Action& action);            // cmd_sweep.cpp: sweep (plant variants)
void add_rig(CLI::App& app, Action& action);              // cmd_rig.cpp: rig (a rig's parameters and statics)
void set_command_line(int argc, char** argv);             // recorded in reports
// CLI11 validator: a decimal integer >= 0 ("-1" would wrap to 2^64 - 1 in an unsigned).
// A decimal integer in 0..max (the option's type's largest value: 2^32 - 1 for an unsigned seed), else the
// message "TEXT is not an integer in 0..MAX".
// A range with a lower bound other than 0 (--jobs 1..1024): "TEXT is not an integer in MIN..MAX". No description
// in --help (only the option's type, UINT): the option's own text gives the range.
CLI::Validator non_negative_integer(std::uint64_t max = std::numeric_limits<std::uint64_t>::max(),
                                    std::uint64_t min = 0);
// CLI11 validator: one of `names`, else "TEXT not in {A,B,...} (did you mean X?)" with io::closest_name's
// suggestion, as for a mistyped command or option (--model gpii, experiment gpi-pd); --help shows {A,B,...}.
CLI::Validator one_of(std::vector<std::string> names);
// Every FLOAT option of `app` and its subcommands reads its number by io/numbers.hpp's rule (a
// decimal literal, the whole text, finite): CLI11's own conversion takes hexadecimal ("0x1p-10")
// and "inf". Call once every option is added.
void check_float_options(CLI::App& app);
// --control-period S (experiment, demo, sweep): the loop's sample time [s] into `period`
// (ExperimentOptions::control_period, which checks it before anything runs or is written).
void add_control_period_option(CLI::App* cmd, double& period);
// --limits LO,HI (simulate/invert, export): finite numbers with LO < HI, else hysteron::Error.
Limits parse_limits(const std::string& text);
// The warning (on stderr, prefixed by `command`) where --limits reach beyond the model's
// input_limits (its training range) by more than kInputCoverageTolerance of their span: the
// inverse then commands inputs the model was never fitted on; a louder one where less than
// half of --limits lies within them (--limits in another unit?). --limits that do not overlap
// the model's input_limits at all (e.g. 0,0.6 on a model in kPa fitted on 8..626) throw
// hysteron::Error. `input_unit`: the model file's, named in both ("" if none).
void warn_limits_beyond_model(const ModelParams& params, const Limits& limits, std::string_view command,
                              std::string_view input_unit);
const std::string& command_line();                        // the recorded command line

// ---- shared by the subcommands (common.cpp) --------------------------------------

// Exit codes of the CLI (README, "Command line"): 0 success; 1 error (bad input or
// usage, a hysteron::Error, a CLI11 parse error); fit: 2 no_convergence or failed,
// 3 poor_fit (model not written unless --force); 4 internal error.
inline constexpr int exit_ok = 0, exit_error = 1, exit_not_converged = 2, exit_poor_fit = 3, exit_internal = 4;

// The units a model file records, its "units": {"input": ..., "output": ...} (fit writes them where
// the record names them); "" where it records none.
struct ModelUnits {
  std::string input, output;
};
ModelUnits model_units(const io::ModelDocument& doc);
// "A:B" (sample indices, half-open; either side may be empty) or "As:Bs" (seconds, needs
// `time`); both sides in the same unit. Throws hysteron::Error naming `opt`.
IndexRange parse_range(const std::string& text, std::string_view opt, const std::vector<double>* time, std::size_t n);
// "As:Bs" ("As:" where r ends at the record's end), which parse_range reads back as r over the time column `time`
// (seconds, not decreasing), in the fewest digits (6 or more) that do: a range of samples said in seconds; none
// where no text does (a stamp repeated at one of r's ends).
std::optional<std::string> seconds_range(const std::vector<double>& time, IndexRange r);
// "Pressure [kPa]" -> {"Pressure", "kPa"}; "" -> {fallback, ""}.
report::Axis parse_axis(const std::string& text, const std::string& fallback);
// Reports: a path ending in .html or .htm (any case) is HTML, anything else JSON.
using io::is_html_path;
// An output path that names standard output: "-", or an existing file that is the one stdout is
// open on (the same st_dev and st_ino: /dev/stdout, /dev/fd/1, or the file or pipe stdout is
// redirected to). A command that prints on stdout treats such an output as it treats "-", so
// stdout never gets two documents. Not the null device (--out /dev/null > /dev/null discards both).
bool names_stdout(const std::string& path);

// What fit and evaluate read from a data file and how the reports describe it.
struct DataSelection {
  std::string file, input, output, time_column;  // time_column empty: no time axis
  std::string time_unit;                         // --time-unit: s, ms or us; "": the column's own, else s
  std::string input_label, output_label;         // "Pressure [kPa]"; empty: the column name
};
struct DataColumns {
  std::vector<double> x, y;
  std::optional<std::vector<double>> t;
  std::string time_unit = "s";  // the time column's unit as read: --time-unit, else its header's, else s
  bool time_unit_from_file = false;  // the file names it (header or units row)
  // the columns' header names and units ("pressure", "kPa"; from a units row or "pressure [kPa]")
  std::string input_name, input_unit, output_name, output_unit;
};
// Registers --data, --input, --output, --time-column, --time-unit, --input-label, --output-label.
void add_data_options(CLI::App* sub, DataSelection& sel);
// The input, output and (if named) time columns of `file`, of equal lengths, the time column in
// seconds (converted here, the one place its unit is read: --time-unit, else the unit its header
// or units row gives, else s; the two disagreeing, or a time unit other than s, ms, us, is an
// error); throws hysteron::Error naming the file otherwise.
DataColumns read_data_columns(const std::string& file, const DataSelection& sel);
// Time columns (rate-pi's sample time, ranges in seconds): throws hysteron::Error naming the file,
// the column and the first sample whose time stamp is not a number or below the one before
// (`why`: what needs ordered stamps), or, unless `repeats_ok` (a range's look-up needs no more than
// that), where more than 1 % of the steps repeat a stamp. Fewer repeats (a logger's clock tick: the
// Festo record test9 has one) are returned as a warning ("" if none).
std::string require_increasing_time(const std::vector<double>& t, const std::string& file, const std::string& column,
                                    std::string_view why, bool repeats_ok = false);
// The time step of an increasing time column (s): the mean of its steps within 0.5 .. 1.5 times the
// median step, so that stamps rounded to a clock's tick or jittered give the record's mean rate
// (Festo test8: 1, 2 and 3 ms steps of 1.887 ms on average, median 2 ms) and a lost sample, a gap,
// a repeated stamp or a backward step does not count. The median step if it is not positive.
double mean_time_step(const std::vector<double>& t);
// "" if every step of an increasing time column lies within 0.4 .. 1.9 times the median step, else
// a warning that names the file, the column and the sample of the widest (a gap) or narrowest step.
std::string uniform_time_warning(const std::vector<double>& t, const std::string& file, const std::string& column);
// --sample-time and --time-column both given must agree: throws hysteron::Error naming both values
// when `sample_time` (> 0; 0: not given) and the mean step of `t` (mean_time_step; if any, and > 0)
// differ by more than kSampleTimeTolerance of that step.
inline constexpr double kSampleTimeTolerance = 0.01;
void check_sample_time_agrees(double sample_time, const std::vector<double>* t, const std::string& file,
                              const std::string& column);
// A rate-dependent model (rate-pi: its rates per second through its dt) run at its dt on the record
// `file`: warnings for a record sampled otherwise (more than 10 % from dt), for the time column's
// faults, and for a record whose sample time is unknown (no time column `t`, `sample_time` 0: the
// model's dt is assumed). The record's sample time is `sample_time` if > 0, else the mean step of
// `t` (mean_time_step). Empty for a rate-independent model. Used by evaluate and by fit's --validate-data files.
std::vector<std::string> rate_time_warnings(const ModelParams& model, const std::vector<double>* t,
                                            double sample_time, const std::string& file, const std::string& column);
// The data section of a fit/evaluation document and the plot data of its HTML report.
io::DataDescription describe_data(const DataSelection& sel, const DataColumns& d, InitialState initial,
                                  IndexRange range);
// Throws hysteron::Error where a record's input or output column (DataColumns' units, from its
// header or units row) and `units` (of `source`: "the model m.json", "the training record r.csv")
// name different units for the same signal ("kPa" and "bar"; compared without brackets and case):
// its scores or outputs would be off by the units' ratio. Silent where either does not say.
void check_units_agree(const ModelUnits& units, const std::string& source, const DataColumns& rec,
                       const DataSelection& sel, const std::string& file);
// The same for one column `c` of `file` (its name and unit, as the reader chose it) against the
// model's unit of the signal `what` ("input" or "output").
void check_column_unit(const io::NamedColumn& c, const std::string& file, const io::ReadOptions& options,
                       const std::string& model_unit, const std::string& model_file, std::string_view what);

report::FitData plot_data(const DataSelection& sel, const DataColumns& d, InitialState initial, IndexRange range);

}  // namespace hysteron::cli
