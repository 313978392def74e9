// The C ABI's loops (include/hysteron/hysteron.h) rebuilt from an experiment's output
// directory, as docs/deploy.md tells a user to: result.json's "controller" of a run and the
// model file it inverts give hysteron_open_loop (mpi-openloop) and hysteron_cascade (mpi-pwm)
// that, fed the run's recorded reference, contraction and pressure readings, command what the
// run commanded; so does the same loop rebuilt in C++ (make_controller, feedforward_preview).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "hysteron/experiment.hpp"
#include "hysteron/hysteron.h"
#include "hysteron/report.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"

using namespace hysteron;

namespace {

// The position loop's fields of a hysteron_ff_pid_params from result.json's numbers.
hysteron_ff_pid_params outer_params(const LoopDesign& d) {
  hysteron_ff_pid_params c;
  EXPECT_EQ(hysteron_ff_pid_default_params(&c), HYSTERON_OK);
  c.sample_time = d.sample_time;
  c.pressure_min = d.feedforward.pressure_limits.lo;
  c.pressure_max = d.feedforward.pressure_limits.hi;
  c.model_scale = d.feedforward.model_scale;
  c.lag_time_constant = d.feedforward.lag_time_constant;
  if (d.pid) {
    c.kp = d.pid->kp;
    c.ki = d.pid->ki;
    c.kd = d.pid->kd;
    c.derivative_filter = d.pid->derivative_filter;
    c.tracking_time = d.pid->tracking_time;
    c.setpoint_weight_p = d.pid->setpoint_weight_p;
    c.setpoint_weight_d = d.pid->setpoint_weight_d;
    c.anti_windup = static_cast<int>(d.pid->anti_windup);  // none, conditional, back_calculation: 0, 1, 2
  }
  return c;
}

hysteron_params* load_model(const std::filesystem::path& file) {
  hysteron_params* p = nullptr;
  EXPECT_EQ(hysteron_params_from_file(file.string().c_str(), &p), HYSTERON_OK) << hysteron_last_error();
  return p;
}

// The model file a variant inverts (docs/deploy.md): the faithful loop the paper's model, the
// compensated one the best.
std::string model_file(const TrackingRun& r) { return r.variant == "faithful" ? "model.json" : "best_model.json"; }

// The run's feedforward preview [m] (feedforward_preview, the documented formula).
std::vector<double> preview_m(const TrackingRun& r) {
  std::vector<double> ref(r.reference_mm.size());
  for (std::size_t k = 0; k < ref.size(); ++k) ref[k] = r.reference_mm[k] * 1e-3;
  return feedforward_preview(r.controller, ref);
}

// The same loop in C++ (make_controller on the run's model): the command (regulator) or the
// duty and the desired pressure (valves) of every sample, against the run's.
void replay_cpp(const ExperimentResult& r, const TrackingRun& run, double& worst_command, double& worst_duty) {
  Controller c = make_controller(run.controller, run.variant == "faithful" ? r.fit.model : r.best_fit.model);
  const std::vector<double> preview = preview_m(run);
  for (std::size_t k = 0; k < run.t.size(); ++k) {
    const double ref = run.reference_mm[k] * 1e-3, meas = run.measured_mm[k] * 1e-3, p = run.pressure_measured_mpa[k];
    std::visit(
        [&](auto& loop) {
          using T = std::decay_t<decltype(loop)>;
          if constexpr (std::is_same_v<T, FeedforwardPidController>) {
            worst_command = std::max(worst_command, std::abs(loop.step(ref, preview[k], meas) - run.pressure_command_mpa[k]));
          } else if constexpr (std::is_same_v<T, OpenLoopController>) {
            worst_command = std::max(worst_command, std::abs(loop.step(ref, preview[k], meas, p) - run.pressure_command_mpa[k]));
          } else {
            worst_duty = std::max(worst_duty, std::abs(loop.step(ref, preview[k], meas, p) - run.duty[k]));
            worst_command = std::max(worst_command, std::abs(loop.desired_pressure() - run.pressure_command_mpa[k]));
          }
        },
        c);
  }
}

struct Worst {
  double command = 0.0, duty = 0.0;
  std::size_t n = 0;
};

// The loop rebuilt through the C ABI from the run's controller (hysteron_open_loop or
// hysteron_cascade, by its "loop") and model file, fed the run's recorded inputs.
Worst replay_c(const std::filesystem::path& dir, const TrackingRun& r) {
  const LoopDesign& d = r.controller;
  Worst w;
  hysteron_open_loop* ol = nullptr;
  hysteron_cascade* cas = nullptr;
  hysteron_params* model = load_model(dir / model_file(r));
  if (d.kind == LoopDesign::Kind::open_loop) {
    hysteron_open_loop_params c;
    EXPECT_EQ(hysteron_open_loop_default_params(&c), HYSTERON_OK);
    c.loop = outer_params(d);
    c.pressure_gain = d.pressure_gain;
    EXPECT_EQ(hysteron_open_loop_create(model, &c, &ol), HYSTERON_OK) << hysteron_last_error();
  } else if (d.kind == LoopDesign::Kind::cascade_pwm && d.pressure_pid && d.pwm) {
    hysteron_cascade_params c;
    EXPECT_EQ(hysteron_cascade_default_params(&c), HYSTERON_OK);
    c.outer = outer_params(d);
    const PidParams& q = *d.pressure_pid;
    c.pressure = {q.kp, q.ki, q.kd, q.derivative_filter, q.tracking_time, q.setpoint_weight_p, q.setpoint_weight_d,
                  q.out_min, q.out_max, static_cast<int>(q.anti_windup)};
    c.pwm = {d.pwm->gain, d.pwm->deadband, d.pwm->min_duty, d.pwm->max_duty, d.pwm->resolution};
    EXPECT_EQ(hysteron_cascade_create(model, &c, &cas), HYSTERON_OK) << hysteron_last_error();
  } else {
    ADD_FAILURE() << r.variant << ": not an open loop or a complete cascade";
  }
  hysteron_params_free(model);
  if (!ol && !cas) return w;
  const std::vector<double> preview = preview_m(r);
  for (std::size_t k = 0; k < r.t.size(); ++k, ++w.n) {
    const double ref = r.reference_mm[k] * 1e-3, meas = r.measured_mm[k] * 1e-3, p = r.pressure_measured_mpa[k];
    double u = -1.0, duty = 0.0;
    EXPECT_EQ(ol ? hysteron_open_loop_step(ol, ref, preview[k], meas, p, &u)
                 : hysteron_cascade_step(cas, ref, preview[k], meas, p, &duty, &u),
              HYSTERON_OK);
    w.command = std::max(w.command, std::abs(u - r.pressure_command_mpa[k]));  // with the valves: p_d
    w.duty = std::max(w.duty, std::abs(duty - r.duty[k]));
  }
  hysteron_open_loop_free(ol);
  hysteron_cascade_free(cas);
  return w;
}

// Runs `name` quickly, writes its directory, reads it back and replays its faithful and
// compensated runs through the C ABI.
void check_replay(const std::string& name, LoopDesign::Kind expected) {
  const ExperimentResult r = run_experiment(test::quick_experiment(name));
  test::TempDir tmp;
  const std::filesystem::path dir = tmp.file("out");
  r.write(dir.string());
  const ExperimentResult back = report::read_experiment_dir(dir.string());
  int replayed = 0;
  bool shaped = false, corrected = false;
  for (const TrackingRun& run : back.runs) {
    if (run.variant != "faithful" && run.variant != "compensated") continue;
    ASSERT_EQ(run.pressure_measured_mpa.size(), run.t.size()) << run.variant;
    EXPECT_EQ(run.controller.kind, expected) << run.variant;
    const Worst w = replay_c(dir, run);
    double cpp_command = 0.0, cpp_duty = 0.0;
    replay_cpp(back, run, cpp_command, cpp_duty);
    EXPECT_LT(cpp_command, 1e-9) << name << " " << run.variant << " " << run.reference << ": make_controller, MPa";
    EXPECT_LT(cpp_duty, 1e-9) << name << " " << run.variant << " " << run.reference << ": make_controller, duty";
    EXPECT_EQ(w.n, run.t.size());
    EXPECT_LT(w.command, 1e-9) << name << " " << run.variant << " " << run.reference << ": MPa";
    EXPECT_LT(w.duty, 1e-9) << name << " " << run.variant << " " << run.reference << ": duty";
    shaped = shaped || run.controller.shaper.has_value();
    corrected = corrected || run.controller.pid.has_value();
    ++replayed;
  }
  EXPECT_GE(replayed, 4);
  EXPECT_TRUE(corrected) << "a compensated loop has a position PID";
  // the nominal rig's gain trial shapes the compensated loops (docs/control.md, section 2), so
  // the preview through the shaper is checked too
  EXPECT_TRUE(shaped);
}

}  // namespace

TEST(CApiLoops, OpenLoopRebuiltFromResultJsonCommandsWhatTheRunCommanded) { check_replay("mpi-openloop", LoopDesign::Kind::open_loop); }

TEST(CApiLoops, CascadeRebuiltFromResultJsonCommandsWhatTheRunCommanded) { check_replay("mpi-pwm", LoopDesign::Kind::cascade_pwm); }
