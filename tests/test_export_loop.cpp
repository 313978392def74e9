// The loop in generated C (hysteron export --loop, src/io/export_loop.cpp) against the
// library's: for loops of every kind, anti-windup rule, shaper and PWM setting, generate the
// C file with the loop, compile it with tests/export/loop_driver.c and step it over 20,000
// samples of a reference, measurements that jump far enough to saturate every PID, pressure
// readings and non-finite inputs, with resets; make_controller + step() fed the same must
// command the same (|difference| <= 1e-12; bit-identical on x86-64, as the model's export).
// The preview of the reference must equal feedforward_preview's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "export_loop_util.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"
#include "temp_dir.hpp"

using namespace hysteron;

namespace {

// Pressure [MPa] -> contraction [mm]: a PI model with about 0-35 mm over 0-0.6 MPa, a gpi
// with a units map, and an mpi-asym (numerical inverse).
ModelParams pi_model() {
  return io::model_from_json(io::parse_json(R"({"model": "pi", "q": 30, "r": [0.02, 0.05, 0.1, 0.15],
      "p": [12, 9, 6, 3], "input_limits": [0, 0.6]})", "pi"), "pi");
}
ModelParams gpi_units_model() {  // a units map: x_m = (x - 0.05) / 0.5, y = 1 + 30 v
  return io::model_from_json(io::parse_json(R"({"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05],
      "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05, "input_origin": 0.05, "input_scale": 0.5,
      "output_offset": 1.0, "output_gain": 30.0, "input_limits": [0, 0.6]})", "gpi"), "gpi");
}
ModelParams gpi_decreasing_model() {  // y = 60 - 30 v: decreasing (a sensor reading length, not contraction)
  return io::model_from_json(io::parse_json(R"({"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05],
      "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05, "input_origin": 0.05, "input_scale": 0.5,
      "output_offset": 60.0, "output_gain": -30.0, "input_limits": [0, 0.6]})", "gpi"), "gpi");
}
ModelParams asym_model() {
  return io::model_from_json(io::parse_json(R"({"model": "mpi-asym", "q": 30, "r": [0.02, 0.05, 0.1],
      "p": [10, 8, 5], "ascending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]},
      "descending": {"envelope": "affine", "c": [0.9, 0.01]}, "input_limits": [0, 0.6]})", "asym"), "asym");
}

PidParams pid(double kp, double ki, double kd, double tf, AntiWindup aw) {
  PidParams p;
  p.kp = kp;
  p.ki = ki;
  p.kd = kd;
  p.derivative_filter = tf;
  p.anti_windup = aw;
  p.out_min = -0.6;
  p.out_max = 0.6;
  return p;
}

enum class M { pi, asym, gpi_units, gpi_decreasing };
ModelParams model_of(M m) {
  return m == M::pi ? pi_model() : m == M::asym ? asym_model() : m == M::gpi_units ? gpi_units_model()
                                                                                   : gpi_decreasing_model();
}

struct Case {
  std::string name;
  LoopDesign design;
  M model = M::pi;
  bool single = false;
};

