// The C ABI's loops (include/hysteron/hysteron.h) rebuilt from an experiment's output
// directory, as docs/deploy.md tells a user to: a run's loop read from result.json
// (hysteron_loop_params_from_file) and the model file it inverts give hysteron_ff_pid (gpi-pid),
// hysteron_open_loop (mpi-openloop) and hysteron_cascade (mpi-pwm) that, fed the run's recorded
// reference (previewed by hysteron_loop_preview), contraction and pressure readings, command
// what the run commanded; so does the same loop rebuilt in C++ (make_controller,
// feedforward_preview), and the loop as generated C (hysteron export --loop: io::generate_c on
// the run's loop and model file, compiled with gcc).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "export_loop_util.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/hysteron.h"
#include "hysteron/io/loop_design.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"
#include "hysteron/report.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"

using namespace hysteron;

namespace {

hysteron_params* load_model(const std::filesystem::path& file) {
  hysteron_params* p = nullptr;
  EXPECT_EQ(hysteron_params_from_file(file.string().c_str(), &p), HYSTERON_OK) << hysteron_last_error();
  return p;
}

// The model file a variant inverts (docs/deploy.md): the faithful loop the paper's model, the
// compensated one the best.
std::string model_file(const TrackingRun& r) { return r.variant == "faithful" ? "model.json" : "best_model.json"; }

// A recorded signal [mm] in the loops' units [m].
std::vector<double> metres(const std::vector<double>& mm) {
  std::vector<double> m(mm.size());
  for (std::size_t k = 0; k < mm.size(); ++k) m[k] = mm[k] * 1e-3;
  return m;
}

// The run's feedforward preview [m] (feedforward_preview, the documented formula).
std::vector<double> preview_m(const TrackingRun& r) { return feedforward_preview(r.controller, metres(r.reference_mm)); }

// The same loop in C++ (make_controller on the run's model): the command (regulator) or the
// duty and the desired pressure (valves) of every sample, against the run's.
void replay_cpp(const ExperimentResult& r, const TrackingRun& run, double& worst_command, double& worst_duty) {
  Controller c = make_controller(run.controller, run.variant == "faithful" ? r.fit.model : r.best_fit.model);
  const std::vector<double> preview = preview_m(run);
  for (std::size_t k = 0; k < run.t.size(); ++k) {
    const double ref = run.reference_mm[k] * 1e-3, meas = run.measured_mm[k] * 1e-3, p = run.pressure_measured_mpa[k];
    const LoopOutput o = step(c, ref, preview[k], meas, p);  // with the valves: p_d
    worst_command = std::max(worst_command, std::abs(o.command_mpa - run.pressure_command_mpa[k]));
    worst_duty = std::max(worst_duty, std::abs(o.duty - run.duty[k]));
  }
}

struct Worst {
  double command = 0.0, duty = 0.0;
  std::size_t n = 0;
};

// A sample k whose argument `which` (0 reference, 1 preview, 2 measured, 3 pressure) is `value`.
struct Fault {
  std::size_t k;
  int which;
  double value;
};

// The loop rebuilt through the C ABI as docs/deploy.md tells a C user to: the run's loop read
// from result.json (hysteron_loop_params_from_file, "VARIANT.REFERENCE"), the object its kind
// names created on the run's model file, and the preview from hysteron_loop_preview; fed the
// run's recorded inputs. The position PID's limit-cycle guard is read and set too
// (hysteron_loop_guard_from_file, hysteron_*_set_guard) unless with_guard is false.
// With `faults`, those samples' arguments are replaced, the step must return
// HYSTERON_ERROR_INVALID_ARGUMENT there (HYSTERON_OK elsewhere), and the differences are to
// the same loop in C++ (make_controller, step) fed the same arguments, not to the run.
Worst replay_c(const std::filesystem::path& dir, const TrackingRun& r, bool with_guard = true,
               const std::vector<Fault>& faults = {}) {
  Worst w;
  hysteron_loop_params c;
  const std::string run = r.variant + "." + r.reference;
  if (hysteron_loop_params_from_file((dir / "result.json").string().c_str(), run.c_str(), &c) != HYSTERON_OK) {
    ADD_FAILURE() << run << ": " << hysteron_last_error();
    return w;
  }
  hysteron_ff_pid* ff = nullptr;
  hysteron_open_loop* ol = nullptr;
  hysteron_cascade* cas = nullptr;
  hysteron_params* model = load_model(dir / model_file(r));
  hysteron_status st = HYSTERON_ERROR_INTERNAL;
  switch (c.kind) {
    case HYSTERON_LOOP_FEEDFORWARD_PID: st = hysteron_ff_pid_create(model, &c.ff_pid, &ff); break;
    case HYSTERON_LOOP_OPEN_LOOP: {
      const hysteron_open_loop_params op{c.ff_pid, c.pressure_gain};
      st = hysteron_open_loop_create(model, &op, &ol);
      break;
    }
    case HYSTERON_LOOP_CASCADE_PWM: {
      const hysteron_cascade_params cp{c.ff_pid, c.pressure, c.pwm};
      st = hysteron_cascade_create(model, &cp, &cas);
      break;
    }
    default: ADD_FAILURE() << run << ": kind " << c.kind;
  }
  EXPECT_EQ(st, HYSTERON_OK) << run << ": " << hysteron_last_error();
  hysteron_params_free(model);
  if (st != HYSTERON_OK) return w;
  hysteron_pid_guard g;
  EXPECT_EQ(hysteron_loop_guard_from_file((dir / "result.json").string().c_str(), run.c_str(), &g), HYSTERON_OK)
      << hysteron_last_error();
  const bool tuned = r.variant != "faithful";  // the faithful loop keeps the paper's PID, unguarded
  EXPECT_EQ(g.period > 0.0, tuned && r.controller.pid.has_value()) << run;
  if (with_guard) {
    EXPECT_EQ(ff ? hysteron_ff_pid_set_guard(ff, &g) : ol ? hysteron_open_loop_set_guard(ol, &g)
                                                           : hysteron_cascade_set_guard(cas, &g),
              HYSTERON_OK)
        << hysteron_last_error();
  }
  const std::vector<double> ref = metres(r.reference_mm);
  std::vector<double> preview(ref.size());
  EXPECT_EQ(hysteron_loop_preview(&c, ref.data(), ref.size(), preview.data(), preview.size()), HYSTERON_OK)
      << hysteron_last_error();
  std::optional<Controller> cpp;
  if (!faults.empty()) cpp.emplace(make_controller(r.controller, io::read_model_file((dir / model_file(r)).string())));
  for (std::size_t k = 0; k < r.t.size(); ++k, ++w.n) {
    double a[4] = {ref[k], preview[k], r.measured_mm[k] * 1e-3, r.pressure_measured_mpa[k]};
    bool faulty = false;
    for (const Fault& f : faults)
      if (f.k == k) {
        a[f.which] = f.value;
        faulty = faulty || f.which != 3 || ff == nullptr;  // hysteron_ff_pid_step takes no pressure
      }
    double u = -1.0, duty = 0.0;
    EXPECT_EQ(ff    ? hysteron_ff_pid_step(ff, a[0], a[1], a[2], &u)
              : ol ? hysteron_open_loop_step(ol, a[0], a[1], a[2], a[3], &u)
                   : hysteron_cascade_step(cas, a[0], a[1], a[2], a[3], &duty, &u),
              faulty ? HYSTERON_ERROR_INVALID_ARGUMENT : HYSTERON_OK)
        << run << " sample " << k;
    double want_u = r.pressure_command_mpa[k], want_duty = r.duty[k];  // with the valves: p_d
    if (cpp) {
      const LoopOutput o = step(*cpp, a[0], a[1], a[2], a[3]);
      want_u = o.command_mpa;
      want_duty = o.duty;
    }
    w.command = std::max(w.command, std::abs(u - want_u));
    w.duty = std::max(w.duty, std::abs(duty - want_duty));
  }
  double scale = 0.0;
  std::size_t cuts = 0;
  EXPECT_EQ(ff    ? hysteron_ff_pid_guard_state(ff, &scale, &cuts)
            : ol ? hysteron_open_loop_guard_state(ol, &scale, &cuts)
                 : hysteron_cascade_guard_state(cas, &scale, &cuts),
            HYSTERON_OK);
  if (with_guard) {
    EXPECT_EQ(cuts, r.controller.guard_cuts) << run;
    EXPECT_EQ(scale, r.controller.guard_final_scale) << run;
  }
  hysteron_ff_pid_free(ff);
  hysteron_open_loop_free(ol);
  hysteron_cascade_free(cas);
  return w;
}

// The loop as generated C, from the files as `hysteron export --model MODEL --loop result.json
// --run VARIANT.REFERENCE` reads them, fed the run's recorded inputs; its own preview of the
// reference must be the library's.
Worst replay_generated(const std::filesystem::path& dir, const TrackingRun& r) {
  Worst w;
  const LoopDesign d = io::read_loop_design((dir / "result.json").string(), r.variant + "." + r.reference);
  const ModelParams model = io::read_model_file((dir / model_file(r)).string());
  const std::vector<double> ref = metres(r.reference_mm), meas = metres(r.measured_mm);
  const std::vector<double> preview = feedforward_preview(d, ref);
  test::TempDir tmp;
  const test::LoopRun got =
      test::run_generated_loop(d, model, tmp.file("."), false, ref, preview, meas, r.pressure_measured_mpa);
  EXPECT_EQ(got.error, "") << r.variant << "." << r.reference;
  EXPECT_EQ(got.preview, preview) << r.variant << "." << r.reference << ": the generated preview";
  EXPECT_EQ(got.command.size(), r.t.size());
  for (std::size_t k = 0; k < got.command.size() && k < r.t.size(); ++k, ++w.n) {
    w.command = std::max(w.command, std::abs(got.command[k] - r.pressure_command_mpa[k]));  // with the valves: p_d
    w.duty = std::max(w.duty, std::abs(got.duty[k] - r.duty[k]));
  }
  return w;
}

// The loop as generated C fed the run's recorded inputs with `faults` (as replay_c's), against the same loop
// in C++ (make_controller, step) fed the same: the largest differences, and the samples whose command or duty
// differ at all.
Worst replay_generated_faults(const std::filesystem::path& dir, const TrackingRun& r, const std::vector<Fault>& faults,
                              std::size_t& differ) {
  Worst w;
  const LoopDesign d = io::read_loop_design((dir / "result.json").string(), r.variant + "." + r.reference);
  const ModelParams model = io::read_model_file((dir / model_file(r)).string());
  std::vector<double> a[4] = {metres(r.reference_mm), {}, metres(r.measured_mm), r.pressure_measured_mpa};
  a[1] = feedforward_preview(d, a[0]);
  for (const Fault& f : faults) a[f.which][f.k] = f.value;
  test::TempDir tmp;
  const test::LoopRun got = test::run_generated_loop(d, model, tmp.file("."), false, a[0], a[1], a[2], a[3]);
  EXPECT_EQ(got.error, "") << r.variant << "." << r.reference;
  Controller c = make_controller(d, model);
  differ = 0;
  for (std::size_t k = 0; k < got.command.size() && k < r.t.size(); ++k, ++w.n) {
    const LoopOutput o = step(c, a[0][k], a[1][k], a[2][k], a[3][k]);
    w.command = std::max(w.command, std::abs(got.command[k] - o.command_mpa));
    w.duty = std::max(w.duty, std::abs(got.duty[k] - o.duty));
    differ += got.command[k] != o.command_mpa || got.duty[k] != o.duty;
  }
  return w;
}

// A learning run's feedforward preview [m], as the run fed it: through the shaper (indices
// clamped to the record: feedforward_preview) or, unshaped, the reference lead samples ahead,
// wrapped around the record (the learning run's reference is periodic).
std::vector<double> learning_preview_m(const LoopDesign& d, const std::vector<double>& ref) {
  if (d.shaper) return feedforward_preview(d, ref);
  std::vector<double> p(ref.size());
  for (std::size_t k = 0; k < ref.size(); ++k) p[k] = ref[(k + d.feedforward_lead) % ref.size()];
  return p;
}

struct LearningWorst {
  double command = 0.0, duty = 0.0, correction_mm = 0.0;
  std::size_t n = 0;
};

// A learning run's loop and learning, from the files as `hysteron export --loop result.json --run
// learning.REF` reads them, fed the run's recorded inputs: in C++ (make_controller and an
// IterativeLearning stepped by step(Controller&, IterativeLearning&, ...)) and as generated C
// (lp_loop_learning_step), against the run's commands and correction_mm.
void replay_learning(const std::filesystem::path& dir, const TrackingRun& r, LearningWorst& cpp, LearningWorst& gen) {
  const std::string where = r.variant + "." + r.reference;
  const LoopDesign d = io::read_loop_design((dir / "result.json").string(), where);
  ASSERT_TRUE(d.learning.has_value()) << where;
  const ModelParams model = io::read_model_file((dir / model_file(r)).string());
  ASSERT_EQ(r.correction_mm.size(), r.t.size()) << where;
  const std::vector<double> ref = metres(r.reference_mm), meas = metres(r.measured_mm);
  const std::vector<double> preview = learning_preview_m(d, ref);
  Controller c = make_controller(d, model);
  IterativeLearning ilc(d.learning->params);
  for (std::size_t k = 0; k < ref.size(); ++k, ++cpp.n) {
    const double c0 = ilc.correction(0);
    const LoopOutput o = step(c, ilc, d, ref[k], preview[k], meas[k], r.pressure_measured_mpa[k]);
    cpp.command = std::max(cpp.command, std::abs(o.command_mpa - r.pressure_command_mpa[k]));
    cpp.duty = std::max(cpp.duty, std::abs(o.duty - r.duty[k]));
    cpp.correction_mm = std::max(cpp.correction_mm, std::abs(c0 * 1e3 - r.correction_mm[k]));
  }
  if (!test::have_gcc()) return;
  test::TempDir tmp;
  const test::LoopRun got =
      test::run_generated_loop(d, model, tmp.file("."), false, ref, preview, meas, r.pressure_measured_mpa);
  ASSERT_EQ(got.error, "") << where;
  ASSERT_EQ(got.command.size(), r.t.size()) << where;
  ASSERT_EQ(got.correction.size(), r.t.size()) << where;
  for (std::size_t k = 0; k < got.command.size(); ++k, ++gen.n) {
    gen.command = std::max(gen.command, std::abs(got.command[k] - r.pressure_command_mpa[k]));
    gen.duty = std::max(gen.duty, std::abs(got.duty[k] - r.duty[k]));
    gen.correction_mm = std::max(gen.correction_mm, std::abs(got.correction[k] * 1e3 - r.correction_mm[k]));
  }
}

// Runs `name` quickly, writes its directory, reads it back and replays its faithful and
// compensated runs through the C ABI; a learning run's ILC parameters are read as well.
// expect_guard_cut: a compensated run's limit-cycle guard cut its gains (and the C ABI's loop
// without the guard then commands otherwise).
void check_replay(const ExperimentOptions& o, LoopDesign::Kind expected, bool expect_guard_cut = false) {
  const std::string name = o.name;
  const int learning_periods = o.learning_periods;
  const ExperimentResult r = run_experiment(o);
  test::TempDir tmp;
  const std::filesystem::path dir = tmp.file("out");
  r.write(dir.string());
  const ExperimentResult back = report::read_experiment_dir(dir.string());
  int replayed = 0;
  bool shaped = false, corrected = false;
  int learnt = 0, guard_cut = 0;
  for (const TrackingRun& run : back.runs) {
    EXPECT_EQ(run.controller.sample_time, o.control_period) << run.variant << " " << run.reference;
    if (run.variant == "learning") {
      hysteron_loop_params c;
      const std::string where = run.variant + "." + run.reference;
      ASSERT_EQ(hysteron_loop_params_from_file((dir / "result.json").string().c_str(), where.c_str(), &c), HYSTERON_OK)
          << hysteron_last_error();
      ASSERT_TRUE(run.controller.learning.has_value());
      const LearningParams& l = run.controller.learning->params;
      EXPECT_EQ(c.has_learning, 1);
      EXPECT_EQ(c.learning.period, l.period);
      EXPECT_EQ(c.learning.gain, l.gain);
      EXPECT_EQ(c.learning.lead, l.lead);
      EXPECT_EQ(c.learning.half_width, l.half_width);
      EXPECT_EQ(c.learning.lookahead, l.lookahead);
      EXPECT_EQ(c.learning.max_correction, l.max_correction);
      EXPECT_EQ(c.learning.rise_tolerance, l.rise_tolerance);
      EXPECT_EQ(c.learning.hold_after_cuts, l.hold_after_cuts);
      EXPECT_EQ(c.learning.max_gain, l.max_gain);
      ++learnt;
      LearningWorst cpp, gen;
      replay_learning(dir, run, cpp, gen);
      EXPECT_EQ(cpp.n, run.t.size());
      EXPECT_LT(cpp.command, 1e-9) << name << " " << where << ": make_controller + IterativeLearning, MPa";
      EXPECT_LT(cpp.duty, 1e-9) << name << " " << where << ": duty";
      EXPECT_LT(cpp.correction_mm, 1e-9) << name << " " << where << ": correction, mm";
      if (test::have_gcc()) {
        EXPECT_EQ(gen.n, run.t.size());
        EXPECT_LT(gen.command, 1e-9) << name << " " << where << ": generated C, MPa";
        EXPECT_LT(gen.duty, 1e-9) << name << " " << where << ": generated C, duty";
        EXPECT_LT(gen.correction_mm, 1e-9) << name << " " << where << ": generated C, correction, mm";
      }
      std::printf("  %s %s: %zu samples; largest difference from the run: C++ %.3g MPa / %.3g duty / %.3g mm "
                  "correction, generated C %.3g MPa / %.3g duty / %.3g mm\n",
                  name.c_str(), where.c_str(), cpp.n, cpp.command, cpp.duty, cpp.correction_mm, gen.command, gen.duty,
                  gen.correction_mm);
    }
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
    if (test::have_gcc()) {
      const Worst g = replay_generated(dir, run);
      EXPECT_EQ(g.n, run.t.size());
      EXPECT_LT(g.command, 1e-9) << name << " " << run.variant << " " << run.reference << ": generated C, MPa";
      EXPECT_LT(g.duty, 1e-9) << name << " " << run.variant << " " << run.reference << ": generated C, duty";
      std::printf("  %s %s.%s: %zu samples; largest difference from the run: C ABI %.3g MPa / %.3g duty, generated C "
                  "%.3g MPa / %.3g duty\n",
                  name.c_str(), run.variant.c_str(), run.reference.c_str(), g.n, w.command, w.duty, g.command, g.duty);
    }
    {
      // A non-finite argument of each kind, once: the C ABI reports it and still commands what the
      // library's step (and so Python's and the generated C's) commands, then and on every later
      // sample (docs/deploy.md).
      const std::size_t n = run.t.size();
      const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
      const std::vector<Fault> faults = {{n / 5, 0, nan}, {2 * n / 5, 1, nan}, {3 * n / 5, 2, -inf}, {4 * n / 5, 3, nan}};
      const Worst f = replay_c(dir, run, true, faults);
      EXPECT_EQ(f.n, n);
      EXPECT_EQ(f.command, 0.0) << name << " " << run.variant << " " << run.reference << ": faults, MPa";
      EXPECT_EQ(f.duty, 0.0) << name << " " << run.variant << " " << run.reference << ": faults, duty";
      // a 200-sample dropout of the position sensor and of the pressure sensor too, in the generated C
      std::vector<Fault> dropouts = faults;
      for (std::size_t k = n / 10; k < n / 10 + 200; ++k) dropouts.push_back({k, 2, nan});
      for (std::size_t k = n / 2; k < n / 2 + 200; ++k) dropouts.push_back({k, 3, nan});
      if (test::have_gcc()) {
        std::size_t differ = 0;
        const Worst g = replay_generated_faults(dir, run, dropouts, differ);
        EXPECT_EQ(g.n, n);
        EXPECT_EQ(differ, 0u) << name << " " << run.variant << " " << run.reference << ": generated C with faults, "
                              << g.command << " MPa, " << g.duty << " duty";
      }
      const Worst fd = replay_c(dir, run, true, dropouts);
      EXPECT_EQ(fd.command, 0.0) << name << " " << run.variant << " " << run.reference << ": dropouts, MPa";
      EXPECT_EQ(fd.duty, 0.0) << name << " " << run.variant << " " << run.reference << ": dropouts, duty";
    }
    if (run.controller.guard_cuts > 0) {
      ++guard_cut;
      EXPECT_GT(replay_c(dir, run, false).command, 1e-6) << name << " " << run.variant << ": the same without the guard";
    }
    shaped = shaped || run.controller.shaper.has_value();
    corrected = corrected || run.controller.pid.has_value();
    ++replayed;
  }
  EXPECT_GE(replayed, 2);
  EXPECT_EQ(guard_cut > 0, expect_guard_cut) << name;
  EXPECT_EQ(learnt > 0, learning_periods > 0);
  EXPECT_TRUE(corrected) << "a compensated loop has a position PID";
  // the nominal rig's gain trial shapes the compensated loops (docs/control.md, section 2), so
  // the preview through the shaper is checked too
  EXPECT_TRUE(shaped);
}

}  // namespace

