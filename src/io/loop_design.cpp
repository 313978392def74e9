// result.json's "controller": LoopDesign's writer and reader (hysteron/io/loop_design.hpp).
#include "hysteron/io/loop_design.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"  // parse_json, read_text_file
#include "json_read.hpp"

namespace hysteron::io {

using nlohmann::json;
using namespace json_read;

namespace {
json pid_json(const PidParams& p) {
  json j = {{"kp_mpa_per_m", p.kp},
          {"ki_mpa_per_m_s", p.ki},
          {"kd_mpa_s_per_m", p.kd},
          {"sample_time_s", p.sample_time},
          {"derivative_filter_s", p.derivative_filter},
          {"out_min_mpa", number(p.out_min)},
          {"out_max_mpa", number(p.out_max)},
          {"anti_windup", std::string(anti_windup_name(p.anti_windup))},
          {"tracking_time_s", p.tracking_time},
          {"setpoint_weight_p", p.setpoint_weight_p},
          {"setpoint_weight_d", p.setpoint_weight_d}};
  if (p.guard.enabled())
    j["guard"] = {{"period_s", p.guard.period},   {"amplitude", p.guard.amplitude}, {"count", p.guard.count},
                  {"memory_periods", p.guard.memory}, {"factor", p.guard.factor},     {"min_scale", p.guard.min_scale}};
  return j;
}

PidParams pid_from(const json& j, std::string_view where) {
  check_keys(j,
             {"kp_mpa_per_m", "ki_mpa_per_m_s", "kd_mpa_s_per_m", "sample_time_s", "derivative_filter_s", "out_min_mpa",
              "out_max_mpa", "anti_windup", "tracking_time_s", "setpoint_weight_p", "setpoint_weight_d", "guard"},
             where);
  PidParams p;
  p.kp = get_double(j, "kp_mpa_per_m", where);
  p.ki = get_double(j, "ki_mpa_per_m_s", where);
  p.kd = get_double(j, "kd_mpa_s_per_m", where);
  p.sample_time = get_double(j, "sample_time_s", where);
  p.derivative_filter = get_double(j, "derivative_filter_s", where);
  p.out_min = get_double(j, "out_min_mpa", where, -std::numeric_limits<double>::infinity());
  p.out_max = get_double(j, "out_max_mpa", where, std::numeric_limits<double>::infinity());
  const std::string aw = get_string(j, "anti_windup", where);
  try {
    p.anti_windup = anti_windup_from_name(aw);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: key \"anti_windup\": {}", where, e.what()));
  }
  p.tracking_time = get_double(j, "tracking_time_s", where);
  p.setpoint_weight_p = get_double(j, "setpoint_weight_p", where);
  p.setpoint_weight_d = get_double(j, "setpoint_weight_d", where);
  if (j.contains("guard")) {  // absent in files written before the guard: off
    const std::string w = key_where(where, "guard");
    const json& g = j["guard"];
    check_keys(g, {"period_s", "amplitude", "count", "memory_periods", "factor", "min_scale"}, w);
    p.guard.period = get_double(g, "period_s", w);
    p.guard.amplitude = get_double(g, "amplitude", w);
    p.guard.count = get_double(g, "count", w);
    p.guard.memory = get_double(g, "memory_periods", w);
    p.guard.factor = get_double(g, "factor", w);
    p.guard.min_scale = get_double(g, "min_scale", w);
  }
  return p;
}

// The names of LoopDesign::Kind in result.json's "loop".
constexpr std::pair<LoopDesign::Kind, std::string_view> kLoopKinds[] = {
    {LoopDesign::Kind::feedforward_pid, "feedforward_pid"},
    {LoopDesign::Kind::open_loop, "open_loop"},
    {LoopDesign::Kind::cascade_pwm, "cascade_pwm"}};

std::string_view loop_kind_name(LoopDesign::Kind k) {
  for (const auto& [kind, name] : kLoopKinds)
    if (kind == k) return name;
  return "unknown";
}

LoopDesign::Kind loop_kind_from(const json& j, std::string_view where) {
  const std::string name = get_string(j, "loop", where);
  for (const auto& [kind, n] : kLoopKinds)
    if (n == name) return kind;
  throw Error(fmt::format("{}: key \"loop\": unknown loop \"{}\" (expected feedforward_pid, open_loop or cascade_pwm)",
                          where, name));
}
}  // namespace

