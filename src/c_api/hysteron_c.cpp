// The C ABI (include/hysteron/hysteron.h) over the C++ core and model files.
//
// Every exported function runs its body inside guard(): no exception crosses the
// boundary (hysteron::Error, JSON errors, std::bad_alloc, anything else), each
// becomes a status code and a message in a thread-local buffer. The message buffer
// is a fixed char array, so setting it never allocates (the per-sample functions
// stay allocation-free on their error path too).
#include "hysteron/hysteron.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <new>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "hysteron/compensation.hpp"
#include "hysteron/control.hpp"
#include "hysteron/error.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/loop_design.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/units.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"
#include "hysteron/models.hpp"
#include "hysteron/version.hpp"

// The opaque handles.
struct hysteron_params {
  hysteron::ModelParams params;
  std::string kind;  // "gpi", ... (NUL-terminated for hysteron_params_kind)
  std::size_t num_operators = 0;  // the length of a state vector (Model::state().y), every kind
  std::string output_unit;  // the model file's "units" output ("" if none): checked against model_scale
  std::string input_unit;   // its "units" input ("" if none): a pressure unit other than MPa is refused by the loops
  std::string source;       // the model file's path, or "model JSON": named in the loops' errors
};

struct hysteron_model {
  hysteron::Model model;
};

struct hysteron_inverse {
  hysteron::ModelParams params;  // for reset_relaxed
  hysteron::Inverse inverse;
  std::size_t num_operators = 0;
};

struct hysteron_ff_pid {
  hysteron::FeedforwardPidController controller;
};

struct hysteron_open_loop {
  hysteron::OpenLoopController controller;
};

struct hysteron_cascade {
  hysteron::CascadePwmController controller;
};

struct hysteron_ilc {
  hysteron::IterativeLearning ilc;
};

namespace {

constexpr std::size_t message_size = 1024;
// The default TLS model, not initial-exec: a dlopen'ed library with 1 KiB of static TLS takes
// about 2/3 of glibc's surplus and could fail to load beside other such libraries (MATLAB,
// LabVIEW, Python with OpenMP). The price: in a dlopen'ed library glibc allocates a thread's
// block lazily, once, at that thread's first error message (hysteron.h, "Errors").
thread_local char t_message[message_size] = "";

// An error with its status, thrown inside guard() by the argument checks.
struct CError {
  hysteron_status status;
  char text[message_size];
};

// "fn: text", truncated to the buffer.
void set_message(const char* fn, const char* text) noexcept {
  std::size_t i = 0;
  const auto put = [&i](const char* s) {
    while (*s != '\0' && i + 1 < message_size) t_message[i++] = *s++;
  };
  put(fn);
  put(": ");
  put(text);
  t_message[i] = '\0';
}

[[noreturn]] void fail(hysteron_status status, const char* format, ...) {
  CError e;
  e.status = status;
  va_list args;
  va_start(args, format);
  std::vsnprintf(e.text, message_size, format, args);
  va_end(args);
  throw e;
}

// nlohmann's message without its "[json.exception.parse_error.101] " prefix (no allocation).
const char* json_message(const char* what) noexcept {
  const char* end = std::strstr(what, "] ");
  return end != nullptr ? end + 2 : what;
}

// Runs body(); maps every exception to a status. `error_status` is the status of a
// hysteron::Error thrown by the C++ library for this function.
template <class F>
hysteron_status guard(const char* fn, hysteron_status error_status, F&& body) noexcept {
  try {
    body();
    return HYSTERON_OK;
  } catch (const CError& e) {
    set_message(fn, e.text);
    return e.status;
  } catch (const hysteron::Error& e) {
    set_message(fn, e.what());
    return error_status;
  } catch (const nlohmann::json::parse_error& e) {
    set_message(fn, json_message(e.what()));
    return HYSTERON_ERROR_PARSE;
  } catch (const std::bad_alloc&) {
    set_message(fn, "out of memory");
    return HYSTERON_ERROR_OUT_OF_MEMORY;
  } catch (const std::exception& e) {
    char text[message_size];
    std::snprintf(text, sizeof text, "internal error (please report): %s", e.what());
    set_message(fn, text);
    return HYSTERON_ERROR_INTERNAL;
  } catch (...) {
    set_message(fn, "internal error (please report): unknown exception");
    return HYSTERON_ERROR_INTERNAL;
  }
}

#define HYSTERON_REQUIRE(ptr)                                                         \
  do {                                                                                \
    if ((ptr) == nullptr) fail(HYSTERON_ERROR_NULL_POINTER, "argument %s is NULL", #ptr); \
  } while (0)

void require_finite(double v, const char* name) {
  if (!std::isfinite(v)) fail(HYSTERON_ERROR_INVALID_ARGUMENT, "argument %s = %g is not finite", name, v);
}

void require_finite_array(const double* v, std::size_t n, const char* name) {
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(v[k]))
      fail(HYSTERON_ERROR_INVALID_ARGUMENT, "%s[%zu] = %g is not finite (nothing was changed)", name, k, v[k]);
}

void require_state_size(std::size_t n, std::size_t expected) {
  if (n != expected)
    fail(HYSTERON_ERROR_INVALID_ARGUMENT,
         "state size n = %zu, but the model's state has %zu entries (its operators; hysteron_params_num_operators)", n,
         expected);
}

// Batches step sample k from in[k] before writing out[k]: out == in (in place) is safe, any other
// overlap would read samples already overwritten (or, written ahead, step on outputs).
void require_same_or_apart(const double* in, const double* out, std::size_t n, const char* in_name,
                           const char* out_name) {
  const auto at = [](const double* p) { return reinterpret_cast<std::uintptr_t>(p); };
  if (n > 0 && in != out && at(out) < at(in + n) && at(in) < at(out + n))
    fail(HYSTERON_ERROR_INVALID_ARGUMENT,
         "%s overlaps %s without being the same array (%s may be %s itself, in place, or apart from it; nothing was "
         "changed)",
         out_name, in_name, out_name, in_name);
}

hysteron_params* make_params(hysteron::io::ModelDocument doc, const std::string& source) {
  auto* h = new hysteron_params{std::move(doc.params), {}, 0, doc.unit("output"), doc.unit("input"), source};
  h->kind = std::string(hysteron::model_name(h->params));
  try {
    // the state's length: the play operators of the PI family, the kernel's entries of the other
    // kinds (kp, rate-pi, bouc-wen, ...), whose Model::num_operators() is 0 (before 2026-11-30 this
    // gave 0 for them and their *_reset_state / *_get_state could not be used)
    h->num_operators = hysteron::Model(h->params).state().y.size();
  } catch (...) {
    delete h;
    throw;
  }
  return h;
}

// The whole file `path` (io::read_text_file; `what` names it; at most max_bytes): its errors are IO.
std::string read_file(const char* path, const char* what,
                      std::size_t max_bytes = hysteron::io::max_model_file_bytes) {
  try {
    return hysteron::io::read_text_file(path, what, max_bytes);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_IO, "%s", e.what());
  }
}

