// The deployed loops on a faulty sensor (audit s26 a3): a non-finite pressure reading closes the
// cascade's valves and holds its position PID; a non-finite position reading holds the position PID's
// correction while the feedforward goes on; the limit-cycle guard restarts in real time. The C ABI
// and the generated C step the same rules (test_c_api_loops.cpp, test_export_loop.cpp compare them).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/control.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/hysteron.h"
#include "hysteron/io/model_file.hpp"
#include "hysteron/loop_design.hpp"
#include "hysteron/plant.hpp"
#include "test_util.hpp"

using namespace hysteron;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

CascadeParams cascade_params() {
  CascadeParams cp;
  cp.feedforward.sample_time = 1e-3;
  cp.position = gpi_paper_pid(1e-3);
  cp.pressure.kp = 20.0;
  cp.pressure.ki = 5.0;
  cp.pressure.sample_time = 1e-3;
  return cp;
}

}  // namespace

// A NaN pressure reading: the duty is 0 (both valves closed) on every blind sample, whatever it was before;
// the position PID's integral (and its whole state) does not move while the reference and the measurement
// do, p_d stays within the limits, and the pressure PID counts the samples. The loop then steps on.
TEST(LoopFaults, CascadeClosesTheValvesOnANaNPressureAndHoldsThePositionIntegral) {
  CascadePwmController c(test::rig_like_gpi(), cascade_params());
  // a reference above the measurement with a low pressure: the inlet is open, the integral rising
  double duty = 0.0;
  for (int k = 0; k < 200; ++k) duty = c.step(0.06, 0.06, 0.03, 0.05);
  ASSERT_GT(duty, 0.1) << "the inlet is not open before the fault: nothing to check";
  const PidState before = c.position().state();
  ASSERT_GT(before.integral, 0.0);
  const std::size_t position_faults = c.position().faults(), pressure_faults = c.pressure().faults();
  for (int k = 0; k < 500; ++k) {
    const double r = 0.06 + 0.01 * std::sin(0.01 * k);
    const double p = k % 3 == 0 ? kNaN : k % 3 == 1 ? std::numeric_limits<double>::infinity()
                                                    : -std::numeric_limits<double>::infinity();
    EXPECT_EQ(c.step(r, r, 0.03, p), 0.0) << "sample " << k;
    EXPECT_EQ(c.pwm().duty(), 0.0);
    EXPECT_EQ(c.position().state().integral, before.integral) << "sample " << k;
    EXPECT_EQ(c.position().output(), before.output);
    EXPECT_GE(c.desired_pressure(), c.pressure_limits().lo);
    EXPECT_LE(c.desired_pressure(), c.pressure_limits().hi);
  }
  EXPECT_EQ(c.position().faults(), position_faults) << "the position sensor was fine";
  EXPECT_EQ(c.pressure().faults(), pressure_faults + 500);
  // the reading back: the inner loop acts again
  EXPECT_GT(c.step(0.06, 0.06, 0.03, 0.05), 0.1);
  EXPECT_NE(c.position().state().integral, before.integral);
}