json to_json(const LoopDesign& d) {
  json j = json::object();
  j["loop"] = std::string(loop_kind_name(d.kind));
  // null: unset, the model's input_limits (the experiments always write the rig's)
  j["feedforward"] = {{"pressure_min_mpa", number(d.feedforward.pressure_limits.lo)},
                      {"pressure_max_mpa", number(d.feedforward.pressure_limits.hi)},
                      {"model_scale_per_m", d.feedforward.model_scale},
                      {"lag_time_constant_s", d.feedforward.lag_time_constant}};
  if (d.pwm)
    j["pwm"] = {{"gain", d.pwm->gain},
                {"deadband", d.pwm->deadband},
                {"min_duty", d.pwm->min_duty},
                {"max_duty", d.pwm->max_duty},
                {"resolution", d.pwm->resolution}};
  if (d.pid) j["pid"] = pid_json(*d.pid);
  if (d.pid && d.pid->guard.enabled()) {
    j["guard_final_scale"] = d.guard_final_scale;
    j["guard_cuts"] = d.guard_cuts;
  }
  if (d.pressure_pid) j["pressure_pid"] = pid_json(*d.pressure_pid);
  if (d.pressure_gain != 0.0) j["pressure_gain"] = d.pressure_gain;
  j["feedforward_lead_samples"] = d.feedforward_lead;
  j["sample_time_s"] = d.sample_time;
  if (d.shaper)
    j["shaper"] = {{"a1", d.shaper->a1},
                   {"a2", d.shaper->a2},
                   {"delay_samples", d.shaper->delay},
                   {"advance_samples", d.shaper->advance}};
  if (d.learning) {
    const auto& l = *d.learning;
    const LearningParams& p = l.params;
    j["learning"] = {{"period_samples", p.period},
                     {"gain", p.gain},
                     {"lead_samples", p.lead},
                     {"half_width", p.half_width},
                     {"lookahead", p.lookahead},
                     {"max_correction_m", number(p.max_correction)},
                     {"rise_tolerance", number(p.rise_tolerance)},
                     {"hold_after_cuts", p.hold_after_cuts},
                     {"max_gain", p.max_gain},
                     {"contraction_bound", number(l.contraction_bound)},
                     {"final_gain", l.final_gain},
                     {"gain_raises", l.gain_raises},
                     {"gain_cuts", l.gain_cuts},
                     {"held", l.held}};
  }
  if (d.adaptation)
    j["adaptation"] = {{"lambda", number(d.adaptation->lambda)},
                       {"delay_samples", d.adaptation->delay},
                       {"margin", number(d.adaptation->margin)}};
  return j;
}