// io::parse_json (strict: also a repeated key or a NUL byte is a parse error), then the model
// with its free-form keys (the units).
hysteron::io::ModelDocument parse_model(const std::string& text, const std::string& where) {
  nlohmann::json j;
  try {
    j = hysteron::io::parse_json(text, where);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_PARSE, "%s", e.what());
  }
  return hysteron::io::model_document_from_json(j, where);
}

void copy_state(const hysteron::ModelState& s, double* y, std::size_t n, double* u) {
  require_state_size(n, s.y.size());
  for (std::size_t i = 0; i < n; ++i) y[i] = s.y[i];
  if (u) *u = s.u;
}

hysteron::ModelState make_state(const double* y, std::size_t n, double u) {
  require_finite_array(y, n, "y");
  require_finite(u, "u");
  hysteron::ModelState s;
  s.y.assign(y, y + n);
  s.u = u;
  return s;
}

}  // namespace

extern "C" {

const char* hysteron_last_error(void) { return t_message; }

const char* hysteron_status_name(hysteron_status status) {
  switch (status) {
    case HYSTERON_OK: return "HYSTERON_OK";
    case HYSTERON_ERROR_NULL_POINTER: return "HYSTERON_ERROR_NULL_POINTER";
    case HYSTERON_ERROR_INVALID_ARGUMENT: return "HYSTERON_ERROR_INVALID_ARGUMENT";
    case HYSTERON_ERROR_PARSE: return "HYSTERON_ERROR_PARSE";
    case HYSTERON_ERROR_MODEL: return "HYSTERON_ERROR_MODEL";
    case HYSTERON_ERROR_IO: return "HYSTERON_ERROR_IO";
    case HYSTERON_ERROR_OUT_OF_MEMORY: return "HYSTERON_ERROR_OUT_OF_MEMORY";
    case HYSTERON_ERROR_INTERNAL: return "HYSTERON_ERROR_INTERNAL";
  }
  return "unknown hysteron_status";
}

const char* hysteron_version_string(void) {
  return hysteron::version.data();  // a string literal: NUL-terminated
}

hysteron_status hysteron_version(int* major, int* minor, int* patch) {
  if (major) *major = hysteron::version_major;
  if (minor) *minor = hysteron::version_minor;
  if (patch) *patch = hysteron::version_patch;
  return HYSTERON_OK;
}

// ---- params -------------------------------------------------------------------

hysteron_status hysteron_params_from_json(const char* json, hysteron_params** out) {
  return guard("hysteron_params_from_json", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(json);
    HYSTERON_REQUIRE(out);
    *out = make_params(parse_model(json, "model JSON"), "model JSON");
  });
}

hysteron_status hysteron_params_from_file(const char* path, hysteron_params** out) {
  return guard("hysteron_params_from_file", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(path);
    HYSTERON_REQUIRE(out);
    *out = make_params(parse_model(read_file(path, "model file"), path), path);
  });
}

hysteron_status hysteron_params_free(hysteron_params* params) {
  delete params;
  return HYSTERON_OK;
}

hysteron_status hysteron_params_kind(const hysteron_params* params, const char** kind) {
  return guard("hysteron_params_kind", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(kind);
    *kind = params->kind.c_str();
  });
}

hysteron_status hysteron_params_num_operators(const hysteron_params* params, size_t* n) {
  return guard("hysteron_params_num_operators", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(n);
    *n = params->num_operators;
  });
}

hysteron_status hysteron_params_input_limits(const hysteron_params* params, double* lo, double* hi) {
  return guard("hysteron_params_input_limits", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(lo);
    HYSTERON_REQUIRE(hi);
    const hysteron::Limits& l = hysteron::input_limits(params->params);
    *lo = l.lo;
    *hi = l.hi;
  });
}

// ---- forward model --------------------------------------------------------------

hysteron_status hysteron_model_create(const hysteron_params* params, hysteron_model** out) {
  return guard("hysteron_model_create", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(out);
    *out = new hysteron_model{hysteron::Model(params->params)};
  });
}

hysteron_status hysteron_model_free(hysteron_model* model) {
  delete model;
  return HYSTERON_OK;
}

hysteron_status hysteron_model_reset(hysteron_model* model) {
  return guard("hysteron_model_reset", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(model);
    model->model.reset();
  });
}

hysteron_status hysteron_model_reset_relaxed(hysteron_model* model, double x0) {
  return guard("hysteron_model_reset_relaxed", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(model);
    require_finite(x0, "x0");
    if (!model->model.reset_relaxed(x0))
      fail(HYSTERON_ERROR_INVALID_ARGUMENT, "x0 = %g is beyond the model's input bound (nothing was changed)", x0);
  });
}

hysteron_status hysteron_model_reset_state(hysteron_model* model, const double* y, size_t n, double u) {
  return guard("hysteron_model_reset_state", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(model);
    if (n > 0) HYSTERON_REQUIRE(y);
    require_state_size(n, model->model.state().y.size());
    model->model.reset(make_state(y, n, u));
  });
}

hysteron_status hysteron_model_get_state(const hysteron_model* model, double* y, size_t n, double* u) {
  return guard("hysteron_model_get_state", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(model);
    if (n > 0) HYSTERON_REQUIRE(y);
    copy_state(model->model.state(), y, n, u);
  });
}

hysteron_status hysteron_model_step(hysteron_model* model, double x, double* y) {
  if (model == nullptr || y == nullptr) {
    set_message("hysteron_model_step", model == nullptr ? "argument model is NULL" : "argument y is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  if (!model->model.accepts(x)) {  // non-finite, or so large that the output could overflow
    *y = model->model.output();
    char text[160];
    if (!std::isfinite(x))
      std::snprintf(text, sizeof text, "argument x = %g is not finite (state unchanged, previous output held)", x);
    else
      std::snprintf(text, sizeof text, "argument x = %g is beyond the model's input bound, the output would overflow "
                    "(state unchanged, previous output held)", x);
    set_message("hysteron_model_step", text);
    return HYSTERON_ERROR_INVALID_ARGUMENT;
  }
  *y = model->model.step(x);
  return HYSTERON_OK;
}

hysteron_status hysteron_model_simulate(hysteron_model* model, const double* x, size_t n_x, double* y, size_t n_y) {
  return guard("hysteron_model_simulate", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(model);
    if (n_x != n_y) fail(HYSTERON_ERROR_INVALID_ARGUMENT, "n_x = %zu and n_y = %zu differ", n_x, n_y);
    if (n_x == 0) return;
    HYSTERON_REQUIRE(x);
    HYSTERON_REQUIRE(y);
    require_same_or_apart(x, y, n_x, "x", "y");
    require_finite_array(x, n_x, "x");
    for (std::size_t k = 0; k < n_x; ++k)
      if (!model->model.accepts(x[k]))
        fail(HYSTERON_ERROR_INVALID_ARGUMENT, "x[%zu] = %g is beyond the model's input bound, the output would "
             "overflow (nothing was changed)", k, x[k]);
    for (std::size_t k = 0; k < n_x; ++k) y[k] = model->model.step(x[k]);
  });
}