std::vector<Case> cases() {
  std::vector<Case> v;
  {
    LoopDesign d;  // gpi-pid's shape: shaped preview, filtered D, lag compensation
    d.kind = LoopDesign::Kind::feedforward_pid;
    d.feedforward.lag_time_constant = 0.02;
    d.pid = pid(9.8, 82, 0.29, 0.008, AntiWindup::conditional);
    d.feedforward_lead = 40;
    d.shaper = LoopDesign::Shaper{0.9, 0.1, 150, 10};
    v.push_back({"ff_pid_conditional_shaped", d, M::pi, false});
    // with a limit-cycle guard that the inputs' jumps trip (a short memory, a low count)
    d.pid->guard = PidGuard{.period = 0.3, .amplitude = 0.002, .count = 1.5, .memory = 10.0, .factor = 0.7,
                            .min_scale = 0.2};
    v.push_back({"ff_pid_guarded", d, M::pi, false});
  }
  {
    LoopDesign d;  // back-calculation with setpoint weights; limits whose reset output is not 0
    d.kind = LoopDesign::Kind::feedforward_pid;
    d.feedforward.pressure_limits = {0.05, 0.55};
    d.pid = pid(20, 150, 0.0, 0.0, AntiWindup::back_calculation);
    d.pid->setpoint_weight_p = 0.7;
    d.pid->setpoint_weight_d = 0.3;
    v.push_back({"ff_pid_back_calculation_asym", d, M::asym, true});
  }
  {
    LoopDesign d;  // the open loop as published: no position loop
    d.kind = LoopDesign::Kind::open_loop;
    d.pressure_gain = 0.5;
    d.feedforward_lead = 25;
    v.push_back({"open_loop_published", d, M::asym, false});
  }
  {
    LoopDesign d;  // with a position PID (no anti-windup, unfiltered D)
    d.kind = LoopDesign::Kind::open_loop;
    d.pressure_gain = 1.3;
    d.pid = pid(6, 30, 0.05, 0.0, AntiWindup::none);
    d.shaper = LoopDesign::Shaper{0.6, 0.4, 90, 0};
    v.push_back({"open_loop_position_pid", d, M::gpi_units, true});
  }
  {
    LoopDesign d;  // the valves: quantised PWM with a dead band and a minimum duty
    d.kind = LoopDesign::Kind::cascade_pwm;
    d.pid = pid(8, 40, 0.2, 0.01, AntiWindup::conditional);
    PidParams pp = pid(12, 60, 0.0, 0.0, AntiWindup::conditional);
    pp.out_min = -1;
    pp.out_max = 1;
    d.pressure_pid = pp;
    d.pwm = PwmParams{1.5, 0.01, 0.05, 0.95, 0.01};
    d.feedforward_lead = 30;
    d.shaper = LoopDesign::Shaper{0.8, 0.2, 120, 5};
    v.push_back({"cascade_quantised_pwm", d, M::asym, false});
    d.pid->guard = PidGuard{.period = 0.3, .amplitude = 0.002, .count = 1.5, .memory = 10.0};
    v.push_back({"cascade_guarded", d, M::asym, true});
  }
  {
    LoopDesign d;  // continuous PWM, back-calculation in the pressure loop
    d.kind = LoopDesign::Kind::cascade_pwm;
    d.feedforward.lag_time_constant = 0.01;
    d.pid = pid(5, 20, 0.0, 0.0, AntiWindup::back_calculation);
    d.pid->tracking_time = 0.05;
    PidParams pp = pid(4, 30, 0.0, 0.0, AntiWindup::back_calculation);
    pp.out_min = -2;  // narrowed to [-1, 1] by the cascade
    pp.out_max = 2;
    d.pressure_pid = pp;
    d.pwm = PwmParams{1.0, 0.0, 0.0, 1.0, 0.0};
    v.push_back({"cascade_continuous_pwm", d, M::pi, true});
  }
  {
    // a decreasing model: each position PID fed sign * (r, y) (feedback_sign -1)
    LoopDesign d;
    d.kind = LoopDesign::Kind::feedforward_pid;
    d.pid = pid(9.8, 82, 0.29, 0.008, AntiWindup::conditional);
    d.feedforward_lead = 40;
    v.push_back({"ff_pid_decreasing_model", d, M::gpi_decreasing, false});
    d.kind = LoopDesign::Kind::open_loop;
    d.pressure_gain = 0.5;
    v.push_back({"open_loop_decreasing_model", d, M::gpi_decreasing, true});
    d.kind = LoopDesign::Kind::cascade_pwm;
    PidParams pp = pid(12, 60, 0.0, 0.0, AntiWindup::conditional);
    pp.out_min = -1;
    pp.out_max = 1;
    d.pressure_pid = pp;
    d.pwm = PwmParams{1.0, 0.0, 0.0, 1.0, 0.0};
    v.push_back({"cascade_decreasing_model", d, M::gpi_decreasing, false});
  }
  return v;
}

Case case_named(const std::string& name) {
  for (const Case& c : cases())
    if (c.name == name) return c;
  throw std::logic_error("no case " + name);
}

struct Inputs {
  std::vector<double> reference, measured, pressure;
  std::vector<std::size_t> resets;
  std::vector<std::size_t> guard_restarts;  // restart_guard before these samples (after a reset there)
  std::size_t nonfinite = 0;
};

Inputs make_inputs(std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Inputs in;
  double meas_offset = 0.0, p = 0.3;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k);
    const double r = 0.016 + 0.012 * std::sin(2 * M_PI * t / 2000) + 0.004 * std::sin(2 * M_PI * 3 * t / 2000);
    if (unit(rng) < 0.002) meas_offset = (unit(rng) - 0.5) * 0.08;  // jumps that saturate the PIDs
    meas_offset *= 0.995;
    double m = r + meas_offset + 0.0005 * (unit(rng) - 0.5);
    p = std::clamp(p + 0.02 * (unit(rng) - 0.5), -0.05, 0.7);
    double pr = p, ref = r;
    const double a = unit(rng);
    if (a > 0.998) {  // a non-finite value in one of the inputs
      const double bad = a > 0.9995 ? std::numeric_limits<double>::quiet_NaN()
                         : a > 0.999 ? std::numeric_limits<double>::infinity()
                                     : -std::numeric_limits<double>::infinity();
      const int which = static_cast<int>(unit(rng) * 3);
      (which == 0 ? ref : which == 1 ? m : pr) = bad;
      ++in.nonfinite;
    }
    in.reference.push_back(ref);
    in.measured.push_back(m);
    in.pressure.push_back(pr);
  }
  for (std::size_t r : {n / 5, n / 2, (4 * n) / 5}) in.resets.push_back(r);
  return in;
}

void reset(Controller& c) {
  std::visit([](auto& l) { l.reset(); }, c);
}

struct Compared {
  double worst_command = 0.0, worst_duty = 0.0, worst_preview = 0.0;
  std::size_t exact = 0, n = 0, at_limits = 0, nonzero_duty = 0;
  std::size_t guard_cuts = 0;  // the most cuts of the library's position PID between two resets
  std::size_t position_faults = 0;  // the most faults of the library's position PID between two resets
  // the counts after each step (loop_driver.c's order) that differ from the library's, the first such
  std::size_t counts_differ = 0;
  std::string first_counts_difference;
  // resets where a count of the library's loop was > 0 just before (the resets the comparison exercises)
  std::size_t resets_with_faults = 0, resets_with_cuts = 0;
  std::size_t restarts_with_cuts = 0;  // guard restarts where the library's position PID had cut its gains
};

