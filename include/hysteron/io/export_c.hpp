#pragma once
// Generated C: one self-contained C99 file per model, with the model's constants
// baked in (docs/export.md). The generated code is the library's per-sample
// arithmetic transcribed operation by operation (the same tanh/atanh kernels, the
// same summation order, the same saturation of the inverse), so on the same
// machine it returns the same numbers as Model::step and Inverse::step; it needs
// only <math.h> and <stdint.h>, never allocates and has no global state.
//
//   hysteron::io::ExportOptions o;
//   o.prefix = "comp";                 // comp_model, comp_model_step(), comp_inverse_step(), ...
//   o.source_name = "gpi.json";        // shown in the file's comments
//   hysteron::io::GeneratedC c = hysteron::io::generate_c(params, o);
//   hysteron::io::write_text_file("comp.c", c.source);
#include <optional>
#include <string>

#include "hysteron/loop_design.hpp"
#include "hysteron/models.hpp"

namespace hysteron::io {

struct ExportOptions {
  // Prefix of every public C name (types, functions, macros in upper case):
  // a C identifier, not starting with an underscore, at most 40 characters, not
  // "hysteron" (the names of the C ABI, include/hysteron/hysteron.h).
  std::string prefix = "compensator";
  // Where the model came from (a file name), written in the comments; empty: not said.
  std::string source_name;
  // The units the model file records (its "units": io::ModelDocument::unit), written in the
  // comments of the .c and the .h file; empty: not said. With a loop, an input in a pressure
  // unit other than MPa (io::input_unit_mismatch) and an output length unit that contradicts the
  // loop's model_scale (io::model_scale_mismatch) are refused.
  std::string input_unit, output_unit;
  // When non-empty, the declarations go to a separate header (GeneratedC::header)
  // that the source #includes by this name (e.g. "compensator.h"). Empty: one .c
  // file with the declarations at its top, which also works when #included.
  std::string header_name;
  // Input limits the inverse saturates at; unset (infinite) fields fall back to the
  // model's input_limits, exactly as InverseOptions::input_limits.
  Limits inverse_limits;
  // The command line shown in the comments (how to regenerate the file); empty: none.
  std::string command_line;
  // A compensating loop around the inverse (hysteron export --loop; docs/export.md "The loop"):
  // the file then also has $P_loop, $P_loop_reset, $P_loop_step and $P_loop_preview, which
  // step exactly as make_controller(*loop, params) with step(). The inverse then saturates at
  // the loop's pressure limits, an unset side the model's input_limits (resolve_pressure_limits),
  // and inverse_limits must be unset or equal to them. A loop with
  // learning (a learning run's) also gets $P_learning and $P_loop_learning_step, which step
  // exactly as an IterativeLearning of its parameters with step(Controller&, IterativeLearning&, ...).
  std::optional<LoopDesign> loop;
  // Where the loop came from (e.g. "out/result.json, run compensated.sine"), for the comments.
  std::string loop_source;
};

struct GeneratedC {
  std::string source;  // the .c file
  std::string header;  // the .h file; empty unless ExportOptions::header_name is set
};

// Validates the model (canonical_structure) and its inverse (hysteron::Inverse with
// options.inverse_limits) and writes the C code. Throws hysteron::Error naming the
// failed condition (e.g. a non-invertible model, mpi-asym without finite limits, a
// bad prefix).
GeneratedC generate_c(const ModelParams& params, const ExportOptions& options = {});

// Why `name` cannot be ExportOptions::prefix, or empty if it can: it must be a C identifier
// of at most 40 characters, not starting or ending with '_', without "__", and neither
// "hysteron" nor "hysteron_*" in any case (the C ABI's names).
std::string c_prefix_problem(const std::string& name);
// True if `name` can be used as ExportOptions::prefix.
bool valid_c_prefix(const std::string& name) noexcept;

}  // namespace hysteron::io
