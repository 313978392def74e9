// hysteron_mex: the MATLAB/Octave gateway of hysteron (docs/matlab.md).
//
//   out = hysteron_mex(command, args...)
//
// One MEX file dispatching on a command; the .m wrappers in matlab/ (hysteron_fit.m, ...)
// parse name/value options into a struct and call it. Only the MATLAB MEX C API (mex.h)
// is used, so the same source builds with MATLAB's `mex` and with Octave's
// `mkoctfile --mex`.
//
// Commands (options: a struct whose fields are checked against the names below)
//   version                          -> char
//   model       spec                 -> model struct (spec: struct, JSON text or file path)
//   model_json  spec                 -> JSON text of the model file
//   load        path                 -> model struct (with "units", "note", "metadata", "training" if present)
//   save        path, spec           -> (writes the model file atomically)
//   simulate    spec, x, opts        -> y                     opts: relaxed
//   invert      spec, y, opts        -> [x, saturated]        opts: limits
//   evaluate    spec, x, y, opts     -> metrics struct        opts: range, initial_state, censored
//                                       (+ outside_input_limits, output_map and three warnings)
//   fit         x, y, opts           -> [model, report]       opts: see fit_options(), and report
//                                                              (HTML file), input_axis, output_axis
//   rig         pressure_mpa, opts   -> struct of columns     opts: params, seed, control_period
//   rig_params  params               -> complete rig parameter struct
//   loop        result, run, model, reference_m, measured_m, pressure_mpa
//                                    -> struct: loop, command_mpa, duty, preview_m
//
// Errors: every C++ exception is caught here and raised as a MATLAB error with an
// identifier "hysteron:..." (mx_json.hpp lists them) and a message naming the command,
// the argument and the field. mexErrMsgIdAndTxt is called only after every C++ object of
// the call has been destroyed (it does not return: MATLAB long-jumps, Octave unwinds).
#include <mex.h>

#include <glog/logging.h>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/units.hpp"
#include "hysteron/io/loop_design.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/loop_design.hpp"
#include "hysteron/models.hpp"
#include "hysteron/plant.hpp"
#include "hysteron/report.hpp"
#include "hysteron/version.hpp"
#include "mx_json.hpp"

namespace hysteron::mex {

namespace {

// ---- options --------------------------------------------------------------------------

// An options struct (or nothing / []): fields checked against the allowed names.
class Options {
 public:
  Options(const mxArray* a, std::string what, std::vector<std::string> allowed)
      : a_(a), what_(std::move(what)), allowed_(std::move(allowed)) {
    if (a_ != nullptr && mxIsEmpty(a_) && !mxIsStruct(a_)) a_ = nullptr;
    if (a_ == nullptr) return;
    if (!mxIsStruct(a_) || mxGetNumberOfElements(a_) != 1)
      throw MexError(id_bad_argument, fmt::format("{}: expected an options struct, got {}", what_, mxGetClassName(a_)));
    for (int f = 0; f < mxGetNumberOfFields(a_); ++f) {
      const std::string name = mxGetFieldNameByNumber(a_, f);
      if (std::find(allowed_.begin(), allowed_.end(), name) == allowed_.end())
        throw MexError(id_bad_argument,
                       fmt::format("{}: unknown option '{}'; the options are {}", what_, name, fmt::join(allowed_, ", ")));
    }
  }
  // The option's value, or nullptr if not given (or given as []).
  const mxArray* get(const char* name) const {
    if (a_ == nullptr) return nullptr;
    const mxArray* v = mxGetField(a_, 0, name);
    return v == nullptr || (mxIsEmpty(v) && !mxIsChar(v)) ? nullptr : v;
  }
  std::string where(const char* name) const { return fmt::format("option '{}'", name); }

