#pragma once
// Model files: one hysteresis model as a JSON object whose keys are the papers'
// symbols (schema in docs/model-files.md). Example (GPI, Eqs. 5-8):
//
//   {"schema": 1, "model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0, 0],
//    "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05,
//    "input_limits": [0, 0.6], "units": {"input": "MPa", "output": "mm"}}
//
// Reading is strict: unknown keys, missing keys, wrong types, wrong array
// lengths and non-finite numbers are errors, and every accepted file is checked
// by constructing hysteron::Model. Every error is a hysteron::Error whose message
// starts with the file (or `where`) and names the key and what was expected.
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <string_view>

#include "hysteron/models.hpp"

namespace hysteron::io {

// Parses a JSON text (a file's contents); errors name `where` and the line and
// column. Stricter than JSON itself where leniency would mislead: a key repeated
// in one object (`{"model": "gpi", "model": "pi"}` would silently load a PI) and
// a NUL byte anywhere in the text are errors. Every JSON input of hysteron
// (model files, rig parameters, reports) is read through this function.
nlohmann::json parse_json(std::string_view text, std::string_view where);

// The largest model file read [bytes]. The largest model the format allows has
// max_operators = 100000 operators with at most 4 arrays of that length (e.g. r, p, z, g),
// each number at most 24 characters plus its separator and pretty-printed indentation
// (~32 bytes): about 13 MB. 64 MB leaves room for any whitespace and notes.
inline constexpr std::size_t max_model_file_bytes = 64u << 20;
// The largest result file of an experiment read for its loop (--loop, the C ABI's loop and
// guard readers) [bytes]: it holds no per-sample arrays, only numbers and the fitted models
// (the candidates, the chosen and the paper's: about a dozen, each at most ~13 MB as above).
inline constexpr std::size_t max_result_file_bytes = std::size_t{256} << 20;

// The whole file (e.g. a JSON file to parse_json), at most max_bytes: Error "PATH: cannot
// open WHAT: REASON", "PATH: read error: REASON", or "PATH: the WHAT is ... more than the N
// bytes any valid one needs" (also for a device such as /dev/zero). A FIFO without a
// writer reads as empty instead of blocking.
std::string read_text_file(const std::string& path, std::string_view what,
                           std::size_t max_bytes = max_model_file_bytes);

// Current (and only) schema version written to and accepted in "schema".
inline constexpr int model_schema_version = 1;

// The training fit's error a model file may record: "training": {"rms": 0.97, "r2": 0.9994,
// "samples": 30000}, in the model's output units (the free-form key "training"; hysteron fit,
// Python's fit and the fit documents' model dicts write it). hysteron evaluate compares a record's
// error with it as fit --validate-data does (output_map_warning, validation_useless).
struct TrainingMetrics {
  double rms = 0.0;  // RMS error on the training range [output units], finite, >= 0
  double r2 = 0.0;   // its R^2, finite, <= 1
  std::size_t samples = 0;
};
nlohmann::json training_to_json(const TrainingMetrics& t);

// A model file as a whole: the model's parameters and the free-form keys beside them
// ("units", "note", "metadata", "training"; not part of the model: hysteron::Model never sees them).
// read_model_document / write_model_file(path, doc) are the one reader and writer of a
// model file: a read-modify-write through them keeps the free-form keys.
struct ModelDocument {
  ModelParams params;
  // The free-form keys as the file has them: an object, empty if none (checked as
  // check_model_extra does).
  nlohmann::json extra = nlohmann::json::object();
  // The unit the document's "units" names for `which` ("input" or "output"); "" if none.
  std::string unit(std::string_view which) const;
  // The training metrics the document's "training" records; nullopt if none.
  std::optional<TrainingMetrics> training() const;
};

// Reads and validates a model file with its free-form keys; path "-" reads standard input
// (named "<stdin>" in errors; empty input is an error). Throws hysteron::Error naming
// `path`, the line/column of a JSON syntax error, or the offending key.
ModelDocument read_model_document(const std::string& path);
// read_model_document(path).params: the parameters only.
ModelParams read_model_file(const std::string& path);

// Parses and validates a model from JSON; `where` (e.g. the file name) starts
// every error message. Free-form keys "units", "note" and "metadata" are
// checked (check_model_extra) and not part of the result (see model_document_from_json).
ModelParams model_from_json(const nlohmann::json& j, std::string_view where);
// The same with the free-form keys (model_extra(j)).
ModelDocument model_document_from_json(const nlohmann::json& j, std::string_view where);

// The free-form keys ("units", "note", "metadata") of a model JSON object, as an
// object (empty if none). Lets a caller keep them on a read-modify-write.
nlohmann::json model_extra(const nlohmann::json& j);

// Throws hysteron::Error "WHERE: key \"K\": ..." unless `extra` is null or an object whose keys
// are among "units" (an object of strings, e.g. {"input": "kPa", "output": "N"}), "note"
// (a string), "metadata" (any JSON value) and "training" (an object with exactly "rms" (finite,
// >= 0), "r2" (finite, <= 1) and "samples" (a whole number >= 0): TrainingMetrics).
void check_model_extra(const nlohmann::json& extra, std::string_view where);

// Model as JSON (with "schema"). model_from_json(model_to_json(p)) reproduces p
// exactly: doubles are written with 17 significant digits. A gpi with free
// weights (non-empty r) is written as r/p, without n/rho/tau/alpha.
nlohmann::json model_to_json(const ModelParams& params);
// model_to_json(doc.params) with doc.extra's keys (checked as check_model_extra does).
nlohmann::json model_to_json(const ModelDocument& doc);

// Writes model_to_json(params) merged with `extra` (null or an object whose keys may only
// be "units", "note", "metadata", checked as check_model_extra does) to `path`, atomically:
// a temporary file in the same directory is renamed over `path`; on failure `path` is left
// untouched. The parameters are validated first. Path "-" writes to stdout.
void write_model_file(const std::string& path, const ModelParams& params, const nlohmann::json& extra = {});
// write_model_file(path, doc.params, doc.extra).
void write_model_file(const std::string& path, const ModelDocument& doc);

}  // namespace hysteron::io