void from_json(const json& j, LoopDesign& d, std::string_view where) {
  d = LoopDesign{};
  if (!j.is_object()) throw Error(fmt::format("{}: expected a JSON object, got {}", where, j.type_name()));
  check_keys(j,
             {"loop", "feedforward", "pwm", "pid", "guard_final_scale", "guard_cuts", "pressure_pid", "pressure_gain",
              "feedforward_lead_samples", "sample_time_s", "shaper", "learning", "adaptation"},
             where);
  if (j.contains("pid")) d.pid = pid_from(j["pid"], key_where(where, "pid"));
  if (j.contains("pressure_pid")) d.pressure_pid = pid_from(j["pressure_pid"], key_where(where, "pressure_pid"));
  d.pressure_gain = opt_double(j, "pressure_gain", where, 0.0);
  if (d.pid && d.pid->guard.enabled()) {  // what the run's guard did; a hand-written loop: nothing yet
    d.guard_final_scale = opt_double(j, "guard_final_scale", where, 1.0);
    d.guard_cuts = j.contains("guard_cuts") ? get_size(j, "guard_cuts", where) : 0;
  }
  d.feedforward_lead = get_size(j, "feedforward_lead_samples", where);
  d.sample_time = get_double(j, "sample_time_s", where);
  if (j.contains("loop")) {
    d.kind = loop_kind_from(j, where);
    const std::string w = key_where(where, "feedforward");
    const json& f = need(j, "feedforward", where);
    check_keys(f, {"pressure_min_mpa", "pressure_max_mpa", "model_scale_per_m", "lag_time_constant_s"}, w);
    // null: unset, the model's input_limits (resolve_pressure_limits)
    const double inf = std::numeric_limits<double>::infinity();
    d.feedforward.pressure_limits = {get_double(f, "pressure_min_mpa", w, -inf),
                                     get_double(f, "pressure_max_mpa", w, inf)};
    d.feedforward.model_scale = get_double(f, "model_scale_per_m", w);
    d.feedforward.lag_time_constant = get_double(f, "lag_time_constant_s", w);
    if (d.kind == LoopDesign::Kind::cascade_pwm) {
      const std::string wp = key_where(where, "pwm");
      const json& x = need(j, "pwm", where);
      check_keys(x, {"gain", "deadband", "min_duty", "max_duty", "resolution"}, wp);
      PwmParams p;
      p.gain = get_double(x, "gain", wp);
      p.deadband = get_double(x, "deadband", wp);
      p.min_duty = get_double(x, "min_duty", wp);
      p.max_duty = get_double(x, "max_duty", wp);
      p.resolution = get_double(x, "resolution", wp);
      d.pwm = p;
    }
  } else {
    // Written before "loop" (2026-11-26): every experiment used the default feedforward and
    // PWM, and the structure follows from the pressure loops. The feedforward's pressure
    // limits were then always 0..0.6 MPa (its default at the time): recorded as such.
    d.feedforward.pressure_limits = {0.0, 0.6};
    d.kind = d.pressure_pid ? LoopDesign::Kind::cascade_pwm
             : d.pressure_gain > 0.0 ? LoopDesign::Kind::open_loop
                                     : LoopDesign::Kind::feedforward_pid;
    if (d.pressure_pid) d.pwm = PwmParams{};
  }
  if (j.contains("shaper")) {
    const std::string w = key_where(where, "shaper");
    const json& s = j["shaper"];
    check_keys(s, {"a1", "a2", "delay_samples", "advance_samples"}, w);
    LoopDesign::Shaper z;
    z.a1 = get_double(s, "a1", w);
    z.a2 = get_double(s, "a2", w);
    z.delay = get_size(s, "delay_samples", w);
    z.advance = get_size(s, "advance_samples", w);
    // a zero-vibration shaper's two impulses (docs/control.md section 2): a1 = 1 / (1 + K) > 0,
    // a2 = K / (1 + K) >= 0 (0: no second impulse), a1 + a2 = 1 (the preview keeps the reference's
    // level); anything else scales or flips the feedforward's preview
    if (!(z.a1 > 0.0) || !(z.a2 >= 0.0) || !(std::abs(z.a1 + z.a2 - 1.0) <= 1e-9))
      throw Error(fmt::format("{}: a1 = {}, a2 = {}: a zero-vibration shaper's weights must be a1 > 0 and a2 >= 0 "
                              "with a1 + a2 = 1 (within 1e-9; here {})",
                              w, z.a1, z.a2, z.a1 + z.a2));
    d.shaper = z;
  }
  if (j.contains("learning")) {
    const std::string w = key_where(where, "learning");
    const json& x = j["learning"];
    check_keys(x,
               {"period_samples", "gain", "lead_samples", "half_width", "lookahead", "max_correction_m",
                "rise_tolerance", "hold_after_cuts", "max_gain", "contraction_bound", "final_gain", "gain_raises",
                "gain_cuts", "held"},
               w);
    LoopDesign::Learning l;
    LearningParams& p = l.params;
    const double inf = std::numeric_limits<double>::infinity();
    p.period = get_size(x, "period_samples", w);
    p.gain = get_double(x, "gain", w);
    p.lead = get_size(x, "lead_samples", w);
    p.half_width = get_size(x, "half_width", w);
    p.lookahead = get_size(x, "lookahead", w);
    p.max_correction = get_double(x, "max_correction_m", w, inf);
    p.rise_tolerance = get_double(x, "rise_tolerance", w, inf);
    p.hold_after_cuts = get_size(x, "hold_after_cuts", w);
    p.max_gain = get_double(x, "max_gain", w);
    l.contraction_bound = get_double(x, "contraction_bound", w);
    l.final_gain = get_double(x, "final_gain", w);
    l.gain_raises = get_size(x, "gain_raises", w);
    l.gain_cuts = get_size(x, "gain_cuts", w);
    l.held = get_bool(x, "held", w);
    d.learning = l;
  }
  if (j.contains("adaptation")) {
    const std::string w = key_where(where, "adaptation");
    const json& x = j["adaptation"];
    check_keys(x, {"lambda", "delay_samples", "margin"}, w);
    LoopDesign::Adaptation a;
    a.lambda = get_double(x, "lambda", w);
    a.delay = get_size(x, "delay_samples", w);
    a.margin = get_double(x, "margin", w);
    d.adaptation = a;
  }
}