 private:
  const mxArray* a_;
  std::string what_;
  std::vector<std::string> allowed_;
};

const mxArray* arg(int nrhs, const mxArray* prhs[], int k) { return k < nrhs ? prhs[k] : nullptr; }

void require_args(int nrhs, int min, int max, std::string_view usage) {
  if (nrhs < min || nrhs > max)
    throw MexError(id_bad_argument, fmt::format("expected {} to {} arguments ({}), got {}", min - 1, max - 1, usage,
                                                nrhs - 1));
}

// ---- models ---------------------------------------------------------------------------

struct ModelSpec {
  ModelParams params;
  nlohmann::json extra;  // "units", "note", "metadata", "training"
};

// Keys of a model file whose value is an array (a MATLAB scalar is one element): every kind's
// (docs/model-files.md), but rate-pi's c is a number.
void wrap_array_keys(nlohmann::json& j) {
  if (!j.is_object()) return;
  const auto kind = j.find("model");
  const bool rate_pi = kind != j.end() && kind->is_string() && *kind == "rate-pi";
  for (const char* key : {"c", "r", "p", "z", "g", "w", "k", "delta", "input_limits"}) {
    if (rate_pi && std::string_view(key) == "c") continue;
    auto it = j.find(key);
    if (it != j.end() && (it->is_number() || it->is_null())) *it = nlohmann::json::array({*it});
  }
  for (const char* key : {"ascending", "descending"}) {
    auto it = j.find(key);
    if (it != j.end()) wrap_array_keys(*it);
  }
}

ModelSpec model_from_json_checked(const nlohmann::json& j, const std::string& where) {
  try {
    return {io::model_from_json(j, where), io::model_extra(j)};
  } catch (const Error& e) {
    throw MexError(id_bad_model, e.what());
  }
}

ModelSpec load_model_file(const std::string& path) {
  ModelSpec spec;
  try {
    spec.params = io::read_model_file(path);  // every error names the file, line, key
  } catch (const Error& e) {
    throw MexError(id_model_file, e.what());
  }
  // the free-form keys the model keeps (read_model_file has checked the file)
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const auto j = nlohmann::json::parse(text.str(), nullptr, false);
  if (!j.is_discarded()) spec.extra = io::model_extra(j);
  return spec;
}

// A struct's input_limits [lo hi]: -Inf / Inf are its unbounded sides (null in the file). Inf as lo,
// -Inf as hi or lo above hi would read as unbounded sides: refused. (Other values: to_json and the
// model reader check them.)
void check_struct_limits(const mxArray* a, const std::string& what) {
  const mxArray* l = mxGetField(a, 0, "input_limits");
  if (l == nullptr || !mxIsDouble(l) || mxIsComplex(l) || mxGetNumberOfElements(l) != 2) return;
  const std::vector<double> v = get_vector(l, what + ".input_limits");
  const auto text = [](double x) { return std::isinf(x) ? std::string(x > 0 ? "Inf" : "-Inf") : fmt::format("{}", x); };
  if (v[0] == HUGE_VAL || v[1] == -HUGE_VAL || v[0] > v[1])
    throw MexError(id_bad_model, fmt::format("{}.input_limits: [{} {}]: expected [lo hi] with lo <= hi (-Inf / Inf: an "
                                             "unbounded side)",
                                             what, text(v[0]), text(v[1])));
}

// spec: a model struct, the JSON text of a model file, or the path of a model file.
ModelSpec model_spec(const mxArray* a, const std::string& what) {
  if (a != nullptr && mxIsChar(a)) {
    const std::string text = get_string(a, what);
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && text[first] == '{') {
      nlohmann::json j;
      try {
        j = nlohmann::json::parse(text);
      } catch (const nlohmann::json::parse_error& e) {
        throw MexError(id_bad_model, fmt::format("{}: not valid JSON: {}", what, e.what()));
      }
      return model_from_json_checked(j, what);
    }
    if (text.empty()) throw MexError(id_bad_argument, fmt::format("{}: empty file name", what));
    return load_model_file(text);
  }
  if (a != nullptr && mxIsStruct(a)) {
    if (mxGetNumberOfElements(a) != 1)
      throw MexError(id_bad_model, fmt::format("{}: expected one model (a 1x1 struct), got a {} struct array", what,
                                               dims(a)));
    check_struct_limits(a, what);
    ToJsonOptions o;
    o.infinite_as_null = {"input_limits"};
    o.null_subtrees = {"metadata"};
    nlohmann::json j = to_json(a, what, o);
    wrap_array_keys(j);
    return model_from_json_checked(j, what);
  }
  throw MexError(id_bad_argument,
                 fmt::format("{}: expected a model struct, the JSON text of a model or a model file name, got {}", what,
                             a ? mxGetClassName(a) : "nothing"));
}

// Unbounded input limits are null in JSON and -Inf / Inf in MATLAB.
void limits_to_infinite(nlohmann::json& model) {
  if (!model.is_object()) return;
  auto it = model.find("input_limits");
  if (it == model.end() || !it->is_array() || it->size() != 2) return;
  if ((*it)[0].is_null()) (*it)[0] = -std::numeric_limits<double>::infinity();
  if ((*it)[1].is_null()) (*it)[1] = std::numeric_limits<double>::infinity();
}

nlohmann::json model_json(const ModelSpec& spec) {
  nlohmann::json j = io::model_to_json(spec.params);
  if (spec.extra.is_object()) j.update(spec.extra);
  return j;
}

mxArray* model_struct(const ModelSpec& spec) {
  nlohmann::json j = model_json(spec);
  limits_to_infinite(j);
  return to_mx(j);
}

// ---- commands ---------------------------------------------------------------------------

using Command = std::function<void(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[])>;

void cmd_version(int, mxArray* plhs[], int nrhs, const mxArray*[]) {
  require_args(nrhs, 1, 1, "no arguments");
  plhs[0] = mxCreateString(std::string(hysteron::version).c_str());
}

void cmd_model(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 2, 2, "model");
  plhs[0] = model_struct(model_spec(prhs[1], "model"));
}