// ---- inverse ----------------------------------------------------------------------

hysteron_status hysteron_inverse_create(const hysteron_params* params, double lo, double hi, hysteron_inverse** out) {
  return guard("hysteron_inverse_create", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(out);
    if (std::isnan(lo) || std::isnan(hi) || lo == std::numeric_limits<double>::infinity() ||
        hi == -std::numeric_limits<double>::infinity() || !(lo < hi))
      fail(HYSTERON_ERROR_INVALID_ARGUMENT,
           "limits lo = %g, hi = %g: need lo < hi, no NaN (-HUGE_VAL / +HUGE_VAL for the model's limits)", lo, hi);
    hysteron::InverseOptions o;
    o.input_limits = {lo, hi};
    auto* h = new hysteron_inverse{params->params, hysteron::Inverse(params->params, o), params->num_operators};
    *out = h;
  });
}

hysteron_status hysteron_inverse_free(hysteron_inverse* inverse) {
  delete inverse;
  return HYSTERON_OK;
}

hysteron_status hysteron_inverse_limits(const hysteron_inverse* inverse, double* lo, double* hi) {
  return guard("hysteron_inverse_limits", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(inverse);
    HYSTERON_REQUIRE(lo);
    HYSTERON_REQUIRE(hi);
    *lo = inverse->inverse.limits().lo;
    *hi = inverse->inverse.limits().hi;
  });
}

hysteron_status hysteron_inverse_reset(hysteron_inverse* inverse) {
  return guard("hysteron_inverse_reset", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(inverse);
    inverse->inverse.reset();
  });
}

hysteron_status hysteron_inverse_reset_relaxed(hysteron_inverse* inverse, double x0) {
  return guard("hysteron_inverse_reset_relaxed", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(inverse);
    require_finite(x0, "x0");
    hysteron::Model m(inverse->params);
    if (!m.reset_relaxed(x0))
      fail(HYSTERON_ERROR_INVALID_ARGUMENT, "x0 = %g is beyond the model's input bound (nothing was changed)", x0);
    inverse->inverse.reset(m.state());
  });
}

hysteron_status hysteron_inverse_reset_state(hysteron_inverse* inverse, const double* y, size_t n, double u) {
  return guard("hysteron_inverse_reset_state", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(inverse);
    if (n > 0) HYSTERON_REQUIRE(y);
    require_state_size(n, inverse->num_operators);
    inverse->inverse.reset(make_state(y, n, u));
  });
}

hysteron_status hysteron_inverse_get_state(const hysteron_inverse* inverse, double* y, size_t n, double* u) {
  return guard("hysteron_inverse_get_state", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(inverse);
    if (n > 0) HYSTERON_REQUIRE(y);
    require_state_size(n, inverse->num_operators);
    copy_state(inverse->inverse.forward_state(), y, n, u);
  });
}

hysteron_status hysteron_inverse_step(hysteron_inverse* inverse, double y_desired, double* x, int* saturated) {
  if (inverse == nullptr || x == nullptr) {
    set_message("hysteron_inverse_step", inverse == nullptr ? "argument inverse is NULL" : "argument x is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  if (!std::isfinite(y_desired)) {
    *x = inverse->inverse.input();
    if (saturated) *saturated = inverse->inverse.saturated() ? 1 : 0;
    char text[128];
    std::snprintf(text, sizeof text, "argument y_desired = %g is not finite (state unchanged, previous input held)",
                  y_desired);
    set_message("hysteron_inverse_step", text);
    return HYSTERON_ERROR_INVALID_ARGUMENT;
  }
  const std::size_t faults = inverse->inverse.faults();
  *x = inverse->inverse.step(y_desired);
  if (saturated) *saturated = inverse->inverse.saturated() ? 1 : 0;
  if (inverse->inverse.faults() != faults) {  // only with an unbounded input limit
    char text[160];
    std::snprintf(text, sizeof text, "y_desired = %g needs an input beyond what a double holds (the inverse has an "
                  "unbounded limit; state unchanged, previous input held)", y_desired);
    set_message("hysteron_inverse_step", text);
    return HYSTERON_ERROR_INVALID_ARGUMENT;
  }
  return HYSTERON_OK;
}

hysteron_status hysteron_inverse_invert(hysteron_inverse* inverse, const double* y, size_t n_y, double* x, size_t n_x,
                                        size_t* n_saturated) {
  return guard("hysteron_inverse_invert", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(inverse);
    if (n_x != n_y) fail(HYSTERON_ERROR_INVALID_ARGUMENT, "n_y = %zu and n_x = %zu differ", n_y, n_x);
    std::size_t sat = 0;
    if (n_y > 0) {
      HYSTERON_REQUIRE(y);
      HYSTERON_REQUIRE(x);
      require_same_or_apart(y, x, n_y, "y", "x");
      require_finite_array(y, n_y, "y");
      for (std::size_t k = 0; k < n_y; ++k) {
        x[k] = inverse->inverse.step(y[k]);
        sat += inverse->inverse.saturated() ? 1 : 0;
      }
    }
    if (n_saturated) *n_saturated = sat;
  });
}

}  // extern "C"

// ---- feedforward + PID --------------------------------------------------------------

