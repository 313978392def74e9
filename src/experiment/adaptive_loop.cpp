// The adaptive variant's shared pieces (detail.hpp): its model for a reference, its
// feedforward step and its notes. The loops themselves are in each experiment's file.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron::experiment {

std::shared_ptr<AdaptiveInverse> adaptive_inverse(const Context& c, bool frozen) {
  if (!c.reference) throw Error("experiment: the adaptive variant needs its reference");
  const Reference& ref = *c.reference;
  // The rig's response delay from the measured pressure to the measured contraction: the pure
  // delay that best fits the fitted model to the identification run (the preview's rule,
  // tuning.cpp, from the measured pressure instead of the command), searched up to 0.3 s.
  const std::vector<double>& pm = c.result.identification.pressure_mpa;
  const std::vector<double>& xm = c.result.identification.contraction_mm;
  const std::vector<double> ys = Model(c.result.best_fit.model).simulate(pm);
  const auto max_delay = std::min<std::size_t>(static_cast<std::size_t>(std::lround(0.3 / c.tc)), xm.size() / 2);
  double best = std::numeric_limits<double>::infinity();
  std::size_t delay = 0;
  for (std::size_t d = 0; d <= max_delay; ++d) {
    double sse = 0.0;
    for (std::size_t k = max_delay; k < xm.size(); ++k) sse += (xm[k] - ys[k - d]) * (xm[k] - ys[k - d]);
    if (sse < best) best = sse, delay = d;
  }
  // Memory of one period: the estimate weighs a whole period of the reference (every loop,
  // both branches).
  const std::size_t memory = ref.period > 0 ? ref.period : ref.ref_m.size();
  AdaptiveInverseParams p;
  p.lambda = 1.0 - 1.0 / static_cast<double>(std::max<std::size_t>(memory, 2));
  p.delay = delay;
  p.input_limits = {0.0, c.pressure_max};
  p.frozen = frozen;
  p.commit_every_update = false;  // AdaptiveFeedforward commits at the bottom of each loop
  return std::make_shared<AdaptiveInverse>(c.result.best_fit.model, pm, xm, p);
}

double AdaptiveFeedforward::step(const Sample& s) noexcept {
  a_->update(s.pressure_mpa, s.measured_m * 1e3);
  // Bottom of a loop of the (previewed) reference: falling, then not falling.
  const double r = s.preview_m;
  if (r1_ < r2_ && r >= r1_) a_->commit();
  r2_ = r1_;
  r1_ = r;
  return std::clamp(a_->step(r * 1e3), 0.0, p_max_);
}

std::string adaptive_description(const AdaptiveInverse& a) {
  return fmt::format("inverse weights adapted online by RLS (lambda = {:.6f}, memory {:.0f} samples = one period of "
                     "the reference; pressure {} samples before the contraction), projected onto {} >= {:.3g}, "
                     "handed to the inverse at the bottom of each loop of the reference, guarded by the fitted model",
                     a.lambda(), 1.0 / (1.0 - a.lambda()), a.delay(),
                     a.inverse().structure().asymmetric ? "p_i >= 0, q" : "q + p_1 + ... + p_i", a.margin());
}

LoopDesign::Adaptation adaptation_of(const AdaptiveInverse& a) { return {a.lambda(), a.delay(), a.margin()}; }

std::string adaptive_note(const AdaptiveInverse& a, const std::string& reference) {
  const auto& n = a.counters();
  const double ja = a.adapted_error(), jf = a.fitted_error();
  return fmt::format("adaptive ({}): {} RLS updates, the projection active on {}, {} hand-overs, the fitted weights in "
                     "use on {} samples, {} switches (guard: the adapted weights are handed over only while their "
                     "forgetting-averaged a-priori prediction error is at most the fitted model's, so the model in use "
                     "never predicts worse than the fitted one; the tracking error is not guaranteed by it); at the end "
                     "RMS prediction error {:.3f} mm adapted vs {:.3f} mm fitted{}{}{}",
                     reference, n.updates, n.projected, n.commits, n.fallback, n.switches,
                     std::sqrt(ja * (1.0 - a.lambda())), std::sqrt(jf * (1.0 - a.lambda())),
                     n.rejected ? fmt::format("; {} weight sets refused by the inverse", n.rejected) : std::string(),
                     n.bounded ? fmt::format("; the covariance at its bound (the prior's trace; forgotten only along the "
                                             "regressor) on {} updates",
                                             n.bounded)
                               : std::string(),
                     a.faults() ? fmt::format("; {} faults: {} measured pairs not finite (ignored), {} covariance resets "
                                              "to the prior (it was no longer positive definite)",
                                              a.faults(), a.faults() - n.resets, n.resets)
                                : std::string());
}

}  // namespace hysteron::experiment
