#pragma once
// result.json's "controller" (LoopDesign, hysteron/loop_design.hpp): the one writer and the one
// reader of a loop's numbers, and the reader of one run's loop out of a whole result.json
// (docs/deploy.md, "From an experiment to a deployment"). The C ABI's
// hysteron_loop_params_from_file and Python's controller_from read through them.
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "hysteron/loop_design.hpp"

namespace hysteron::io {

// {"loop", "feedforward", "pid" | absent, "pressure_pid" | absent, "pressure_gain" | absent,
// "pwm" | absent, "sample_time_s", "feedforward_lead_samples", "shaper" | absent,
// "learning" | absent}. A "controller" without "loop" (written before 2026-11-26) is read with
// the structure its pressure loops imply and the default feedforward and PWM.
nlohmann::json to_json(const LoopDesign& d);
void from_json(const nlohmann::json& j, LoopDesign& d, std::string_view where);

// The loop of one run of a result.json document `doc` (`where` names it in messages):
// `run` is "VARIANT" (an experiment with one reference, e.g. "compensated") or
// "VARIANT.REFERENCE" (e.g. "learning.triangle"; also accepted where the variant has one
// reference, if it is that one). An empty `run` takes `doc` as a "controller" object itself,
// or as one run's entry (an object with a "controller"). Throws Error naming the runs there
// are when `run` is not one of them, or when a variant has several references and `run`
// names none; also for a run of the adaptive variant without "adaptation" (a file written
// before 2026-11-27: its loop would read as one with a fixed inverse).
LoopDesign loop_design_of_run(const nlohmann::json& doc, std::string_view run, std::string_view where);
// The same from the file `path` (its name is the `where` of messages).
LoopDesign read_loop_design(const std::string& path, std::string_view run);

}  // namespace hysteron::io
