// The compensating controllers' pressure limits where the caller names none: the model's
// input_limits (a fitted model's training input range), never the nominal rig's 0..0.6 MPa; a
// model without finite ones is refused naming the parameter; given limits win. For every
// controller kind, make_controller and the loop's JSON, the generated C and the C ABI.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "export_loop_util.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/error.hpp"
#include "hysteron/hysteron.h"
#include "hysteron/identify.hpp"
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/loop_design.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"

using namespace hysteron;

namespace {

constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double tc = 1e-3;  // [s]


// Table 3's gains with unbounded output limits: only the pressure limits bound the command.
PidParams pid_table3() {
  PidParams p;
  p.kp = 5.0;
  p.ki = 1.0;
  p.sample_time = tc;
  return p;
}

struct Range {
  double lo = inf, hi = -inf;
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
};

// The reference of the drives below: 2 s at 1 m (ten times the muscle's stroke, the measured
// contraction at 0) then 2 s at -1 m (measured 0.1 m): every loop is pushed into both limits.
double drive_reference(int k) { return k < 2000 ? 1.0 : -1.0; }
double drive_measured(int k) { return k < 2000 ? 0.0 : 0.1; }

// The pressure commands [MPa] of each controller kind (the cascade's: its desired pressure) on
// `model` with `ff` over the drive.
std::vector<Range> command_ranges(const ModelParams& model, const FeedforwardParams& ff) {
  InverseFeedforward inv(model, ff);
  FeedforwardPidController fp(model, ff, pid_table3());
  OpenLoopParams pure;  // as published: no position PID
  pure.feedforward = ff;
  OpenLoopController ol_pure(model, pure);
  OpenLoopParams olp;
  olp.feedforward = ff;
  olp.position = pid_table3();
  OpenLoopController ol(model, olp);
  CascadeParams cp;
  cp.feedforward = ff;
  cp.position = pid_table3();
  cp.pressure.kp = 20.0;
  cp.pressure.sample_time = tc;
  CascadePwmController cc(model, cp);
  std::vector<Range> r(5);
  double p_pure = 0.0, p_ol = 0.0, p_cc = 0.0;  // measured: each loop's last command (one sample late)
  for (int k = 0; k < 4000; ++k) {
    const double ref = drive_reference(k), y = drive_measured(k);
    r[0].add(inv.step(ref));
    r[1].add(fp.step(ref, ref, y));
    r[2].add(p_pure = ol_pure.step(ref, ref, y, p_pure));
    r[3].add(p_ol = ol.step(ref, ref, y, p_ol));
    cc.step(ref, ref, y, p_cc);
    r[4].add(p_cc = cc.desired_pressure());
  }
  // the resolved limits each controller reports are the ones it clamps to
  for (const Limits& l : {inv.pressure_limits(), fp.pressure_limits(), ol_pure.pressure_limits(), ol.pressure_limits(),
                          cc.pressure_limits(), ol.params().feedforward.pressure_limits,
                          cc.params().feedforward.pressure_limits, inv.params().pressure_limits}) {
    EXPECT_EQ(l.lo, r[0].lo);
    EXPECT_EQ(l.hi, r[0].hi);
  }
  return r;
}

const char* const kinds[] = {"InverseFeedforward", "FeedforwardPidController", "OpenLoopController (no PID)",
                             "OpenLoopController", "CascadePwmController (p_d)"};

// Every kind commanded exactly [lo, hi] over the drive.
void expect_ranges(const std::vector<Range>& r, double lo, double hi, const std::string& what) {
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_EQ(r[i].lo, lo) << kinds[i] << ", " << what;
    EXPECT_EQ(r[i].hi, hi) << kinds[i] << ", " << what;
  }
}

}  // namespace

// A muscle rated 0.4 MPa, its model identified on 0..0.4 MPa: no command above 0.4 MPa (the
// nominal rig's 0.6 used to be the default); one rated 0.8 MPa: commands up to 0.8, not capped
// at 0.6.
TEST(PressureLimits, DefaultIsTheModelsInputLimits) {
  const FeedforwardParams ff;  // no limits named
  EXPECT_FALSE(ff.pressure_limits.bounded());
  expect_ranges(command_ranges(test::rig_like_gpi({0.0, 0.4}), ff), 0.0, 0.4, "model on 0..0.4 MPa");
  expect_ranges(command_ranges(test::rig_like_gpi({0.0, 0.8}), ff), 0.0, 0.8, "model on 0..0.8 MPa");
  expect_ranges(command_ranges(test::rig_like_gpi({0.05, 0.35}), ff), 0.05, 0.35, "model on 0.05..0.35 MPa");
}