void cmd_model_json(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 2, 2, "model");
  plhs[0] = mxCreateString(model_json(model_spec(prhs[1], "model")).dump(2).c_str());
}

void cmd_load(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 2, 2, "file");
  const std::string path = get_string(prhs[1], "file");
  if (path.empty()) throw MexError(id_bad_argument, "file: empty file name");
  plhs[0] = model_struct(load_model_file(path));
}

void cmd_save(int, mxArray*[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 3, 3, "file, model");
  const std::string path = get_string(prhs[1], "file");
  if (path.empty()) throw MexError(id_bad_argument, "file: empty file name");
  const ModelSpec spec = model_spec(prhs[2], "model");
  try {
    io::write_model_file(path, spec.params, spec.extra);
  } catch (const Error& e) {
    throw MexError(id_model_file, e.what());
  }
}

void cmd_simulate(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 3, 4, "model, x, options");
  const ModelSpec spec = model_spec(prhs[1], "model");
  const std::vector<double> x = get_vector(prhs[2], "x");
  require_finite(x, "x");
  const Options opt(arg(nrhs, prhs, 3), "simulate options", {"relaxed"});
  const bool relaxed = opt.get("relaxed") && get_bool(opt.get("relaxed"), opt.where("relaxed"));
  Model model(spec.params);
  if (relaxed && !x.empty()) model.reset_relaxed(x.front());
  plhs[0] = make_vector(model.simulate(x), prhs[2]);
}

Limits limits_option(const mxArray* a, const std::string& what) {
  const std::vector<double> v = get_vector(a, what);
  if (v.size() != 2) throw MexError(id_bad_argument, fmt::format("{}: expected [lo hi], got {} numbers", what, v.size()));
  if (std::isnan(v[0]) || std::isnan(v[1])) throw MexError(id_non_finite, fmt::format("{}: NaN limit", what));
  if (!(v[0] < v[1])) throw MexError(id_bad_argument, fmt::format("{}: lo = {} must be < hi = {}", what, v[0], v[1]));
  return {v[0], v[1]};
}

void cmd_invert(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 3, 4, "model, y, options");
  const ModelSpec spec = model_spec(prhs[1], "model");
  const std::vector<double> y = get_vector(prhs[2], "y");
  require_finite(y, "y");
  const Options opt(arg(nrhs, prhs, 3), "invert options", {"limits"});
  InverseOptions io;
  if (opt.get("limits")) io.input_limits = limits_option(opt.get("limits"), opt.where("limits"));
  Inverse inv(spec.params, io);
  std::vector<double> x(y.size());
  std::vector<bool> saturated(y.size());
  for (std::size_t k = 0; k < y.size(); ++k) {
    x[k] = inv.step(y[k]);
    saturated[k] = inv.saturated();
  }
  if (inv.faults() != 0) throw Error(fmt::format("{} samples could not be inverted", inv.faults()));
  plhs[0] = make_vector(x, prhs[2]);
  if (nlhs > 1) plhs[1] = make_logical_vector(saturated, prhs[2]);
}

InitialState initial_state_option(const mxArray* a, const std::string& what) {
  const std::string s = get_string(a, what);
  if (s == "virgin") return InitialState::virgin;
  if (s == "relaxed") return InitialState::relaxed;
  throw MexError(id_bad_argument, fmt::format("{}: expected 'virgin' or 'relaxed', got '{}'", what, s));
}

// [first last], 1-based and inclusive (last = Inf: to the end) -> [first - 1, last).
IndexRange range_option(const mxArray* a, const std::string& what) {
  const std::vector<double> v = get_vector(a, what);
  if (v.size() != 2)
    throw MexError(id_bad_argument, fmt::format("{}: expected [first last] (sample numbers, 1-based), got {} numbers",
                                                what, v.size()));
  const bool first_ok = v[0] >= 1 && v[0] == std::trunc(v[0]) && std::isfinite(v[0]);
  const bool last_ok = (v[1] == std::trunc(v[1]) && std::isfinite(v[1])) || v[1] == HUGE_VAL;
  if (!first_ok || !last_ok || v[1] < v[0])
    throw MexError(id_bad_argument, fmt::format("{}: expected [first last] with integers 1 <= first <= last (last may "
                                                "be Inf), got [{} {}]",
                                                what, v[0], v[1]));
  IndexRange r;
  r.begin = static_cast<std::size_t>(v[0]) - 1;
  r.end = std::isinf(v[1]) ? IndexRange::npos : static_cast<std::size_t>(v[1]);
  return r;
}