// The position PID of whichever loop `c` holds.
const Pid& position_pid(const Controller& c) {
  return std::visit(
      [](const auto& l) -> const Pid& {
        if constexpr (std::is_same_v<std::decay_t<decltype(l)>, FeedforwardPidController>)
          return l.pid();
        else
          return l.position();
      },
      c);
}

// The library's counts in loop_driver.c's order: the position PID's faults, guard_cuts, gain_scale, the inverse's
// faults and, with the valves, the pressure PID's faults, guard_cuts, gain_scale and the PWM's faults.
std::vector<double> library_counts(const Controller& c) {
  const Pid& pos = position_pid(c);
  std::vector<double> v{static_cast<double>(pos.faults()), static_cast<double>(pos.state().guard_cuts),
                        pos.state().gain_scale};
  std::visit([&](const auto& l) { v.push_back(static_cast<double>(l.feedforward().faults())); }, c);
  if (const auto* cas = std::get_if<CascadePwmController>(&c))
    v.insert(v.end(), {static_cast<double>(cas->pressure().faults()),
                       static_cast<double>(cas->pressure().state().guard_cuts), cas->pressure().state().gain_scale,
                       static_cast<double>(cas->pwm().faults())});
  return v;
}

std::string counts_text(const std::vector<double>& v) {
  std::string t;
  for (double x : v) {
    if (!t.empty()) t += ' ';
    t += fmt::format("{}", x);
  }
  return t;
}

// The library's loop on the same inputs (the reference's finite values previewed, as a user
// would: the preview of a non-finite sample is fed as is).
Compared compare(const Case& c, const Inputs& in, const test::LoopRun& got, const std::vector<double>& preview) {
  Compared r;
  const ModelParams model = model_of(c.model);
  Controller ctl = make_controller(c.design, model);
  const Limits lim = pressure_limits(ctl);  // the design's, or where unset (most cases) the model's [0, 0.6]
  std::size_t next = 0, next_restart = 0;
  for (std::size_t k = 0; k < in.reference.size() && k < got.command.size(); ++k) {
    while (next < in.resets.size() && in.resets[next] <= k) {
      if (in.resets[next] == k) {
        const std::vector<double> before = library_counts(ctl);
        bool faults = before[0] > 0 || before[3] > 0, cuts = before[1] > 0;
        if (before.size() > 4) {
          faults = faults || before[4] > 0 || before[7] > 0;
          cuts = cuts || before[5] > 0;
        }
        r.resets_with_faults += faults;
        r.resets_with_cuts += cuts;
        reset(ctl);
      }
      ++next;
    }
    while (next_restart < in.guard_restarts.size() && in.guard_restarts[next_restart] <= k) {
      if (in.guard_restarts[next_restart] == k) {
        r.restarts_with_cuts += position_pid(ctl).state().guard_cuts > 0;
        std::visit([](auto& l) { l.restart_guard(); }, ctl);
      }
      ++next_restart;
    }
    const LoopOutput o = step(ctl, in.reference[k], preview[k], in.measured[k], in.pressure[k]);
    if (k < got.counts.size()) {
      const std::vector<double> lib = library_counts(ctl);
      if (lib != got.counts[k]) {
        if (r.counts_differ++ == 0)
          r.first_counts_difference = "sample " + std::to_string(k) + ": library " + counts_text(lib) +
                                      ", generated C " + counts_text(got.counts[k]);
      }
    }
    r.guard_cuts = std::max(r.guard_cuts, position_pid(ctl).state().guard_cuts);
    r.position_faults = std::max(r.position_faults, position_pid(ctl).faults());
    r.worst_command = std::max(r.worst_command, std::abs(o.command_mpa - got.command[k]));
    r.worst_duty = std::max(r.worst_duty, std::abs(o.duty - got.duty[k]));
    r.exact += o.command_mpa == got.command[k] && o.duty == got.duty[k];
    r.at_limits += o.command_mpa == lim.lo || o.command_mpa == lim.hi;
    r.nonzero_duty += o.duty != 0.0;
    ++r.n;
  }
  for (std::size_t k = 0; k < preview.size() && k < got.preview.size(); ++k)
    r.worst_preview = std::max(r.worst_preview, std::abs(preview[k] - got.preview[k]));
  return r;
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class ExportLoop : public ::testing::TestWithParam<Case> {};

TEST_P(ExportLoop, StepsAsTheLibrarysLoop) {
  if (!test::have_gcc()) GTEST_SKIP() << "gcc not found: generated C not compiled";
  const Case& c = GetParam();
  test::TempDir dir;
  const Inputs in = make_inputs(20000, 777u + static_cast<unsigned>(c.name.size()));
  // the preview of the reference with its non-finite samples, as the C function computes it
  const std::vector<double> preview = feedforward_preview(c.design, in.reference);
  const test::LoopRun got = test::run_generated_loop(c.design, model_of(c.model), dir.file("."),
                                                     c.single, in.reference, preview, in.measured, in.pressure,
                                                     in.resets, {}, in.guard_restarts);
  ASSERT_EQ(got.error, "");
  ASSERT_EQ(got.command.size(), in.reference.size());
  ASSERT_EQ(got.preview.size(), in.reference.size());
  const Compared r = compare(c, in, got, preview);
  EXPECT_LE(r.worst_command, 1e-12) << "MPa";
  EXPECT_LE(r.worst_duty, 1e-12);
  EXPECT_EQ(r.worst_preview, 0.0) << "the preview takes no arithmetic but the shaper's, in the same order";
#if defined(__x86_64__) && defined(__SSE2__)
  EXPECT_EQ(r.exact, r.n) << "not bit-identical to the library's loop";
#endif
  // the fault counts and the guard's cuts agree after every step, across the resets too (review s18: the
  // library's Pid::reset kept faults, the generated C's pid_reset zeroed them)
  ASSERT_EQ(got.counts.size(), r.n);
  EXPECT_EQ(got.counts[0].size(), c.design.kind == LoopDesign::Kind::cascade_pwm ? 8u : 4u);
  EXPECT_EQ(r.counts_differ, 0u) << "first: " << r.first_counts_difference;
  // what the inputs exercised
  EXPECT_GT(in.nonfinite, 10u);
  EXPECT_GE(r.resets_with_faults, 2u) << "no reset after a fault: the reset of the counts is not compared";
  EXPECT_GT(r.at_limits, 10u) << "the loop never commanded a pressure limit";
  if (c.design.kind == LoopDesign::Kind::cascade_pwm) {
    EXPECT_GT(r.nonzero_duty, r.n / 10);
  }
  if (c.design.pid && c.design.pid->guard.enabled()) {
    EXPECT_GE(r.guard_cuts, 1u) << "the limit-cycle guard never cut the gains";
    EXPECT_GE(r.resets_with_cuts, 1u) << "no reset after a cut: the reset of the cut gains is not compared";
    // the guard restarted (lp_loop_restart_guard, Pid::restart_guard) at three samples of a run without resets
    Inputs again = in;
    again.resets.clear();
    again.guard_restarts = {in.reference.size() / 4, in.reference.size() / 2, (3 * in.reference.size()) / 4};
    test::TempDir dir2;
    const test::LoopRun got2 = test::run_generated_loop(c.design, model_of(c.model), dir2.file("."), c.single,
                                                        again.reference, preview, again.measured, again.pressure, {},
                                                        {}, again.guard_restarts);
    ASSERT_EQ(got2.error, "");
    const Compared r2 = compare(c, again, got2, preview);
    EXPECT_LE(r2.worst_command, 1e-12) << "guard restarts: MPa";
    EXPECT_LE(r2.worst_duty, 1e-12) << "guard restarts";
#if defined(__x86_64__) && defined(__SSE2__)
    EXPECT_EQ(r2.exact, r2.n) << "guard restarts: not bit-identical to the library's loop";
#endif
    EXPECT_EQ(r2.counts_differ, 0u) << "guard restarts: first: " << r2.first_counts_difference;
    EXPECT_GE(r2.restarts_with_cuts, 1u) << "no guard restart after a cut: lp_loop_restart_guard is not compared";
    std::printf("  %s: guard restarted %zu times after cuts, bit-identical %zu / %zu\n", c.name.c_str(),
                r2.restarts_with_cuts, r2.exact, r2.n);
  }
  std::printf("  %s: %zu samples (%zu non-finite inputs, %zu at a pressure limit, %zu resets, %zu after faults, %zu "
              "after cuts, %zu guard restarts after cuts): largest difference %.3g MPa, %.3g duty, %.3g preview; "
              "bit-identical %zu / %zu; counts differ after %zu steps\n",
              c.name.c_str(), r.n, in.nonfinite, r.at_limits, in.resets.size(), r.resets_with_faults,
              r.resets_with_cuts, r.restarts_with_cuts, r.worst_command, r.worst_duty, r.worst_preview, r.exact, r.n,
              r.counts_differ);
}

INSTANTIATE_TEST_SUITE_P(Export, ExportLoop, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& p) { return p.param.name; });