namespace {

hysteron::AntiWindup to_anti_windup(int a, const char* field) {
  switch (a) {
    case HYSTERON_ANTI_WINDUP_NONE: return hysteron::AntiWindup::none;
    case HYSTERON_ANTI_WINDUP_CONDITIONAL: return hysteron::AntiWindup::conditional;
    case HYSTERON_ANTI_WINDUP_BACK_CALCULATION: return hysteron::AntiWindup::back_calculation;
    default:
      fail(HYSTERON_ERROR_INVALID_ARGUMENT, "%s = %d: expected 0 (none), 1 (conditional) or 2 (back_calculation)",
           field, a);
  }
}

hysteron::FeedforwardParams to_feedforward(const hysteron_ff_pid_params& c) {
  hysteron::FeedforwardParams ff;
  ff.pressure_limits = {c.pressure_min, c.pressure_max};
  ff.model_scale = c.model_scale;
  ff.lag_time_constant = c.lag_time_constant;
  ff.sample_time = c.sample_time;
  return ff;
}

// A PID at `sample_time`; `name` prefixes the anti-windup's field in messages ("": none).
hysteron::PidParams to_pid(const hysteron_pid_params& c, double sample_time, const char* name) {
  hysteron::PidParams pid;
  pid.kp = c.kp;
  pid.ki = c.ki;
  pid.kd = c.kd;
  pid.sample_time = sample_time;
  pid.derivative_filter = c.derivative_filter;
  pid.tracking_time = c.tracking_time;
  pid.setpoint_weight_p = c.setpoint_weight_p;
  pid.setpoint_weight_d = c.setpoint_weight_d;
  pid.out_min = c.out_min;
  pid.out_max = c.out_max;
  const std::string field = *name ? std::string(name) + ".anti_windup" : std::string("anti_windup");
  pid.anti_windup = to_anti_windup(c.anti_windup, field.c_str());
  return pid;
}

// The position PID of a hysteron_ff_pid_params (output limits: the caller's).
hysteron::PidParams to_pid(const hysteron_ff_pid_params& c) {
  const double inf = std::numeric_limits<double>::infinity();
  return to_pid(hysteron_pid_params{c.kp, c.ki, c.kd, c.derivative_filter, c.tracking_time, c.setpoint_weight_p,
                                    c.setpoint_weight_d, -inf, inf, c.anti_windup},
                c.sample_time, "");
}

// The controller's parameters are the caller's arguments: their errors are INVALID_ARGUMENT
// (checked before the model, whose errors are MODEL).
// `inner`: the cascade's pressure loop, whose errors are prefixed "pressure: " (both PIDs'
// messages name their field as pid.FIELD).
void check_controller(const hysteron::FeedforwardParams& ff, const hysteron::PidParams& position,
                      const hysteron::PidParams* inner = nullptr, const hysteron::PwmParams* pwm = nullptr,
                      double pressure_gain = 0.0) {
  try {
    ff.validate();
    hysteron::Pid check(position);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_INVALID_ARGUMENT, "%s", e.what());
  }
  try {
    if (inner) hysteron::Pid check(*inner);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_INVALID_ARGUMENT, "pressure: %s", e.what());
  }
  try {
    if (pwm) hysteron::PwmModulator check(*pwm);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_INVALID_ARGUMENT, "%s", e.what());
  }
  if (!std::isfinite(pressure_gain) || pressure_gain < 0.0)
    fail(HYSTERON_ERROR_INVALID_ARGUMENT, "pressure_gain = %g: expected a finite value >= 0", pressure_gain);
}

// ff's pressure limits resolved on the model: an unset (infinite) side is its input_limits there
// (hysteron::resolve_pressure_limits). A side the model cannot give, or a resolved lo >= hi, is the
// caller's argument: INVALID_ARGUMENT naming `prefix`pressure_min / pressure_max.
void resolve_limits(const hysteron_params& model, hysteron::FeedforwardParams& ff, const char* prefix) {
  // a model whose input is in kPa, bar, ... under the loop's pressures in MPa (its inverse saturates):
  // the model's to change, not an argument (MODEL)
  if (const std::string why = hysteron::io::input_unit_mismatch(model.input_unit); !why.empty())
    fail(HYSTERON_ERROR_MODEL, "%s: %s", model.source.c_str(), why.c_str());
  // a model_scale that contradicts the model file's output unit (a model in m under the default
  // 1000 asks the inverse for outputs 1000x too large and saturates)
  if (const std::string why = hysteron::io::model_scale_mismatch(ff.model_scale, model.output_unit); !why.empty())
    fail(HYSTERON_ERROR_INVALID_ARGUMENT, "%s%s: set %smodel_scale = %.10g", prefix, why.c_str(), prefix,
         hysteron::io::length_units_per_metre(model.output_unit));
  const hysteron::Limits given = ff.pressure_limits;
  try {
    ff.pressure_limits = hysteron::resolve_pressure_limits(model.params, given);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_INVALID_ARGUMENT, "%spressure_min = %g, %spressure_max = %g: %s", prefix, given.lo, prefix,
         given.hi, e.what());
  }
}

// "arguments ... not all finite" for the controllers' step functions (no allocation).
bool finite_step_args(const char* fn, double reference_m, double preview_m, double measured_m,
                      const double* pressure) noexcept {
  if (std::isfinite(reference_m) && std::isfinite(preview_m) && std::isfinite(measured_m) &&
      (pressure == nullptr || std::isfinite(*pressure)))
    return true;
  // The loop still steps, as the library's step and the generated C do: each part ignores the
  // value it cannot use (docs/deploy.md, "A non-finite argument").
  const char* what =
      pressure ? "not all finite (the loop stepped without them: a non-finite reference or measurement holds the "
                 "position PID's state and correction, the feedforward going on, a non-finite preview the "
                 "inverse's, a non-finite pressure the pressure loop's; the cascade's valves then closed)"
               : "not all finite (the loop stepped without them: a non-finite reference or measurement holds the "
                 "position PID's state and correction, the feedforward going on, a non-finite preview the "
                 "inverse's)";
  char text[512];
  if (pressure)
    std::snprintf(text, sizeof text, "arguments reference_m = %g, preview_m = %g, measured_m = %g, pressure_mpa = %g: %s",
                  reference_m, preview_m, measured_m, *pressure, what);
  else
    std::snprintf(text, sizeof text, "arguments reference_m = %g, preview_m = %g, measured_m = %g: %s", reference_m,
                  preview_m, measured_m, what);
  set_message(fn, text);
  return false;
}

// A PID that counted a fault in this step (Pid::step: an intermediate overflowed, e.g. the error
// reference_m - measured_m of two huge finite values is inf): its state is unchanged and its
// last output held; reported as INVALID_ARGUMENT like a non-finite argument.
hysteron_status pid_overflow(const char* fn, std::size_t faults_before, std::size_t faults_after, double reference_m,
                             double measured_m) noexcept {
  if (faults_after == faults_before) return HYSTERON_OK;
  char text[260];
  std::snprintf(text, sizeof text,
                "reference_m = %g, measured_m = %g (or the pressures): the PID's error or terms overflow (its state "
                "unchanged, its correction held)", reference_m, measured_m);
  set_message(fn, text);
  return HYSTERON_ERROR_INVALID_ARGUMENT;
}

// ---- a loop from result.json: LoopDesign -> the C structs --------------------------------
// Everything the structs cannot hold exactly is an error (MODEL): the loop must command what
// the run commanded.

// The PID's fields; its output limits [lo, hi] are checked against the ones the C controller
// applies (`applied_lo`, `applied_hi`: the C++ controller intersects the two, so they match when
// the recorded ones are not narrower).
void check_pid_limits(const hysteron::PidParams& p, double applied_lo, double applied_hi, double sample_time,
                      const char* where) {
  if (p.sample_time != sample_time)
    fail(HYSTERON_ERROR_MODEL, "%s.sample_time_s = %g differs from the loop's sample_time_s = %g", where,
         p.sample_time, sample_time);
  if ((std::isinf(applied_lo) && p.out_min > applied_lo) || (std::isinf(applied_hi) && p.out_max < applied_hi))
    fail(HYSTERON_ERROR_MODEL,
         "%s: output limits [%g, %g]: the loop leaves its pressure limits to the model's input_limits (null in "
         "feedforward), which the C controller then applies to the PID; whether they are as narrow is not known "
         "here: name the pressure limits, or leave the PID's unbounded (not representable)",
         where, p.out_min, p.out_max);
  if (!(p.out_min <= applied_lo) || !(p.out_max >= applied_hi))
    fail(HYSTERON_ERROR_MODEL,
         "%s: output limits [%g, %g] are narrower than the [%g, %g] the C controller applies (not representable)",
         where, p.out_min, p.out_max, applied_lo, applied_hi);
}

