#pragma once
// The compensating loop in generated C (hysteron export --loop, docs/export.md "The loop"):
// make_controller's loop and step() (src/core/loop_design.cpp, compensation.cpp, control.cpp)
// transcribed into C99 with the loop's numbers baked in, around the generated inverse.
// Keep the two in step: tests/test_export_loop.cpp compares them sample by sample.
#include <string>

#include "hysteron/loop_design.hpp"
#include "hysteron/models.hpp"

namespace hysteron::io::detail {

// The loop's C text, with the $P / $U placeholders of the rest of the generated file.
struct LoopC {
  std::string comment;       // lines " * ..." for the file's leading comment
  std::string declarations;  // types and prototypes (the header's part)
  std::string definitions;   // constants and functions (the .c file's part)
  Limits pressure_limits;    // [MPa] baked in: d's, each unset side the model's (resolve_pressure_limits)
};

// Checks that the loop can be built on `model` (make_controller's checks) and that the
// generated C can hold it (sample counts below 2^31), then writes it, with its learning if
// d.learning (append_learning_c). Throws Error naming the reason.
LoopC loop_c(const LoopDesign& d, const ModelParams& model);

// The iterative learning of d.learning (IterativeLearning, learning.hpp, transcribed in
// export_learning.cpp) and the learning loop's step (step(Controller&, IterativeLearning&, ...),
// loop_design.hpp), appended to `out` (the text of d's loop). Throws Error if the parameters are
// invalid (LearningParams::validate) or the period does not fit generated C.
void append_learning_c(const LoopDesign& d, LoopC& out);

}  // namespace hysteron::io::detail
