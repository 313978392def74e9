#pragma once
// A compensating loop in numbers: which controller (inverse feedforward + PID, the open loop
// with a pressure loop, the cascade on switching valves), its gains, the feedforward's preview
// and the learning around it. `hysteron experiment` records one per tracking run (result.json's
// "controller", io/loop_design.hpp); make_controller rebuilds the loop from it, and the C ABI
// reads it (hysteron_loop_params_from_file). Core: the C++ standard library only.
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "hysteron/compensation.hpp"
#include "hysteron/control.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/models.hpp"

namespace hysteron {

// The compensator a tracking run used, in the numbers its deployment needs (docs/deploy.md:
// hysteron_pid, hysteron_ilc and the inverse feedforward of the C ABI); result.json's
// "controller". Units: contraction in m, pressure in MPa (the loops' own units).
struct LoopDesign {
  // Which controller the loop is (result.json "loop"; docs/deploy.md):
  //   feedforward_pid  FeedforwardPidController  hysteron_ff_pid      (gpi-pid)
  //   open_loop        OpenLoopController        hysteron_open_loop   (mpi-openloop)
  //   cascade_pwm      CascadePwmController      hysteron_cascade     (mpi-pwm)
  // The adaptive variant has the same structure with an inverse adapted online (adaptation).
  enum class Kind { feedforward_pid, open_loop, cascade_pwm };
  Kind kind = Kind::feedforward_pid;
  // The inverse feedforward's pressure limits [MPa], model units per metre and the lag it
  // compensates [s] (FeedforwardParams without the sample time: that is sample_time below).
  struct Feedforward {
    // [MPa]; an infinite side (unset, the default; null in JSON): the model's input_limits
    // (resolve_pressure_limits). The experiments always record the rig's.
    Limits pressure_limits;
    double model_scale = 1000.0;
    double lag_time_constant = 0.0;
  };
  Feedforward feedforward;
  // cascade_pwm: the valves' PWM modulator.
  std::optional<PwmParams> pwm;
  // The position loop's PID (absent: no position loop, e.g. the faithful open loop), with its
  // limit-cycle guard (pid->guard; off in the faithful and baseline loops).
  std::optional<PidParams> pid;
  // What the guard did by the end of the run: the factor on the PID's gains then and how often
  // it cut them (1 and 0 where it never acted or there is none). make_controller's loop starts
  // from the tuned gains.
  double guard_final_scale = 1.0;
  std::size_t guard_cuts = 0;
  // The pressure loop inside it, where the loop has one: the valves' PI (error in MPa -> PWM
  // duty, mpi-pwm) or the proportional loop p_cmd = p_d + k_p (p_d - p) (mpi-openloop; 0: none).
  std::optional<PidParams> pressure_pid;
  double pressure_gain = 0.0;
  // The control period [s]: every count of samples here is in it.
  double sample_time = 1e-3;
  // The feedforward's preview of the reference [samples] (0: the inverse is fed the current
  // reference).
  std::size_t feedforward_lead = 0;
  // Zero-vibration shaper on the feedforward's preview (docs/control.md, section 2):
  // preview(k) = s(k + lead), s(k) = a1 r(k + advance) + a2 r(k + advance - delay); absent:
  // unshaped.
  struct Shaper {
    double a1 = 1.0, a2 = 0.0;
    std::size_t delay = 0, advance = 0;  // [samples]
  };
  std::optional<Shaper> shaper;
  // Iterative learning (the learning variant): the parameters its IterativeLearning was built
  // with (supervision included; the correction is in m, added to the PID's reference and, lead
  // samples ahead, to the feedforward's preview), the design's contraction bound on the
  // identified loop, and what the supervisor did by the end of the run.
  struct Learning {
    LearningParams params;
    double contraction_bound = 0.0;
    double final_gain = 0.0;  // L in use at the end
    std::size_t gain_raises = 0, gain_cuts = 0;
    bool held = false;
  };
  std::optional<Learning> learning;
  // The adaptive variant: the inverse's weights re-identified online by RLS with forgetting
  // (AdaptiveInverse, experiment.hpp), handed to the inverse at the bottom of each loop of the
  // reference. Not part of make_controller (it builds the fitted, fixed inverse): generated C
  // and the C ABI's hysteron_loop_params_from_file refuse such a loop rather than drop it.
  struct Adaptation {
    double lambda = 1.0;     // forgetting factor
    std::size_t delay = 0;   // samples by which the contraction lags the pressure in the pairs
    double margin = 0.0;     // the invertibility constraints' margin (model units)
  };
  std::optional<Adaptation> adaptation;
  // The feedforward's parameters at the loop's sample time.
  FeedforwardParams feedforward_params() const {
    return {feedforward.pressure_limits, feedforward.model_scale, feedforward.lag_time_constant, sample_time};
  }
};

// The loop a run's `controller` describes, rebuilt on `model` (the model file the run inverts:
// best_model.json for the compensated and learning loops, model.json for the faithful one;
// docs/deploy.md), by d.kind: FeedforwardPidController (the PID's limits the pressure limits),
// OpenLoopController or CascadePwmController. Without d.pid the position loop is off (the open
// loop as published; the other two get a zero PID). Unset pressure limits are the model's
// (resolve_pressure_limits: an Error where it has none). Throws Error on invalid numbers. The
// learning is not part of it (an IterativeLearning from d.learning->params adds its correction
// to the reference and the preview).
// A loop with d.adaptation (an adaptive run's) is refused: make_controller's inverse is fixed.
using Controller = std::variant<FeedforwardPidController, OpenLoopController, CascadePwmController>;
Controller make_controller(const LoopDesign& d, const ModelParams& model);
// The pressure limits [MPa] the loop `c` clamps to, resolved on its model.
const Limits& pressure_limits(const Controller& c) noexcept;
// Why a loop with an adaptation cannot be rebuilt with a fixed inverse ("" without one): the
// message make_controller and the C ABI's reader give.
std::string adaptation_refusal(const LoopDesign& d);

// One sample of whichever loop `c` holds: the pressure command [MPa] (with the valves, the
// cascade's desired pressure p_d) and the PWM duty in [-1, 1] (0 without valves). The arguments
// are those of the loops' step(); pressure_mpa (the measured gauge pressure) is not used by the
// feedforward_pid loop. Real-time safe: no allocation, no exception.
struct LoopOutput {
  double command_mpa = 0.0;
  double duty = 0.0;
};
LoopOutput step(Controller& c, double reference_m, double preview_m, double measured_m, double pressure_mpa) noexcept;

// One sample of a learning loop (the learning variant of `hysteron experiment`; docs/control.md,
// section 3): `c` fed the reference plus the correction c_j(k) (ilc.correction(0)) and the preview
// plus the correction d.feedforward_lead samples ahead; then `ilc` records the error
// reference_m - measured_m, or 0 where the command is at one of c's pressure limits (there the
// loop has no authority left, and the Q-filter would spread the error's integral). `ilc` is built
// from d.learning->params. Real-time safe: no allocation, no exception.
LoopOutput step(Controller& c, IterativeLearning& ilc, const LoopDesign& d, double reference_m, double preview_m,
                double measured_m, double pressure_mpa) noexcept;

// The reference the loop's feedforward is fed, for a recorded reference (any units, e.g. m):
// through d.shaper if there is one, s(k) = a1 r(k + advance) + a2 r(k + advance - delay), then
// d.feedforward_lead samples ahead, preview(k) = s(k + lead); indices clamped to the record, as
// `hysteron experiment`'s tracking runs do.
std::vector<double> feedforward_preview(const LoopDesign& d, std::span<const double> reference);
// The same into `preview` (reference.size() values; it may not alias `reference`), without
// allocating. Throws Error on a length mismatch.
void feedforward_preview(const LoopDesign& d, std::span<const double> reference, std::span<double> preview);

}  // namespace hysteron