hysteron_pid_params c_pid(const hysteron::PidParams& p) {
  return {p.kp, p.ki, p.kd, p.derivative_filter, p.tracking_time, p.setpoint_weight_p, p.setpoint_weight_d,
          p.out_min, p.out_max, static_cast<int>(p.anti_windup)};
}

// `where`: the controller's path in messages, e.g. "out/result.json.compensated.sine.controller".
void to_c_loop(const hysteron::LoopDesign& d, const std::string& where, hysteron_loop_params& c) {
  // the numbers the objects would refuse (check_controller, the learning), refused here with
  // the run's path (MODEL)
  try {
    hysteron::PidParams none;
    none.sample_time = d.sample_time;
    check_controller(d.feedforward_params(), d.pid.value_or(none), d.pressure_pid ? &*d.pressure_pid : nullptr,
                     d.pwm ? &*d.pwm : nullptr, d.pressure_gain);
  } catch (const CError& e) {
    fail(HYSTERON_ERROR_MODEL, "%s: %s", where.c_str(), e.text);
  }
  try {
    if (d.learning) d.learning->params.validate();
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_MODEL, "%s: %s", where.c_str(), e.what());
  }
  if (d.shaper && (!std::isfinite(d.shaper->a1) || !std::isfinite(d.shaper->a2)))
    fail(HYSTERON_ERROR_MODEL, "%s.shaper: a1 = %g, a2 = %g: must be finite", where.c_str(), d.shaper->a1,
         d.shaper->a2);
  if (d.pressure_pid && d.pressure_pid->guard.enabled())
    fail(HYSTERON_ERROR_MODEL, "%s.pressure_pid.guard: the C ABI's loops have a limit-cycle guard on the position PID "
         "only (hysteron_*_set_guard)", where.c_str());
  hysteron_loop_params out{};
  hysteron_open_loop_params open_loop;
  hysteron_cascade_params cascade;
  if (hysteron_open_loop_default_params(&open_loop) != HYSTERON_OK ||
      hysteron_cascade_default_params(&cascade) != HYSTERON_OK ||
      hysteron_ilc_default_params(&out.learning) != HYSTERON_OK)
    fail(HYSTERON_ERROR_INTERNAL, "default parameters");
  out.ff_pid = open_loop.loop;  // hysteron_ff_pid_default_params
  out.pressure_gain = open_loop.pressure_gain;
  out.pressure = cascade.pressure;
  out.pwm = cascade.pwm;
  using Kind = hysteron::LoopDesign::Kind;
  const hysteron::Limits lim = d.feedforward.pressure_limits;
  hysteron_ff_pid_params& f = out.ff_pid;
  f.sample_time = d.sample_time;
  f.pressure_min = lim.lo;
  f.pressure_max = lim.hi;
  f.model_scale = d.feedforward.model_scale;
  f.lag_time_constant = d.feedforward.lag_time_constant;
  if (d.pid) {
    const double span = lim.hi - lim.lo;
    const std::string w = where + ".pid";
    if (d.kind == Kind::open_loop)
      check_pid_limits(*d.pid, -span, span, d.sample_time, w.c_str());
    else
      check_pid_limits(*d.pid, lim.lo, lim.hi, d.sample_time, w.c_str());
    const hysteron_pid_params q = c_pid(*d.pid);
    f.kp = q.kp;
    f.ki = q.ki;
    f.kd = q.kd;
    f.derivative_filter = q.derivative_filter;
    f.tracking_time = q.tracking_time;
    f.setpoint_weight_p = q.setpoint_weight_p;
    f.setpoint_weight_d = q.setpoint_weight_d;
    f.anti_windup = q.anti_windup;
  } else {
    f.kp = f.ki = f.kd = 0.0;  // no position loop
  }
  switch (d.kind) {
    case Kind::feedforward_pid: out.kind = HYSTERON_LOOP_FEEDFORWARD_PID; break;
    case Kind::open_loop:
      out.kind = HYSTERON_LOOP_OPEN_LOOP;
      out.pressure_gain = d.pressure_gain;
      break;
    case Kind::cascade_pwm: {
      out.kind = HYSTERON_LOOP_CASCADE_PWM;
      if (!d.pressure_pid) fail(HYSTERON_ERROR_MODEL, "%s: a cascade_pwm loop needs its pressure_pid", where.c_str());
      if (d.pressure_pid->sample_time != d.sample_time)
        fail(HYSTERON_ERROR_MODEL, "%s.pressure_pid.sample_time_s = %g differs from the loop's sample_time_s = %g",
             where.c_str(), d.pressure_pid->sample_time, d.sample_time);
      out.pressure = c_pid(*d.pressure_pid);
      const hysteron::PwmParams w = d.pwm.value_or(hysteron::PwmParams{});
      out.pwm = {w.gain, w.deadband, w.min_duty, w.max_duty, w.resolution};
      break;
    }
  }
  out.feedforward_lead = d.feedforward_lead;
  const hysteron::LoopDesign::Shaper z = d.shaper.value_or(hysteron::LoopDesign::Shaper{});
  out.shaped = d.shaper ? 1 : 0;
  out.shaper_a1 = z.a1;
  out.shaper_a2 = z.a2;
  out.shaper_delay = z.delay;
  out.shaper_advance = z.advance;
  if (d.learning) {
    const hysteron::LearningParams& p = d.learning->params;
    out.has_learning = 1;
    out.learning = {p.period, p.gain, p.lead, p.half_width, p.lookahead, p.max_correction, p.rise_tolerance,
                    p.hold_after_cuts, p.max_gain};
  }
  c = out;
}

// io::parse_json (strict), then the run's loop.
// Returns the run's loop as read (out: its C structs, every check made).
hysteron::LoopDesign read_loop(const std::string& text, const char* run, const std::string& where,
                               hysteron_loop_params& out) {
  nlohmann::json j;
  try {
    j = hysteron::io::parse_json(text, where);
  } catch (const hysteron::Error& e) {
    fail(HYSTERON_ERROR_PARSE, "%s", e.what());
  }
  const std::string r = run ? run : "";
  const std::string at = r.empty() ? where : where + "." + r + ".controller";
  const hysteron::LoopDesign d = hysteron::io::loop_design_of_run(j, r, where);
  if (d.adaptation) fail(HYSTERON_ERROR_MODEL, "%s: %s", at.c_str(), hysteron::adaptation_refusal(d).c_str());
  to_c_loop(d, at, out);
  return d;
}

hysteron_pid_guard to_c_guard(const hysteron::PidGuard& g) {
  return {g.period, g.amplitude, g.count, g.memory, g.factor, g.min_scale};
}

hysteron::PidGuard from_c_guard(const hysteron_pid_guard& g) {
  return {g.period, g.amplitude, g.count, g.memory, g.factor, g.min_scale};
}