// Extreme finite inputs (review s17): among the samples of make_inputs, every 7th from sample 100 on
// has the reference and the measurement at +-1e308 of opposite signs (the PID's error r - y overflows),
// or one of reference, measurement, pressure at +-1e308, alternating. The generated C must hold
// exactly the samples the library's PIDs hold (faults) and step bit for bit as the library's loop,
// also for the review's configuration: setpoint weights 0, conditional anti-windup, K_p <= 1, guarded.
TEST(ExportLoopCheck, ExtremeFiniteInputsStepAsTheLibrarysLoop) {
  if (!test::have_gcc()) GTEST_SKIP() << "gcc not found: generated C not compiled";
  std::vector<Case> all = cases();
  {
    LoopDesign d;
    d.kind = LoopDesign::Kind::feedforward_pid;
    d.pid = pid(0.5, 20, 0.01, 0.01, AntiWindup::conditional);
    d.pid->setpoint_weight_p = 0.0;
    d.pid->setpoint_weight_d = 0.0;
    d.pid->guard = PidGuard{.period = 0.3, .amplitude = 0.002, .count = 1.5, .memory = 10.0};
    all.push_back({"ff_pid_weights_0_guarded", d, M::pi, false});
  }
  Inputs in = make_inputs(3000, 4242u);
  const double big = 1e308;
  for (std::size_t k = 100; k < in.reference.size(); k += 7) {
    const double s = (k / 7) % 2 == 0 ? 1.0 : -1.0;
    switch ((k / 7) % 5) {
      case 0:
      case 1: in.reference[k] = s * big; in.measured[k] = -s * big; break;
      case 2: in.measured[k] = s * big; break;
      case 3: in.reference[k] = s * big; break;
      default: in.pressure[k] = s * big; break;
    }
  }
  // the samples whose error r - y overflows (each a fault of the position PID), the most between two resets
  // (a reset restarts the count)
  std::size_t overflowing = 0, cur = 0, next = 0;
  for (std::size_t k = 0; k < in.reference.size(); ++k) {
    if (next < in.resets.size() && in.resets[next] == k) {
      cur = 0;
      ++next;
    }
    cur += std::isinf(in.reference[k] - in.measured[k]);
    overflowing = std::max(overflowing, cur);
  }
  ASSERT_GT(overflowing, 40u);
  for (const Case& c : all) {
    test::TempDir dir;
    const std::vector<double> preview = feedforward_preview(c.design, in.reference);
    const test::LoopRun got = test::run_generated_loop(c.design, model_of(c.model), dir.file("."), c.single,
                                                       in.reference, preview, in.measured, in.pressure, in.resets, {},
                                                       in.guard_restarts);
    ASSERT_EQ(got.error, "") << c.name;
    ASSERT_EQ(got.command.size(), in.reference.size()) << c.name;
    const Compared r = compare(c, in, got, preview);
    EXPECT_LE(r.worst_command, 1e-12) << c.name << " [MPa]";
    EXPECT_LE(r.worst_duty, 1e-12) << c.name;
#if defined(__x86_64__) && defined(__SSE2__)
    EXPECT_EQ(r.exact, r.n) << c.name << ": not bit-identical to the library's loop";
#endif
    if (c.design.pid) {
      EXPECT_GE(r.position_faults, overflowing) << c.name << ": the extremes held too few samples of the position PID";
    }
    EXPECT_EQ(r.counts_differ, 0u) << c.name << ": first: " << r.first_counts_difference;
    std::printf("  %s: %zu samples with extremes: bit-identical %zu, position PID faults %zu (most between resets)\n",
                c.name.c_str(), r.n, r.exact, r.position_faults);
  }
}