namespace {
// The keys of j whose values `keep` accepts, comma-separated.
std::string names_of(const json& j, bool (*keep)(const json&)) {
  std::string s;
  for (const auto& [k, v] : j.items())
    if (keep(v)) s += (s.empty() ? "" : ", ") + k;
  return s.empty() ? "none" : s;
}
LoopDesign read(const json& j, const std::string& where) {
  LoopDesign d;
  from_json(j, d, where);
  return d;
}
bool is_run(const json& v) { return v.is_object() && v.contains("controller"); }
bool is_variant(const json& v) {
  if (is_run(v)) return true;
  if (!v.is_object()) return false;
  for (const auto& [k, e] : v.items())
    if (is_run(e)) return true;
  return false;
}
}  // namespace

namespace {
// A run of the adaptive variant whose controller does not record its "adaptation" (a
// result.json written before 2026-11-27): its loop would read as one with a fixed inverse.
LoopDesign unless_unmarked_adaptive(LoopDesign d, std::string_view variant, std::string_view where) {
  if (variant == "adaptive" && !d.adaptation)
    throw Error(fmt::format("{}: an adaptive run's loop, written before its \"adaptation\" was recorded: its inverse "
                            "was adapted online (RLS), which a loop with a fixed inverse does not do: use the "
                            "compensated run's loop",
                            where));
  return d;
}
}  // namespace

LoopDesign loop_design_of_run(const json& doc, std::string_view run, std::string_view where) {
  if (!doc.is_object()) throw Error(fmt::format("{}: expected a JSON object, got {}", where, doc.type_name()));
  if (run.empty()) {
    if (is_run(doc)) return read(doc["controller"], key_where(where, "controller"));
    if (doc.contains("sample_time_s")) return read(doc, std::string(where));
    throw Error(fmt::format("{}: not a controller; name a run of the result.json (variants: {})", where,
                            names_of(doc, is_variant)));
  }
  const std::size_t dot = run.find('.');
  const std::string variant(run.substr(0, dot));
  const std::string reference(dot == std::string_view::npos ? std::string_view() : run.substr(dot + 1));
  const auto v = doc.find(variant);
  if (variant.empty() || v == doc.end() || !is_variant(*v))
    throw Error(fmt::format("{}: no run \"{}\" (variants: {})", where, variant, names_of(doc, is_variant)));
  const std::string vw = key_where(where, variant);
  if (is_run(*v)) {  // one reference
    if (!reference.empty() && v->value("reference", std::string()) != reference)
      throw Error(fmt::format("{}: no reference \"{}\" (this experiment has one: \"{}\")", vw, reference,
                              v->value("reference", std::string())));
    return unless_unmarked_adaptive(read((*v)["controller"], key_where(vw, "controller")), variant, vw);
  }
  if (reference.empty())
    throw Error(fmt::format("{}: one run per reference ({}): name one, e.g. \"{}.{}\"", vw, names_of(*v, is_run),
                            variant, v->items().begin().key()));
  const auto e = v->find(reference);
  if (e == v->end() || !is_run(*e))
    throw Error(fmt::format("{}: no reference \"{}\" (references: {})", vw, reference, names_of(*v, is_run)));
  const std::string ew = key_where(vw, reference);
  return unless_unmarked_adaptive(read((*e)["controller"], key_where(ew, "controller")), variant, ew);
}

LoopDesign read_loop_design(const std::string& path, std::string_view run) {
  return loop_design_of_run(parse_json(read_text_file(path, "result file", max_result_file_bytes), path), run, path);
}

}  // namespace hysteron::io