// A NaN position reading (or reference): the PID's state is held and the command is this sample's feedforward
// plus the PID's correction before the fault (its output minus its feedforward then), in all three loops: with a
// correction of 0 (a PID without gains) exactly the feedforward InverseFeedforward gives for the preview.
TEST(LoopFaults, AHeldPidKeepsFeedingForward) {
  const GpiParams model = test::rig_like_gpi();
  FeedforwardParams ff;
  PidParams none;  // no gains: the correction is 0, the command the feedforward itself
  none.out_min = -0.6;
  none.out_max = 0.6;
  FeedforwardPidController fp(model, ff, none);
  CascadeParams cp = cascade_params();
  cp.position = none;
  CascadePwmController cc(model, cp);
  InverseFeedforward inverse(model, ff);
  for (int k = 0; k < 3000; ++k) {
    const double r = 0.05 + 0.03 * std::sin(2 * M_PI * k / 2000.0);
    const double y = k >= 1000 && k < 2000 ? kNaN : r;
    const double want = inverse.step(r);
    EXPECT_EQ(fp.step(r, r, y), want) << "sample " << k;
    cc.step(r, r, y, 0.3);
    EXPECT_EQ(cc.desired_pressure(), want) << "sample " << k;
  }
  EXPECT_EQ(fp.pid().faults(), 1000u);
  EXPECT_EQ(cc.position().faults(), 1000u);
  // with gains: the correction held, the feedforward moving; a non-finite reference alike
  FeedforwardPidController g(model, ff, gpi_paper_pid(1e-3));
  InverseFeedforward inv2(model, ff);
  double u = 0.0, u_ff = 0.0;
  for (int k = 0; k < 500; ++k) {
    u_ff = inv2.step(0.04);
    u = g.step(0.04, 0.04, 0.035);
  }
  const double correction = u - u_ff, integral = g.pid().state().integral;
  ASSERT_GT(std::abs(correction), 1e-3);
  for (int k = 0; k < 300; ++k) {
    const double pv = 0.04 + 1e-4 * k;
    const double want = std::clamp(inv2.step(pv) + correction, 0.0, 0.6);
    EXPECT_NEAR(g.step(k % 2 ? kNaN : pv, pv, k % 2 ? 0.035 : kNaN), want, 1e-15) << "sample " << k;
    EXPECT_EQ(g.pid().state().integral, integral);
  }
}

namespace {

// Audit a3's scenario: the run's loop (make_controller on its model) on the nominal PamRig, 7 s of a sine
// 30..70 mm at 0.5 Hz from rest; over [4, 5) s the position sensor reads NaN (dropout), or the loop is fed
// the same NaN but the command is held at its last value before 4 s (frozen: what the feedforward+PID loop
// commanded before 2026-12-01). Returns the largest |r - y| (true contraction) over [4, 5.5) s [m].
enum class Scenario { nominal, dropout, frozen };

double worst_error(const TrackingRun& run, const ModelParams& model, Scenario sc) {
  const LoopDesign& d = run.controller;
  Controller c = make_controller(d, model);
  PamRig rig(PamRigParams{}, 1);
  const double ts = d.sample_time;
  const int nsub = static_cast<int>(std::lround(ts / rig.dt()));
  const auto n = static_cast<std::size_t>(std::lround(7.0 / ts));
  std::vector<double> ref(n);
  for (std::size_t k = 0; k < n; ++k) ref[k] = 0.050 - 0.020 * std::cos(2 * M_PI * 0.5 * static_cast<double>(k) * ts);
  const std::vector<double> preview = feedforward_preview(d, ref);
  RigInputs in;
  RigOutputs out = rig.step(in);
  double worst = 0.0, held = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * ts;
    const bool blind = sc != Scenario::nominal && t >= 4.0 - 1e-12 && t < 5.0 - 1e-12;
    const LoopOutput o = step(c, ref[k], preview[k], blind ? kNaN : out.contraction_measured,
                              out.pressure_measured * 1e-6);
    in.pressure_command = sc == Scenario::frozen && blind ? held : o.command_mpa;
    held = in.pressure_command;
    for (int i = 0; i < nsub; ++i) out = rig.step(in);
    if (t >= 4.0 - 1e-12 && t < 5.5) worst = std::max(worst, std::abs(ref[k] - out.contraction));
  }
  EXPECT_TRUE(rig.ok());
  return worst;
}

}  // namespace

