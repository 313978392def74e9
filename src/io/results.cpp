// The to_json / from_json pairs of every result type (see hysteron/io/results.hpp).
#include "hysteron/io/results.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"
#include "json_read.hpp"

namespace hysteron::io {

namespace {

using nlohmann::json;
using namespace json_read;

// A model (null when there is none).
json model_or_null(FitStatus s, const ModelParams& m) { return has_model(s) ? model_to_json(m) : json(nullptr); }
// A fitted model with its training error (the model file's "training"), as hysteron fit writes its file.
json model_or_null(FitStatus s, const ModelParams& m, const FitMetrics& train) {
  json j = model_or_null(s, m);
  if (json t = training_json(train); j.is_object() && !t.is_null()) j["training"] = std::move(t);
  return j;
}
// A model that may not have been set (e.g. an experiment's baseline): null unless valid.
json valid_model_or_null(const ModelParams& m) {
  try {
    (void)Model(m);
  } catch (const Error&) {
    return nullptr;
  }
  return model_to_json(m);
}
void read_model(const json& j, std::string_view key, std::string_view where, ModelParams& m) {
  const json& v = need(j, key, where);
  if (v.is_null()) return;
  m = model_from_json(v, key_where(where, key));
}

FitModel model_kind_from(const json& j, std::string_view key, std::string_view where) {
  const std::string name = get_string(j, key, where);
  try {
    return fit_model_from_name(name);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: key \"{}\": {}", where, key, e.what()));
  }
}

}  // namespace

// ---- names ---------------------------------------------------------------------

FitStatus fit_status_from_name(std::string_view name, std::string_view where) {
  for (FitStatus s : {FitStatus::not_run, FitStatus::converged, FitStatus::no_convergence, FitStatus::failed,
                      FitStatus::poor_fit, FitStatus::invalid_input})
    if (fit_status_name(s) == name) return s;
  throw Error(fmt::format("{}: unknown fit status \"{}\"", where, name));
}

std::string_view initial_state_name(InitialState s) noexcept {
  return s == InitialState::relaxed ? "relaxed" : "virgin";
}

InitialState initial_state_from_name(std::string_view name, std::string_view where) {
  if (name == "virgin") return InitialState::virgin;
  if (name == "relaxed") return InitialState::relaxed;
  throw Error(fmt::format("{}: unknown initial state \"{}\" (expected virgin or relaxed)", where, name));
}

// ---- FitMetrics ------------------------------------------------------------------

json training_json(const FitMetrics& train) {
  if (!(std::isfinite(train.rms) && train.rms >= 0.0 && std::isfinite(train.r2) && train.r2 <= 1.0)) return nullptr;
  return training_to_json({train.rms, train.r2, train.n});
}

FitMetrics training_metrics(const ModelDocument& doc) {
  FitMetrics train;
  train.rms = train.r2 = nan;
  if (const auto t = doc.training()) {
    train.rms = t->rms;
    train.r2 = t->r2;
    train.n = t->samples;
  }
  return train;
}

json to_json(const FitMetrics& m) {
  return {{"rms", number(m.rms)}, {"max", number(m.max)}, {"mae", number(m.mae)},
          {"rms_percent_span", number(m.rms_percent_span)}, {"r2", number(m.r2)}, {"n", m.n}};
}

void from_json(const json& j, FitMetrics& m, std::string_view where) {
  m.rms = get_double(j, "rms", where);
  m.max = get_double(j, "max", where);
  m.mae = get_double(j, "mae", where);
  m.rms_percent_span = get_double(j, "rms_percent_span", where);
  m.r2 = get_double(j, "r2", where);
  m.n = get_size(j, "n", where);
}

// ---- FitParameter ----------------------------------------------------------------

json to_json(const FitParameter& p) {
  return {{"name", p.name}, {"value", number(p.value)}, {"std_error", number(p.std_error)}, {"held", p.held},
          {"at_bound", p.at_bound}};
}

void from_json(const json& j, FitParameter& p, std::string_view where) {
  p.name = get_string(j, "name", where);
  p.value = get_double(j, "value", where);
  p.std_error = j.contains("std_error") ? get_double(j, "std_error", where) : nan;
  p.held = opt_bool(j, "held", where, false);
  p.at_bound = opt_bool(j, "at_bound", where, false);
}

// ---- InverseCheck ----------------------------------------------------------------

json to_json(const InverseCheck& c) {
  json j = {{"max_slope", number(c.max_slope)}, {"max_jump", number(c.max_jump)},
            {"max_input_step", number(c.max_input_step)}, {"increasing", c.increasing}};
  if (!c.no_inverse.empty()) j["no_inverse"] = c.no_inverse;  // why max_slope is null
  return j;
}

void from_json(const json& j, InverseCheck& c, std::string_view where) {
  c.max_slope = get_double(j, "max_slope", where, std::numeric_limits<double>::infinity());
  c.max_jump = get_double(j, "max_jump", where);
  c.max_input_step = get_double(j, "max_input_step", where);
  c.increasing = get_bool(j, "increasing", where);
  c.no_inverse = opt_string(j, "no_inverse", where);
}

// ---- FitCandidate ----------------------------------------------------------------

json to_json(const FitCandidate& c) {
  return {{"kind", std::string(fit_model_name(c.kind))},
          // the samples of fold 0's fit, whose status, message, train, model and parameters these are
          {"fit_range", to_json(c.fit_range)},
          {"status", std::string(fit_status_name(c.status))},
          {"message", c.message},
          {"train", to_json(c.train)},
          {"holdout", to_json(c.holdout)},
          {"holdout_score", number(c.holdout_score)},
          {"num_parameters", c.num_parameters},
          {"time_s", number(c.time_s)},
          {"chosen", c.chosen},
          {"model", model_or_null(c.status, c.model, c.train)}};
}