// Review s18: a limit-cycle guard whose limit a T_u / pi is just above DBL_MIN (a = 1e-307 at T_u = 1 s, and
// limits within 1.0000001 DBL_MIN) held every sample once its integral of |e| dt exceeded about 4 (the integral
// over the limit overflowed), in the library and the generated C alike. Driven by ordinary errors (a constant
// error of 1 m, or a pressure error of 20 MPa, for 10 s, then square waves of +-20 with half-cycles of T_u / 2),
// the guarded PIDs of the generated C and the library hold no sample, step bit for bit alike, with the same counts,
// and the square waves make them cut their gains.
TEST(ExportLoopCheck, GuardNearDblMinKeepsSteppingAsTheLibrarysLoop) {
  if (!test::have_gcc()) GTEST_SKIP() << "gcc not found: generated C not compiled";
  const double dbl_min = std::numeric_limits<double>::min();
  for (const auto& [tu, a] : {std::pair{1.0, 1e-307}, std::pair{0.3, 1.0000001 * dbl_min * M_PI / 0.3}}) {
    const PidGuard guard{.period = tu, .amplitude = a};
    std::vector<Case> all;
    {
      LoopDesign d;
      d.kind = LoopDesign::Kind::feedforward_pid;
      d.pid = pid(0.001, 0.001, 0.0, 0.0, AntiWindup::none);
      d.pid->guard = guard;
      all.push_back({"ff_pid_guard_near_dbl_min", d, M::pi, false});
    }
    {
      LoopDesign d;
      d.kind = LoopDesign::Kind::cascade_pwm;
      d.pid = pid(0.001, 0.001, 0.0, 0.0, AntiWindup::none);
      d.pid->guard = guard;
      PidParams pp = pid(0.001, 0.001, 0.0, 0.0, AntiWindup::none);
      pp.out_min = -1;
      pp.out_max = 1;
      pp.guard = guard;
      d.pressure_pid = pp;
      d.pwm = PwmParams{1.0, 0.0, 0.0, 1.0, 0.0};
      all.push_back({"cascade_guards_near_dbl_min", d, M::pi, true});
    }
    const std::size_t n = 20000, half = static_cast<std::size_t>(std::lround(tu / 2 / 1e-3));
    Inputs in;
    for (std::size_t k = 0; k < n; ++k) {
      const double r = 0.016 + 0.004 * std::sin(2 * M_PI * static_cast<double>(k) / 2000);
      const double sq = ((k - n / 2) / half) % 2 == 0 ? 20.0 : -20.0;
      in.reference.push_back(r);
      in.measured.push_back(k < n / 2 ? r - 1.0 : r + sq);  // e = 1 m, then -+20 m
      in.pressure.push_back(k < n / 2 ? -20.0 : sq);        // p_d - p about 20 MPa, then -+20 MPa
    }
    for (const Case& c : all) {
      const std::string what = c.name + fmt::format(", T_u {} s, a {}", tu, a);
      test::TempDir dir;
      const std::vector<double> preview = feedforward_preview(c.design, in.reference);
      const test::LoopRun got = test::run_generated_loop(c.design, model_of(c.model), dir.file("."), c.single,
                                                         in.reference, preview, in.measured, in.pressure);
      ASSERT_EQ(got.error, "") << what;
      ASSERT_EQ(got.counts.size(), n) << what;
      const Compared r = compare(c, in, got, preview);
#if defined(__x86_64__) && defined(__SSE2__)
      EXPECT_EQ(r.exact, r.n) << what << ": not bit-identical to the library's loop";
#endif
      EXPECT_EQ(r.counts_differ, 0u) << what << ": first: " << r.first_counts_difference;
      // the generated C's own counts at the end: no sample held, the gains cut
      const std::vector<double>& last = got.counts.back();
      EXPECT_EQ(last[0], 0.0) << what << ": the position PID held samples";
      EXPECT_GE(last[1], 1.0) << what << ": the position PID's guard never cut";
      if (c.design.kind == LoopDesign::Kind::cascade_pwm) {
        EXPECT_EQ(last[4], 0.0) << what << ": the pressure PID held samples";
        EXPECT_GE(last[5], 1.0) << what << ": the pressure PID's guard never cut";
      }
      std::printf("  %s: bit-identical %zu / %zu, final counts %s\n", what.c_str(), r.exact, r.n,
                  counts_text(last).c_str());
    }
  }
}