// The position PID of each C ABI loop.
const hysteron::Pid& position_pid(const hysteron::FeedforwardPidController& c) { return c.pid(); }
const hysteron::Pid& position_pid(const hysteron::OpenLoopController& c) { return c.position(); }
const hysteron::Pid& position_pid(const hysteron::CascadePwmController& c) { return c.position(); }

// hysteron_{ff_pid,open_loop,cascade}_set_guard and _guard_state on handle h (its .controller).
template <class Handle>
hysteron_status set_guard_of(const char* fn, Handle* h, const hysteron_pid_guard* g) {
  return guard(fn, HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(h);
    HYSTERON_REQUIRE(g);
    h->controller.set_guard(from_c_guard(*g));
  });
}

template <class Handle>
hysteron_status restart_guard_of(const char* fn, Handle* h) {
  return guard(fn, HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(h);
    h->controller.restart_guard();
  });
}

template <class Handle>
hysteron_status guard_state_of(const char* fn, const Handle* h, double* gain_scale, size_t* cuts) {
  return guard(fn, HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(h);
    const hysteron::PidState& s = position_pid(h->controller).state();
    if (gain_scale) *gain_scale = s.gain_scale;
    if (cuts) *cuts = s.guard_cuts;
  });
}

// The run's position PID's guard (off without a PID or a guard), after every check
// hysteron_loop_params_from_json makes on the run's loop (read_loop).
void read_guard(const std::string& text, const char* run, const std::string& where, hysteron_pid_guard& out) {
  hysteron_loop_params checked;
  const hysteron::LoopDesign d = read_loop(text, run, where, checked);
  out = to_c_guard(d.pid ? d.pid->guard : hysteron::PidGuard{});
}

}  // namespace

extern "C" {

hysteron_status hysteron_ff_pid_default_params(hysteron_ff_pid_params* params) {
  return guard("hysteron_ff_pid_default_params", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    const hysteron::FeedforwardParams ff;
    const hysteron::PidParams pid;
    params->sample_time = ff.sample_time;
    params->pressure_min = ff.pressure_limits.lo;
    params->pressure_max = ff.pressure_limits.hi;
    params->model_scale = ff.model_scale;
    params->lag_time_constant = ff.lag_time_constant;
    params->kp = pid.kp;
    params->ki = pid.ki;
    params->kd = pid.kd;
    params->derivative_filter = pid.derivative_filter;
    params->tracking_time = pid.tracking_time;
    params->setpoint_weight_p = pid.setpoint_weight_p;
    params->setpoint_weight_d = pid.setpoint_weight_d;
    params->anti_windup = HYSTERON_ANTI_WINDUP_CONDITIONAL;
  });
}

hysteron_status hysteron_ff_pid_create(const hysteron_params* params, const hysteron_ff_pid_params* controller,
                                       hysteron_ff_pid** out) {
  return guard("hysteron_ff_pid_create", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(controller);
    HYSTERON_REQUIRE(out);
    hysteron::FeedforwardParams ff = to_feedforward(*controller);
    hysteron::PidParams pid = to_pid(*controller);
    // Controller parameters first (their errors are the caller's arguments), then the model.
    check_controller(ff, pid);
    resolve_limits(*params, ff, "");
    pid.out_min = ff.pressure_limits.lo;  // the controller clamps to the pressure limits anyway
    pid.out_max = ff.pressure_limits.hi;
    hysteron::FeedforwardPidController c(params->params, ff, pid);
    *out = new hysteron_ff_pid{std::move(c)};
  });
}

hysteron_status hysteron_ff_pid_free(hysteron_ff_pid* controller) {
  delete controller;
  return HYSTERON_OK;
}

hysteron_status hysteron_ff_pid_reset(hysteron_ff_pid* controller) {
  return guard("hysteron_ff_pid_reset", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(controller);
    controller->controller.reset();
  });
}

hysteron_status hysteron_ff_pid_step(hysteron_ff_pid* controller, double reference_m, double preview_m,
                                     double measured_m, double* pressure_mpa) {
  if (controller == nullptr || pressure_mpa == nullptr) {
    set_message("hysteron_ff_pid_step",
                controller == nullptr ? "argument controller is NULL" : "argument pressure_mpa is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  const bool finite = finite_step_args("hysteron_ff_pid_step", reference_m, preview_m, measured_m, nullptr);
  const std::size_t faults = controller->controller.pid().faults();
  *pressure_mpa = controller->controller.step(reference_m, preview_m, measured_m);
  if (!finite) return HYSTERON_ERROR_INVALID_ARGUMENT;
  return pid_overflow("hysteron_ff_pid_step", faults, controller->controller.pid().faults(), reference_m, measured_m);
}

// ---- open loop + pressure loop -------------------------------------------------------

hysteron_status hysteron_open_loop_default_params(hysteron_open_loop_params* params) {
  return guard("hysteron_open_loop_default_params", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    if (hysteron_ff_pid_default_params(&params->loop) != HYSTERON_OK) fail(HYSTERON_ERROR_INTERNAL, "loop");
    params->pressure_gain = hysteron::OpenLoopParams{}.pressure_gain;
  });
}

hysteron_status hysteron_open_loop_create(const hysteron_params* params, const hysteron_open_loop_params* controller,
                                          hysteron_open_loop** out) {
  return guard("hysteron_open_loop_create", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(controller);
    HYSTERON_REQUIRE(out);
    hysteron::OpenLoopParams p;
    p.feedforward = to_feedforward(controller->loop);
    p.position = to_pid(controller->loop);
    p.pressure_gain = controller->pressure_gain;
    check_controller(p.feedforward, p.position, nullptr, nullptr, p.pressure_gain);
    resolve_limits(*params, p.feedforward, "loop.");
    const double span = p.feedforward.pressure_limits.hi - p.feedforward.pressure_limits.lo;
    p.position.out_min = -span;  // the controller's limits of the correction
    p.position.out_max = span;
    hysteron::OpenLoopController c(params->params, p);
    *out = new hysteron_open_loop{std::move(c)};
  });
}

hysteron_status hysteron_open_loop_free(hysteron_open_loop* controller) {
  delete controller;
  return HYSTERON_OK;
}

hysteron_status hysteron_open_loop_reset(hysteron_open_loop* controller) {
  return guard("hysteron_open_loop_reset", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(controller);
    controller->controller.reset();
  });
}