void from_json(const json& j, FitCandidate& c, std::string_view where) {
  c.kind = model_kind_from(j, "kind", where);
  c.status = fit_status_from_name(get_string(j, "status", where), key_where(where, "status"));
  c.message = opt_string(j, "message", where);
  c.fit_range = {};
  if (j.contains("fit_range")) from_json(j["fit_range"], c.fit_range, key_where(where, "fit_range"));  // absent before it
  from_json(need(j, "train", where), c.train, key_where(where, "train"));
  from_json(need(j, "holdout", where), c.holdout, key_where(where, "holdout"));
  c.holdout_score = opt_double(j, "holdout_score", where, nan);  // absent in files before it
  c.num_parameters = j.contains("num_parameters") ? get_size(j, "num_parameters", where) : 0;  // likewise
  c.time_s = get_double(j, "time_s", where);
  c.chosen = get_bool(j, "chosen", where);
  c.model = ModelParams{};
  read_model(j, "model", where, c.model);
}

// ---- FitReport -------------------------------------------------------------------

json to_json(const FitReport& r) {
  json params = json::array();
  for (const auto& p : r.parameters) params.push_back(to_json(p));
  json candidates = json::array();
  for (const auto& c : r.candidates) candidates.push_back(to_json(c));
  json faults = json::array();
  for (const SensorFaultRun& f : r.fault_runs)
    faults.push_back({{"rows", to_json(f.rows)}, {"column", f.input ? "input" : "output"}});
  return {{"status", std::string(fit_status_name(r.status))},
          {"message", r.message},
          {"model_kind", std::string(fit_model_name(r.model_kind))},
          {"initial_cost", number(r.initial_cost)},
          {"final_cost", number(r.final_cost)},
          {"iterations", r.iterations},
          {"total_iterations", r.total_iterations},
          {"num_starts", r.num_starts},
          {"time_s", number(r.time_s)},
          {"model", model_or_null(r.status, r.model, r.train)},
          {"parameters", params},
          {"covariance_note", r.covariance_note},
          {"train", to_json(r.train)},
          {"reference", to_json(r.reference)},
          {"inverse", to_json(r.inverse)},
          {"warnings", r.warnings},
          {"fault_runs", faults},
          {"fault_free_train", r.fault_free_train ? to_json(*r.fault_free_train) : json(nullptr)},
          {"candidates", candidates}};
}

void from_json(const json& j, FitReport& r, std::string_view where) {
  r = FitReport{};
  r.status = fit_status_from_name(get_string(j, "status", where), key_where(where, "status"));
  r.message = opt_string(j, "message", where);
  r.model_kind = model_kind_from(j, "model_kind", where);
  r.initial_cost = opt_double(j, "initial_cost", where, 0.0);
  r.final_cost = opt_double(j, "final_cost", where, 0.0);
  r.iterations = opt_int(j, "iterations", where, 0);
  r.total_iterations = opt_int(j, "total_iterations", where, 0);
  r.num_starts = j.contains("num_starts") ? get_int(j, "num_starts", where) : opt_int(j, "starts", where, 0);
  r.time_s = opt_double(j, "time_s", where, 0.0);
  read_model(j, "model", where, r.model);
  if (j.contains("parameters")) {
    const json& ps = get_array(j, "parameters", where);
    for (std::size_t i = 0; i < ps.size(); ++i)
      r.parameters.push_back(from_json<FitParameter>(ps[i], fmt::format("{}.parameters[{}]", where, i)));
  }
  r.covariance_note = opt_string(j, "covariance_note", where);
  if (j.contains("train")) from_json(j["train"], r.train, key_where(where, "train"));
  if (j.contains("reference")) from_json(j["reference"], r.reference, key_where(where, "reference"));
  if (j.contains("inverse")) from_json(j["inverse"], r.inverse, key_where(where, "inverse"));
  if (j.contains("warnings")) {
    const json& w = get_array(j, "warnings", where);
    for (std::size_t i = 0; i < w.size(); ++i) {
      if (!w[i].is_string()) wrong_type(w[i], fmt::format("warnings[{}]", i), where, "a string");
      r.warnings.push_back(w[i].get<std::string>());
    }
  }
  // a range of samples a fit names: [begin, end] with begin < end
  const auto rows = [&](const json& v, const std::string& at) {
    if (!v.is_array() || v.size() != 2 || v[1].is_null())
      throw Error(fmt::format("{}: expected a range [begin, end] of samples with begin < end, got {}", at, v.dump()));
    IndexRange t;
    from_json(v, t, at);
    if (t.end == IndexRange::npos || t.begin >= t.end)
      throw Error(fmt::format("{}: expected a range [begin, end] of samples with begin < end, got {}", at, v.dump()));
    return t;
  };
  if (j.contains("fault_runs")) {  // absent in files before them
    const json& fs = get_array(j, "fault_runs", where);
    for (std::size_t i = 0; i < fs.size(); ++i) {
      const std::string at = fmt::format("{}.fault_runs[{}]", where, i);
      const std::string column = get_string(fs[i], "column", at);
      if (column != "input" && column != "output")
        throw Error(fmt::format("{}.column: expected \"input\" or \"output\", got \"{}\"", at, column));
      r.fault_runs.push_back({rows(need(fs[i], "rows", at), at + ".rows"), column == "input"});
    }
  }
  if (j.contains("fault_free_train") && !j["fault_free_train"].is_null())
    r.fault_free_train = rows(j["fault_free_train"], key_where(where, "fault_free_train"));
  if (j.contains("candidates")) {
    const json& cs = get_array(j, "candidates", where);
    for (std::size_t i = 0; i < cs.size(); ++i)
      r.candidates.push_back(from_json<FitCandidate>(cs[i], fmt::format("{}.candidates[{}]", where, i)));
  }
}