// The open loop without a pressure loop (pressure_gain 0) and absurd pressure limits: p_d at the
// upper limit 1e300 and a finite pressure reading of -DBL_MAX made p_d - p overflow, and 0 * inf
// commanded NaN (audit2 F2), in the library and the generated C alike. Now p_d itself, finite,
// in both, bit for bit; with k_p > 0 the overflowing term takes the command to a limit.
TEST(ExportLoopCheck, ZeroPressureGainNeverCommandsNaN) {
  const double big = std::numeric_limits<double>::max();
  const std::vector<double> reference = {1e3, 1e3, 1e3, 0.01, -1e3, 0.02},
                            measured = {0.0, 0.0, 0.0, 0.0, 0.0, 0.01},
                            pressure = {-big, big, 0.2, -big, big, 0.3};
  for (const double k_p : {0.0, 0.5}) {
    LoopDesign d;
    d.kind = LoopDesign::Kind::open_loop;
    d.pressure_gain = k_p;
    d.feedforward.pressure_limits = {-1e300, 1e300};
    const ModelParams model = gpi_units_model();  // saturating: 1 km of reference is beyond reach
    Controller ctl = make_controller(d, model);
    std::vector<double> lib;
    for (std::size_t k = 0; k < reference.size(); ++k) {
      lib.push_back(step(ctl, reference[k], reference[k], measured[k], pressure[k]).command_mpa);
      EXPECT_TRUE(std::isfinite(lib.back())) << "k_p " << k_p << ", sample " << k << ": " << lib.back();
    }
    if (k_p == 0.0) {
      EXPECT_EQ(lib[0], 1e300);  // p_d: the upper limit
      EXPECT_EQ(lib[1], 1e300);
    } else {
      EXPECT_EQ(lib[0], 1e300);   // p_d + 0.5 (p_d + DBL_MAX): +inf, clamped
      EXPECT_EQ(lib[1], -1e300);  // p_d + 0.5 (p_d - DBL_MAX)
    }
    if (!test::have_gcc()) continue;
    test::TempDir dir;
    const test::LoopRun got =
        test::run_generated_loop(d, model, dir.file("."), true, reference, reference, measured, pressure);
    ASSERT_EQ(got.error, "");
    ASSERT_EQ(got.command.size(), lib.size());
    for (std::size_t k = 0; k < lib.size(); ++k)
      EXPECT_EQ(got.command[k], lib[k]) << "k_p " << k_p << ", sample " << k << ": the generated C's command";
  }
}

// The comparison can fail: the C file of a loop whose K_p, pressure PID K_i or shaper weight
// is 1e-9 off (relative), compared with the library's loop, differs.
TEST(ExportLoopCheck, PerturbedNumberIsDetected) {
  if (!test::have_gcc()) GTEST_SKIP() << "gcc not found";
  const Case c = case_named("cascade_quantised_pwm");
  const Inputs in = make_inputs(5000, 99u);
  const std::vector<double> preview = feedforward_preview(c.design, in.reference);
  for (int which = 0; which < 3; ++which) {
    LoopDesign d = c.design;
    if (which == 0) d.pid->kp *= 1 + 1e-9;
    if (which == 1) d.pressure_pid->ki *= 1 + 1e-9;
    if (which == 2) d.shaper->a2 *= 1 + 1e-9;
    test::TempDir dir;
    // the C file's own preview is compared with the unperturbed design's
    const test::LoopRun got =
        test::run_generated_loop(d, asym_model(), dir.file("."), false, in.reference, preview, in.measured, in.pressure);
    ASSERT_EQ(got.error, "");
    const Compared r = compare(c, in, got, preview);
    EXPECT_GT(std::max({r.worst_command, r.worst_duty, r.worst_preview}), 0.0) << "perturbation " << which;
    EXPECT_LT(r.exact, r.n) << "perturbation " << which;
  }
}

// ---- with iterative learning (src/io/export_learning.cpp) --------------------------------

struct LearningCase {
  Case loop;
  bool warm = false;  // start from a correction (lp_learning_warm_start; IterativeLearning::reset(c))
};

