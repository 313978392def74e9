// make_controller and feedforward_preview (hysteron/loop_design.hpp).
#include "hysteron/loop_design.hpp"

#include <algorithm>
#include <cstddef>
#include <utility>

#include "hysteron/error.hpp"

namespace hysteron {

Controller make_controller(const LoopDesign& d, const ModelParams& model) {
  const FeedforwardParams ff = d.feedforward_params();
  PidParams pid;
  pid.sample_time = d.sample_time;
  if (d.pid) pid = *d.pid;
  switch (d.kind) {
    case LoopDesign::Kind::feedforward_pid:
      return Controller(std::in_place_type<FeedforwardPidController>, model, ff, pid);
    case LoopDesign::Kind::open_loop: {
      OpenLoopParams p;
      p.feedforward = ff;
      p.position = pid;
      p.pressure_gain = d.pressure_gain;
      return Controller(std::in_place_type<OpenLoopController>, model, p);
    }
    case LoopDesign::Kind::cascade_pwm: {
      if (!d.pressure_pid) throw Error("controller: a cascade_pwm loop needs its pressure_pid");
      CascadeParams p;
      p.feedforward = ff;
      p.position = pid;
      p.pressure = *d.pressure_pid;
      p.pwm = d.pwm.value_or(PwmParams{});
      return Controller(std::in_place_type<CascadePwmController>, model, p);
    }
  }
  throw Error("controller: unknown loop kind");
}

void feedforward_preview(const LoopDesign& d, std::span<const double> reference, std::span<double> preview) {
  if (preview.size() != reference.size())
    throw Error("feedforward_preview: the preview must have the reference's length");
  const auto n = static_cast<std::ptrdiff_t>(reference.size());
  const auto at = [&](std::ptrdiff_t k) { return reference[static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(k, 0, n - 1))]; };
  const auto lead = static_cast<std::ptrdiff_t>(d.feedforward_lead);
  for (std::ptrdiff_t k = 0; k < n; ++k) {
    const std::ptrdiff_t j = std::min(k + lead, n - 1);  // s(k + lead), held at the end
    if (d.shaper) {
      const auto adv = static_cast<std::ptrdiff_t>(d.shaper->advance), D = static_cast<std::ptrdiff_t>(d.shaper->delay);
      preview[static_cast<std::size_t>(k)] = d.shaper->a1 * at(j + adv) + d.shaper->a2 * at(j + adv - D);
    } else {
      preview[static_cast<std::size_t>(k)] = at(j);
    }
  }
}

std::vector<double> feedforward_preview(const LoopDesign& d, std::span<const double> reference) {
  std::vector<double> preview(reference.size());
  feedforward_preview(d, reference, preview);
  return preview;
}

}  // namespace hysteron