// step_feedforward (the experiments' adaptive variants: the compensated controller around the adaptive
// inverse's feedforward) is step() with the feedforward given: fed the same inverse's output, each
// controller commands bit for bit what step() does, through position and pressure dropouts; fed
// another feedforward, a held sample commands that feedforward plus the held correction (not the
// whole held command), and a blind inner loop closes the cascade's valves.
TEST(LoopFaults, StepFeedforwardIsStepAroundAGivenFeedforward) {
  const GpiParams model = test::rig_like_gpi();
  FeedforwardParams ff;
  ff.sample_time = 1e-3;
  ff.pressure_limits = {0.0, 0.6};
  OpenLoopParams op;
  op.feedforward = ff;
  op.position = gpi_paper_pid(1e-3);
  op.pressure_gain = 0.5;
  CascadeParams cp = cascade_params();
  cp.feedforward = ff;
  FeedforwardPidController fa(model, ff, gpi_paper_pid(1e-3)), fb(model, ff, gpi_paper_pid(1e-3));
  OpenLoopController oa(model, op), ob(model, op);
  CascadePwmController ca(model, cp), cb(model, cp);
  InverseFeedforward i1(model, ff), i2(model, ff), i3(model, ff);
  for (int k = 0; k < 4000; ++k) {
    const double r = 0.05 + 0.03 * std::sin(2 * M_PI * k / 2000.0);
    const double y = (k >= 1000 && k < 1500) ? kNaN : r - 0.002 * std::cos(2 * M_PI * k / 700.0);
    const double p = (k >= 2500 && k < 3000) ? kNaN : 0.25 + 0.05 * std::sin(2 * M_PI * k / 900.0);
    ASSERT_EQ(fa.step(r, r, y), fb.step_feedforward(r, i1.step(r), y)) << "sample " << k;
    ASSERT_EQ(oa.step(r, r, y, p), ob.step_feedforward(r, i2.step(r), y, p)) << "sample " << k;
    ASSERT_EQ(ca.step(r, r, y, p), cb.step_feedforward(r, i3.step(r), y, p)) << "sample " << k;
    ASSERT_EQ(ca.desired_pressure(), cb.desired_pressure()) << "sample " << k;
  }
  EXPECT_EQ(fb.pid().faults(), 500u);
  EXPECT_EQ(cb.pressure().faults(), 500u);
  // another feedforward: during a position dropout the command moves with it, by exactly its change
  FeedforwardPidController g(model, ff, gpi_paper_pid(1e-3));
  CascadePwmController h(model, cp);
  double held = 0.0;
  for (int k = 0; k < 300; ++k) {
    const double u_ff = 0.2 + 0.1 * k / 300.0;  // a ramp no inverse of this model gives
    const bool blind = k >= 200;
    const double u = g.step_feedforward(0.04, u_ff, blind ? kNaN : 0.039);
    const double d = h.step_feedforward(0.04, u_ff, 0.039, blind ? kNaN : 0.3);
    if (k == 199) held = u - u_ff;  // the correction at the dropout
    if (blind) {
      EXPECT_NEAR(u, u_ff + held, 1e-12) << "sample " << k;
      EXPECT_EQ(d, 0.0) << "sample " << k << ": the valves stay closed while the pressure is unknown";
    }
  }
}

// After reset() a loop has no correction yet: a first sample the PID holds (no measurement yet)
// commands this sample's feedforward itself, whatever the loop held before the reset (the mutant
// "reset keeps ff_held" commanded the old run's feedforward difference on top of it).
TEST(LoopFaults, AFirstHeldSampleAfterAResetCommandsTheFeedforward) {
  const GpiParams model = test::rig_like_gpi();
  FeedforwardParams ff;
  ff.sample_time = 1e-3;
  ff.pressure_limits = {0.0, 0.6};
  CascadeParams cp = cascade_params();
  cp.feedforward = ff;
  FeedforwardPidController fp(model, ff, gpi_paper_pid(1e-3));
  CascadePwmController cc(model, cp);
  for (int k = 0; k < 2000; ++k) {  // a run that leaves a correction and a feedforward far from the next one's
    const double r = 0.07 + 0.02 * std::sin(2 * M_PI * k / 1000.0);
    (void)fp.step_feedforward(r, 0.45, r - 0.003);
    (void)cc.step_feedforward(r, 0.45, r - 0.003, 0.4);
  }
  fp.reset();
  cc.reset();
  EXPECT_EQ(fp.step_feedforward(0.02, 0.12, kNaN), 0.12);
  (void)cc.step_feedforward(0.02, 0.12, kNaN, 0.1);
  EXPECT_EQ(cc.desired_pressure(), 0.12);
}