// ---- ranges, data, evaluations -----------------------------------------------------

json to_json(const IndexRange& r) {
  return json::array({r.begin, r.end == IndexRange::npos ? json(nullptr) : json(r.end)});
}

void from_json(const json& j, IndexRange& r, std::string_view where) {
  if (!j.is_array() || j.size() != 2)
    throw Error(fmt::format("{}: expected a range [begin, end] (end null: to the end), got {}", where, j.dump()));
  r.begin = j[0].is_null() ? 0 : as_size(j[0], "[0]", where);
  r.end = j[1].is_null() ? IndexRange::npos : as_size(j[1], "[1]", where);
}

double time_unit_seconds(std::string_view unit, std::string_view where) {
  if (unit == "s") return 1.0;
  if (unit == "ms") return 1e-3;
  if (unit == "us") return 1e-6;
  throw Error(fmt::format("{}: unknown time unit \"{}\" (expected s, ms or us)", where, unit));
}

std::string time_unit_named(std::string_view unit, std::string_view where) {
  std::string u = strip_unit_brackets(unit);
  if (u == "\xC2\xB5s" || u == "\xCE\xBCs") return "us";  // micro sign, Greek mu
  std::transform(u.begin(), u.end(), u.begin(), [](unsigned char ch) { return std::tolower(ch); });
  const auto any = [&](std::initializer_list<std::string_view> names) {
    return std::find(names.begin(), names.end(), u) != names.end();
  };
  if (any({"s", "sec", "secs", "second", "seconds"})) return "s";
  if (any({"ms", "msec", "msecs", "millisecond", "milliseconds"})) return "ms";
  if (any({"us", "usec", "usecs", "microsecond", "microseconds"})) return "us";
  if (any({"ns", "nsec", "nanosecond", "nanoseconds", "min", "mins", "minute", "minutes", "h", "hr", "hrs", "hour",
           "hours", "d", "day", "days"}))
    throw Error(fmt::format("{} is in \"{}\", a time unit that is not read: give the column in s, ms or us", where,
                            strip_unit_brackets(unit)));
  return std::string();
}

json to_json(const DataDescription& d) {
  json j = {{"input", {{"file", d.input_file}, {"column", d.input_column}}},
            {"output", {{"file", d.output_file.empty() ? d.input_file : d.output_file}, {"column", d.output_column}}},
            {"input_axis", {{"label", d.input_label}, {"unit", d.input_unit}}},
            {"output_axis", {{"label", d.output_label}, {"unit", d.output_unit}}},
            {"initial_state", std::string(initial_state_name(d.initial_state))},
            {"train", to_json(d.train)},
            {"censored", d.censored}};
  if (!d.time_column.empty()) {
    j["time_column"] = d.time_column;
    j["time_unit"] = d.time_unit;
    j["time_unit_given"] = d.time_unit_given;
  }
  return j;
}

void from_json(const json& j, DataDescription& d, std::string_view where) {
  d = DataDescription{};
  const json& in = need(j, "input", where);
  d.input_file = get_string(in, "file", key_where(where, "input"));
  d.input_column = opt_string(in, "column", key_where(where, "input"));
  const json& out = need(j, "output", where);
  d.output_file = get_string(out, "file", key_where(where, "output"));
  d.output_column = opt_string(out, "column", key_where(where, "output"));
  d.time_column = opt_string(j, "time_column", where);
  // documents before 2026-11-30 have no time_unit: their time columns were in seconds or drawn as such
  d.time_unit = opt_string(j, "time_unit", where, "s");
  (void)time_unit_seconds(d.time_unit, key_where(where, "time_unit"));
  d.time_unit_given = opt_bool(j, "time_unit_given", where, true);
  if (j.contains("input_axis")) {
    d.input_label = opt_string(j["input_axis"], "label", key_where(where, "input_axis"), d.input_label);
    d.input_unit = opt_string(j["input_axis"], "unit", key_where(where, "input_axis"));
  }
  if (j.contains("output_axis")) {
    d.output_label = opt_string(j["output_axis"], "label", key_where(where, "output_axis"), d.output_label);
    d.output_unit = opt_string(j["output_axis"], "unit", key_where(where, "output_axis"));
  }
  if (d.input_label.empty()) d.input_label = "Input";
  if (d.output_label.empty()) d.output_label = "Output";
  d.initial_state = initial_state_from_name(opt_string(j, "initial_state", where, "virgin"),
                                            key_where(where, "initial_state"));
  if (j.contains("train")) from_json(j["train"], d.train, key_where(where, "train"));
  if (j.contains("censored")) {
    if (!j["censored"].is_boolean()) wrong_type(j["censored"], "censored", where, "true or false");
    d.censored = j["censored"].get<bool>();
  }
}

json to_json(const Evaluation& e) {
  json j = to_json(e.metrics);
  j["file"] = e.file;
  j["range"] = to_json(e.range);
  if (!e.error.empty()) j["error"] = e.error;
  if (e.censored_recorded) j["censored_samples"] = e.censored;
  if (e.outside_input_limits_recorded) j["outside_input_limits"] = e.outside_input_limits;
  j["output_map"] = {{"gain", number(e.output_map.gain)},
                     {"offset", number(e.output_map.offset)},
                     {"r2", number(e.output_map.r2)},
                     {"r2_mapped", number(e.output_map.r2_mapped)},
                     {"rms", number(e.output_map.rms)},
                     {"rms_mapped", number(e.output_map.rms_mapped)},
                     {"span", number(e.output_map.span)}};
  return j;
}