hysteron_status hysteron_open_loop_step(hysteron_open_loop* controller, double reference_m, double preview_m,
                                        double measured_m, double pressure_mpa, double* command_mpa) {
  if (controller == nullptr || command_mpa == nullptr) {
    set_message("hysteron_open_loop_step",
                controller == nullptr ? "argument controller is NULL" : "argument command_mpa is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  const bool finite = finite_step_args("hysteron_open_loop_step", reference_m, preview_m, measured_m, &pressure_mpa);
  const std::size_t faults = controller->controller.position().faults();
  *command_mpa = controller->controller.step(reference_m, preview_m, measured_m, pressure_mpa);
  if (!finite) return HYSTERON_ERROR_INVALID_ARGUMENT;
  return pid_overflow("hysteron_open_loop_step", faults, controller->controller.position().faults(), reference_m,
                      measured_m);
}

// ---- cascade with switching valves -----------------------------------------------------

hysteron_status hysteron_cascade_default_params(hysteron_cascade_params* params) {
  return guard("hysteron_cascade_default_params", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    if (hysteron_ff_pid_default_params(&params->outer) != HYSTERON_OK) fail(HYSTERON_ERROR_INTERNAL, "outer");
    const hysteron::PidParams pid;
    hysteron_pid_params& q = params->pressure;
    q.kp = 20.0;  // duty per MPa: the dead-zone MPI paper's P loop (mpi-pwm's faithful variant)
    q.ki = pid.ki;
    q.kd = pid.kd;
    q.derivative_filter = pid.derivative_filter;
    q.tracking_time = pid.tracking_time;
    q.setpoint_weight_p = pid.setpoint_weight_p;
    q.setpoint_weight_d = pid.setpoint_weight_d;
    q.out_min = -1.0;
    q.out_max = 1.0;
    q.anti_windup = HYSTERON_ANTI_WINDUP_CONDITIONAL;
    const hysteron::PwmParams pwm;
    params->pwm = {pwm.gain, pwm.deadband, pwm.min_duty, pwm.max_duty, pwm.resolution};
  });
}

hysteron_status hysteron_cascade_create(const hysteron_params* params, const hysteron_cascade_params* controller,
                                        hysteron_cascade** out) {
  return guard("hysteron_cascade_create", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(controller);
    HYSTERON_REQUIRE(out);
    hysteron::CascadeParams p;
    p.feedforward = to_feedforward(controller->outer);
    p.position = to_pid(controller->outer);
    p.pressure = to_pid(controller->pressure, controller->outer.sample_time, "pressure");
    const hysteron_pwm_params& w = controller->pwm;
    p.pwm = {w.gain, w.deadband, w.min_duty, w.max_duty, w.resolution};
    check_controller(p.feedforward, p.position, &p.pressure, &p.pwm);
    resolve_limits(*params, p.feedforward, "outer.");
    p.position.out_min = p.feedforward.pressure_limits.lo;  // the controller clamps p_d to them
    p.position.out_max = p.feedforward.pressure_limits.hi;
    hysteron::CascadePwmController c(params->params, p);
    *out = new hysteron_cascade{std::move(c)};
  });
}

hysteron_status hysteron_cascade_free(hysteron_cascade* controller) {
  delete controller;
  return HYSTERON_OK;
}

hysteron_status hysteron_cascade_reset(hysteron_cascade* controller) {
  return guard("hysteron_cascade_reset", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(controller);
    controller->controller.reset();
  });
}

hysteron_status hysteron_cascade_step(hysteron_cascade* controller, double reference_m, double preview_m,
                                      double measured_m, double pressure_mpa, double* duty,
                                      double* desired_pressure_mpa) {
  if (controller == nullptr || duty == nullptr) {
    set_message("hysteron_cascade_step", controller == nullptr ? "argument controller is NULL" : "argument duty is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  const bool finite = finite_step_args("hysteron_cascade_step", reference_m, preview_m, measured_m, &pressure_mpa);
  const hysteron::CascadePwmController& c = controller->controller;
  const std::size_t faults = c.position().faults() + c.pressure().faults();
  *duty = controller->controller.step(reference_m, preview_m, measured_m, pressure_mpa);
  if (desired_pressure_mpa) *desired_pressure_mpa = controller->controller.desired_pressure();
  if (!finite) return HYSTERON_ERROR_INVALID_ARGUMENT;
  return pid_overflow("hysteron_cascade_step", faults, c.position().faults() + c.pressure().faults(), reference_m,
                      measured_m);
}

// ---- the position PID's limit-cycle guard ------------------------------------------

hysteron_status hysteron_pid_guard_default(hysteron_pid_guard* guard) {
  return ::guard("hysteron_pid_guard_default", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(guard);
    *guard = to_c_guard(hysteron::PidGuard{});
  });
}

hysteron_status hysteron_ff_pid_set_guard(hysteron_ff_pid* controller, const hysteron_pid_guard* guard) {
  return set_guard_of("hysteron_ff_pid_set_guard", controller, guard);
}

hysteron_status hysteron_open_loop_set_guard(hysteron_open_loop* controller, const hysteron_pid_guard* guard) {
  return set_guard_of("hysteron_open_loop_set_guard", controller, guard);
}

hysteron_status hysteron_cascade_set_guard(hysteron_cascade* controller, const hysteron_pid_guard* guard) {
  return set_guard_of("hysteron_cascade_set_guard", controller, guard);
}

hysteron_status hysteron_ff_pid_restart_guard(hysteron_ff_pid* controller) {
  return restart_guard_of("hysteron_ff_pid_restart_guard", controller);
}

hysteron_status hysteron_open_loop_restart_guard(hysteron_open_loop* controller) {
  return restart_guard_of("hysteron_open_loop_restart_guard", controller);
}

hysteron_status hysteron_cascade_restart_guard(hysteron_cascade* controller) {
  return restart_guard_of("hysteron_cascade_restart_guard", controller);
}

hysteron_status hysteron_ff_pid_guard_state(const hysteron_ff_pid* controller, double* gain_scale, size_t* cuts) {
  return guard_state_of("hysteron_ff_pid_guard_state", controller, gain_scale, cuts);
}

hysteron_status hysteron_open_loop_guard_state(const hysteron_open_loop* controller, double* gain_scale, size_t* cuts) {
  return guard_state_of("hysteron_open_loop_guard_state", controller, gain_scale, cuts);
}

hysteron_status hysteron_cascade_guard_state(const hysteron_cascade* controller, double* gain_scale, size_t* cuts) {
  return guard_state_of("hysteron_cascade_guard_state", controller, gain_scale, cuts);
}

// ---- iterative learning control ---------------------------------------------------

hysteron_status hysteron_ilc_default_params(hysteron_ilc_params* params) {
  return guard("hysteron_ilc_default_params", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(params);
    const hysteron::LearningParams d;
    params->period = d.period;
    params->gain = d.gain;
    params->lead = d.lead;
    params->half_width = d.half_width;
    params->lookahead = d.lookahead;
    params->max_correction = d.max_correction;
    params->rise_tolerance = d.rise_tolerance;
    params->hold_after_cuts = d.hold_after_cuts;
    params->max_gain = d.max_gain;
  });
}

hysteron_status hysteron_ilc_create(const hysteron_ilc_params* params, hysteron_ilc** out) {
  return guard("hysteron_ilc_create", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(params);
    HYSTERON_REQUIRE(out);
    hysteron::LearningParams p;
    p.period = params->period;
    p.gain = params->gain;
    p.lead = params->lead;
    p.half_width = params->half_width;
    p.lookahead = params->lookahead;
    p.max_correction = params->max_correction;
    p.rise_tolerance = params->rise_tolerance;
    p.hold_after_cuts = params->hold_after_cuts;
    p.max_gain = params->max_gain;
    // the constructor validates: its hysteron::Error is this call's INVALID_ARGUMENT (guard)
    *out = new hysteron_ilc{hysteron::IterativeLearning(p)};
  });
}