// A 1 s dropout of the position sensor in the feedforward+PID loop (gpi-pid's compensated loop) on the
// simulated rig: the loop keeps feeding forward, its error stays far below that of the command frozen over the
// dropout. The bound: the nominal run's error plus a quarter of what freezing the command adds to it.
TEST(LoopFaults, PositionDropoutOnTheRigKeepsFollowingTheReference) {
  const ExperimentResult r = run_experiment(test::quick_experiment("gpi-pid"));
  const TrackingRun* run = nullptr;
  for (const TrackingRun& x : r.runs)
    if (x.variant == "compensated") run = &x;
  ASSERT_NE(run, nullptr);
  ASSERT_EQ(run->controller.kind, LoopDesign::Kind::feedforward_pid);
  const double nominal = worst_error(*run, r.best_fit.model, Scenario::nominal);
  const double frozen = worst_error(*run, r.best_fit.model, Scenario::frozen);
  const double dropout = worst_error(*run, r.best_fit.model, Scenario::dropout);
  std::printf("  max |r - y| over [4, 5.5) s: nominal %.2f mm, 1 s dropout %.2f mm, command frozen over it %.2f mm\n",
              nominal * 1e3, dropout * 1e3, frozen * 1e3);
  ASSERT_GT(frozen, 4.0 * nominal) << "freezing the command costs little here: the test shows nothing";
  EXPECT_LT(dropout, nominal + 0.25 * (frozen - nominal));
}