void from_json(const json& j, Evaluation& e, std::string_view where) {
  from_json(j, e.metrics, where);
  e.file = opt_string(j, "file", where);
  e.range = {};
  if (j.contains("range")) from_json(j["range"], e.range, key_where(where, "range"));
  e.error = opt_string(j, "error", where);
  // absent in documents before they were recorded: unknown (not 0)
  e.censored_recorded = j.contains("censored_samples");
  e.censored = e.censored_recorded ? get_size(j, "censored_samples", where) : 0;
  e.outside_input_limits_recorded = j.contains("outside_input_limits");
  e.outside_input_limits = e.outside_input_limits_recorded ? get_size(j, "outside_input_limits", where) : 0;
  e.output_map = {};
  if (j.contains("output_map")) {  // absent in files before it
    const json& m = j["output_map"];
    const std::string mw = key_where(where, "output_map");
    e.output_map = {opt_double(m, "gain", mw, nan),      opt_double(m, "offset", mw, nan),
                    opt_double(m, "r2", mw, nan),        opt_double(m, "r2_mapped", mw, nan),
                    opt_double(m, "rms", mw, nan),       opt_double(m, "rms_mapped", mw, nan),
                    opt_double(m, "span", mw, nan)};
  }
}

// ---- documents -------------------------------------------------------------------

json to_json(const FitDocument& d) {
  json j = {{"format", std::string(fit_document_format)}, {"schema", results_schema_version}};
  j.update(to_json(d.fit));
  for (std::size_t i = 0; i < d.candidate_validation.size() && i < d.fit.candidates.size(); ++i) {
    json v = json::array();
    for (const auto& m : d.candidate_validation[i]) v.push_back(to_json(m));
    j["candidates"][i]["validate"] = v;
  }
  j["data"] = to_json(d.data);
  // the first set, as every --validate-data file is listed in validate_files (one the model could not be
  // run on too, with its "error"): null where that set was not scored
  j["validate"] = d.validation.empty() || !d.validation.front().error.empty() ? json(nullptr)
                                                                               : to_json(d.validation.front().metrics);
  json files = json::array();
  for (const auto& e : d.validation) files.push_back(to_json(e));
  j["validate_files"] = files;
  j["model_written"] = d.model_written;
  j["model_file"] = d.model_file;
  return j;
}

void from_json(const json& j, FitDocument& d, std::string_view where) {
  if (!j.is_object()) throw Error(fmt::format("{}: expected a JSON object, got {}", where, j.type_name()));
  if (j.contains("format") && j["format"] != std::string(fit_document_format))
    throw Error(fmt::format("{}: not a hysteron fit report (format {})", where, j["format"].dump()));
  if (j.contains("schema") && j["schema"] != results_schema_version)
    throw Error(fmt::format("{}: unsupported fit report schema {} (this hysteron reads schema {})", where,
                            j["schema"].dump(), results_schema_version));
  d = FitDocument{};
  from_json(j, d.fit, where);
  if (j.contains("candidates")) {
    bool any = false;
    for (const auto& c : j["candidates"]) any = any || c.contains("validate");
    if (any) {
      const json& cs = j["candidates"];
      for (std::size_t i = 0; i < cs.size(); ++i) {
        std::vector<FitMetrics> v;
        if (cs[i].contains("validate")) {
          const std::string w = fmt::format("{}.candidates[{}].validate", where, i);
          const json& a = cs[i]["validate"];
          if (!a.is_array()) throw Error(fmt::format("{}: expected an array, got {}", w, a.type_name()));
          for (std::size_t k = 0; k < a.size(); ++k)
            v.push_back(from_json<FitMetrics>(a[k], fmt::format("{}[{}]", w, k)));
        }
        d.candidate_validation.push_back(std::move(v));
      }
    }
  }
  if (j.contains("data")) from_json(j["data"], d.data, key_where(where, "data"));
  if (j.contains("validate_files")) {
    const json& a = get_array(j, "validate_files", where);
    for (std::size_t i = 0; i < a.size(); ++i)
      d.validation.push_back(from_json<Evaluation>(a[i], fmt::format("{}.validate_files[{}]", where, i)));
  } else if (j.contains("validate") && !j["validate"].is_null()) {
    d.validation.push_back({"", {}, from_json<FitMetrics>(j["validate"], key_where(where, "validate")), 0, 0, {}});
  }
  d.model_written = opt_bool(j, "model_written", where, false);
  d.model_file = opt_string(j, "model_file", where);
}

json to_json(const EvaluationDocument& d) {
  json j = {{"format", std::string(evaluation_document_format)},
            {"schema", results_schema_version},
            {"model_file", d.model_file},
            {"model_kind", std::string(model_name(d.model))},
            {"model", model_to_json(d.model)},
            {"data", to_json(d.data)}};
  j["metrics"] = to_json(d.result);
  j["warnings"] = d.warnings;
  j["useless"] = d.useless;
  return j;
}

void from_json(const json& j, EvaluationDocument& d, std::string_view where) {
  if (!j.is_object() || j.value("format", std::string()) != evaluation_document_format)
    throw Error(fmt::format("{}: not a hysteron evaluation (expected \"format\": \"{}\")", where,
                            evaluation_document_format));
  if (!j.contains("schema") || !j["schema"].is_number_integer() || j["schema"] != results_schema_version)
    throw Error(fmt::format("{}: unsupported evaluation schema {} (this hysteron reads schema {})", where,
                            j.value("schema", json()).dump(), results_schema_version));
  d = EvaluationDocument{};
  d.model_file = opt_string(j, "model_file", where);
  d.model = model_from_json(need(j, "model", where), key_where(where, "model"));
  from_json(need(j, "data", where), d.data, key_where(where, "data"));
  const json& metrics = need(j, "metrics", where);
  from_json(metrics, d.result, key_where(where, "metrics"));
  if (j.contains("warnings")) {
    const json& w = get_array(j, "warnings", where);
    for (std::size_t i = 0; i < w.size(); ++i) {
      if (!w[i].is_string()) wrong_type(w[i], fmt::format("warnings[{}]", i), where, "a string");
      d.warnings.push_back(w[i].get<std::string>());
    }
  }
  d.useless = opt_bool(j, "useless", where, false);
  // the evaluated range: every evaluate writes it (the fit document's validations may lack one)
  if (!metrics.contains("range"))
    throw Error(fmt::format("{}: metrics.range is missing (the evaluated range [begin, end] the metrics are of)", where));
  if (d.result.range.begin >= d.result.range.end)
    throw Error(fmt::format("{}: metrics.range [{}, {}) is empty (the evaluated range [begin, end) the metrics are "
                            "of holds no sample)",
                            where, d.result.range.begin, d.result.range.end));
  // before censored scoring (2026-11-26) evaluate scored a clipping record as recorded and wrote
  // neither key; from then on both (data.censored a little later: censored_samples alone means
  // the default, censored)
  if (!j["data"].contains("censored") && !d.result.censored_recorded) d.data.censored = false;
}