hysteron_status hysteron_ilc_free(hysteron_ilc* ilc) {
  delete ilc;
  return HYSTERON_OK;
}

hysteron_status hysteron_ilc_reset(hysteron_ilc* ilc) {
  return guard("hysteron_ilc_reset", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(ilc);
    ilc->ilc.reset();
  });
}

hysteron_status hysteron_ilc_reset_to(hysteron_ilc* ilc, const double* correction, size_t n) {
  return guard("hysteron_ilc_reset_to", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(ilc);
    HYSTERON_REQUIRE(correction);
    ilc->ilc.reset(std::span<const double>(correction, n));  // its Error: INVALID_ARGUMENT (guard)
  });
}

hysteron_status hysteron_ilc_correction(const hysteron_ilc* ilc, size_t ahead, double* correction) {
  if (ilc == nullptr || correction == nullptr) {
    set_message("hysteron_ilc_correction", ilc == nullptr ? "argument ilc is NULL" : "argument correction is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  if (ahead > ilc->ilc.params().lookahead) {
    char text[160];
    std::snprintf(text, sizeof text, "argument ahead = %zu is beyond params.lookahead = %zu", ahead,
                  ilc->ilc.params().lookahead);
    set_message("hysteron_ilc_correction", text);
    return HYSTERON_ERROR_INVALID_ARGUMENT;
  }
  *correction = ilc->ilc.correction(ahead);
  return HYSTERON_OK;
}

hysteron_status hysteron_ilc_step(hysteron_ilc* ilc, double error) {
  if (ilc == nullptr) {
    set_message("hysteron_ilc_step", "argument ilc is NULL");
    return HYSTERON_ERROR_NULL_POINTER;
  }
  const std::size_t overflows = ilc->ilc.overflows();
  ilc->ilc.step(error);  // a non-finite error is learnt as 0 and counted
  if (!std::isfinite(error)) {
    char text[160];
    std::snprintf(text, sizeof text, "argument error = %g is not finite (learnt as 0; the sample advanced)", error);
    set_message("hysteron_ilc_step", text);
    return HYSTERON_ERROR_INVALID_ARGUMENT;
  }
  if (ilc->ilc.overflows() != overflows) {  // the update of an earlier phase (D samples behind) overflowed
    set_message("hysteron_ilc_step", "the update of the correction overflowed (errors of the order of 1e308): that "
                                     "phase kept its correction of the period before (the sample advanced)");
    return HYSTERON_ERROR_INVALID_ARGUMENT;
  }
  return HYSTERON_OK;
}

hysteron_status hysteron_ilc_overflows(const hysteron_ilc* ilc, size_t* overflows) {
  return guard("hysteron_ilc_overflows", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(ilc);
    HYSTERON_REQUIRE(overflows);
    *overflows = ilc->ilc.overflows();
  });
}

hysteron_status hysteron_ilc_state(const hysteron_ilc* ilc, size_t* phase, size_t* iteration, double* gain,
                                   size_t* gain_cuts, size_t* gain_raises, int* held, size_t* faults) {
  return guard("hysteron_ilc_state", HYSTERON_ERROR_INTERNAL, [&] {
    HYSTERON_REQUIRE(ilc);
    const hysteron::IterativeLearning& l = ilc->ilc;
    if (phase) *phase = l.phase();
    if (iteration) *iteration = l.iteration();
    if (gain) *gain = l.gain();
    if (gain_cuts) *gain_cuts = l.gain_cuts();
    if (gain_raises) *gain_raises = l.gain_raises();
    if (held) *held = l.held() ? 1 : 0;
    if (faults) *faults = l.faults();
  });
}

// ---- a loop from result.json --------------------------------------------------------

hysteron_status hysteron_loop_params_from_json(const char* json, const char* run, hysteron_loop_params* out) {
  return guard("hysteron_loop_params_from_json", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(json);
    HYSTERON_REQUIRE(out);
    read_loop(json, run, "result.json", *out);
  });
}

hysteron_status hysteron_loop_params_from_file(const char* path, const char* run, hysteron_loop_params* out) {
  return guard("hysteron_loop_params_from_file", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(path);
    HYSTERON_REQUIRE(out);
    read_loop(read_file(path, "result file", hysteron::io::max_result_file_bytes), run, path, *out);
  });
}

hysteron_status hysteron_loop_guard_from_json(const char* json, const char* run, hysteron_pid_guard* out) {
  return guard("hysteron_loop_guard_from_json", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(json);
    HYSTERON_REQUIRE(out);
    read_guard(json, run, "result.json", *out);
  });
}

hysteron_status hysteron_loop_guard_from_file(const char* path, const char* run, hysteron_pid_guard* out) {
  return guard("hysteron_loop_guard_from_file", HYSTERON_ERROR_MODEL, [&] {
    HYSTERON_REQUIRE(path);
    HYSTERON_REQUIRE(out);
    read_guard(read_file(path, "result file", hysteron::io::max_result_file_bytes), run, path, *out);
  });
}

hysteron_status hysteron_loop_preview(const hysteron_loop_params* loop, const double* reference, size_t n_reference,
                                      double* preview, size_t n_preview) {
  return guard("hysteron_loop_preview", HYSTERON_ERROR_INVALID_ARGUMENT, [&] {
    HYSTERON_REQUIRE(loop);
    if (n_reference > 0) {
      HYSTERON_REQUIRE(reference);
      HYSTERON_REQUIRE(preview);
    }
    if (n_preview != n_reference)
      fail(HYSTERON_ERROR_INVALID_ARGUMENT, "n_preview = %zu, but n_reference = %zu", n_preview, n_reference);
    const auto at = [](const double* p) { return reinterpret_cast<std::uintptr_t>(p); };
    if (n_reference > 0 && at(preview) < at(reference + n_reference) && at(reference) < at(preview + n_preview))
      fail(HYSTERON_ERROR_INVALID_ARGUMENT, "preview overlaps reference");
    require_finite_array(reference, n_reference, "reference");
    hysteron::LoopDesign d;
    d.feedforward_lead = loop->feedforward_lead;
    if (loop->shaped) {
      if (!std::isfinite(loop->shaper_a1) || !std::isfinite(loop->shaper_a2))
        fail(HYSTERON_ERROR_INVALID_ARGUMENT, "shaper_a1 = %g, shaper_a2 = %g: must be finite", loop->shaper_a1,
             loop->shaper_a2);
      d.shaper = hysteron::LoopDesign::Shaper{loop->shaper_a1, loop->shaper_a2, loop->shaper_delay, loop->shaper_advance};
    }
    hysteron::feedforward_preview(d, {reference, n_reference}, {preview, n_preview});
  });
}

}  // extern "C"