void equal_lengths(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size())
    throw MexError(id_bad_argument, fmt::format("x and y must have the same length, got {} and {}", x.size(), y.size()));
}

void cmd_evaluate(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 4, 5, "model, x, y, options");
  const ModelSpec spec = model_spec(prhs[1], "model");
  const std::vector<double> x = get_vector(prhs[2], "x"), y = get_vector(prhs[3], "y");
  require_finite(x, "x");
  require_finite(y, "y");
  equal_lengths(x, y);
  const Options opt(arg(nrhs, prhs, 4), "evaluate options", {"range", "initial_state", "censored"});
  const IndexRange range = opt.get("range") ? range_option(opt.get("range"), opt.where("range")) : IndexRange{};
  const InitialState init =
      opt.get("initial_state") ? initial_state_option(opt.get("initial_state"), opt.where("initial_state"))
                               : InitialState::virgin;
  // censored: where y clips (detect_clipping), a sample at the limit that the model puts beyond
  // it is scored as met, as `hysteron evaluate` does by default and Python's evaluate(censored=True)
  const bool censored = opt.get("censored") && get_bool(opt.get("censored"), opt.where("censored"));
  // the metrics and what Python's evaluate adds (io::Evaluation, as `hysteron evaluate --json`):
  // outside_input_limits, output_map, and the warnings hysteron_evaluate.m raises
  io::Evaluation e;
  e.metrics = evaluate_scored(spec.params, x, y, range, init, censored, &e.censored);
  e.censored_recorded = censored;  // censored_samples only when asked, as Python's
  const InputCoverage coverage = input_coverage(spec.params, x, range);
  e.outside_input_limits = coverage.outside;
  e.output_map = output_map(spec.params, x, y, range, init, censored);
  nlohmann::json m = io::to_json(e);
  m.erase("file");
  m.erase("range");
  // hysteron evaluate scores censored by default, this does not: where the output clips, say how
  // many samples it would not count as errors (Python's clipping_warning)
  std::string clipping;
  if (!censored) {
    std::size_t would = 0;
    (void)evaluate_scored(spec.params, x, y, range, init, true, &would);
    if (would > 0)
      clipping = fmt::format("hysteron_evaluate: the output clips: {} samples at its limit where the model predicts "
                             "beyond it are scored as errors here ('censored', false, the default); hysteron evaluate "
                             "and fit score them as censored, no error: pass 'censored', true to score as they do",
                             would);
  }
  m["clipping_warning"] = clipping;
  m["input_coverage_warning"] = input_coverage_warning(coverage, "hysteron_evaluate's record");
  // The diagnosis and verdict of hysteron evaluate (judge_evaluation) against the training error the
  // model's "training" records (hysteron_fit's model and hysteron fit's file carry it): the output
  // map's warning or the input map's (an input in another zero or unit), and useless
  const FitMetrics train = io::training_metrics(io::ModelDocument{spec.params, spec.extra});
  const IndexRange rr = range.resolved(x.size());
  const EvaluationVerdict v = judge_evaluation(spec.params, x, y, range, init, censored, e.output_map, e.metrics, train,
                                               coverage.span_share, "hysteron_evaluate's record",
                                               fmt::format("samples {}..{}", rr.begin + 1, rr.end));  // 1-based
  m["output_map_warning"] = v.diagnosis.warning;
  m["stuck_output_warning"] = v.diagnosis.sensor_warning;
  m["stuck_input_warning"] = v.diagnosis.input_sensor_warning;
  m["outlier_warning"] = v.diagnosis.outlier_warning;
  const InputMap& im = v.diagnosis.input_map;
  m["input_map"] = im.found ? nlohmann::json{{"scale", im.scale}, {"shift", im.shift}, {"rms", im.rms},
                                             {"r2", im.r2}, {"rms_as_is", im.rms_as_is}}
                            : nlohmann::json::array();  // [] where none
  if (const auto t = spec.extra.find("training"); t != spec.extra.end())
    m["training"] = *t;
  else
    m["training"] = nlohmann::json::array();
  m["useless"] = v.useless;
  m["useless_warning"] = v.useless_warning;
  plhs[0] = to_mx(m);
}