// The same with a model fit() identified on a record whose pressure spans 0..0.4 MPa: its
// input_limits are that range, and so are the commands.
TEST(PressureLimits, AFittedModelsTrainingRangeBoundsTheCommands) {
  Model truth(test::rig_like_gpi({0.0, 0.4}));
  std::vector<double> x, y;
  for (double a : {0.4, 0.3, 0.2, 0.1})
    for (int k = 0; k <= 400; ++k) {
      x.push_back(a * (1.0 - std::abs(2.0 * k / 400.0 - 1.0)));  // triangles [MPa]
      y.push_back(truth.step(x.back()));
    }
  FitOptions o;
  o.model = FitModel::pi;
  o.num_operators = 8;
  const FitReport fit = hysteron::fit(x, y, o);
  ASSERT_TRUE(fit.status != FitStatus::invalid_input && fit.status != FitStatus::failed) << fit.full_report();
  const Limits& fitted = input_limits(fit.model);
  ASSERT_EQ(fitted.lo, 0.0);  // the record's range: 0 and 0.4 are samples of it
  ASSERT_EQ(fitted.hi, 0.4);
  expect_ranges(command_ranges(fit.model, FeedforwardParams{}), 0.0, 0.4, "fitted on 0..0.4 MPa");
}

// A hand-written model without finite input_limits and no limits named: refused, naming the
// parameter (it used to get 0..0.6 MPa).
TEST(PressureLimits, AModelWithoutInputLimitsNeedsThemGiven) {
  for (const Limits& ml : {Limits{}, Limits{0.0, inf}, Limits{-inf, 0.5}}) {
    const ModelParams model = test::rig_like_gpi(ml);
    FeedforwardParams ff;  // none named: the model's side that is finite is not enough
    const std::string why = fmt::format("[{}, {}]", ml.lo, ml.hi);
    OpenLoopParams olp;
    olp.feedforward = ff;
    CascadeParams cp;
    cp.feedforward = ff;
    cp.position = pid_table3();
    cp.pressure.kp = 20.0;
    cp.pressure.sample_time = tc;
    for (const std::string& m : {test::error_of([&] { InverseFeedforward(model, ff); }),
                                 test::error_of([&] { FeedforwardPidController(model, ff, pid_table3()); }),
                                 test::error_of([&] { OpenLoopController(model, olp); }),
                                 test::error_of([&] { CascadePwmController(model, cp); }),
                                 test::error_of([&] { resolve_pressure_limits(model, ff.pressure_limits); })})
      EXPECT_NE(m.find("pressure_limits must be given"), std::string::npos) << why << ": " << m;
    // named, they are used
    ff.pressure_limits = {0.0, 0.5};
    expect_ranges(command_ranges(model, ff), 0.0, 0.5, "given on a model without limits " + why);
  }
}

// Limits named by the caller win, also wider than the model's input_limits (the user's choice);
// a side left infinite is the model's; NaN, or lo >= hi once resolved, is refused.
TEST(PressureLimits, GivenLimitsWin) {
  const ModelParams model = test::rig_like_gpi({0.0, 0.4});
  FeedforwardParams ff;
  ff.pressure_limits = {0.05, 0.5};
  expect_ranges(command_ranges(model, ff), 0.05, 0.5, "given 0.05..0.5");
  ff.pressure_limits = {0.0, 0.3};
  expect_ranges(command_ranges(model, ff), 0.0, 0.3, "given 0..0.3");
  ff.pressure_limits = {0.1, inf};
  expect_ranges(command_ranges(model, ff), 0.1, 0.4, "given 0.1..(the model's)");
  ff.pressure_limits = {-inf, 0.3};
  expect_ranges(command_ranges(model, ff), 0.0, 0.3, "given (the model's)..0.3");
  for (const Limits& bad : {Limits{0.5, inf}, Limits{0.3, 0.1}, Limits{std::nan(""), 0.4}, Limits{0.0, std::nan("")},
                            Limits{inf, inf}, Limits{-inf, -inf}}) {
    ff.pressure_limits = bad;
    const std::string m = test::error_of([&] { InverseFeedforward(model, ff); });
    EXPECT_NE(m.find("pressure_limits"), std::string::npos) << bad.lo << ", " << bad.hi << ": " << m;
  }
}