// restart_guard in each interface (C++, C ABI; the generated C in test_export_loop.cpp, Python in pytest): a
// loop whose guard cut its gains gets them back as tuned, no cuts; the rest of the state goes on.
TEST(LoopFaults, RestartGuardRestoresTheTunedGains) {
  PidParams p = gpi_paper_pid(1e-3, -10.0, 10.0);
  p.guard = PidGuard{.period = 0.02, .amplitude = 1e-3, .count = 2.0};
  Pid pid(p);
  // a square-wave error at the guard's period: a ring it cuts
  for (int k = 0; k < 400 && pid.state().guard_cuts == 0; ++k) pid.step((k / 10) % 2 ? 0.01 : -0.01, 0.0);
  ASSERT_GT(pid.state().guard_cuts, 0u);
  ASSERT_LT(pid.state().gain_scale, 1.0);
  const double integral = pid.state().integral;
  const std::size_t before = hysteron_test::allocations();
  pid.restart_guard();
  EXPECT_EQ(hysteron_test::allocations(), before);
  EXPECT_EQ(pid.state().gain_scale, 1.0);
  EXPECT_EQ(pid.state().guard_cuts, 0u);
  EXPECT_EQ(pid.state().guard_count, 0.0);
  EXPECT_EQ(pid.state().integral, integral);
  EXPECT_EQ(pid.params().guard.period, 0.02) << "the guard is kept";

  // the C ABI's three loops, driven into a ring of their position PID by a measurement that alternates
  hysteron_params* model = nullptr;
  const std::string json = io::model_to_json(test::rig_like_gpi()).dump();
  ASSERT_EQ(hysteron_params_from_json(json.c_str(), &model), HYSTERON_OK) << hysteron_last_error();
  hysteron_ff_pid_params fp;
  ASSERT_EQ(hysteron_ff_pid_default_params(&fp), HYSTERON_OK);
  fp.kp = 5.0;
  fp.ki = 100.0;
  hysteron_open_loop_params op;
  ASSERT_EQ(hysteron_open_loop_default_params(&op), HYSTERON_OK);
  op.loop = fp;
  hysteron_cascade_params cp;
  ASSERT_EQ(hysteron_cascade_default_params(&cp), HYSTERON_OK);
  cp.outer = fp;
  hysteron_ff_pid* f = nullptr;
  hysteron_open_loop* o = nullptr;
  hysteron_cascade* c = nullptr;
  ASSERT_EQ(hysteron_ff_pid_create(model, &fp, &f), HYSTERON_OK) << hysteron_last_error();
  ASSERT_EQ(hysteron_open_loop_create(model, &op, &o), HYSTERON_OK) << hysteron_last_error();
  ASSERT_EQ(hysteron_cascade_create(model, &cp, &c), HYSTERON_OK) << hysteron_last_error();
  hysteron_params_free(model);
  hysteron_pid_guard g;
  ASSERT_EQ(hysteron_pid_guard_default(&g), HYSTERON_OK);
  g.period = 0.02;
  g.amplitude = 1e-3;
  g.count = 2.0;
  ASSERT_EQ(hysteron_ff_pid_set_guard(f, &g), HYSTERON_OK);
  ASSERT_EQ(hysteron_open_loop_set_guard(o, &g), HYSTERON_OK);
  ASSERT_EQ(hysteron_cascade_set_guard(c, &g), HYSTERON_OK);
  for (int k = 0; k < 400; ++k) {
    const double y = 0.03 + ((k / 10) % 2 ? 0.01 : -0.01);
    double u, d;
    hysteron_ff_pid_step(f, 0.03, 0.03, y, &u);
    hysteron_open_loop_step(o, 0.03, 0.03, y, 0.3, &u);
    hysteron_cascade_step(c, 0.03, 0.03, y, 0.3, &d, &u);
  }
  double scale[3];
  size_t cuts[3];
  ASSERT_EQ(hysteron_ff_pid_guard_state(f, &scale[0], &cuts[0]), HYSTERON_OK);
  ASSERT_EQ(hysteron_open_loop_guard_state(o, &scale[1], &cuts[1]), HYSTERON_OK);
  ASSERT_EQ(hysteron_cascade_guard_state(c, &scale[2], &cuts[2]), HYSTERON_OK);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(cuts[i], 0u) << "loop " << i << ": the guard never cut";
    EXPECT_LT(scale[i], 1.0) << "loop " << i;
  }
  const std::size_t allocs = hysteron_test::allocations();
  EXPECT_EQ(hysteron_ff_pid_restart_guard(f), HYSTERON_OK);
  EXPECT_EQ(hysteron_open_loop_restart_guard(o), HYSTERON_OK);
  EXPECT_EQ(hysteron_cascade_restart_guard(c), HYSTERON_OK);
  EXPECT_EQ(hysteron_test::allocations(), allocs);
  ASSERT_EQ(hysteron_ff_pid_guard_state(f, &scale[0], &cuts[0]), HYSTERON_OK);
  ASSERT_EQ(hysteron_open_loop_guard_state(o, &scale[1], &cuts[1]), HYSTERON_OK);
  ASSERT_EQ(hysteron_cascade_guard_state(c, &scale[2], &cuts[2]), HYSTERON_OK);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(scale[i], 1.0) << "loop " << i;
    EXPECT_EQ(cuts[i], 0u) << "loop " << i;
  }
  EXPECT_EQ(hysteron_ff_pid_restart_guard(nullptr), HYSTERON_ERROR_NULL_POINTER);
  hysteron_ff_pid_free(f);
  hysteron_open_loop_free(o);
  hysteron_cascade_free(c);
}

// The new rules allocate nothing: the loops stepped through faults of every input and guard restarts.
TEST(LoopFaults, FaultsAndRestartsDoNotAllocate) {
  const GpiParams model = test::rig_like_gpi();
  FeedforwardParams ff;
  FeedforwardPidController fp(model, ff, gpi_paper_pid(1e-3));
  CascadePwmController cc(model, cascade_params());
  const std::size_t before = hysteron_test::allocations();
  double acc = 0;
  for (int k = 0; k < 5000; ++k) {
    const double r = 0.05 + 0.04 * std::sin(0.002 * k);
    const double y = k % 7 == 0 ? kNaN : r - 0.001, p = k % 5 == 0 ? kNaN : 0.3;
    acc += fp.step(k % 11 == 0 ? kNaN : r, r, y) + cc.step(r, r, y, p);
    if (k % 1000 == 0) {
      fp.restart_guard();
      cc.restart_guard();
    }
  }
  EXPECT_EQ(hysteron_test::allocations(), before);
  EXPECT_TRUE(std::isfinite(acc));
}
