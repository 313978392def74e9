// make_controller and feedforward_preview (hysteron/loop_design.hpp).
#include "hysteron/loop_design.hpp"

#include <algorithm>
#include <cstddef>
#include <type_traits>
#include <utility>
#include <variant>

#include "format.hpp"

#include "hysteron/error.hpp"

namespace hysteron {

std::string adaptation_refusal(const LoopDesign& d) {
  if (!d.adaptation) return {};
  return detail::format("its inverse is adapted online (\"adaptation\": RLS with forgetting, lambda = {}; an "
                        "adaptive run), which a loop with a fixed inverse does not do: use the compensated run's loop "
                        "(the same structure with the fitted inverse)",
                        d.adaptation->lambda);
}

Controller make_controller(const LoopDesign& d, const ModelParams& model) {
  if (d.adaptation) throw Error("controller: " + adaptation_refusal(d));
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

const Limits& pressure_limits(const Controller& c) noexcept {
  return std::visit([](const auto& loop) -> const Limits& { return loop.pressure_limits(); }, c);
}

LoopOutput step(Controller& c, double reference_m, double preview_m, double measured_m, double pressure_mpa) noexcept {
  return std::visit(
      [&](auto& loop) -> LoopOutput {
        using T = std::decay_t<decltype(loop)>;
        if constexpr (std::is_same_v<T, FeedforwardPidController>) {
          return {loop.step(reference_m, preview_m, measured_m), 0.0};
        } else if constexpr (std::is_same_v<T, OpenLoopController>) {
          return {loop.step(reference_m, preview_m, measured_m, pressure_mpa), 0.0};
        } else {
          const double duty = loop.step(reference_m, preview_m, measured_m, pressure_mpa);
          return {loop.desired_pressure(), duty};
        }
      },
      c);
}

LoopOutput step(Controller& c, IterativeLearning& ilc, const LoopDesign& d, double reference_m, double preview_m,
                double measured_m, double pressure_mpa) noexcept {
  const LoopOutput o = step(c, reference_m + ilc.correction(0), preview_m + ilc.correction(d.feedforward_lead),
                            measured_m, pressure_mpa);
  const Limits& lim = pressure_limits(c);  // d's, or where unset the model's
  const bool saturated = o.command_mpa <= lim.lo || o.command_mpa >= lim.hi;
  ilc.step(saturated ? 0.0 : reference_m - measured_m);
  return o;
}

namespace {
// j + plus - minus clamped to [0, n), for j in [0, n) and any plus, minus (a file's counts of
// samples may be as large as a size_t holds: no overflow).
std::size_t clamped_index(std::size_t j, std::size_t plus, std::size_t minus, std::size_t n) noexcept {
  if (plus >= minus) {
    const std::size_t up = plus - minus;
    return up >= n - 1 - j ? n - 1 : j + up;
  }
  const std::size_t down = minus - plus;
  return down >= j ? 0 : j - down;
}
}  // namespace

void feedforward_preview(const LoopDesign& d, std::span<const double> reference, std::span<double> preview) {
  if (preview.size() != reference.size())
    throw Error("feedforward_preview: the preview must have the reference's length");
  const std::size_t n = reference.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t j = clamped_index(k, d.feedforward_lead, 0, n);  // s(k + lead), held at the end
    if (d.shaper) {
      const double r1 = reference[clamped_index(j, d.shaper->advance, 0, n)];
      const double r2 = reference[clamped_index(j, d.shaper->advance, d.shaper->delay, n)];
      preview[k] = d.shaper->a1 * r1 + d.shaper->a2 * r2;
    } else {
      preview[k] = reference[j];
    }
  }
}

std::vector<double> feedforward_preview(const LoopDesign& d, std::span<const double> reference) {
  std::vector<double> preview(reference.size());
  feedforward_preview(d, reference, preview);
  return preview;
}

}  // namespace hysteron