// A loop design without limits (null in its JSON) is rebuilt with the model's: make_controller,
// the learning step's saturation test and pressure_limits(Controller); its JSON keeps them
// unset, a file written before "loop" existed had 0..0.6 MPa.
TEST(PressureLimits, LoopDesignWithoutLimitsTakesTheModels) {
  LoopDesign d;
  EXPECT_FALSE(d.feedforward.pressure_limits.bounded());
  d.pid = pid_table3();
  d.sample_time = tc;
  const nlohmann::json j = io::to_json(d);
  EXPECT_TRUE(j["feedforward"]["pressure_min_mpa"].is_null()) << j.dump();
  EXPECT_TRUE(j["feedforward"]["pressure_max_mpa"].is_null()) << j.dump();
  LoopDesign back;
  io::from_json(j, back, "controller");
  EXPECT_EQ(back.feedforward.pressure_limits, Limits{});
  // named limits are written as numbers and read back
  LoopDesign named = d;
  named.feedforward.pressure_limits = {0.0, 0.45};
  io::from_json(io::to_json(named), back, "controller");
  EXPECT_EQ(back.feedforward.pressure_limits, (Limits{0.0, 0.45}));
  // a file from before "loop" (2026-11-26): the default feedforward of the time, 0..0.6 MPa
  nlohmann::json old = j;
  old.erase("loop");
  old.erase("feedforward");
  io::from_json(old, back, "controller");
  EXPECT_EQ(back.feedforward.pressure_limits, (Limits{0.0, 0.6}));

  for (const double top : {0.4, 0.8}) {
    const ModelParams model = test::rig_like_gpi({0.0, top});
    for (const LoopDesign::Kind kind :
         {LoopDesign::Kind::feedforward_pid, LoopDesign::Kind::open_loop, LoopDesign::Kind::cascade_pwm}) {
      LoopDesign k = d;
      k.kind = kind;
      if (kind == LoopDesign::Kind::open_loop) k.pressure_gain = 0.5;
      if (kind == LoopDesign::Kind::cascade_pwm) {
        k.pressure_pid = PidParams{};
        k.pressure_pid->kp = 20.0;
        k.pressure_pid->sample_time = tc;
        k.pwm = PwmParams{};
      }
      Controller c = make_controller(k, model);
      EXPECT_EQ(pressure_limits(c), (Limits{0.0, top}));
      Range r;
      for (int s = 0; s < 4000; ++s)
        r.add(step(c, drive_reference(s), drive_reference(s), drive_measured(s), 0.0).command_mpa);
      EXPECT_EQ(r.lo, 0.0) << static_cast<int>(kind);
      EXPECT_EQ(r.hi, top) << static_cast<int>(kind);
    }
    // the learning step learns nothing where the command is at the model's limit
    LoopDesign l = d;
    LearningParams lp;
    lp.period = 100;
    lp.gain = 0.5;
    l.learning = LoopDesign::Learning{lp};
    Controller c = make_controller(l, model);
    IterativeLearning ilc(lp);
    for (int s = 0; s < 300; ++s) {
      const LoopOutput o = step(c, ilc, l, 1.0, 1.0, 0.0, 0.0);
      EXPECT_EQ(o.command_mpa, top);
    }
    for (std::size_t s = 0; s < lp.period; ++s) EXPECT_EQ(ilc.correction(s), 0.0) << s;
  }
  EXPECT_NE(test::error_of([&] { make_controller(d, test::rig_like_gpi({})); }).find("pressure_limits must be given"),
            std::string::npos);
}