const std::vector<std::string> fit_option_names = {
    "model",        "num_operators",    "num_dead_zones", "initial_state",      "train",
    "huber_delta",  "num_starts",       "num_threads",    "seed",               "max_iterations",
    "fix_scale",    "free_weights",     "compute_covariance", "min_slope",      "stall_iterations",
    "stall_tolerance", "holdout_fraction", "poor_fit_ratio", "censor_passes", "sample_time", "report", "input_axis",
    "output_axis"};

FitOptions fit_options(const Options& opt) {
  FitOptions o;
  auto integer = [&](const char* name, auto& field) {
    if (const mxArray* v = opt.get(name)) {
      const long long k = get_integer(v, opt.where(name));
      if (k < std::numeric_limits<int>::min() || k > std::numeric_limits<int>::max())
        throw MexError(id_bad_argument, fmt::format("{}: {} is out of range", opt.where(name), k));
      field = static_cast<std::remove_reference_t<decltype(field)>>(k);
    }
  };
  auto number = [&](const char* name, double& field) {
    if (const mxArray* v = opt.get(name)) field = get_scalar(v, opt.where(name));
  };
  auto flag = [&](const char* name, bool& field) {
    if (const mxArray* v = opt.get(name)) field = get_bool(v, opt.where(name));
  };
  if (const mxArray* v = opt.get("model")) {
    const std::string kind = get_string(v, opt.where("model"));
    try {
      o.model = fit_model_from_name(kind);
    } catch (const Error& e) {
      throw MexError(id_bad_argument, fmt::format("{}: {}", opt.where("model"), e.what()));
    }
  }
  integer("num_operators", o.num_operators);
  integer("num_dead_zones", o.num_dead_zones);
  if (const mxArray* v = opt.get("initial_state")) o.initial_state = initial_state_option(v, opt.where("initial_state"));
  if (const mxArray* v = opt.get("train")) o.train = range_option(v, opt.where("train"));
  number("huber_delta", o.huber_delta);
  integer("num_starts", o.num_starts);
  integer("num_threads", o.num_threads);
  if (const mxArray* v = opt.get("seed")) {
    const long long s = get_integer(v, opt.where("seed"));
    if (s < 0 || s > std::numeric_limits<unsigned>::max())
      throw MexError(id_bad_argument, fmt::format("{}: expected 0..{}, got {}", opt.where("seed"),
                                                  std::numeric_limits<unsigned>::max(), s));
    o.seed = static_cast<unsigned>(s);
  }
  integer("max_iterations", o.max_iterations);
  flag("fix_scale", o.gpi_fix_scale);
  flag("free_weights", o.gpi_free_weights);
  flag("compute_covariance", o.compute_covariance);
  number("min_slope", o.min_slope);
  integer("stall_iterations", o.stall_iterations);
  number("stall_tolerance", o.stall_tolerance);
  number("holdout_fraction", o.holdout_fraction);
  integer("censor_passes", o.censor_passes);
  number("poor_fit_ratio", o.poor_fit_ratio);
  number("sample_time", o.sample_time);  // s; rate-pi's dt (its rates are per second)
  return o;
}

// {label, unit}: a cell of two texts (or one text: the label).
report::Axis axis_option(const mxArray* a, const std::string& what) {
  if (mxIsChar(a)) return {get_string(a, what), ""};
  if (!mxIsCell(a) || mxGetNumberOfElements(a) != 2)
    throw MexError(id_bad_argument, fmt::format("{}: expected {{label, unit}}, e.g. {{'Pressure', 'kPa'}}", what));
  return {get_string(mxGetCell(a, 0), what + " label"), get_string(mxGetCell(a, 1), what + " unit")};
}

