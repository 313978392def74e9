// From an experiment to a deployed loop (docs/deploy.md, "From an experiment to a
// deployment"): run gpi-pid's experiment with 3 learning periods, rebuild its learning loop
// from the run's controller numbers (result.json's "controller") and the fitted model with
// the classes a deployment uses (FeedforwardPidController, IterativeLearning), warm-start the
// learning from the correction the run ended with, and track 2 more periods on the rig with
// another noise seed (another day on the rig), beside the same loop started cold. The rig
// starts vented at rest, so each period's RMS error is taken from 1 s on. Fails unless the warm
// start's error is below half the cold start's in both periods. (In C++ the result is in
// memory; result.json holds the same numbers, io::from_json<ExperimentResult> reads them.)
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <hysteron/compensation.hpp>
#include <hysteron/experiment.hpp>
#include <hysteron/learning.hpp>
#include <hysteron/plant.hpp>

int main() {
  hysteron::ExperimentOptions o;
  o.name = "gpi-pid";
  o.learning_periods = 3;
  const hysteron::ExperimentResult res = hysteron::run_experiment(o);
  const hysteron::TrackingRun* run = nullptr;
  for (const auto& r : res.runs)
    if (r.variant == "learning") run = &r;
  if (!run || !run->controller.pid || !run->controller.learning) return 1;
  const hysteron::LoopDesign& ctl = run->controller;
  const hysteron::LearningParams& q = ctl.learning->params;
  const double ts = ctl.sample_time;  // the control period
  const std::size_t n = q.period, lead = ctl.feedforward_lead;

  // the reference over one period and the correction the run's last period applied [m]
  std::vector<double> r(n), learnt(n), preview(n);
  for (std::size_t k = 0; k < n; ++k) {
    r[k] = run->reference_mm[k] * 1e-3;
    learnt[k] = run->correction_mm[run->correction_mm.size() - n + k] * 1e-3;
  }
  // the feedforward's preview: lead samples ahead, through the shaper if the run had one
  for (std::size_t k = 0; k < n; ++k) {
    preview[k] = r[k];
    if (ctl.shaper) {
      const std::size_t a = (k + ctl.shaper->advance) % n;
      preview[k] = ctl.shaper->a1 * r[a] + ctl.shaper->a2 * r[(a + n - ctl.shaper->delay % n) % n];
    }
  }

  // RMS error [mm] from 1 s on of 2 periods, the learning warm-started or not
  auto track = [&](bool warm) {
    hysteron::IterativeLearning ilc(q);
    if (warm) ilc.reset(learnt);
    hysteron::FeedforwardParams ff = ctl.feedforward_params();  // the run's pressure limits, scale, lag, T_s
    hysteron::FeedforwardPidController fb(res.best_fit.model, ff, *ctl.pid);
    const hysteron::Limits lim = fb.pressure_limits();  // [MPa]
    hysteron::PamRig rig(hysteron::PamRigParams{}, 7);
    rig.reset();
    const auto every = hysteron::control_steps(ts, rig.dt(), "example");  // rig steps per control period
    const auto skip = static_cast<std::size_t>(std::lround(1.0 / ts));
    double y = 0.0;
    std::vector<double> rms;
    for (int j = 0; j < 2; ++j) {
      double e2 = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        const double e = r[k] - y;
        if (k >= skip) e2 += e * e;
        const double cmd = fb.step(r[k] + ilc.correction(0), preview[(k + lead) % n] + ilc.correction(lead), y);
        ilc.step(cmd <= lim.lo || cmd >= lim.hi ? 0.0 : e);  // no learning at a pressure limit
        hysteron::RigOutputs out;
        for (int s = 0; s < every; ++s) out = rig.step({cmd, 0.0, hysteron::Actuation::regulator});
        y = out.contraction_measured;
      }
      rms.push_back(std::sqrt(e2 / static_cast<double>(n - skip)) * 1e3);
    }
    rig.check();
    return rms;
  };
  const std::vector<double> cold = track(false), warm = track(true);
  fmt::print("experiment (seed 1): RMS per period");
  for (const auto& p : run->periods) fmt::print(" {:.3f}", p.rms_error_mm);
  fmt::print(" mm\nthe loop rebuilt from its controller numbers on the rig (seed 7), RMS from 1 s on per period "
             "[mm]: cold start {:.3f} {:.3f}, warm start {:.3f} {:.3f}\n",
             cold[0], cold[1], warm[0], warm[1]);
  return warm[0] < 0.5 * cold[0] && warm[1] < 0.5 * cold[1] ? 0 : 1;
}
