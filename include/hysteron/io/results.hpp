#pragma once
// One serialization layer for every result type: to_json / from_json pairs, side by
// side, for the fit metrics, parameters, inverse check, candidates, fit reports, the
// documents `hysteron fit --report/--json` and `hysteron evaluate` write, and the
// experiment result. The CLI, the HTML report and the Python module use only these.
//
// Conventions (every writer here):
//  - keys are snake_case; enums are written by name (fit_status_name, fit_model_name,
//    "virgin" / "relaxed");
//  - a non-finite number is written as null; null reads back as NaN, except where a
//    field documents otherwise (InverseCheck::max_slope: null = +inf, "not invertible");
//  - a model is the model-file object of io::model_to_json (null when there is none:
//    status not_run, invalid_input or failed);
//  - an index range is [begin, end] with end null for "to the end".
// Reading is strict about what it needs (missing keys and wrong types are a
// hysteron::Error naming `where` and the key) and tolerant of keys it does not know.
//
// from_json(j, where) -> T is spelled io::from_json<T>(j, where).
#include <cstddef>
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/experiment.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/loop_design.hpp"  // LoopDesign (result.json "controller")
#include "hysteron/io/model_file.hpp"  // parse_json

namespace hysteron::io {

// Schema of the fit and evaluation documents ("schema" key); the reader refuses others.
inline constexpr int results_schema_version = 1;
inline constexpr std::string_view fit_document_format = "hysteron-fit-report";
inline constexpr std::string_view evaluation_document_format = "hysteron-evaluation";

// Names of the enums (the inverse of fit_status_name / fit_model_name). Throw hysteron::Error.
FitStatus fit_status_from_name(std::string_view name, std::string_view where);
std::string_view initial_state_name(InitialState s) noexcept;
InitialState initial_state_from_name(std::string_view name, std::string_view where);

// ---- what a fit or an evaluation was run on -------------------------------------

// Where the data came from and what they mean (files as given on the command line).
struct DataDescription {
  std::string input_file, input_column;
  std::string output_file, output_column;  // output_file empty: the input file
  std::string time_column;                 // empty: no time axis
  std::string time_unit = "s";             // of the time column: s, ms or us (time_unit_seconds)
  // time_unit is the user's --time-unit, for every file (documents before 2026-12-01: always);
  // false: the training file's header gave it, and a file that names no unit is in s
  bool time_unit_given = true;
  std::string input_label = "Input", input_unit;
  std::string output_label = "Output", output_unit;
  InitialState initial_state = InitialState::virgin;
  IndexRange train{};  // fit: the training range; evaluate: the evaluated range
  // A record whose output clips is fitted and scored as censored data (fit: censor_passes > 0;
  // evaluate: not --uncensored); a report regenerated from the document scores it the same.
  bool censored = true;
};

// The keys result.json's writer (to_json(ExperimentResult)) puts beside reference names in the
// objects keyed by them (the published figures' "source" and errors; a variant's errors, which
// a single reference's object holds itself): no reference may take one as its name
// (parse_references refuses it), or the file would not read back.
inline constexpr std::array<std::string_view, 4> kKeysBesideReferenceNames = {"source", "max_error_mm", "mae_mm",
                                                                             "rms_error_mm"};

// Seconds in one unit of a time column: "s" 1, "ms" 1e-3, "us" 1e-6; throws hysteron::Error naming
// `where` and the unit for any other.
double time_unit_seconds(std::string_view unit, std::string_view where);
// The time unit (s, ms or us) a column's unit text names ("ms", "msec", "[s]", "seconds", "µs", ...;
// io::column_unit gives the text); "" if it names none; throws hysteron::Error ("`where` is in
// ...") for a time unit that is not read (min, h, ns).
std::string time_unit_named(std::string_view unit, std::string_view where);

// A model checked on (a range of) a record.
struct Evaluation {
  std::string file;      // the record ("" = the fit's own record)
  IndexRange range{};    // samples scored (resolved: end is a sample index)
  FitMetrics metrics;
  std::size_t censored = 0;  // clipped samples of the range scored as censored (evaluate_censored)
  std::size_t outside_input_limits = 0;  // samples of the range whose input is outside the model's (input_coverage)
  OutputMap output_map;  // the record's output against the prediction (output_map; NaN in files before it)
  // Not scored: why the model could not be run on the record (hysteron::Error's text, e.g. an input
  // sample beyond the model's input bound); its metrics are then NaN ("error" in the document, absent
  // where scored). fit counts such a validation set as useless (exit 3), never leaves it out.
  std::string error = {};
  // false where a document predates the count ("censored_samples" / "outside_input_limits" absent):
  // the count is unknown, not 0 (to_json then leaves the key out again)
  bool censored_recorded = true;
  bool outside_input_limits_recorded = true;
};

// The document of `hysteron fit --report FILE.json` and `--json`.
struct FitDocument {
  FitReport fit;
  DataDescription data;
  // Validation sets: a range of the fit's record, or each --validate-data file.
  std::vector<Evaluation> validation;
  // FitModel::automatic: candidate_validation[i][k] = metrics of fit.candidates[i]'s
  // model on validation[k] (empty if not computed).
  std::vector<std::vector<FitMetrics>> candidate_validation;
  bool model_written = false;
  std::string model_file;
};

// The document of `hysteron evaluate --json / --report FILE.json`. from_json of a document written
// before censored scoring (hysteron before 2026-11-26: neither "data.censored" nor
// "metrics.censored_samples") sets data.censored = false: it was scored as recorded.
struct EvaluationDocument {
  std::string model_file;
  ModelParams model;
  DataDescription data;  // data.train = the evaluated range
  Evaluation result;
  // the warnings evaluate printed and its verdict (validation_useless: exit 3); a document from before
  // 2026-12-01 records neither (read as none and false)
  std::vector<std::string> warnings;
  bool useless = false;
};

// The model file's "training" (TrainingMetrics: rms, r2, samples) of a fit's training metrics;
// null where they are not finite (nothing to record). hysteron fit's model file, the fit documents'
// "model" dicts (and so Python's fit) and the experiments' model files carry it.
nlohmann::json training_json(const FitMetrics& train);
// The reverse: a model document's "training" as FitMetrics (rms, r2, n; the other fields 0), rms and
// r2 NaN where the document records none (judge_evaluation: nothing to compare with). evaluate's
// training error in the CLI, Python and MATLAB.
FitMetrics training_metrics(const ModelDocument& doc);

// ---- to_json / from_json pairs ----------------------------------------------------

nlohmann::json to_json(const FitMetrics& m);
void from_json(const nlohmann::json& j, FitMetrics& m, std::string_view where);

nlohmann::json to_json(const FitParameter& p);
void from_json(const nlohmann::json& j, FitParameter& p, std::string_view where);

nlohmann::json to_json(const InverseCheck& c);
void from_json(const nlohmann::json& j, InverseCheck& c, std::string_view where);

nlohmann::json to_json(const FitCandidate& c);
void from_json(const nlohmann::json& j, FitCandidate& c, std::string_view where);

// Every field of FitReport (the model through model_to_json / model_from_json).
nlohmann::json to_json(const FitReport& r);
void from_json(const nlohmann::json& j, FitReport& r, std::string_view where);

nlohmann::json to_json(const IndexRange& r);
void from_json(const nlohmann::json& j, IndexRange& r, std::string_view where);

nlohmann::json to_json(const DataDescription& d);
void from_json(const nlohmann::json& j, DataDescription& d, std::string_view where);

nlohmann::json to_json(const Evaluation& e);
void from_json(const nlohmann::json& j, Evaluation& e, std::string_view where);

// to_json(fit) plus "format", "schema", "data", "validate" (the first validation set's
// metrics, or null where there is none or it was not scored: see its "error"), "validate_files"
// (every set, with "file" and "range", "error" for one the model could not be run on),
// "model_written", "model_file"; each candidate gets "validate": [metrics per set].
// from_json also reads the older CLI report (no "format", "starts" for "num_starts").
nlohmann::json to_json(const FitDocument& d);
void from_json(const nlohmann::json& j, FitDocument& d, std::string_view where);

nlohmann::json to_json(const EvaluationDocument& d);
void from_json(const nlohmann::json& j, EvaluationDocument& d, std::string_view where);

nlohmann::json to_json(const TrackingErrors& e);
void from_json(const nlohmann::json& j, TrackingErrors& e, std::string_view where);

// null if the paper gives no figures; {"source", "max_error_mm", ...} for one reference;
// {"source", "<reference>": {"max_error_mm", ...}, ...} for several.
nlohmann::json to_json(const PublishedFigures& p);
void from_json(const nlohmann::json& j, PublishedFigures& p, std::string_view where);

// The experiment summary (result.json, `experiment --json`): every field but the time
// series (identification.csv, tracking_*.csv) and the fits' parameter tables; the
// fitted models are included. from_json fills the runs without their series.
nlohmann::json to_json(const ExperimentResult& r);
void from_json(const nlohmann::json& j, ExperimentResult& r, std::string_view where);

template <class T>
T from_json(const nlohmann::json& j, std::string_view where) {
  T out{};
  from_json(j, out, where);
  return out;
}

}  // namespace hysteron::io