void cmd_fit(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 3, 4, "x, y, options");
  const std::vector<double> x = get_vector(prhs[1], "x"), y = get_vector(prhs[2], "y");
  require_finite(x, "x");
  require_finite(y, "y");
  equal_lengths(x, y);
  const Options opt(arg(nrhs, prhs, 3), "fit options", fit_option_names);
  const FitOptions o = fit_options(opt);
  report::FitData data;
  const std::string html = opt.get("report") ? get_string(opt.get("report"), opt.where("report")) : std::string();
  if (const mxArray* v = opt.get("input_axis")) data.input = axis_option(v, opt.where("input_axis"));
  if (const mxArray* v = opt.get("output_axis")) data.output = axis_option(v, opt.where("output_axis"));
  const FitReport r = fit(x, y, o);
  if (r.status == FitStatus::invalid_input) throw MexError(id_fit_input, r.message);
  if (!html.empty()) {
    data.x = x;
    data.y = y;
    data.initial_state = o.initial_state;
    data.train = o.train;
    data.source = "MATLAB/Octave vectors (hysteron_fit)";
    report::write_fit_report(r, data, html,
                             fmt::format("hysteron_fit(x, y, 'model', '{}', 'num_operators', {})",
                                         fit_model_name(o.model), o.num_operators));
  }
  nlohmann::json rep = io::to_json(r);
  limits_to_infinite(rep["model"]);
  if (auto it = rep.find("candidates"); it != rep.end() && it->is_array())
    for (auto& c : *it)
      if (c.is_object() && c.contains("model")) limits_to_infinite(c["model"]);
  // as the option train: [first last], 1-based and inclusive ([] where none)
  for (nlohmann::json& f : rep["fault_runs"]) f["rows"] = {f["rows"][0].get<std::size_t>() + 1, f["rows"][1]};
  rep["fault_free_train"] = r.fault_free_train ? nlohmann::json::array({r.fault_free_train->begin + 1,
                                                                         r.fault_free_train->end})
                                               : nlohmann::json::array();
  rep["ok"] = r.ok();
  rep["report"] = r.full_report();
  // the model with its training error ("training"), as hysteron fit's model file and the report's model
  nlohmann::json extra = nlohmann::json::object();
  if (nlohmann::json t = io::training_json(r.train); !t.is_null()) extra["training"] = std::move(t);
  plhs[0] = has_model(r.status) ? model_struct({r.model, extra}) : mxCreateDoubleMatrix(0, 0, mxREAL);
  if (nlhs > 1) {
    plhs[1] = to_mx(rep);
    // a list of texts is a cell array, also when it is empty
    if (r.warnings.empty()) mxSetField(plhs[1], 0, "warnings", mxCreateCellMatrix(1, 0));
  }
}

PamRigParams rig_params_option(const mxArray* a, const std::string& what) {
  if (a == nullptr) return {};
  if (mxIsChar(a)) return load_rig_params(get_string(a, what));
  if (mxIsStruct(a) && mxGetNumberOfElements(a) == 1) return rig_params_from_json(to_json(a, what), what);
  throw MexError(id_bad_argument, fmt::format("{}: expected a (partial) rig parameter struct or a JSON file name, got {}",
                                              what, mxGetClassName(a)));
}

void cmd_rig_params(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 1, 2, "params");
  const mxArray* a = arg(nrhs, prhs, 1);
  if (a != nullptr && mxIsEmpty(a) && !mxIsStruct(a)) a = nullptr;
  plhs[0] = to_mx(rig_params_to_json(rig_params_option(a, "params")));
}

void cmd_rig(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 2, 3, "pressure_mpa, options");
  const std::vector<double> p = get_vector(prhs[1], "pressure_mpa");
  require_finite(p, "pressure_mpa");
  const Options opt(arg(nrhs, prhs, 2), "rig options", {"params", "seed", "control_period"});
  const PamRigParams params = rig_params_option(opt.get("params"), opt.where("params"));
  std::uint64_t seed = 1;
  if (const mxArray* v = opt.get("seed")) {
    const long long s = get_integer(v, opt.where("seed"));
    if (s < 0) throw MexError(id_bad_argument, fmt::format("{}: expected >= 0, got {}", opt.where("seed"), s));
    seed = static_cast<std::uint64_t>(s);
  }
  double control_period = 1e-3;
  if (const mxArray* v = opt.get("control_period")) control_period = get_scalar(v, opt.where("control_period"));
  if (!(control_period > 0))
    throw MexError(id_bad_argument, fmt::format("{}: must be > 0, got {}", opt.where("control_period"), control_period));
  PamRig rig(params, seed);
  std::int64_t every = 1;  // rig steps per sample: a whole number, as the experiments and Python check
  try {
    every = control_steps(control_period, rig.dt(), opt.where("control_period"));
  } catch (const Error& e) {
    throw MexError(id_bad_argument, e.what());
  }
  std::vector<double> t, cmd, pr, x, xm;
  for (auto* v : {&t, &cmd, &pr, &x, &xm}) v->reserve(p.size());
  RigInputs in;
  for (double u : p) {
    in.pressure_command = u;
    RigOutputs o;
    for (std::int64_t k = 0; k < every; ++k) o = rig.step(in);
    t.push_back(o.time);
    cmd.push_back(u);
    pr.push_back(o.pressure_measured * 1e-6);
    x.push_back(o.contraction * 1e3);
    xm.push_back(o.contraction_measured * 1e3);
    if (!rig.ok()) break;
  }
  rig.check();  // throws hysteron::Error naming the time and the state if it diverged
  const char* names[] = {"t", "pressure_command_mpa", "pressure_mpa", "contraction_mm", "contraction_measured_mm"};
  mxArray* s = mxCreateStructMatrix(1, 1, 5, names);
  mxSetField(s, 0, "t", make_vector(t, nullptr));
  mxSetField(s, 0, "pressure_command_mpa", make_vector(cmd, nullptr));
  mxSetField(s, 0, "pressure_mpa", make_vector(pr, nullptr));
  mxSetField(s, 0, "contraction_mm", make_vector(x, nullptr));
  mxSetField(s, 0, "contraction_measured_mm", make_vector(xm, nullptr));
  plhs[0] = s;
}