std::vector<LearningCase> learning_cases() {
  const std::vector<Case> base = cases();
  std::vector<LearningCase> v;
  {
    Case c = base[0];  // supervision as the experiments': rise 0, L doubled up to 0.5; held after 1 halving
    c.name = "ff_pid_supervised_held";
    // pressure limits the PID (+-0.6) never reaches: no error is zeroed, so each period's error is
    // the inputs' (the errors of every third period made larger below: the supervisor acts)
    c.design.feedforward.pressure_limits = {-1.0, 1.0};
    const LearningParams p{.period = 1500, .gain = 0.2, .lead = 20, .half_width = 40,
                           .lookahead = c.design.feedforward_lead, .rise_tolerance = 0.0, .hold_after_cuts = 1,
                           .max_gain = 0.5};
    c.design.learning = LoopDesign::Learning{p, 0.7, 0.0, 0, 0, false};
    v.push_back({c, false});
  }
  {
    Case c = base[3];  // no supervision, no Q-filter, a correction limit; one .c file
    c.name = "open_loop_unsupervised_limited";
    const LearningParams p{.period = 2000, .gain = 0.5, .max_correction = 0.002};
    c.design.learning = LoopDesign::Learning{p, 0.9, 0.0, 0, 0, false};
    v.push_back({c, false});
  }
  {
    Case c = base[4];  // a wide filter (taps beyond its reach skipped; h above the period, its 2 x 454
                       // summed taps within it), a tolerance, warm start
    c.name = "cascade_wide_filter_warm";
    const LearningParams p{.period = 2500, .gain = 0.3, .lead = 35, .half_width = 5000,
                           .lookahead = c.design.feedforward_lead, .max_correction = 0.003, .rise_tolerance = 0.1};
    c.design.learning = LoopDesign::Learning{p, 0.5, 0.0, 0, 0, false};
    v.push_back({c, true});
  }
  return v;
}

void PrintTo(const LearningCase& c, std::ostream* os) { *os << c.loop.name; }

class ExportLearning : public ::testing::TestWithParam<LearningCase> {};

TEST_P(ExportLearning, StepsAsTheLibrarysLearningLoop) {
  if (!test::have_gcc()) GTEST_SKIP() << "gcc not found: generated C not compiled";
  const Case& c = GetParam().loop;
  const LoopDesign& d = c.design;
  const LearningParams& lp = d.learning->params;
  test::TempDir dir;
  Inputs in = make_inputs(20000, 4242u + static_cast<unsigned>(c.name.size()));
  if (lp.rise_tolerance == 0.0)  // every third period measured 1 mm off: its error rises, the supervisor acts
    for (std::size_t k = 0; k < in.measured.size(); ++k)
      if ((k / lp.period) % 3 == 2) in.measured[k] += 0.001;
  const std::vector<double> preview = feedforward_preview(d, in.reference);
  std::vector<double> warm;
  if (GetParam().warm)  // a smooth correction, partly beyond the limit (clipped by both)
    for (std::size_t k = 0; k < lp.period; ++k)
      warm.push_back(0.005 * std::sin(2 * M_PI * static_cast<double>(k) / static_cast<double>(lp.period)));
  const test::LoopRun got = test::run_generated_loop(d, model_of(c.model), dir.file("."), c.single, in.reference,
                                                     preview, in.measured, in.pressure, in.resets, warm);
  ASSERT_EQ(got.error, "");
  ASSERT_EQ(got.command.size(), in.reference.size());
  ASSERT_EQ(got.correction.size(), in.reference.size());
  EXPECT_EQ(got.warm_status, 0);

  // the library: make_controller + IterativeLearning, stepped by step(Controller&, IterativeLearning&, ...)
  Controller ctl = make_controller(d, model_of(c.model));
  IterativeLearning ilc(lp);
  if (!warm.empty()) ilc.reset(warm);
  double worst_command = 0.0, worst_duty = 0.0, worst_correction = 0.0, largest_correction = 0.0;
  std::size_t exact = 0, next = 0, periods = 0, cuts = 0, raises = 0;
  bool held = false;
  for (std::size_t k = 0; k < in.reference.size(); ++k) {
    while (next < in.resets.size() && in.resets[next] <= k) {
      if (in.resets[next] == k) {
        periods += ilc.iteration();
        cuts += ilc.gain_cuts();
        raises += ilc.gain_raises();
        held = held || ilc.held();
        reset(ctl);
        ilc.reset();
      }
      ++next;
    }
    const double c0 = ilc.correction(0);
    const LoopOutput o = step(ctl, ilc, d, in.reference[k], preview[k], in.measured[k], in.pressure[k]);
    worst_command = std::max(worst_command, std::abs(o.command_mpa - got.command[k]));
    worst_duty = std::max(worst_duty, std::abs(o.duty - got.duty[k]));
    worst_correction = std::max(worst_correction, std::abs(c0 - got.correction[k]));
    largest_correction = std::max(largest_correction, std::abs(c0));
    exact += o.command_mpa == got.command[k] && o.duty == got.duty[k] && c0 == got.correction[k];
  }
  periods += ilc.iteration();
  cuts += ilc.gain_cuts();
  raises += ilc.gain_raises();
  held = held || ilc.held();
  const std::size_t n = in.reference.size();
  EXPECT_LE(worst_command, 1e-12) << "MPa";
  EXPECT_LE(worst_duty, 1e-12);
  EXPECT_LE(worst_correction, 1e-15) << "m";
#if defined(__x86_64__) && defined(__SSE2__)
  EXPECT_EQ(exact, n) << "not bit-identical to the library's learning loop";
#endif
  // what the inputs exercised: corrections learnt (up to the limit where there is one), periods
  // completed, and the supervisor's actions where it supervises
  EXPECT_GT(largest_correction, 1e-4);
  EXPECT_LE(largest_correction, lp.max_correction);
  EXPECT_GE(periods, 3u);
  if (c.name == "ff_pid_supervised_held") {
    EXPECT_GT(cuts, 0u);
    EXPECT_GT(raises, 0u);
    EXPECT_TRUE(held);
  }
  if (c.name == "cascade_wide_filter_warm") {
    EXPECT_LT(IterativeLearning(lp).filter_reach(), lp.half_width) << "the filter's far taps are skipped";
  }
  std::printf("  %s: %zu samples, %zu periods, L halved %zu / doubled %zu times%s, largest correction %.3g m: "
              "largest difference %.3g MPa, %.3g duty, %.3g m correction; bit-identical %zu / %zu\n",
              c.name.c_str(), n, periods, cuts, raises, held ? ", held" : "", largest_correction, worst_command,
              worst_duty, worst_correction, exact, n);
}