// ---- experiment ------------------------------------------------------------------

json to_json(const TrackingErrors& e) {
  return {{"max_error_mm", number(e.max_error_mm)}, {"mae_mm", number(e.mae_mm)},
          {"rms_error_mm", number(e.rms_error_mm)}};
}

void from_json(const json& j, TrackingErrors& e, std::string_view where) {
  e.max_error_mm = get_double(j, "max_error_mm", where);
  e.mae_mm = get_double(j, "mae_mm", where);
  e.rms_error_mm = get_double(j, "rms_error_mm", where);
}

// LoopDesign: io/loop_design.hpp (src/io/loop_design.cpp).

namespace {
json published_errors(const PublishedErrors& e) {
  json j = json::object();
  if (std::isfinite(e.max_error_mm)) j["max_error_mm"] = e.max_error_mm;
  if (std::isfinite(e.mae_mm)) j["mae_mm"] = e.mae_mm;
  if (std::isfinite(e.rms_error_mm)) j["rms_error_mm"] = e.rms_error_mm;
  return j;
}
PublishedErrors published_errors_from(const json& j, std::string reference, std::string_view where) {
  PublishedErrors e;
  e.reference = std::move(reference);
  e.max_error_mm = opt_double(j, "max_error_mm", where, nan);
  e.mae_mm = opt_double(j, "mae_mm", where, nan);
  e.rms_error_mm = opt_double(j, "rms_error_mm", where, nan);
  return e;
}
}  // namespace

json to_json(const PublishedFigures& p) {
  if (p.errors.empty()) return nullptr;
  json j = {{"source", p.source}};
  if (p.errors.size() == 1 && p.errors.front().reference.empty()) {
    j.update(published_errors(p.errors.front()));
  } else {
    for (const auto& e : p.errors) j[e.reference] = published_errors(e);
  }
  return j;
}

void from_json(const json& j, PublishedFigures& p, std::string_view where) {
  p = PublishedFigures{};
  if (j.is_null()) return;
  if (!j.is_object()) throw Error(fmt::format("{}: expected an object or null, got {}", where, j.type_name()));
  p.source = opt_string(j, "source", where);
  if (j.contains("max_error_mm")) {
    p.errors.push_back(published_errors_from(j, "", where));
    return;
  }
  for (const auto& [key, v] : j.items())
    if (v.is_object()) p.errors.push_back(published_errors_from(v, key, key_where(where, key)));
}