// A run's loop (result.json's "controller"; docs/deploy.md) replayed over recorded signals: the
// commands it gives for the reference, contraction and pressure readings, sample by sample, as
// on a target. `source`: a result.json file name, or JSON text (a result.json or a controller).
LoopDesign loop_source(const std::string& source, const std::string& run) {
  try {
    const auto first = source.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && source[first] == '{')
      return io::loop_design_of_run(io::parse_json(source, "result"), run, "result");
    if (source.empty()) throw MexError(id_bad_argument, "result: empty file name");
    return io::read_loop_design(source, run);
  } catch (const Error& e) {
    throw MexError(id_bad_argument, e.what());
  }
}

void cmd_loop(int, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  require_args(nrhs, 6, 7, "result, run, model, reference_m, measured_m, pressure_mpa");
  const std::string run = get_string(prhs[2], "run");
  const LoopDesign d = loop_source(get_string(prhs[1], "result"), run);
  // a learning run commanded its loop plus the correction its iterative learning learnt period by
  // period: the loop alone does not command what the run commanded (as an adaptive run's, refused
  // by make_controller)
  if (d.learning)
    throw Error(fmt::format("controller{}: its loop has an iterative learning (\"learning\"; a learning run), which "
                            "hysteron_loop does not replay: its commands would not be the run's. Replay the loop "
                            "with its learning through the C ABI (hysteron_loop_params_from_file: has_learning, "
                            "then hysteron_ilc_create / hysteron_ilc_correction / hysteron_ilc_step) or "
                            "`hysteron export --loop RESULT.json --run {}` (a C99 file), or use the compensated "
                            "run's loop (the same loop without the learning)",
                            run.empty() ? "" : fmt::format(" of run \"{}\"", run),
                            run.empty() ? "learning.REFERENCE" : run));
  const ModelSpec spec = model_spec(prhs[3], "model");
  const std::vector<double> ref = get_vector(prhs[4], "reference_m");
  const std::vector<double> meas = get_vector(prhs[5], "measured_m");
  require_finite(ref, "reference_m");
  require_finite(meas, "measured_m");
  if (meas.size() != ref.size())
    throw MexError(id_bad_argument, fmt::format("measured_m has {} values, reference_m {}", meas.size(), ref.size()));
  std::vector<double> pressure;
  if (const mxArray* a = arg(nrhs, prhs, 6); a != nullptr && !mxIsEmpty(a)) {
    pressure = get_vector(a, "pressure_mpa");
    require_finite(pressure, "pressure_mpa");
    if (pressure.size() != ref.size())
      throw MexError(id_bad_argument,
                     fmt::format("pressure_mpa has {} values, reference_m {}", pressure.size(), ref.size()));
  } else if (d.kind != LoopDesign::Kind::feedforward_pid) {
    throw MexError(id_bad_argument, "pressure_mpa: this loop has a pressure loop: give the measured pressure [MPa]");
  }
  // a model in another pressure unit than MPa, or a length unit the loop's model_scale contradicts, is
  // refused as by the C ABI, Python's controller_from and hysteron export --loop (io/units.hpp)
  const auto unit = [&](const char* which) {
    const auto u = spec.extra.find("units");
    if (u == spec.extra.end() || !u->is_object()) return std::string();
    const auto v = u->find(which);
    return v != u->end() && v->is_string() ? v->get<std::string>() : std::string();
  };
  if (const std::string why = io::input_unit_mismatch(unit("input")); !why.empty())
    throw MexError(id_bad_model, fmt::format("model: {}", why));
  if (const std::string why = io::model_scale_mismatch(d.feedforward.model_scale, unit("output")); !why.empty())
    throw MexError(id_bad_model,
                   fmt::format("model: {}: the loop was designed for a model in another length unit", why));
  Controller c = make_controller(d, spec.params);
  const std::vector<double> preview = feedforward_preview(d, ref);
  std::vector<double> command(ref.size()), duty(ref.size(), 0.0);
  for (std::size_t k = 0; k < ref.size(); ++k) {
    const LoopOutput o = step(c, ref[k], preview[k], meas[k], pressure.empty() ? 0.0 : pressure[k]);
    command[k] = o.command_mpa;
    duty[k] = o.duty;
  }
  const char* kinds[] = {"feedforward_pid", "open_loop", "cascade_pwm"};
  const char* names[] = {"loop", "command_mpa", "duty", "preview_m"};
  mxArray* out = mxCreateStructMatrix(1, 1, 4, names);
  mxSetField(out, 0, "loop", mxCreateString(kinds[static_cast<int>(d.kind)]));
  mxSetField(out, 0, "command_mpa", make_vector(command, prhs[4]));
  mxSetField(out, 0, "duty", make_vector(duty, prhs[4]));
  mxSetField(out, 0, "preview_m", make_vector(preview, prhs[4]));
  plhs[0] = out;
}

