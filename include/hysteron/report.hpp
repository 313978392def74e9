#pragma once
#include "hysteron/version.hpp"
// Plots (through gnuplot) and self-contained HTML reports of fits and experiments.
//
// Plots: every function renders one figure with gnuplot, run as a child process
// on a generated script with the data inline ($data << EOD blocks); nothing is
// left in the temporary directory. The format follows the output path's
// extension: .svg (vector, embeddable in HTML) or .png (pngcairo). Every axis
// has a label with its unit, every figure a title and a legend. Long series are
// thinned to about max_points per series: a series over time (x never decreases)
// keeps each bucket's minimum and maximum (so error peaks survive); a path in the
// plane (a loop) is drawn through the cells of a grid over its box that it enters
// first, broken where it runs over cells already drawn. Throws hysteron::Error if a figure has no finite
// data, if a label is empty, if the gnuplot binary cannot be run (the binary is
// "gnuplot" on PATH, or $HYSTERON_GNUPLOT) or if gnuplot fails.
//
// Reports: one HTML file, no external resources (the plots are inline SVG), with
// the tables of parameters and errors beside the paper's published figures, the
// command line that made it, the hysteron version and the date. Written atomically.
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/experiment.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/results.hpp"  // io::EvaluationDocument

namespace hysteron::report {

// Version string shown in reports (kept equal to the CMake project version).
inline constexpr std::string_view hysteron_version = hysteron::version;

// ---- plots ---------------------------------------------------------------------

struct Axis {
  std::string label;  // e.g. "Pressure" (required)
  std::string unit;   // e.g. "MPa" (empty for dimensionless quantities)
};

struct Labels {
  std::string title;  // required
  Axis x;
  Axis y;
};

// One curve. style: "lines", "points" or "linespoints".
struct Series {
  std::string label;  // legend entry (required)
  std::vector<double> x, y;
  std::string style = "lines";
  std::string color;  // "#rrggbb"; empty = gnuplot's default sequence
  bool dashed = false;
};

struct PlotSpec {
  Labels labels;
  std::vector<Series> series;
  int width = 900;                // pixels
  int height = 520;
  std::size_t max_points = 4000;  // per series, after decimation (>= 16)
  bool equal_axes = false;        // same range on x and y (desired vs actual)
};

// Renders to path (.svg or .png). Throws hysteron::Error (see above).
void plot(const PlotSpec& spec, const std::string& path);
// Renders and returns the file's bytes: an SVG document ("svg") or a PNG ("png").
std::string render(const PlotSpec& spec, std::string_view format);

// The points of (x, y) that render() draws of a series with at most max_points (>= 16) points,
// in order (a non-finite sample as it is, a NaN pair where the drawn line breaks): a series whose
// x never decreases keeps its first and last samples and the least and the largest y of each of
// (max_points - 2) / 2 buckets of samples; any other (a loop, actual against desired) is thinned
// along its path on a grid over its box, with the samples at the box's edges (docs/report.md).
// A Series of these points draws the same picture as (x, y) (render() thins it no further; the
// axes' ranges and a large offset's reference come out the same), so that a long record's series
// need not be copied whole into a PlotSpec. Throws Error when x and y differ in length or
// max_points is below 16.
struct ThinnedPoints {
  std::vector<double> x, y;
};
ThinnedPoints thin_for_plot(std::span<const double> x, std::span<const double> y, std::size_t max_points = 4000);
// A Series of thin_for_plot's points for PlotSpec's default max_points.
Series thinned_series(std::string label, std::span<const double> x, std::span<const double> y, std::string color,
                      bool dashed = false, std::string style = "lines");

// Fig. 5 / Fig. 9: output against input. measured (and model, if non-empty)
// against input; samples [0, major_end) are drawn as the major loop, the rest
// as minor loops (major_end = 0: no split).
void plot_hysteresis_loops(std::span<const double> input, std::span<const double> measured,
                           std::span<const double> model, const Labels& labels, const std::string& path,
                           std::size_t major_end = 0);
// Fig. 4: the identification input against time: the command, and the
// measured input if non-empty.
void plot_identification_input(std::span<const double> t, std::span<const double> command,
                               std::span<const double> measured, const Labels& labels, const std::string& path);
// Fig. 11: desired and actual output against time.
void plot_tracking(std::span<const double> t, std::span<const double> desired, std::span<const double> actual,
                   const Labels& labels, const std::string& path);
// Fig. 12: tracking error (desired - actual) against time.
void plot_tracking_error(std::span<const double> t, std::span<const double> desired,
                         std::span<const double> actual, const Labels& labels, const std::string& path);
// Fig. 13: actual against desired output, with the ideal line y = x.
void plot_desired_vs_actual(std::span<const double> desired, std::span<const double> actual, const Labels& labels,
                            const std::string& path);
// Fit residuals (measured - model) against x (time or sample index).
void plot_fit_residuals(std::span<const double> x, std::span<const double> measured,
                        std::span<const double> model, const Labels& labels, const std::string& path);

// ---- reports -------------------------------------------------------------------

// A validation set shown in a fit report: another record (x, y, optional t), or a
// range of the fit's own record (x empty).
struct ValidationData {
  std::string name;              // e.g. the file name; "" = the fit's record
  std::vector<double> x, y, t;   // empty x: the fit's record
  IndexRange range{};            // the samples scored
};

// What write_fit_report needs besides the FitReport: the data and their meaning.
struct FitData {
  std::vector<double> x, y;            // the record fit() saw (input, measured output)
  std::vector<double> t;               // optional time axis (else the sample index)
  Axis input{"Input", ""};
  Axis output{"Output", ""};
  std::string source;                  // e.g. "data.csv (columns pressure, length)"
  InitialState initial_state = InitialState::virgin;
  IndexRange train{};                  // the training range of the fit
  std::vector<ValidationData> validation;  // shown with their metrics, loops and residuals
  // A validation (or evaluated) record whose output clips is scored as censored
  // (evaluate_censored), as `hysteron fit` and `hysteron evaluate` score it by default.
  bool censor_clipped = true;
  // The data files read for it (read_fit_report_json, read_evaluation_json): `hysteron report`
  // never writes its page over one of them.
  std::vector<std::string> files;
};

// HTML report of an experiment (what `hysteron experiment NAME --out DIR` computed).
void write_experiment_report(const ExperimentResult& result, const std::string& html_path,
                             const std::string& command_line);
// HTML report of a fit: status, warnings, the reference PI and the inverse check,
// the candidates of FitModel::automatic (with their validation RMS on every
// validation set), parameters with standard errors, metrics (training and, if the
// training range is not the whole record, validation; every validation set), measured
// vs model loops, residuals (against time if data.t is given).
void write_fit_report(const FitReport& fit, const FitData& data, const std::string& html_path,
                      const std::string& command_line);
// HTML report of `hysteron evaluate` from its document (`evaluate --report x.html`, `hysteron
// report ev.json`): a saved model against a record (data.train is the evaluated range); the
// evaluated range's metrics are the document's (and the whole record's where the range is a
// part), with what it records besides (censored samples, samples outside the model's input
// limits, the output map), the model file's keys, loops, output over the record, residuals.
void write_evaluation_report(const io::EvaluationDocument& doc, const FitData& data, const std::string& html_path,
                             const std::string& command_line);

// Reads a directory written by ExperimentResult::write (result.json,
// identification.csv, tracking_<variant>_<reference>.csv, model.json,
// best_model.json). Throws hysteron::Error naming the missing or malformed file.
ExperimentResult read_experiment_dir(const std::string& dir);

// Fit report JSON ("hysteron fit --report fit.json"): io::to_json(io::FitDocument), see
// hysteron/io/results.hpp; the "data" object names the files and columns:
//   "data": {"input": {"file", "column"}, "output": {"file", "column"},
//            "input_axis": {"label", "unit"}, "output_axis": {"label", "unit"},
//            "time_column" (optional), "time_unit": "s" | "ms" | "us" (of the time column, drawn in
//            seconds; absent: "s"), "initial_state": "virgin" | "relaxed", "train": [begin, end|null]}
// Data file paths are stored as given; relative paths are resolved against the
// JSON file's directory first, then the current directory.
inline constexpr int fit_report_schema = 1;
// As an override (hysteron report --data/--input/--output/--time-column/--time-unit/--no-time),
// each non-empty field replaces the document's own and the others are kept: --data FILE replaces
// the input and output files (output_file empty: FILE), --input only the input column, --output
// only the output column, --time-column the time column (in time_unit; empty: the unit the file's
// header gives it, else s, as fit and evaluate read it), --time-unit
// alone the unit of the document's time column; no_time draws against the sample index. The
// document's time column is looked up in the file given by --data too, an error if it is not there.
struct FitDataSource {
  std::string input_file, input_column, output_file, output_column;
  std::string time_column, time_unit;
  bool no_time = false;
};
// The "Data:" line of a fit or evaluation page: the files and columns as the document names them
// (`fit` / `evaluate --report x.html` and `hysteron report x.json` word it alike).
std::string data_source_line(const io::DataDescription& d);
nlohmann::json fit_report_to_json(const FitReport& fit, const FitData& data, const FitDataSource& source);
// Parses such a file and loads its data (and its validation files). Also reads the JSON
// of older versions of `hysteron fit --report` (no "format", no "data": the data then
// come from data_override; see FitDataSource for how it overrides "data"). Throws
// hysteron::Error naming the file (malformed JSON, other format or schema, missing keys,
// unreadable data: then the data file too).
struct LoadedFit {
  FitReport fit;
  FitData data;
};
LoadedFit read_fit_report_json(const std::string& path, const FitDataSource& data_override = {});

// Evaluation JSON ("hysteron evaluate --report ev.json" or --json): io::to_json(io::EvaluationDocument),
// "format": "hysteron-evaluation"; its "data" object as a fit report's (the evaluated range in
// "train"). Loads the record it names as read_fit_report_json does (the same data_override, paths,
// time_unit) and checks that the model scored on it again gives the document's RMS over the same
// number of samples. Throws hysteron::Error naming the file (malformed JSON, other format or
// schema, missing keys, a missing or unreadable data file, data that are not the record evaluated).
struct LoadedEvaluation {
  io::EvaluationDocument document;
  FitData data;
};
LoadedEvaluation read_evaluation_json(const std::string& path, const FitDataSource& data_override = {});

// `hysteron report INPUT --out report.html`: INPUT is an experiment directory, a fit report
// or an evaluation JSON file, told apart by its "format" key (a fit report of an older
// hysteron has none); another format is an error naming it (data_override: see
// read_fit_report_json).
void write_report_from(const std::string& input, const std::string& html_path, const std::string& command_line,
                       const FitDataSource& data_override = {});

// HTML-escapes text (&, <, >, ", ').
std::string html_escape(std::string_view text);

}  // namespace hysteron::report