json to_json(const ExperimentResult& r) {
  json j;
  j["schema"] = 1;
  j["experiment"] = r.name;
  j["title"] = r.title;
  j["seed"] = r.seed;
  j["control_period_s"] = number(r.control_period_s);
  std::vector<std::string> refs, variants;
  for (const auto& run : r.runs) {
    if (std::find(refs.begin(), refs.end(), run.reference) == refs.end()) refs.push_back(run.reference);
    if (std::find(variants.begin(), variants.end(), run.variant) == variants.end()) variants.push_back(run.variant);
  }
  j["variants"] = variants;
  for (const auto& variant : variants) {
    json v = json::object();
    for (const auto& run : r.runs) {
      if (run.variant != variant) continue;
      json e = to_json(run.errors);
      e["reference"] = run.reference;
      e["description"] = run.description;
      e["saturated_samples"] = run.saturated;
      e["scored_from_s"] = run.scored_from_s;
      e["controller"] = to_json(run.controller);
      if (!run.periods.empty()) {
        json per = json::array();
        for (const auto& p : run.periods) per.push_back(to_json(p));
        e["periods"] = per;
      }
      if (refs.size() == 1) v = e; else v[run.reference] = e;
    }
    j[variant] = v;
  }
  // derived from the runs (the reader does not read it back): "ok", or "not_below_baseline" with the runs
  const std::vector<std::string> useless = r.not_below_baseline();
  j["status"] = useless.empty() ? "ok" : "not_below_baseline";
  j["not_below_baseline"] = useless;
  j["published"] = to_json(r.published);
  j["identification"] = {{"model", std::string(fit_model_name(r.fit.model_kind))},
                         {"train_end", r.id_train_end},
                         {"status", std::string(fit_status_name(r.fit.status))},
                         {"message", r.fit.message},
                         {"train", to_json(r.fit.train)},
                         {"validate", to_json(r.validation)},
                         {"fit_time_s", number(r.fit.time_s)},
                         {"parameters", model_or_null(r.fit.status, r.fit.model)},
                         {"covariance_note", r.fit.covariance_note}};
  // the fitted parameters with their standard errors (the report's table; `hysteron report DIR` reads them back)
  j["identification"]["fitted_parameters"] = json::array();
  for (const FitParameter& p : r.fit.parameters) j["identification"]["fitted_parameters"].push_back(to_json(p));
  j["best_model"] = {{"model", std::string(fit_model_name(r.best_fit.model_kind))},
                     {"status", std::string(fit_status_name(r.best_fit.status))},
                     {"validate_second_run", to_json(r.best_validation)},
                     {"choice", std::string(fit_model_name(r.model_choice))},
                     {"reason", r.model_reason},
                     {"candidates", json::array()},
                     {"parameters", model_or_null(r.best_fit.status, r.best_fit.model)}};
  for (const auto& c : r.candidates)
    j["best_model"]["candidates"].push_back({{"model", std::string(fit_model_name(c.kind))},
                                             {"ok", c.ok},
                                             {"status", std::string(fit_status_name(c.status))},
                                             {"message", c.message},
                                             {"validate_second_run", to_json(c.validation)},
                                             {"fit_time_s", number(c.fit_time_s)},
                                             {"chosen", c.chosen}});
  j["baseline_model"] = valid_model_or_null(r.baseline_model);
  j["lead_s"] = number(r.lead_s);
  j["model_identification_top_mpa"] = number(r.model_id_top_mpa);
  j["pressure_limit_mpa"] = number(r.pressure_limit_mpa);
  j["dynamics"] = {{"dead_time_s", number(r.dynamics.dead_time_s)},
                   {"lag_s", number(r.dynamics.lag_s)},
                   {"gain_m_per_mpa", number(r.dynamics.gain_m_per_mpa)},
                   {"rms_mm", number(r.dynamics.rms_mm)},
                   {"position_relay_gain_mpa_per_m", number(r.dynamics.position_relay_gain)},
                   {"position_relay_period_s", number(r.dynamics.position_relay_period_s)},
                   {"position_relay_amplitude_mpa", number(r.dynamics.position_relay_amplitude_mpa)},
                   {"position_relay_level_mpa", number(r.dynamics.position_relay_level_mpa)},
                   {"position_relay_hysteresis_m", number(r.dynamics.position_relay_hysteresis_m)},
                   {"mode_frequency_hz", number(r.dynamics.mode_frequency_hz)},
                   {"mode_damping", number(r.dynamics.mode_damping)},
                   {"pressure_relay_gain_per_mpa", number(r.dynamics.relay_gain)},
                   {"pressure_relay_period_s", number(r.dynamics.relay_period_s)},
                   {"pressure_relay_level_mpa", number(r.dynamics.relay_level_mpa)},
                   {"pressure_relay_duty", number(r.dynamics.relay_duty)}};
  j["reach"] = {{"min_mm", number(r.reach_min_mm)},
                {"max_mm", number(r.reach_max_mm)},
                {"top_mm", number(r.reach_top_mm)},
                {"top_pressure_mpa", number(r.reach_top_pressure_mpa)},
                {"pressure_max_mpa", number(r.reach_pressure_max_mpa)}};
  j["references"] = json::array();
  for (const auto& rr : r.reference_ranges)
    j["references"].push_back({{"reference", rr.reference},
                               {"paper_min_mm", number(rr.paper_min_mm)},
                               {"paper_max_mm", number(rr.paper_max_mm)},
                               {"min_mm", number(rr.min_mm)},
                               {"max_mm", number(rr.max_mm)},
                               {"scaled", rr.scaled},
                               {"reachable", rr.reachable}});
  j["gain_trials"] = json::array();
  for (const auto& g : r.gain_trials) {
    json rms = json::array(), rms_shaped = json::array();
    for (double x : g.rms_mm) rms.push_back(number(x));
    for (double x : g.rms_shaped_mm) rms_shaped.push_back(number(x));
    j["gain_trials"].push_back({{"reference", g.reference},
                                {"scale", number(g.scale)},
                                {"shaped", g.shaped},
                                {"scales", g.scales},
                                {"rms_mm", rms},
                                {"rms_shaped_mm", rms_shaped},
                                {"early_stop", g.early_stop}});
  }
  j["messages"] = r.messages;
  j["units"] = {{"pressure", "MPa"}, {"contraction", "mm"}, {"time", "s"}};
  j["wall_time_s"] = number(r.wall_time_s);
  return j;
}