const std::map<std::string, Command>& commands() {
  static const std::map<std::string, Command> table = {
      {"version", cmd_version},   {"model", cmd_model},     {"model_json", cmd_model_json},
      {"load", cmd_load},         {"save", cmd_save},       {"simulate", cmd_simulate},
      {"invert", cmd_invert},     {"evaluate", cmd_evaluate}, {"fit", cmd_fit},
      {"rig", cmd_rig},           {"rig_params", cmd_rig_params}, {"loop", cmd_loop}};
  return table;
}

// Ceres logs through glog: as the CLI and the Python module do, keep its lines off the
// user's console (only FATAL), unless glog was initialised by the host or
// HYSTERON_KEEP_GLOG=1 is set.
void silence_glog() {
  static bool done = false;
  if (done) return;
  done = true;
  const char* keep = std::getenv("HYSTERON_KEEP_GLOG");
  if (keep && *keep && std::string_view(keep) != "0") return;
  if (google::IsGoogleLoggingInitialized()) return;
  FLAGS_minloglevel = google::GLOG_FATAL;
  FLAGS_logtostderr = false;
  FLAGS_alsologtostderr = false;
  FLAGS_stderrthreshold = google::GLOG_FATAL;
}

std::string command_list() {
  std::vector<std::string> names;
  for (const auto& [name, cmd] : commands()) names.push_back(name);
  return fmt::format("{}", fmt::join(names, ", "));
}

void run(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[], std::string& command) {
  silence_glog();
  if (nrhs < 1 || !mxIsChar(prhs[0]))
    throw MexError(id_bad_argument, fmt::format("usage: hysteron_mex(command, ...) with a command among {}", command_list()));
  const std::string name = get_string(prhs[0], "command");
  const auto it = commands().find(name);
  if (it == commands().end())
    throw MexError(id_bad_argument, fmt::format("unknown command '{}'; the commands are {}", name, command_list()));
  command = name;
  it->second(nlhs, plhs, nrhs, prhs);
}

void copy_text(char* dst, std::size_t size, std::string_view src) {
  const std::size_t n = std::min(size - 1, src.size());
  std::copy_n(src.data(), n, dst);
  dst[n] = '\0';
}

}  // namespace

}  // namespace hysteron::mex

void mexFunction(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  using namespace hysteron::mex;
  // plain buffers: nothing to destroy when mexErrMsgIdAndTxt leaves this function
  char id[128];
  char message[8192];
  bool failed = true;
  {
    std::string command = "hysteron_mex";  // the command once it is known
    std::string prefix;                     // the message without the command
    try {
      run(nlhs, plhs, nrhs, prhs, command);
      failed = false;
    } catch (const MexError& e) {
      copy_text(id, sizeof id, e.id());
      prefix = e.what();
    } catch (const hysteron::Error& e) {
      copy_text(id, sizeof id, id_error);
      prefix = e.what();
    } catch (const std::bad_alloc&) {
      copy_text(id, sizeof id, "hysteron:outOfMemory");
      prefix = "out of memory";
    } catch (const std::exception& e) {
      copy_text(id, sizeof id, id_internal);
      prefix = fmt::format("internal error (a bug, please report it): {}", e.what());
    } catch (...) {
      copy_text(id, sizeof id, id_internal);
      prefix = "internal error (a bug, please report it): unknown exception";
    }
    if (failed) {
      try {
        copy_text(message, sizeof message,
                  command == "hysteron_mex" ? "hysteron: " + prefix : "hysteron " + command + ": " + prefix);
      } catch (...) {
        copy_text(message, sizeof message, prefix);
      }
    }
  }
  if (failed) mexErrMsgIdAndTxt(id, "%s", message);
}