// Generated C bakes in the resolved limits: the loop's, or where unset the model's; it commands
// what make_controller's loop commands.
TEST(PressureLimits, GeneratedLoopBakesInTheResolvedLimits) {
  LoopDesign d;
  d.pid = pid_table3();
  d.sample_time = tc;
  const ModelParams model = test::rig_like_gpi({0.0, 0.4});
  io::ExportOptions o;
  o.prefix = "lp";
  o.loop = d;
  const io::GeneratedC g = io::generate_c(model, o);
  EXPECT_NE(g.source.find("lp_pressure_lo = 0.0, lp_pressure_hi = 0.4;"), std::string::npos);
  // the inverse's limits must be the loop's resolved ones
  o.inverse_limits = {0.0, 0.6};
  const std::string m = test::error_of([&] { io::generate_c(model, o); });
  EXPECT_NE(m.find("differ from the loop's pressure limits [0, 0.4]"), std::string::npos) << m;
  o.inverse_limits = {0.0, 0.4};
  EXPECT_NO_THROW(io::generate_c(model, o));
  o.inverse_limits = {};
  o.loop->feedforward.pressure_limits = {0.0, 0.3};
  EXPECT_NE(io::generate_c(model, o).source.find("lp_pressure_lo = 0.0, lp_pressure_hi = 0.3;"), std::string::npos);
  io::ExportOptions bare;
  bare.loop = d;
  EXPECT_NE(test::error_of([&] { io::generate_c(test::rig_like_gpi({}), bare); }).find("pressure_limits must be given"), std::string::npos);

  if (!test::have_gcc()) GTEST_SKIP() << "no gcc";
  std::vector<double> ref, meas, pressure(4000, 0.0);
  for (int k = 0; k < 4000; ++k) {
    ref.push_back(drive_reference(k));
    meas.push_back(drive_measured(k));
  }
  test::TempDir dir;
  const test::LoopRun run = test::run_generated_loop(d, model, dir.path(), true, ref, ref, meas, pressure);
  ASSERT_EQ(run.error, "");
  ASSERT_EQ(run.command.size(), ref.size());
  Controller c = make_controller(d, model);
  for (std::size_t k = 0; k < ref.size(); ++k)
    ASSERT_EQ(run.command[k], step(c, ref[k], ref[k], meas[k], 0.0).command_mpa) << k;
  EXPECT_EQ(*std::max_element(run.command.begin(), run.command.end()), 0.4);
  EXPECT_EQ(*std::min_element(run.command.begin(), run.command.end()), 0.0);
}

namespace {

hysteron_params* c_model(const Limits& limits) {
  const std::string text = io::model_to_json(test::rig_like_gpi(limits)).dump();
  hysteron_params* p = nullptr;
  EXPECT_EQ(hysteron_params_from_json(text.c_str(), &p), HYSTERON_OK) << hysteron_last_error();
  return p;
}

// The C ABI's three loops on `model` with `f` (default or given limits): their command ranges
// over the drive (the cascade's desired pressure), or the status and message of the first
// create that failed.
struct CRun {
  hysteron_status status = HYSTERON_OK;
  std::string message;
  std::vector<Range> ranges;
};
CRun c_ranges(const hysteron_params* model, const hysteron_ff_pid_params& f) {
  CRun out;
  hysteron_open_loop_params op;
  hysteron_cascade_params cp;
  EXPECT_EQ(hysteron_open_loop_default_params(&op), HYSTERON_OK);
  EXPECT_EQ(hysteron_cascade_default_params(&cp), HYSTERON_OK);
  op.loop = f;
  cp.outer = f;
  hysteron_ff_pid* fp = nullptr;
  hysteron_open_loop* ol = nullptr;
  hysteron_cascade* cc = nullptr;
  const auto note = [&](hysteron_status s) {  // the first failure's status and message
    if (s != HYSTERON_OK && out.status == HYSTERON_OK) {
      out.status = s;
      out.message = hysteron_last_error();
    }
  };
  note(hysteron_ff_pid_create(model, &f, &fp));
  note(hysteron_open_loop_create(model, &op, &ol));
  note(hysteron_cascade_create(model, &cp, &cc));
  if (fp && ol && cc) {
    out.ranges.resize(3);
    double p_ol = 0.0, p_d = 0.0;  // measured: each loop's last command (one sample late)
    for (int k = 0; k < 4000; ++k) {
      const double ref = drive_reference(k), y = drive_measured(k);
      double u = 0.0, duty = 0.0;
      EXPECT_EQ(hysteron_ff_pid_step(fp, ref, ref, y, &u), HYSTERON_OK);
      out.ranges[0].add(u);
      EXPECT_EQ(hysteron_open_loop_step(ol, ref, ref, y, p_ol, &p_ol), HYSTERON_OK);
      out.ranges[1].add(p_ol);
      EXPECT_EQ(hysteron_cascade_step(cc, ref, ref, y, p_d, &duty, &p_d), HYSTERON_OK);
      out.ranges[2].add(p_d);
    }
  }
  hysteron_ff_pid_free(fp);
  hysteron_open_loop_free(ol);
  hysteron_cascade_free(cc);
  return out;
}

}  // namespace