TEST(CApiLoops, FeedforwardPidRebuiltFromResultJsonCommandsWhatTheRunCommanded) {
  check_replay(test::quick_experiment("gpi-pid", 2), LoopDesign::Kind::feedforward_pid);
}

// At 0.5 ms (2 kHz): result.json's loop, every count in samples of 0.5 ms, rebuilt through the C ABI
// and the generated C, commands what the run commanded, sample by sample (learning included).
TEST(CApiLoops, FeedforwardPidAtHalfAMillisecondRebuiltFromResultJsonCommandsWhatTheRunCommanded) {
  ExperimentOptions o = test::quick_experiment("gpi-pid", 2);
  o.control_period = 5e-4;
  check_replay(o, LoopDesign::Kind::feedforward_pid);
}

TEST(CApiLoops, OpenLoopRebuiltFromResultJsonCommandsWhatTheRunCommanded) {
  check_replay(test::quick_experiment("mpi-openloop"), LoopDesign::Kind::open_loop);
}

TEST(CApiLoops, CascadeRebuiltFromResultJsonCommandsWhatTheRunCommanded) {
  check_replay(test::quick_experiment("mpi-pwm"), LoopDesign::Kind::cascade_pwm);
}

// hysteron_loop_guard_from_json: the guard as written; one the loop would refuse, and a guard on
// the pressure PID (which the C ABI cannot set), refused with the path and the field.
TEST(CApiLoops, GuardIsReadCheckedLikeTheLoop) {
  LoopDesign d;
  d.feedforward.pressure_limits = {0.0, 0.6};  // as the experiments write them
  d.pid = PidParams{.kp = 9.8, .ki = 82.0, .out_min = 0.0, .out_max = 0.6};
  d.pid->guard = PidGuard{.period = 0.239, .amplitude = 2.15e-3};
  hysteron_pid_guard g{};
  const std::string ok = io::to_json(d).dump();
  ASSERT_EQ(hysteron_loop_guard_from_json(ok.c_str(), nullptr, &g), HYSTERON_OK) << hysteron_last_error();
  {
    // pressure limits left to the model (null) with a bounded PID: whether the C controller's
    // limits (the model's) match the PID's is not known from the file: refused, saying why
    LoopDesign unset = d;
    unset.feedforward.pressure_limits = {};
    const std::string u = io::to_json(unset).dump();
    EXPECT_EQ(hysteron_loop_guard_from_json(u.c_str(), nullptr, &g), HYSTERON_ERROR_MODEL);
    EXPECT_NE(std::string(hysteron_last_error()).find("the loop leaves its pressure limits to the model"),
              std::string::npos)
        << hysteron_last_error();
  }
  EXPECT_EQ(g.period, 0.239);
  EXPECT_EQ(g.amplitude, 2.15e-3);
  EXPECT_EQ(g.factor, PidGuard{}.factor);
  LoopDesign bad = d;
  bad.pid->guard.factor = 1.5;
  const std::string b = io::to_json(bad).dump();
  hysteron_pid_guard untouched{};
  untouched.period = -7.0;
  EXPECT_EQ(hysteron_loop_guard_from_json(b.c_str(), nullptr, &untouched), HYSTERON_ERROR_MODEL);
  EXPECT_NE(std::string(hysteron_last_error()).find("pid.guard.factor = 1.5"), std::string::npos)
      << hysteron_last_error();
  EXPECT_EQ(untouched.period, -7.0);  // written only on success
  LoopDesign inner = d;
  inner.kind = LoopDesign::Kind::cascade_pwm;
  inner.pwm = PwmParams{};
  inner.pressure_pid = PidParams{.kp = 20.0, .out_min = -1.0, .out_max = 1.0};
  inner.pressure_pid->guard = PidGuard{.period = 0.02, .amplitude = 0.01};
  const std::string i = io::to_json(inner).dump();
  EXPECT_EQ(hysteron_loop_guard_from_json(i.c_str(), nullptr, &g), HYSTERON_ERROR_MODEL);
  EXPECT_NE(std::string(hysteron_last_error()).find("pressure_pid.guard"), std::string::npos) << hysteron_last_error();
  hysteron_loop_params lp;
  EXPECT_EQ(hysteron_loop_params_from_json(i.c_str(), nullptr, &lp), HYSTERON_ERROR_MODEL);
  // a hand-written controller without what a run's guard did reads as nothing done yet
  nlohmann::json hand = io::to_json(d);
  hand.erase("guard_cuts");
  hand.erase("guard_final_scale");
  const LoopDesign back = io::from_json<LoopDesign>(hand, "controller");
  EXPECT_TRUE(back.pid->guard.enabled());
  EXPECT_EQ(back.guard_cuts, 0u);
  EXPECT_EQ(back.guard_final_scale, 1.0);
}

// Tuned on the nominal rig, tracking with the load damping halved: the compensated loop rings
// and its limit-cycle guard cuts the gains (docs/control.md, section 2); the C ABI's loop with
// the run's guard commands what the run commanded, and without it does not.
TEST(CApiLoops, GuardedLoopRebuiltFromResultJsonCommandsWhatTheRunCommanded) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  PamRigParams changed = o.rig;
  changed.load.damping = 200.0;
  o.tracking_rig = changed;
  check_replay(o, LoopDesign::Kind::feedforward_pid, true);
}
