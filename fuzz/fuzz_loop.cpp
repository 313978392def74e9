// libFuzzer target: result.json's "controller" reader (io::loop_design_of_run, the reader behind
// the C ABI's hysteron_loop_params_from_file), for a bare controller object and for the runs
// "compensated", "compensated.sine" and "learning.triangle" of a whole result.json. An accepted
// loop must survive a write/read round trip unchanged; where make_controller accepts it (on a
// fixed PI model), its steps must give finite commands inside the pressure limits (a duty in
// [-1, 1] with the valves), whatever finite reference, preview and measurements it is fed, and
// hysteron export --loop must write it as C (io::generate_c) unless a count of samples is beyond
// 2^31 - 1, its learning's parameters are invalid or the learning's state would be more than
// 2^31 - 1 bytes (refused with hysteron::Error). Only hysteron::Error may escape.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include "hysteron/error.hpp"
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/loop_design.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"

namespace io = hysteron::io;

namespace {

const hysteron::ModelParams& model() {
  static const hysteron::ModelParams m = io::model_from_json(
      io::parse_json(R"({"model": "pi", "q": 0.4, "r": [0, 0.1, 0.25, 0.5], "p": [0.3, 0.2, 0.15, 0.1],
                         "input_limits": [0, 0.6]})",
                     "model"),
      "model");
  return m;
}

void check(bool ok) {
  if (!ok) std::abort();
}

// A few samples of the loop: commands finite and inside the limits.
void run(const hysteron::LoopDesign& d) {
  std::optional<hysteron::Controller> c;
  try {
    c.emplace(hysteron::make_controller(d, model()));
  } catch (const hysteron::Error&) {
    return;
  }
  // the limits the loop applies: d's, each unset (infinite) side the model's input_limits [0, 0.6]
  const hysteron::Limits lim = hysteron::pressure_limits(*c);
  const hysteron::Limits& given = d.feedforward.pressure_limits;
  check(lim.lo == (std::isinf(given.lo) ? 0.0 : given.lo) && lim.hi == (std::isinf(given.hi) ? 0.6 : given.hi));
  const double inputs[][4] = {{0.0, 0.0, 0.0, 0.0},     {0.01, 0.012, 0.009, 0.2}, {0.05, 0.05, -0.02, 0.7},
                              {1e3, -1e3, 1e6, -1e6},   {-0.01, 0.3, 0.02, 0.1},   {1e-300, 1e300, -1e300, 5e-324},
                              {0.02, 0.02, 0.02, 0.3}};
  for (int rep = 0; rep < 3; ++rep)
    for (const auto& x : inputs) {
      const hysteron::LoopOutput o = hysteron::step(*c, x[0], x[1], x[2], x[3]);
      check(std::isfinite(o.command_mpa) && o.command_mpa >= lim.lo && o.command_mpa <= lim.hi);  // p_d with valves
      check(std::isfinite(o.duty) && o.duty >= -1.0 && o.duty <= 1.0);
    }
  // generated C: every loop make_controller accepts, but those generated C cannot hold
  constexpr std::size_t max_count = 2147483647u;
  bool learning_holdable = true;
  if (d.learning) {
    const hysteron::LearningParams& p = d.learning->params;
    try {
      p.validate();
    } catch (const hysteron::Error&) {
      learning_holdable = false;
    }
    const double doubles = std::isfinite(p.rise_tolerance) ? 5.0 : 4.0;
    learning_holdable = learning_holdable && p.period <= max_count && p.lead <= max_count &&
                        p.half_width <= max_count && p.lookahead <= max_count && p.hold_after_cuts <= max_count &&
                        doubles * 8.0 * static_cast<double>(p.period) <= static_cast<double>(max_count);
  }
  const bool holdable = learning_holdable && d.feedforward_lead <= max_count &&
                        (!d.shaper || (d.shaper->advance <= max_count && d.shaper->delay <= max_count));
  io::ExportOptions o;
  o.prefix = "fz";
  o.loop = d;
  try {
    const io::GeneratedC g = io::generate_c(model(), o);
    check(holdable && g.source.find("double fz_loop_step(fz_loop *c") != std::string::npos);
    check(!d.learning || g.source.find("double fz_loop_learning_step(fz_loop *c") != std::string::npos);
  } catch (const hysteron::Error&) {
    check(!holdable);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  nlohmann::json doc;
  try {
    doc = io::parse_json(text, "fuzz.json");
  } catch (const hysteron::Error&) {
    return 0;
  }
  for (const std::string_view which : {"", "compensated", "compensated.sine", "learning.triangle"}) {
    hysteron::LoopDesign d;
    try {
      d = io::loop_design_of_run(doc, which, "fuzz.json");
    } catch (const hysteron::Error&) {
      continue;
    }
    const nlohmann::json j = io::to_json(d);
    hysteron::LoopDesign again;
    try {
      io::from_json(io::parse_json(j.dump(), "round-trip"), again, "round-trip");
    } catch (const hysteron::Error&) {
      std::abort();  // a loop the reader accepted must be written in a form it accepts
    }
    check(io::to_json(again).dump() == j.dump());  // (NaN, read from null, dumps as null both times)
    run(d);
  }
  return 0;
}