// The C ABI: the default limits are -HUGE_VAL / +HUGE_VAL, the model file's input_limits (as
// hysteron_inverse_create's); a model without them is INVALID_ARGUMENT naming pressure_min /
// pressure_max; given limits win; a loop read from JSON with null limits takes the model's.
TEST(PressureLimits, CApiDefaultIsTheModelsInputLimits) {
  hysteron_ff_pid_params f;
  ASSERT_EQ(hysteron_ff_pid_default_params(&f), HYSTERON_OK);
  EXPECT_EQ(f.pressure_min, -inf);
  EXPECT_EQ(f.pressure_max, inf);
  f.kp = 5.0;
  f.ki = 1.0;
  for (const double top : {0.4, 0.8}) {
    hysteron_params* model = c_model({0.0, top});
    const CRun r = c_ranges(model, f);
    ASSERT_EQ(r.status, HYSTERON_OK) << r.message;
    for (const Range& x : r.ranges) {
      EXPECT_EQ(x.lo, 0.0) << top;
      EXPECT_EQ(x.hi, top) << top;
    }
    hysteron_ff_pid_params given = f;
    given.pressure_min = 0.05;
    given.pressure_max = 0.5;  // wider than the model's 0.4: the user's choice
    const CRun g = c_ranges(model, given);
    ASSERT_EQ(g.status, HYSTERON_OK) << g.message;
    for (const Range& x : g.ranges) {
      EXPECT_EQ(x.lo, 0.05);
      EXPECT_EQ(x.hi, 0.5);
    }
    hysteron_params_free(model);
  }
  hysteron_params* bare = c_model({});
  const CRun e = c_ranges(bare, f);
  EXPECT_EQ(e.status, HYSTERON_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(e.message.find("pressure_min = -inf, pressure_max = inf: feedforward: pressure_limits must be given"),
            std::string::npos)
      << e.message;
  hysteron_ff_pid_params given = f;
  given.pressure_min = 0.0;
  given.pressure_max = 0.5;
  const CRun g = c_ranges(bare, given);
  ASSERT_EQ(g.status, HYSTERON_OK) << g.message;
  for (const Range& x : g.ranges) EXPECT_EQ(x.hi, 0.5);
  hysteron_params_free(bare);

  // a loop with null limits, read through the C ABI, then created on a 0..0.4 MPa model
  LoopDesign d;
  d.sample_time = tc;
  d.pid = pid_table3();
  const std::string text = io::to_json(d).dump();
  hysteron_loop_params lp;
  ASSERT_EQ(hysteron_loop_params_from_json(text.c_str(), nullptr, &lp), HYSTERON_OK) << hysteron_last_error();
  EXPECT_EQ(lp.ff_pid.pressure_min, -inf);
  EXPECT_EQ(lp.ff_pid.pressure_max, inf);
  hysteron_params* model = c_model({0.0, 0.4});
  const CRun l = c_ranges(model, lp.ff_pid);
  ASSERT_EQ(l.status, HYSTERON_OK) << l.message;
  EXPECT_EQ(l.ranges[0].hi, 0.4);
  hysteron_params_free(model);
}

// A non-finite reference on the first sample (and the first after a reset) holds the position
// PID's output, the command the controller starts from: 0 within its pressure limits. With
// limits resolved from a model fitted above 0 MPa (0.05..0.4) the C ABI held 0, below the lower
// limit, where the library holds 0.05 (review of 2026-11-30). Since 2026-12-01 the C ABI steps
// the loop without the faulty argument, as the library does: the open loop, which has no
// position PID by default, commands its feedforward through the pressure loop, and the
// cascade's pressure loop acts on the held p_d; both within their limits.
TEST(PressureLimits, CApiFirstSampleFaultHoldsACommandWithinTheLimits) {
  hysteron_params* model = c_model({0.05, 0.4});
  const double nan = std::nan("");
  hysteron_ff_pid_params f;
  ASSERT_EQ(hysteron_ff_pid_default_params(&f), HYSTERON_OK);
  f.kp = 5.0;
  hysteron_ff_pid* fp = nullptr;
  ASSERT_EQ(hysteron_ff_pid_create(model, &f, &fp), HYSTERON_OK) << hysteron_last_error();
  hysteron_open_loop_params o;
  ASSERT_EQ(hysteron_open_loop_default_params(&o), HYSTERON_OK);
  hysteron_open_loop* ol = nullptr;
  ASSERT_EQ(hysteron_open_loop_create(model, &o, &ol), HYSTERON_OK) << hysteron_last_error();
  hysteron_cascade_params c;
  ASSERT_EQ(hysteron_cascade_default_params(&c), HYSTERON_OK);
  hysteron_cascade* cs = nullptr;
  ASSERT_EQ(hysteron_cascade_create(model, &c, &cs), HYSTERON_OK) << hysteron_last_error();
  for (int pass = 0; pass < 2; ++pass) {  // at create, then after a step and a reset
    double u = -1.0, duty = -2.0, pd = -1.0;
    EXPECT_EQ(hysteron_ff_pid_step(fp, nan, 0.0, 0.0, &u), HYSTERON_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(u, 0.05) << pass;
    u = -1.0;
    EXPECT_EQ(hysteron_open_loop_step(ol, nan, 0.0, 0.0, 0.0, &u), HYSTERON_ERROR_INVALID_ARGUMENT);
    EXPECT_TRUE(u >= 0.05 && u <= 0.4) << pass << ": " << u;
    EXPECT_EQ(hysteron_cascade_step(cs, nan, 0.0, 0.0, 0.0, &duty, &pd), HYSTERON_ERROR_INVALID_ARGUMENT);
    EXPECT_TRUE(duty >= -1.0 && duty <= 1.0) << pass << ": " << duty;
    EXPECT_EQ(pd, 0.05) << pass;
    EXPECT_EQ(hysteron_ff_pid_step(fp, 0.01, 0.01, 0.0, &u), HYSTERON_OK);
    EXPECT_EQ(hysteron_open_loop_step(ol, 0.01, 0.01, 0.0, 0.1, &u), HYSTERON_OK);
    EXPECT_EQ(hysteron_cascade_step(cs, 0.01, 0.01, 0.0, 0.1, &duty, &pd), HYSTERON_OK);
    ASSERT_EQ(hysteron_ff_pid_reset(fp), HYSTERON_OK);
    ASSERT_EQ(hysteron_open_loop_reset(ol), HYSTERON_OK);
    ASSERT_EQ(hysteron_cascade_reset(cs), HYSTERON_OK);
  }
  hysteron_ff_pid_free(fp);
  hysteron_open_loop_free(ol);
  hysteron_cascade_free(cs);
  hysteron_params_free(model);
}

// A model file whose output is in m (its "units") under the controllers' default model_scale of
// 1000 (mm) asked the inverse for outputs 1000x too large: every command at the top limit,
// silently. The C ABI's controllers refuse a model_scale that contradicts the model's length unit
// and take the one it implies; a model without units is as before.
TEST(PressureLimits, CApiModelScaleAgreesWithTheModelsLengthUnit) {
  const std::string body = R"("model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10,
      "rho": 0.3, "tau": 1.5, "alpha": 0.05, "input_limits": [0, 0.6])";
  hysteron_params *in_m = nullptr, *plain = nullptr;
  ASSERT_EQ(hysteron_params_from_json(("{" + body + R"(, "output_gain": 0.03, "units": {"input": "MPa", "output": "m"}})")
                                          .c_str(),
                                      &in_m),
            HYSTERON_OK)
      << hysteron_last_error();
  ASSERT_EQ(hysteron_params_from_json(("{" + body + R"(, "output_gain": 0.03})").c_str(), &plain), HYSTERON_OK);
  hysteron_ff_pid_params f;
  ASSERT_EQ(hysteron_ff_pid_default_params(&f), HYSTERON_OK);
  ASSERT_EQ(f.model_scale, 1000.0);
  hysteron_ff_pid* fp = nullptr;
  EXPECT_EQ(hysteron_ff_pid_create(in_m, &f, &fp), HYSTERON_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(fp, nullptr);
  EXPECT_NE(std::string(hysteron_last_error()).find("model_scale = 1000"), std::string::npos) << hysteron_last_error();
  EXPECT_NE(std::string(hysteron_last_error()).find("output is in m (1 per metre)"), std::string::npos);
  hysteron_open_loop_params o;
  ASSERT_EQ(hysteron_open_loop_default_params(&o), HYSTERON_OK);
  hysteron_open_loop* ol = nullptr;
  EXPECT_EQ(hysteron_open_loop_create(in_m, &o, &ol), HYSTERON_ERROR_INVALID_ARGUMENT);
  hysteron_cascade_params c;
  ASSERT_EQ(hysteron_cascade_default_params(&c), HYSTERON_OK);
  hysteron_cascade* cs = nullptr;
  EXPECT_EQ(hysteron_cascade_create(in_m, &c, &cs), HYSTERON_ERROR_INVALID_ARGUMENT);
  // with model_scale 1, the model in m commands what the same model without units does
  f.model_scale = 1.0;
  f.kp = 0.0;
  f.ki = 0.0;
  hysteron_ff_pid *a = nullptr, *b = nullptr;
  ASSERT_EQ(hysteron_ff_pid_create(in_m, &f, &a), HYSTERON_OK) << hysteron_last_error();
  ASSERT_EQ(hysteron_ff_pid_create(plain, &f, &b), HYSTERON_OK) << hysteron_last_error();
  for (const double r : {0.010, 0.020, 0.030}) {
    double ua = -1, ub = -2;
    ASSERT_EQ(hysteron_ff_pid_step(a, r, r, r, &ua), HYSTERON_OK);
    ASSERT_EQ(hysteron_ff_pid_step(b, r, r, r, &ub), HYSTERON_OK);
    EXPECT_EQ(ua, ub);
    EXPECT_GT(ua, 0.0);
    EXPECT_LT(ua, 0.6);
  }
  hysteron_ff_pid_free(a);
  hysteron_ff_pid_free(b);
  hysteron_params_free(in_m);
  hysteron_params_free(plain);
}

// A model file whose input is in kPa (bar, Pa, psi, ...) under the loops' pressures in MPa: the
// inverse saturated at the limits given in MPa (0.6 kPa), silently, through every loop of the C
// ABI, a loop from a result.json and the generated C (hysteron export --loop). Each now refuses
// it naming the unit and the file and saying to refit in MPa; a model in MPa, without units, or
// with an input unit that is no pressure is as before.
TEST(PressureLimits, ModelInputInAnotherPressureUnitIsRefusedByTheLoops) {
  const std::string body = R"("model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10,
      "rho": 0.3, "tau": 1.5, "alpha": 0.05, "output_gain": 30)";
  const auto with_units = [&](const std::string& units, const std::string& limits) {
    return "{" + body + ", \"input_limits\": " + limits + (units.empty() ? "" : ", \"units\": " + units) + "}";
  };
  test::TempDir dir;
  const std::string kpa_path = dir.write("model_kpa.json", with_units(R"({"input": "kPa", "output": "mm"})", "[0, 600]"));
  hysteron_params* kpa = nullptr;
  ASSERT_EQ(hysteron_params_from_file(kpa_path.c_str(), &kpa), HYSTERON_OK) << hysteron_last_error();
  hysteron_ff_pid_params f;
  ASSERT_EQ(hysteron_ff_pid_default_params(&f), HYSTERON_OK);
  hysteron_ff_pid* fp = nullptr;
  EXPECT_EQ(hysteron_ff_pid_create(kpa, &f, &fp), HYSTERON_ERROR_MODEL);
  EXPECT_EQ(fp, nullptr);
  const std::string said = hysteron_last_error();
  for (const char* part : {"hysteron_ff_pid_create: ", "model_kpa.json", "the model's input is in kPa, not MPa",
                           "refit the model with its pressure in MPa", "1 kPa = 0.001 MPa"})
    EXPECT_NE(said.find(part), std::string::npos) << part << " in: " << said;
  hysteron_open_loop_params o;
  ASSERT_EQ(hysteron_open_loop_default_params(&o), HYSTERON_OK);
  hysteron_open_loop* ol = nullptr;
  EXPECT_EQ(hysteron_open_loop_create(kpa, &o, &ol), HYSTERON_ERROR_MODEL);
  hysteron_cascade_params c;
  ASSERT_EQ(hysteron_cascade_default_params(&c), HYSTERON_OK);
  hysteron_cascade* cs = nullptr;
  EXPECT_EQ(hysteron_cascade_create(kpa, &c, &cs), HYSTERON_ERROR_MODEL);
  // the loop of a result.json on it (the fixture's runs are in MPa and mm)
  const std::string result = std::string(HYSTERON_SOURCE_DIR) + "/tests/c_api/result.json";
  hysteron_loop_params lp;
  ASSERT_EQ(hysteron_loop_params_from_file(result.c_str(), "compensated.sine", &lp), HYSTERON_OK)
      << hysteron_last_error();
  EXPECT_EQ(hysteron_ff_pid_create(kpa, &lp.ff_pid, &fp), HYSTERON_ERROR_MODEL);
  EXPECT_NE(std::string(hysteron_last_error()).find("is in kPa"), std::string::npos) << hysteron_last_error();
  // the other pressure units, by hysteron_params_from_json ("model JSON" named)
  for (const char* unit : {"bar", "Pa", "psi", "[KPa]", "barg", "psig"}) {  // gauge spellings too
    hysteron_params* m = nullptr;
    ASSERT_EQ(hysteron_params_from_json(with_units(fmt::format(R"({{"input": "{}"}})", unit), "[0, 6]").c_str(), &m),
              HYSTERON_OK)
        << hysteron_last_error();
    EXPECT_EQ(hysteron_ff_pid_create(m, &f, &fp), HYSTERON_ERROR_MODEL) << unit;
    EXPECT_NE(std::string(hysteron_last_error()).find("model JSON: the model's input is in"), std::string::npos)
        << hysteron_last_error();
    hysteron_params_free(m);
  }
  // MPa, no units, an input that is no pressure: as before
  for (const std::string& units : {std::string(R"({"input": "MPa", "output": "mm"})"), std::string(R"({"input": "MPag"})"), std::string(),
                                  std::string(R"({"input": "V"})"), std::string(R"({"input": "pressure"})")}) {
    hysteron_params* m = nullptr;
    ASSERT_EQ(hysteron_params_from_json(with_units(units, "[0, 0.6]").c_str(), &m), HYSTERON_OK);
    ASSERT_EQ(hysteron_ff_pid_create(m, &f, &fp), HYSTERON_OK) << units << ": " << hysteron_last_error();
    hysteron_ff_pid_free(fp);
    fp = nullptr;
    hysteron_params_free(m);
  }
  hysteron_params_free(kpa);
  // the generated C (hysteron export --loop, Python's export_c(controller=)) refuses it alike
  const ModelParams model = io::read_model_document(kpa_path).params;
  io::ExportOptions e;
  e.loop = io::read_loop_design(result, "compensated.sine");
  e.loop_source = "\"result.json\"";
  e.input_unit = "kPa";
  e.output_unit = "mm";
  const std::string refused = test::error_of([&] { (void)io::generate_c(model, e); });
  EXPECT_TRUE(test::has(refused, "the loop of \"result.json\": the model's input is in kPa, not MPa")) << refused;
  EXPECT_TRUE(test::has(refused, "refit the model with its pressure in MPa")) << refused;
  e.input_unit = "MPa";
  EXPECT_NO_THROW((void)io::generate_c(model, e));
  e.input_unit.clear();
  EXPECT_NO_THROW((void)io::generate_c(model, e));
  e.loop.reset();
  e.input_unit = "kPa";  // the model alone, in its own units: as before
  EXPECT_NO_THROW((void)io::generate_c(model, e));
}

// Inverse limits that share nothing with the model's input_limits (limits in MPa on a model in kPa)
// are refused by the library's Inverse, so by Python's Inverse and export_c, the generated C and the
// C ABI's hysteron_inverse_create alike; before 2026-12-01 only the CLI's --limits refused them.
// Limits that overlap them, or reach beyond them, are taken (the CLI warns on the latter).
TEST(PressureLimits, InverseLimitsOutsideTheModelsInputLimitsAreRefused) {
  const ModelParams kpa = test::rig_like_gpi({8.0, 626.0});
  InverseOptions o;
  o.input_limits = {0.0, 0.6};
  try {
    Inverse inv(kpa, o);
    ADD_FAILURE() << "limits [0, 0.6] on a model fitted on [8, 626] were taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lie outside the model's input_limits [8, 626]"), std::string::npos)
        << e.what();
  }
  o.input_limits = {0.0, 10.0};  // overlapping: taken
  EXPECT_NO_THROW(Inverse(kpa, o));
  o.input_limits = {0.0, 700.0};  // beyond on both sides: taken
  EXPECT_NO_THROW(Inverse(kpa, o));
  io::ExportOptions e;
  e.inverse_limits = Limits{0.0, 0.6};
  EXPECT_THROW(io::generate_c(kpa, e), Error);
  hysteron_params* p = c_model({8.0, 626.0});
  hysteron_inverse* ci = nullptr;
  EXPECT_EQ(hysteron_inverse_create(p, 0.0, 0.6, &ci), HYSTERON_ERROR_MODEL);
  EXPECT_NE(std::string(hysteron_last_error()).find("outside the model's input_limits"), std::string::npos)
      << hysteron_last_error();
  EXPECT_EQ(ci, nullptr);
  EXPECT_EQ(hysteron_inverse_create(p, 0.0, 10.0, &ci), HYSTERON_OK) << hysteron_last_error();
  hysteron_inverse_free(ci);
  hysteron_params_free(p);
}