INSTANTIATE_TEST_SUITE_P(Export, ExportLearning, ::testing::ValuesIn(learning_cases()),
                         [](const ::testing::TestParamInfo<LearningCase>& p) { return p.param.loop.name; });

// The comparison can fail: the learning gain, the phase lead or the filter's width 1 off, the
// generated learning differs from the library's.
TEST(ExportLoopCheck, PerturbedLearningIsDetected) {
  if (!test::have_gcc()) GTEST_SKIP() << "gcc not found";
  const LearningCase lc = learning_cases()[0];
  const LoopDesign& d = lc.loop.design;
  const Inputs in = make_inputs(6000, 5u);
  const std::vector<double> preview = feedforward_preview(d, in.reference);
  for (int which = 0; which < 3; ++which) {
    LoopDesign p = d;
    if (which == 0) p.learning->params.gain *= 1 + 1e-9;
    if (which == 1) p.learning->params.lead += 1;
    if (which == 2) p.learning->params.half_width += 1;
    test::TempDir dir;
    const test::LoopRun got = test::run_generated_loop(p, model_of(lc.loop.model), dir.file("."), false, in.reference,
                                                       preview, in.measured, in.pressure);
    ASSERT_EQ(got.error, "");
    Controller ctl = make_controller(d, model_of(lc.loop.model));
    IterativeLearning ilc(d.learning->params);
    std::size_t differ = 0;
    for (std::size_t k = 0; k < in.reference.size() && k < got.command.size(); ++k) {
      const double c0 = ilc.correction(0);
      const LoopOutput o = step(ctl, ilc, d, in.reference[k], preview[k], in.measured[k], in.pressure[k]);
      differ += o.command_mpa != got.command[k] || c0 != got.correction[k];
    }
    EXPECT_GT(differ, 0u) << "perturbation " << which;
  }
}

TEST(ExportLoopCheck, LoopsGeneratedCCannotHoldAreRefused) {
  const ModelParams m = pi_model();
  auto refused = [&](const LoopDesign& d, const std::string& expected, Limits limits = {}) {
    io::ExportOptions o;
    o.loop = d;
    o.inverse_limits = limits;
    try {
      (void)io::generate_c(m, o);
      ADD_FAILURE() << "accepted; expected: " << expected;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  LoopDesign ok = cases()[0].design;
  {
    LoopDesign d = ok;
    d.learning = LoopDesign::Learning{};  // period 0
    refused(d, "learning.period = 0: must be >= 2 samples");
    d.learning->params = {.period = 1000, .lead = 750, .half_width = 300, .lookahead = 40};  // reach 110
    refused(d, "learning: lead + 2 reach + lookahead = 750 + 2 x 110 + 40 must be < period = 1000");
    // periods generated C could not hold (beyond a 32-bit int; a state of more than 2 GB) are refused
    // since 2026-11-29 by the learning's own bound, 10^7 samples, before generated C's checks
    d.learning->params = {.period = (std::size_t{1} << 31) + 10, .lead = 10, .half_width = 3, .lookahead = 5};
    refused(d, "learning.period = 2147483658: must be <= 10000000 samples");
    d.learning->params = {.period = 60'000'000, .lead = 10, .half_width = 3, .lookahead = 5, .rise_tolerance = 0.0};
    refused(d, "learning.period = 60000000: must be <= 10000000 samples");
  }
  {
    LoopDesign d = ok;
    d.feedforward_lead = std::size_t{1} << 31;
    refused(d, "feedforward_lead = 2147483648 samples");
  }
  {
    LoopDesign d = ok;
    d.shaper->delay = std::numeric_limits<std::size_t>::max();
    refused(d, "shaper.delay");
  }
  {
    LoopDesign d = ok;
    d.pid->kp = -1;
    refused(d, "pid.kp = -1");
  }
  {
    LoopDesign d = case_named("cascade_quantised_pwm").design;
    d.pressure_pid.reset();
    refused(d, "needs its pressure_pid");
  }
  refused(ok, "differ from the loop's pressure limits", Limits{0.0, 0.5});
  // the loop's own limits may be given
  io::ExportOptions o;
  o.loop = ok;
  o.inverse_limits = ok.feedforward.pressure_limits;
  EXPECT_NO_THROW((void)io::generate_c(m, o));
}

}  // namespace