void from_json(const json& j, ExperimentResult& r, std::string_view where) {
  if (!j.is_object()) throw Error(fmt::format("{}: expected a JSON object, got {}", where, j.type_name()));
  if (j.contains("schema") && j["schema"] != 1)
    throw Error(fmt::format("{}: unsupported schema {} (this hysteron reads schema 1)", where, j["schema"].dump()));
  if (!j.contains("experiment") || !j.contains("identification"))
    throw Error(fmt::format("{}: not an experiment result (no \"experiment\"/\"identification\" keys)", where));
  r = ExperimentResult{};
  r.name = get_string(j, "experiment", where);
  r.title = get_string(j, "title", where);
  r.seed = need(j, "seed", where).get<std::uint64_t>();
  if (j.contains("published")) from_json(j["published"], r.published, key_where(where, "published"));
  r.wall_time_s = opt_double(j, "wall_time_s", where, 0.0);
  r.lead_s = opt_double(j, "lead_s", where, 0.0);
  r.model_id_top_mpa = opt_double(j, "model_identification_top_mpa", where, 0.0);  // absent in files before it
  r.pressure_limit_mpa = opt_double(j, "pressure_limit_mpa", where, 0.6);  // absent before it: the fixed 0.6 MPa

  const json& id = need(j, "identification", where);
  const std::string idw = key_where(where, "identification");
  r.fit.model_kind = model_kind_from(id, "model", idw);
  r.fit.status = fit_status_from_name(get_string(id, "status", idw), key_where(idw, "status"));
  r.fit.message = opt_string(id, "message", idw);
  from_json(need(id, "train", idw), r.fit.train, key_where(idw, "train"));
  from_json(need(id, "validate", idw), r.validation, key_where(idw, "validate"));
  r.fit.time_s = opt_double(id, "fit_time_s", idw, 0.0);
  r.id_train_end = id.contains("train_end") ? get_size(id, "train_end", idw) : 0;
  if (id.contains("parameters")) read_model(id, "parameters", idw, r.fit.model);
  if (id.contains("fitted_parameters")) {  // absent in files before 2026-12-01
    const json& ps = get_array(id, "fitted_parameters", idw);
    for (std::size_t i = 0; i < ps.size(); ++i)
      r.fit.parameters.push_back(from_json<FitParameter>(ps[i], fmt::format("{}.fitted_parameters[{}]", idw, i)));
  }
  r.fit.covariance_note = opt_string(id, "covariance_note", idw);
  if (j.contains("best_model")) {
    const json& b = j["best_model"];
    const std::string bw = key_where(where, "best_model");
    r.best_fit.model_kind = model_kind_from(b, "model", bw);
    r.best_fit.status = fit_status_from_name(opt_string(b, "status", bw, "converged"), key_where(bw, "status"));
    if (b.contains("validate_second_run"))
      from_json(b["validate_second_run"], r.best_validation, key_where(bw, "validate_second_run"));
    if (b.contains("parameters")) read_model(b, "parameters", bw, r.best_fit.model);
    // older files: no choice (the candidates were fixed then), no candidates
    r.model_choice = b.contains("choice") ? model_kind_from(b, "choice", bw) : FitModel::automatic;
    r.model_reason = opt_string(b, "reason", bw);
    if (b.contains("candidates")) {
      const json& cs = b["candidates"];
      const std::string cw = key_where(bw, "candidates");
      if (!cs.is_array()) throw Error(fmt::format("{}: expected an array", cw));
      for (std::size_t i = 0; i < cs.size(); ++i) {
        const std::string w = fmt::format("{}[{}]", cw, i);
        if (!cs[i].is_object()) throw Error(fmt::format("{}: expected an object", w));
        ModelCandidate c;
        c.kind = model_kind_from(cs[i], "model", w);
        c.ok = get_bool(cs[i], "ok", w);
        c.status = fit_status_from_name(opt_string(cs[i], "status", w, "not_run"), key_where(w, "status"));
        c.message = opt_string(cs[i], "message", w);
        if (cs[i].contains("validate_second_run"))
          from_json(cs[i]["validate_second_run"], c.validation, key_where(w, "validate_second_run"));
        c.fit_time_s = opt_double(cs[i], "fit_time_s", w, 0.0);
        c.chosen = opt_bool(cs[i], "chosen", w, false);
        r.candidates.push_back(std::move(c));
      }
    }
  }
  if (j.contains("baseline_model") && !j["baseline_model"].is_null())
    r.baseline_model = model_from_json(j["baseline_model"], key_where(where, "baseline_model"));

  if (j.contains("dynamics")) {
    const json& d = j["dynamics"];
    const std::string dw = key_where(where, "dynamics");
    r.dynamics.dead_time_s = opt_double(d, "dead_time_s", dw, 0.0);
    r.dynamics.lag_s = opt_double(d, "lag_s", dw, 0.0);
    r.dynamics.gain_m_per_mpa = opt_double(d, "gain_m_per_mpa", dw, 0.0);
    r.dynamics.rms_mm = opt_double(d, "rms_mm", dw, 0.0);
    r.dynamics.position_relay_gain = opt_double(d, "position_relay_gain_mpa_per_m", dw, 0.0);
    r.dynamics.position_relay_period_s = opt_double(d, "position_relay_period_s", dw, 0.0);
    r.dynamics.position_relay_amplitude_mpa = opt_double(d, "position_relay_amplitude_mpa", dw, 0.0);
    r.dynamics.position_relay_hysteresis_m = opt_double(d, "position_relay_hysteresis_m", dw, 0.0);
    r.dynamics.mode_frequency_hz = opt_double(d, "mode_frequency_hz", dw, 0.0);
    r.dynamics.mode_damping = opt_double(d, "mode_damping", dw, 0.0);
    r.dynamics.relay_gain = opt_double(d, "pressure_relay_gain_per_mpa", dw, 0.0);
    r.dynamics.relay_period_s = opt_double(d, "pressure_relay_period_s", dw, 0.0);
    // files before the levels were written: both relays ran at 0.3 MPa where they ran at all
    r.dynamics.position_relay_level_mpa =
        opt_double(d, "position_relay_level_mpa", dw, r.dynamics.position_relay_gain > 0.0 ? 0.3 : 0.0);
    r.dynamics.relay_level_mpa = opt_double(d, "pressure_relay_level_mpa", dw, r.dynamics.relay_gain > 0.0 ? 0.3 : 0.0);
    r.dynamics.relay_duty = opt_double(d, "pressure_relay_duty", dw, r.dynamics.relay_gain > 0.0 ? 0.5 : 0.0);
  }
  if (j.contains("reach")) {  // absent in files before it
    const json& a = j["reach"];
    const std::string aw = key_where(where, "reach");
    r.reach_min_mm = get_double(a, "min_mm", aw);
    r.reach_max_mm = get_double(a, "max_mm", aw);
    r.reach_top_mm = opt_double(a, "top_mm", aw, nan);  // absent in files before them
    r.reach_top_pressure_mpa = opt_double(a, "top_pressure_mpa", aw, nan);
    r.reach_pressure_max_mpa = opt_double(a, "pressure_max_mpa", aw, nan);
  }
  if (j.contains("references")) {
    const json& rs = j["references"];
    const std::string rw = key_where(where, "references");
    if (!rs.is_array()) throw Error(fmt::format("{}: expected an array", rw));
    for (std::size_t i = 0; i < rs.size(); ++i) {
      const std::string w = fmt::format("{}[{}]", rw, i);
      ReferenceRange rr;
      rr.reference = get_string(rs[i], "reference", w);
      rr.paper_min_mm = get_double(rs[i], "paper_min_mm", w);
      rr.paper_max_mm = get_double(rs[i], "paper_max_mm", w);
      rr.min_mm = get_double(rs[i], "min_mm", w);
      rr.max_mm = get_double(rs[i], "max_mm", w);
      rr.scaled = get_bool(rs[i], "scaled", w);
      rr.reachable = get_bool(rs[i], "reachable", w);
      r.reference_ranges.push_back(std::move(rr));
    }
  }
  if (j.contains("gain_trials")) {  // absent in files before the gain trial
    const json& gs = j["gain_trials"];
    const std::string gw = key_where(where, "gain_trials");
    if (!gs.is_array()) throw Error(fmt::format("{}: expected an array", gw));
    for (std::size_t i = 0; i < gs.size(); ++i) {
      const std::string w = fmt::format("{}[{}]", gw, i);
      if (!gs[i].is_object()) throw Error(fmt::format("{}: expected an object", w));
      GainTrial g;
      g.reference = get_string(gs[i], "reference", w);
      g.scale = get_double(gs[i], "scale", w);
      g.scales = get_doubles(gs[i], "scales", w);
      for (double s : g.scales)
        if (!(s > 0.0)) throw Error(fmt::format("{}: key \"scales\": expected positive numbers", w));
      g.rms_mm = get_doubles(gs[i], "rms_mm", w, std::numeric_limits<double>::infinity());  // null: diverged
      g.shaped = opt_bool(gs[i], "shaped", w, false);
      g.early_stop = opt_bool(gs[i], "early_stop", w, false);
      if (gs[i].contains("rms_shaped_mm"))
        g.rms_shaped_mm = get_doubles(gs[i], "rms_shaped_mm", w, std::numeric_limits<double>::infinity());
      if (g.scales.size() != g.rms_mm.size() || (!g.rms_shaped_mm.empty() && g.rms_shaped_mm.size() != g.scales.size()))
        throw Error(fmt::format("{}: scales has {} values, rms_mm {}, rms_shaped_mm {}", w, g.scales.size(),
                                g.rms_mm.size(), g.rms_shaped_mm.size()));
      if (g.shaped && g.rms_shaped_mm.empty())
        throw Error(fmt::format("{}: shaped is true but rms_shaped_mm is empty", w));
      r.gain_trials.push_back(std::move(g));
    }
  }
  if (j.contains("messages")) {
    const json& m = j["messages"];
    if (!m.is_array()) throw Error(fmt::format("{}: expected an array of strings", key_where(where, "messages")));
    for (const auto& x : m) {
      if (!x.is_string()) throw Error(fmt::format("{}: expected an array of strings", key_where(where, "messages")));
      r.messages.push_back(x.get<std::string>());
    }
  }
  // the variants in the file's order ("variants"; older files: the three of schema 1)
  std::vector<std::string> variants{"faithful", "compensated", "baseline"};
  if (j.contains("variants")) {
    const json& v = j["variants"];
    if (!v.is_array()) throw Error(fmt::format("{}: expected an array of names", key_where(where, "variants")));
    variants.clear();
    for (const auto& x : v) {
      if (!x.is_string()) throw Error(fmt::format("{}: expected an array of names", key_where(where, "variants")));
      variants.push_back(x.get<std::string>());
    }
  }
  std::optional<double> period_of_runs;  // the first run's controller sample time
  for (const auto& variant : variants) {
    if (!j.contains(variant)) continue;
    const json& v = j[variant];
    const std::string vw = key_where(where, variant);
    auto add = [&](const json& e, const std::string& reference, const std::string& w) {
      TrackingRun run;
      run.variant = variant;
      run.reference = opt_string(e, "reference", w, reference);
      run.description = opt_string(e, "description", w);
      run.saturated = e.contains("saturated_samples") ? get_size(e, "saturated_samples", w) : 0;
      run.scored_from_s = opt_double(e, "scored_from_s", w, 0.0);
      from_json(e, run.errors, w);
      if (e.contains("controller")) {
        from_json(e["controller"], run.controller, key_where(w, "controller"));
        if (!period_of_runs) period_of_runs = run.controller.sample_time;
      }
      if (e.contains("periods")) {
        const json& per = e["periods"];
        const std::string pw = key_where(w, "periods");
        if (!per.is_array()) throw Error(fmt::format("{}: expected an array", pw));
        for (std::size_t i = 0; i < per.size(); ++i) {
          TrackingErrors te;
          from_json(per[i], te, fmt::format("{}[{}]", pw, i));
          run.periods.push_back(te);
        }
      }
      r.runs.push_back(std::move(run));
    };
    if (v.contains("max_error_mm")) {
      add(v, "", vw);
    } else {
      for (const auto& [key, e] : v.items())
        if (e.is_object()) add(e, key, key_where(vw, key));
    }
  }
  // the control period (files before it: their runs' controller period, else the 1 ms of then)
  r.control_period_s = opt_double(j, "control_period_s", where, period_of_runs.value_or(1e-3));
  if (!(r.control_period_s > 0.0) || !std::isfinite(r.control_period_s))
    throw Error(fmt::format("{}: key \"control_period_s\" = {}: must be a finite period > 0 s", where, r.control_period_s));
}

}  // namespace hysteron::io

namespace hysteron {

nlohmann::json ExperimentResult::to_json() const { return io::to_json(*this); }

const PublishedErrors* PublishedFigures::find(const std::string& reference) const noexcept {
  for (const auto& e : errors)
    if (e.reference == reference || (errors.size() == 1 && e.reference.empty())) return &e;
  return nullptr;
}

}  // namespace hysteron
